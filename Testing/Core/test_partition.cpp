// SPDX-License-Identifier: MIT
// Whole-brick pieces (Partition.h) and reading one piece of a file (readCsgvPiece): every brick
// belongs to exactly one piece; a piece decodes to exactly its box of the whole volume; only its
// bricks' bytes are read; bad boxes and files are clear errors.
#include "TestData.h"

#include "csgv/base/FileUtil.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/codec/Partition.h"
#include "csgv/inputs/Procedural.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

using namespace csgv;
using namespace csgvtest;

TEST(BrickPartition, EveryBrickBelongsToExactlyOnePieceAndPiecesAreBalanced) {
    const std::array<uint32_t, 3> grids[] = {{1, 1, 1}, {3, 5, 7}, {8, 8, 8}, {33, 2, 17}, {1, 1, 40}, {128, 128, 128}};
    for (const auto& g : grids)
        for (uint32_t n = 1; n <= 64; ++n) {
            std::vector<uint8_t> owners(size_t(g[0]) * g[1] * g[2], 0);
            uint64_t smallest = ~uint64_t(0), largest = 0;
            for (uint32_t p = 0; p < n; ++p) {
                const BrickBox b = brickPartition(g, n, p);
                for (int a = 0; a < 3; ++a) ASSERT_LE(b.hi[a], g[a]);
                smallest = std::min(smallest, b.bricks());
                largest = std::max(largest, b.bricks());
                if (b.empty()) continue;
                for (uint32_t z = b.lo[2]; z < b.hi[2]; ++z)
                    for (uint32_t y = b.lo[1]; y < b.hi[1]; ++y)
                        for (uint32_t x = b.lo[0]; x < b.hi[0]; ++x) ++owners[x + size_t(g[0]) * (y + size_t(g[1]) * z)];
            }
            EXPECT_TRUE(std::all_of(owners.begin(), owners.end(), [](uint8_t o) { return o == 1; }))
                << g[0] << "x" << g[1] << "x" << g[2] << " in " << n << " pieces";
            if (uint64_t(g[0]) * g[1] * g[2] >= 64ull * n) {
                EXPECT_LE(largest, 2 * smallest) << n << " pieces";
            }
        }
    EXPECT_EQ(brickPartition({4, 4, 4}, 1, 0), (BrickBox{{0, 0, 0}, {4, 4, 4}}));
    EXPECT_TRUE(brickPartition({4, 4, 4}, 2, 2).empty()) << "no such piece";
    EXPECT_EQ(brickPartition({4, 2, 2}, 2, 1), (BrickBox{{2, 0, 0}, {4, 2, 2}})) << "the longest axis is cut";
}

namespace {

/// The labels of `box` (bricks) cut out of a whole volume.
LabelVolume crop(const LabelVolume& whole, const BrickBox& box, uint32_t brickSize) {
    LabelVolume out;
    std::array<uint32_t, 3> lo{};
    for (int a = 0; a < 3; ++a) {
        lo[a] = box.lo[a] * brickSize;
        out.dim[a] = std::min(box.hi[a] * brickSize, whole.dim[a]) - lo[a];
    }
    out.labels.resize(size_t(out.voxelCount()));
    for (uint32_t z = 0; z < out.dim[2]; ++z)
        for (uint32_t y = 0; y < out.dim[1]; ++y)
            for (uint32_t x = 0; x < out.dim[0]; ++x)
                out.labels[size_t(out.index(x, y, z))] = whole.at(lo[0] + x, lo[1] + y, lo[2] + z);
    return out;
}

uint64_t brickBytes(const CompressedVolume& v) {
    uint64_t n = 0;
    for (const auto& a : v.arrays) n += a.size() * 4;
    return n;
}

} // namespace

TEST(ReadCsgvPiece, EveryPieceOfEveryFixtureDecodesToItsBoxAndReadsOnlyItsBricks) {
    for (const std::string& name : allFixtureNames()) {
        const CompressedVolume whole = loadFixture(name);
        const Result<LabelVolume> labels = decodeVolume(whole, 0);
        ASSERT_TRUE(labels.isOk()) << name << ": " << labels.message();
        const uint64_t fileBytes = fixtureBytes(name).size();
        const uint64_t headBytes = fileBytes - brickBytes(whole);
        for (uint32_t n : {1u, 2u, 3u, 4u, 7u}) {
            uint64_t allBrickBytes = 0;
            for (uint32_t p = 0; p < n; ++p) {
                const BrickBox box = brickPartition(whole.brickGrid(), n, p);
                if (box.empty()) continue;
                uint64_t read = 0;
                Result<CompressedVolume> piece = readCsgvPiece(fixture(name), box, &read);
                ASSERT_TRUE(piece.isOk()) << name << " piece " << p << " of " << n << ": " << piece.message();
                EXPECT_EQ(piece->brickCount(), box.bricks());
                const Result<LabelVolume> got = decodeVolume(*piece, 0);
                ASSERT_TRUE(got.isOk()) << got.message();
                const LabelVolume want = crop(*labels, box, whole.brickSize);
                EXPECT_EQ(got->dim, want.dim);
                EXPECT_TRUE(got->labels == want.labels) << name << " piece " << p << " of " << n;
                EXPECT_EQ(read, headBytes + brickBytes(*piece)) << name << ": the header and the piece's bricks only";
                allBrickBytes += brickBytes(*piece);
            }
            EXPECT_EQ(allBrickBytes, brickBytes(whole)) << name << ": every brick read once in " << n << " pieces";
        }
    }
}

TEST(ReadCsgvPiece, TheWholeBoxIsTheFileAndBadBoxesOrFilesAreErrors) {
    SynthSpec spec;
    spec.dim = {70, 45, 33};
    spec.cellSize = 7;
    const Result<LabelVolume> src = generateVolume(spec);
    ASSERT_TRUE(src.isOk());
    EncodeOptions o;
    o.brickSize = 16;
    o.maxArrayWords = 4096; // several encoding arrays: runs of bricks cross their ends
    const Result<CompressedVolume> vol = encodeVolume(*src, o);
    ASSERT_TRUE(vol.isOk()) << vol.message();
    ASSERT_GT(vol->arrays.size(), 2u);
    const std::string path = tempDir() + "/piece.csgv";
    ASSERT_TRUE(writeCsgv(path, *vol).isOk());
    const BrickBox all{{0, 0, 0}, vol->brickGrid()};
    Result<CompressedVolume> whole = readCsgvPiece(path, all);
    ASSERT_TRUE(whole.isOk()) << whole.message();
    const Result<LabelVolume> back = decodeVolume(*whole, 0);
    ASSERT_TRUE(back.isOk());
    EXPECT_TRUE(back->labels == src->labels);
    // A middle piece, across array ends.
    const BrickBox mid{{1, 1, 0}, {4, 3, 3}};
    Result<CompressedVolume> piece = readCsgvPiece(path, mid);
    ASSERT_TRUE(piece.isOk()) << piece.message();
    EXPECT_TRUE(decodeVolume(*piece, 0)->labels == crop(*src, mid, 16).labels);
    // The same piece cut from the volume in memory is the same container.
    Result<CompressedVolume> cutOut = extractPiece(*vol, mid);
    ASSERT_TRUE(cutOut.isOk()) << cutOut.message();
    EXPECT_EQ(serializeCsgv(*cutOut), serializeCsgv(*piece));
    EXPECT_FALSE(extractPiece(*vol, BrickBox{{0, 0, 0}, {9, 1, 1}}).isOk());
    // The header alone describes the volume without its arrays.
    Result<CompressedVolume> head = readCsgvHeader(path);
    ASSERT_TRUE(head.isOk()) << head.message();
    EXPECT_EQ(head->dim, vol->dim);
    EXPECT_EQ(head->brickStarts, vol->brickStarts);
    EXPECT_TRUE(head->arrays.empty());
    // Boxes outside the grid or empty.
    Result<CompressedVolume> outside = readCsgvPiece(path, BrickBox{{0, 0, 0}, {5, 3, 4}});
    ASSERT_FALSE(outside.isOk());
    EXPECT_NE(outside.message().find("outside"), std::string::npos) << outside.message();
    EXPECT_FALSE(readCsgvPiece(path, BrickBox{{2, 0, 0}, {2, 3, 3}}).isOk());
    // A truncated file names what is missing; a file that is not CSGV says so.
    std::vector<uint8_t> bytes = serializeCsgv(*vol);
    const std::string cut = tempDir() + "/cut.csgv";
    {
        std::ofstream f(cut, std::ios::binary);
        f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size() - 100));
    }
    Result<CompressedVolume> truncated = readCsgvPiece(cut, all);
    ASSERT_FALSE(truncated.isOk());
    EXPECT_NE(truncated.message().find("truncated"), std::string::npos) << truncated.message();
    // A brick start pointing past its array is caught before anything is read for it.
    const uint64_t startsAt = 41 + 128 + 4 + 8; // rANS two tables
    bytes[size_t(startsAt + 4 * 3)] = 0xFF;
    bytes[size_t(startsAt + 4 * 3 + 3)] = 0x7F;
    const std::string bad = tempDir() + "/bad.csgv";
    {
        std::ofstream f(bad, std::ios::binary);
        f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    }
    Result<CompressedVolume> broken = readCsgvPiece(bad, BrickBox{{0, 0, 0}, {5, 1, 1}});
    ASSERT_FALSE(broken.isOk());
    EXPECT_NE(broken.message().find("brick"), std::string::npos) << broken.message();
}

TEST(JoinPieces, PiecesEncodedApartWithSharedCountsJoinToTheWholeEncodingByteForByte) {
    // The writer's parallel path: each process encodes its whole-brick piece, the pieces' symbol
    // counts are summed (shareCounts), and the joined file equals the encoding of the whole.
    SynthSpec spec;
    spec.dim = {70, 45, 33};
    spec.cellSize = 7;
    const Result<LabelVolume> src = generateVolume(spec);
    ASSERT_TRUE(src.isOk());
    for (int32_t encoding : {kEncodingNibble, kEncodingRans1, kEncodingRans2})
        for (uint32_t maxWords : {kMaxWordsPerArray, 4096u}) {
            EncodeOptions o;
            o.brickSize = 16;
            o.encoding = encoding;
            o.maxArrayWords = maxWords;
            const Result<CompressedVolume> whole = encodeVolume(*src, o);
            ASSERT_TRUE(whole.isOk()) << whole.message();
            const std::vector<uint8_t> want = serializeCsgv(*whole);
            for (uint32_t n : {1u, 2u, 3u, 5u, 8u, 100u}) {
                std::vector<BrickBox> boxes;
                for (uint32_t p = 0; p < n; ++p) boxes.push_back(brickPartition(whole->brickGrid(), n, p));
                // Round 1 gathers every piece's counts (and stops), round 2 encodes with the sum.
                SymbolCounts total;
                for (const BrickBox& box : boxes) {
                    if (box.empty()) continue;
                    EncodeOptions count = o;
                    count.shareCounts = [&](const SymbolCounts& c) -> Result<SymbolCounts> {
                        total += c;
                        return Status::error("counted");
                    };
                    const Result<CompressedVolume> stopped = encodeVolume(crop(*src, box, 16), count);
                    ASSERT_FALSE(stopped.isOk());
                    EXPECT_EQ(stopped.message(), "counted");
                }
                std::vector<CompressedVolume> pieces(boxes.size());
                for (size_t p = 0; p < boxes.size(); ++p) {
                    if (boxes[p].empty()) continue;
                    EncodeOptions shared = o;
                    shared.shareCounts = [&](const SymbolCounts&) -> Result<SymbolCounts> { return total; };
                    Result<CompressedVolume> piece = encodeVolume(crop(*src, boxes[p], 16), shared);
                    ASSERT_TRUE(piece.isOk()) << piece.message();
                    pieces[p] = std::move(*piece);
                }
                Result<CompressedVolume> joined = joinPieces(src->dim, boxes, pieces, maxWords);
                ASSERT_TRUE(joined.isOk()) << joined.message();
                EXPECT_TRUE(serializeCsgv(*joined) == want)
                    << encodingName(encoding) << ", " << n << " pieces, arrays of " << maxWords << " words";
                EXPECT_TRUE(pieces.back().arrays.empty()) << "joined pieces are released";
            }
            // Pieces cut out of the file join back to it too.
            std::vector<BrickBox> boxes = {brickPartition(whole->brickGrid(), 2, 0),
                                           brickPartition(whole->brickGrid(), 2, 1)};
            std::vector<CompressedVolume> cut = {*extractPiece(*whole, boxes[0]), *extractPiece(*whole, boxes[1])};
            Result<CompressedVolume> joined = joinPieces(src->dim, boxes, cut, maxWords);
            ASSERT_TRUE(joined.isOk()) << joined.message();
            EXPECT_TRUE(serializeCsgv(*joined) == want);
        }
}

TEST(JoinPieces, GapsOverlapsAndMismatchedPiecesAreErrors) {
    SynthSpec spec;
    spec.dim = {40, 33, 20};
    spec.cellSize = 5;
    const Result<LabelVolume> src = generateVolume(spec);
    ASSERT_TRUE(src.isOk());
    EncodeOptions o;
    o.brickSize = 16;
    const Result<CompressedVolume> whole = encodeVolume(*src, o);
    ASSERT_TRUE(whole.isOk());
    const BrickBox a = brickPartition(whole->brickGrid(), 2, 0), b = brickPartition(whole->brickGrid(), 2, 1);
    auto join = [&](std::vector<BrickBox> boxes, std::vector<CompressedVolume> pieces) {
        return joinPieces(src->dim, boxes, pieces);
    };
    const CompressedVolume pa = *extractPiece(*whole, a), pb = *extractPiece(*whole, b);
    EXPECT_TRUE(join({a, b}, {pa, pb}).isOk());
    EXPECT_TRUE(join({a, b, BrickBox{}}, {pa, pb, CompressedVolume{}}).isOk()) << "empty pieces are skipped";
    Result<CompressedVolume> gap = join({a}, {pa});
    ASSERT_FALSE(gap.isOk());
    EXPECT_NE(gap.message().find("is in no piece"), std::string::npos) << gap.message();
    Result<CompressedVolume> twice = join({a, b, a}, {pa, pb, pa});
    ASSERT_FALSE(twice.isOk());
    EXPECT_NE(twice.message().find("is in pieces 0 and 2"), std::string::npos) << twice.message();
    CompressedVolume otherTables = pb;
    otherTables.freqA[0] += 1;
    otherTables.freqA[1] -= 1;
    Result<CompressedVolume> mismatch = join({a, b}, {pa, otherTables});
    ASSERT_FALSE(mismatch.isOk());
    EXPECT_NE(mismatch.message().find("piece 1 differs"), std::string::npos) << mismatch.message();
    Result<CompressedVolume> swapped = join({b, a}, {pa, pb});
    ASSERT_FALSE(swapped.isOk());
    EXPECT_NE(swapped.message().find("voxels along axis"), std::string::npos) << swapped.message();
    EXPECT_FALSE(join({a, b}, {pa}).isOk());
    EXPECT_FALSE(join({BrickBox{}}, {CompressedVolume{}}).isOk());
}

TEST(EmbedPiece, APieceInItsVolumesIndexSpaceKeepsItsBricksAndTheRestIsLabelZero) {
    // MPI ranks render their piece in the whole volume's index space: the piece's bricks at their
    // place, every other brick absent (label 0), for every fixture and encoding.
    for (const std::string& name : allFixtureNames()) {
        const CompressedVolume whole = loadFixture(name);
        const Result<LabelVolume> labels = decodeVolume(whole, 0);
        ASSERT_TRUE(labels.isOk()) << labels.message();
        for (uint32_t n : {2u, 3u}) {
            const BrickBox box = brickPartition(whole.brickGrid(), n, n - 1);
            Result<CompressedVolume> piece = extractPiece(whole, box);
            ASSERT_TRUE(piece.isOk());
            Result<CompressedVolume> embedded = embedPiece(*piece, box, whole.dim);
            ASSERT_TRUE(embedded.isOk()) << name << ": " << embedded.message();
            EXPECT_EQ(embedded->dim, whole.dim);
            EXPECT_EQ(embedded->brickCount(), whole.brickCount());
            const Result<LabelVolume> got = decodeVolume(*embedded, 0);
            ASSERT_TRUE(got.isOk()) << name << ": " << got.message();
            const uint32_t B = whole.brickSize;
            bool same = true;
            for (uint32_t z = 0; z < whole.dim[2] && same; ++z)
                for (uint32_t y = 0; y < whole.dim[1] && same; ++y)
                    for (uint32_t x = 0; x < whole.dim[0] && same; ++x) {
                        const bool mine = box.contains(x / B, y / B, z / B);
                        same = got->at(x, y, z) == (mine ? labels->at(x, y, z) : 0u);
                    }
            EXPECT_TRUE(same) << name << ": piece " << n - 1 << " of " << n;
            // The piece's bricks keep their words.
            const uint64_t inside = box.lo[0] + uint64_t(whole.brickGrid()[0]) *
                                                    (box.lo[1] + uint64_t(whole.brickGrid()[1]) * box.lo[2]);
            const BrickWords a = embedded->brick(inside), b = whole.brick(inside);
            EXPECT_TRUE(a.size == b.size && std::equal(a.words, a.words + a.size, b.words)) << name;
        }
    }
    const CompressedVolume whole = loadFixture(allFixtureNames().front());
    const BrickBox box = brickPartition(whole.brickGrid(), 2, 0);
    const CompressedVolume piece = *extractPiece(whole, box);
    EXPECT_FALSE(embedPiece(piece, brickPartition(whole.brickGrid(), 2, 1), whole.dim).isOk()) << "wrong box";
    EXPECT_FALSE(embedPiece(piece, BrickBox{}, whole.dim).isOk()) << "empty box";
}
