// SPDX-License-Identifier: MIT
// The encoder: Volcanite's files reproduced byte for byte, exact round trips over every encoding,
// brick size and operation mask on odd-sized volumes, the coarse-label rule at every level,
// thread-count independence, worst-case bricks and split arrays.
#include "TestData.h"

#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/inputs/Procedural.h"

#include "csgv/base/FileUtil.h"

#include <algorithm>
#include <filesystem>
#include <gtest/gtest.h>
#include <map>
#include <new>

using namespace csgv;
using namespace csgvtest;

namespace {

LabelVolume synth(uint32_t w, uint32_t h, uint32_t d, uint64_t seed, uint32_t cell) {
    SynthSpec s;
    s.dim = {w, h, d};
    s.seed = seed;
    s.cellSize = cell;
    Result<LabelVolume> v = generateVolume(s);
    EXPECT_TRUE(v.isOk()) << v.message();
    return *v;
}

/// Encodes, serialises, parses and decodes every level; compares with the reference pyramid.
void expectRoundTrip(const LabelVolume& src, const EncodeOptions& o, bool everyLevel, const std::string& what) {
    Result<CompressedVolume> enc = encodeVolume(src, o);
    ASSERT_TRUE(enc.isOk()) << what << ": " << enc.message();
    const std::vector<uint8_t> bytes = serializeCsgv(*enc);
    Result<CompressedVolume> back = parseCsgv(bytes.data(), bytes.size());
    ASSERT_TRUE(back.isOk()) << what << ": " << back.message();
    LabelVolume expected = src;
    const uint32_t levels = everyLevel ? back->levels() : 1;
    for (uint32_t lod = 0; lod < levels; ++lod) {
        if (lod > 0) expected = referenceCoarsen(expected);
        Result<LabelVolume> got = decodeVolume(*back, lod);
        ASSERT_TRUE(got.isOk()) << what << " lod " << lod << ": " << got.message();
        ASSERT_EQ(got->dim, expected.dim) << what;
        ASSERT_TRUE(got->labels == expected.labels) << what << " lod " << lod;
    }
}

const char* kMasks[] = {"default", "all", "p", "n", "l", "d", "s", "pnl", "pnld", "pnds", "ds", "xs", "yzl", "lds", "pxs"};

} // namespace

TEST(Encoder, ReproducesVolcanitesFilesByteForByte) {
    // Given the frequency tables Volcanite chose, our operation choice and layout give its bytes.
    int compared = 0;
    for (const std::string& name : allFixtureNames()) {
        const CompressedVolume theirs = loadFixture(name);
        if (theirs.legacyDelta() || name.find("_attr") != std::string::npos) continue; // we never write those
        EncodeOptions o;
        o.brickSize = theirs.brickSize;
        o.encoding = theirs.encoding;
        o.opMask = theirs.opMask;
        o.fixedTables = true;
        o.tableA = theirs.freqA;
        o.tableB = theirs.freqB;
        Result<CompressedVolume> ours = encodeVolume(sourceVolume(name), o);
        ASSERT_TRUE(ours.isOk()) << name << ": " << ours.message();
        EXPECT_TRUE(serializeCsgv(*ours) == fixtureBytes(name)) << name;
        ++compared;
    }
    EXPECT_EQ(compared, 9);
}

TEST(Encoder, OwnTablesAreNoLargerThanVolcanitesOnItsFixtures) {
    for (const std::string& name : allFixtureNames()) {
        const CompressedVolume theirs = loadFixture(name);
        if (theirs.legacyDelta() || name.find("_attr") != std::string::npos) continue;
        EncodeOptions o;
        o.brickSize = theirs.brickSize;
        o.encoding = theirs.encoding;
        o.opMask = theirs.opMask;
        Result<CompressedVolume> ours = encodeVolume(sourceVolume(name), o);
        ASSERT_TRUE(ours.isOk()) << ours.message();
        EXPECT_LE(ours->serializedSize(), theirs.serializedSize()) << name;
    }
}

TEST(Encoder, EveryEncodingBrickSizeAndMaskRoundTripsOnOddVolumes) {
    // No dimension is a multiple of any brick size; small cells give many labels per brick.
    const LabelVolume src = synth(37, 29, 23, 11, 5);
    for (int32_t enc : {0, 1, 2})
        for (uint32_t b : {8u, 16u, 32u, 64u, 128u})
            for (const char* mask : kMasks) {
                EncodeOptions o;
                o.encoding = enc;
                o.brickSize = b;
                o.opMask = *parseOperationMask(mask);
                expectRoundTrip(src, o, b <= 16, std::string(encodingName(enc)) + " b" + std::to_string(b) + " " + mask);
            }
    EncodeOptions none;
    none.opMask = 0; // PALETTE_ADV only
    expectRoundTrip(src, none, true, "no operations but PALETTE_ADV");
}

TEST(Encoder, EveryLevelOfALargerVolumeMatchesTheCoarseRule) {
    const LabelVolume src = synth(150, 101, 77, 3, 9);
    for (const char* mask : {"default", "all"}) {
        EncodeOptions o;
        o.opMask = *parseOperationMask(mask);
        expectRoundTrip(src, o, true, mask);
    }
}

TEST(Encoder, TinyAndDegenerateVolumes) {
    LabelVolume one;
    one.dim = {1, 1, 1};
    one.labels = {42};
    LabelVolume flat;
    flat.dim = {40, 33, 17};
    flat.labels.assign(40 * 33 * 17, 7);
    LabelVolume line;
    line.dim = {300, 1, 1};
    for (uint32_t i = 0; i < 300; ++i) line.labels.push_back(i / 7);
    LabelVolume unique; // every voxel a different label, including 0 and 0xFFFFFFFE
    unique.dim = {19, 17, 13};
    for (uint32_t i = 0; i < 19 * 17 * 13; ++i) unique.labels.push_back(i == 5 ? 0xFFFFFFFEu : i * 2654435761u % 0xFFFFFFF0u);
    for (const LabelVolume* v : {&one, &flat, &line, &unique})
        for (int32_t enc : {0, 1, 2})
            for (uint32_t b : {8u, 32u, 128u})
                for (const char* mask : {"default", "all", "pnl"}) {
                    EncodeOptions o;
                    o.encoding = enc;
                    o.brickSize = b;
                    o.opMask = *parseOperationMask(mask);
                    expectRoundTrip(*v, o, true,
                                    std::to_string(v->dim[0]) + "x" + std::to_string(v->dim[1]) + " " + mask);
                }
}

TEST(Encoder, WorstCaseBrickOfEveryVoxelADifferentLabel) {
    LabelVolume v;
    v.dim = {128, 128, 128};
    v.labels.resize(size_t(v.voxelCount()));
    for (size_t i = 0; i < v.labels.size(); ++i) v.labels[i] = uint32_t(i * 7919u + 1u);
    for (const char* mask : {"default", "all"})
        for (int32_t enc : {0, 2}) {
            EncodeOptions o;
            o.brickSize = 128;
            o.encoding = enc;
            o.opMask = *parseOperationMask(mask);
            Result<CompressedVolume> c = encodeVolume(v, o);
            ASSERT_TRUE(c.isOk()) << c.message();
            EXPECT_EQ(c->maxPalette, 128u * 128u * 128u);
            Result<LabelVolume> d = decodeVolume(*c, 0);
            ASSERT_TRUE(d.isOk()) << d.message();
            EXPECT_TRUE(d->labels == v.labels) << mask;
        }
}

TEST(Encoder, ThreadCountDoesNotChangeTheBytes) {
    const LabelVolume src = synth(130, 97, 71, 5, 12);
    for (int32_t enc : {0, 1, 2}) {
        EncodeOptions o;
        o.encoding = enc;
        o.opMask = kMaskAll;
        o.threads = 1;
        Result<CompressedVolume> a = encodeVolume(src, o);
        o.threads = 2;
        Result<CompressedVolume> b = encodeVolume(src, o);
        o.threads = 3;
        Result<CompressedVolume> c = encodeVolume(src, o);
        ASSERT_TRUE(a.isOk() && b.isOk() && c.isOk());
        EXPECT_TRUE(serializeCsgv(*a) == serializeCsgv(*b));
        EXPECT_TRUE(serializeCsgv(*a) == serializeCsgv(*c));
    }
}

TEST(Encoder, SplitsIntoEqualBrickCountArraysWhenTooLarge) {
    const LabelVolume src = synth(100, 90, 80, 9, 7);
    EncodeOptions o;
    o.brickSize = 16;
    Result<CompressedVolume> one = encodeVolume(src, o);
    ASSERT_TRUE(one.isOk());
    ASSERT_EQ(one->arrays.size(), 1u);
    o.maxArrayWords = uint32_t(one->arrays[0].size() / 5);
    Result<CompressedVolume> split = encodeVolume(src, o);
    ASSERT_TRUE(split.isOk()) << split.message();
    EXPECT_GE(split->arrays.size(), 5u);
    EXPECT_NE(split->bricksPerArray, kSingleArray);
    for (const auto& a : split->arrays) EXPECT_LE(a.size(), o.maxArrayWords);
    const std::vector<uint8_t> bytes = serializeCsgv(*split);
    Result<CompressedVolume> back = parseCsgv(bytes.data(), bytes.size());
    ASSERT_TRUE(back.isOk()) << back.message();
    Result<LabelVolume> d = decodeVolume(*back, 0);
    ASSERT_TRUE(d.isOk()) << d.message();
    EXPECT_TRUE(d->labels == src.labels);
}

namespace {

std::vector<uint8_t> readBytes(const std::string& path) {
    Result<std::vector<uint8_t>> b = readFile(path, uint64_t(1) << 30);
    EXPECT_TRUE(b.isOk()) << b.message();
    return b ? *b : std::vector<uint8_t>{};
}

/// @brief Serves a LabelVolume through readSlab only (as a file source would).
class CopySlabSource : public SlabSource {
public:
    explicit CopySlabSource(const LabelVolume& v) : m_v(v) {}
    std::array<uint32_t, 3> dimensions() const override { return m_v.dim; }
    Status readSlab(uint32_t z0, uint32_t depth, uint32_t* out) override {
        const size_t slice = size_t(m_v.dim[0]) * m_v.dim[1];
        std::copy_n(m_v.labels.data() + slice * z0, slice * depth, out);
        return Status::ok();
    }

private:
    const LabelVolume& m_v;
};

/// @brief The same, reading bands of rows too (as an HDF5 file or the generator does); records
/// the bands asked for.
class RowSlabSource : public CopySlabSource {
public:
    explicit RowSlabSource(const LabelVolume& v) : CopySlabSource(v), m_v(v) {}
    bool readsRows() const override { return true; }
    uint32_t chunkDepth() const override { return chunks; }
    Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint32_t* out) override {
        bands.push_back({z0, depth, y0, rows});
        const uint32_t W = m_v.dim[0], H = m_v.dim[1];
        for (uint32_t z = 0; z < depth; ++z)
            std::copy_n(m_v.labels.data() + (size_t(z0 + z) * H + y0) * W, size_t(W) * rows,
                        out + size_t(z) * rows * W);
        return Status::ok();
    }
    std::vector<std::array<uint32_t, 4>> bands;
    uint32_t chunks = 1;

private:
    const LabelVolume& m_v;
};

} // namespace

TEST(Encoder, ToFileReadsBandsOfBrickRowsFromSourcesThatReadRows) {
    // Bands of one, two and all brick rows (the last band partial: 60 = 3 * 16 + 12) give the bytes
    // of the in-memory encoder, and the encoder holds only a band.
    const LabelVolume src = synth(70, 60, 50, 9, 7);
    EncodeOptions o;
    o.brickSize = 16;
    Result<CompressedVolume> mem = encodeVolume(src, o);
    ASSERT_TRUE(mem.isOk()) << mem.message();
    const uint64_t brickRow = 70 * 16 * 16 * 4;
    for (uint64_t maxBand : {uint64_t(1), 2 * brickRow + 5, uint64_t(64) << 20}) {
        const std::string path = tempDir() + "/bands.csgv";
        EncodeToFileOptions fo;
        fo.maxBandBytes = maxBand;
        RowSlabSource slabs(src);
        const uint32_t rows = maxBand == 1 ? 16 : maxBand < 60 * 70 * 16 * 4 ? 32 : 60;
        EXPECT_EQ(encoderBandBytes(slabs, 16, maxBand), uint64_t(70) * rows * 16 * 4) << maxBand;
        const Status s = encodeToFile(slabs, o, path, fo);
        ASSERT_TRUE(s.isOk()) << s.message();
        EXPECT_TRUE(readBytes(path) == serializeCsgv(*mem)) << "band budget " << maxBand;
        if (rows == 60) {
            EXPECT_TRUE(slabs.bands.empty()) << "a band of the whole slab is read with readSlab";
            continue;
        }
        // Every slab in bands of `rows` rows, in order, depth 16 but the last (50 = 3 * 16 + 2).
        std::vector<std::array<uint32_t, 4>> want;
        for (uint32_t z0 = 0; z0 < 50; z0 += 16)
            for (uint32_t y0 = 0; y0 < 60; y0 += rows) want.push_back({z0, std::min(16u, 50 - z0), y0, std::min(rows, 60 - y0)});
        EXPECT_EQ(slabs.bands, want) << maxBand;
    }
    // A source stored in chunks 20 slices deep is read in bands two slabs (32 slices) deep, so that
    // no chunk is read twice; same bytes. The budget counts the depth: one brick row here.
    {
        RowSlabSource slabs(src);
        slabs.chunks = 20;
        EncodeToFileOptions fo;
        fo.maxBandBytes = 2 * brickRow + 5;
        EXPECT_EQ(encoderBandBytes(slabs, 16, fo.maxBandBytes), uint64_t(70) * 16 * 32 * 4);
        const std::string path = tempDir() + "/deep-bands.csgv";
        ASSERT_TRUE(encodeToFile(slabs, o, path, fo).isOk());
        EXPECT_TRUE(readBytes(path) == serializeCsgv(*mem));
        std::vector<std::array<uint32_t, 4>> want;
        for (uint32_t z0 : {0u, 32u})
            for (uint32_t y0 = 0; y0 < 60; y0 += 16) want.push_back({z0, z0 ? 18u : 32u, y0, std::min(16u, 60 - y0)});
        EXPECT_EQ(slabs.bands, want);
    }
    // A plain source is read in whole slabs whatever the budget.
    CopySlabSource plain(src);
    EXPECT_EQ(encoderBandBytes(plain, 16, 1), uint64_t(70) * 60 * 16 * 4);
}

TEST(Encoder, ReservedLabelInABandIsReportedAtItsVoxel) {
    LabelVolume src = synth(40, 40, 20, 5, 3);
    src.labels[size_t(7 + 40 * (33 + 40 * 18))] = kInvalidLabel;
    EncodeToFileOptions fo;
    fo.maxBandBytes = 1; // bands of one brick row
    RowSlabSource slabs(src);
    EncodeOptions o;
    o.brickSize = 16;
    const Status s = encodeToFile(slabs, o, tempDir() + "/reserved-band.csgv", fo);
    ASSERT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("label 0xFFFFFFFF at voxel (7, 33, 18) is reserved"), std::string::npos) << s.message();
    // In a band two slabs deep, the first brick in file order is named, not the first one encoded.
    src.labels[size_t(39 + 40 * (39 + 40 * 3))] = kInvalidLabel;
    RowSlabSource deep(src);
    deep.chunks = 32;
    const Status d = encodeToFile(deep, o, tempDir() + "/reserved-band.csgv", fo);
    ASSERT_FALSE(d.isOk());
    EXPECT_NE(d.message().find("label 0xFFFFFFFF at voxel (39, 39, 3) is reserved"), std::string::npos) << d.message();
}

namespace {

/// @brief A RowSlabSource that lists boxes it holds one label in (SlabSource::uniformBoxes),
/// clipped to each region asked about, as a chunked file lists chunks never written.
class UniformBoxSource : public RowSlabSource {
public:
    UniformBoxSource(const LabelVolume& v, std::vector<UniformBox> boxes) : RowSlabSource(v), m_boxes(std::move(boxes)) {}
    Status readSlab(uint32_t z0, uint32_t depth, uint32_t* out) override {
        bands.push_back({z0, depth, 0, dimensions()[1]}); // whole slabs are reads too
        return RowSlabSource::readSlab(z0, depth, out);
    }
    void uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, std::vector<UniformBox>& out) override {
        out.clear();
        const std::array<uint32_t, 3> lo = {0, y0, z0}, hi = {dimensions()[0], y0 + rows, z0 + depth};
        for (UniformBox b : m_boxes) {
            for (int a = 0; a < 3; ++a) {
                b.lo[a] = std::max(b.lo[a], lo[a]);
                b.hi[a] = std::min(b.hi[a], hi[a]);
            }
            if (b.voxels() > 0) out.push_back(b);
        }
    }

private:
    std::vector<UniformBox> m_boxes;
};

/// `v` with every voxel of `box` set to its value.
void paint(LabelVolume& v, const UniformBox& box) {
    for (uint32_t z = box.lo[2]; z < box.hi[2]; ++z)
        for (uint32_t y = box.lo[1]; y < box.hi[1]; ++y)
            for (uint32_t x = box.lo[0]; x < box.hi[0]; ++x)
                v.labels[size_t(x + uint64_t(v.dim[0]) * (y + uint64_t(v.dim[1]) * z))] = uint32_t(box.value);
}

} // namespace

TEST(Encoder, UniformBoxesGiveTheBytesOfReadingEveryVoxel) {
    // Labels 7 over y < 28 (in four boxes cut where no brick is), 3 and 0 in boxes of odd sizes,
    // the rest Voronoi cells: every brick size, encoding and operation mask gives the bytes of the
    // in-memory encoder, which reads every voxel. Bricks the boxes cover are not read: with bricks
    // of 16 no band asks for rows 0..15.
    LabelVolume src = synth(70, 60, 50, 9, 7);
    const std::vector<UniformBox> boxes = {{{{0, 0, 0}}, {{37, 28, 19}}, 7},  {{{37, 0, 0}}, {{70, 28, 19}}, 7},
                                           {{{0, 0, 19}}, {{37, 28, 50}}, 7}, {{{37, 0, 19}}, {{70, 28, 50}}, 7},
                                           {{{10, 30, 20}}, {{45, 60, 41}}, 3}, {{{50, 40, 0}}, {{70, 60, 50}}, 0}};
    for (const UniformBox& b : boxes) paint(src, b);
    const auto check = [&](const EncodeOptions& o, const std::string& what) {
        Result<CompressedVolume> mem = encodeVolume(src, o);
        ASSERT_TRUE(mem.isOk()) << what << ": " << mem.message();
        UniformBoxSource slabs(src, boxes);
        const std::string path = tempDir() + "/uniform-boxes.csgv";
        const Status s = encodeToFile(slabs, o, path);
        ASSERT_TRUE(s.isOk()) << what << ": " << s.message();
        EXPECT_TRUE(readBytes(path) == serializeCsgv(*mem)) << what;
        if (o.brickSize == 16) {
            for (const auto& band : slabs.bands) EXPECT_GE(band[2], 16u) << what << ": rows 0..15 are uniform";
        }
    };
    for (uint32_t brick : {8u, 16u, 32u})
        for (int32_t encoding : {kEncodingNibble, kEncodingRans1, kEncodingRans2}) {
            EncodeOptions o;
            o.brickSize = brick;
            o.encoding = encoding;
            check(o, "brick " + std::to_string(brick) + " " + encodingName(encoding));
        }
    for (const char* mask : kMasks) {
        EncodeOptions o;
        o.brickSize = 16;
        o.opMask = *parseOperationMask(mask);
        check(o, std::string("mask ") + mask);
    }
}

TEST(Encoder, AVolumeOfUniformBoxesIsNeverRead) {
    // One label everywhere, listed as boxes that cut bricks: no read at all, the bytes of the
    // volume read voxel by voxel, and the reserved label is still read and named at its voxel.
    LabelVolume src;
    src.dim = {45, 38, 29};
    src.labels.assign(size_t(45 * 38 * 29), 5u);
    const std::vector<UniformBox> boxes = {{{{0, 0, 0}}, {{45, 13, 29}}, 5}, {{{0, 13, 0}}, {{45, 38, 29}}, 5}};
    for (uint32_t brick : {8u, 16u, 32u}) {
        EncodeOptions o;
        o.brickSize = brick;
        Result<CompressedVolume> mem = encodeVolume(src, o);
        ASSERT_TRUE(mem.isOk()) << mem.message();
        UniformBoxSource slabs(src, boxes);
        const std::string path = tempDir() + "/uniform-all.csgv";
        ASSERT_TRUE(encodeToFile(slabs, o, path).isOk());
        EXPECT_TRUE(readBytes(path) == serializeCsgv(*mem)) << brick;
        EXPECT_TRUE(slabs.bands.empty()) << brick;
        // The same boxes ignored: every band read, the same bytes.
        o.useUniformBoxes = false;
        UniformBoxSource ignored(src, boxes);
        ASSERT_TRUE(encodeToFile(ignored, o, path).isOk());
        EXPECT_TRUE(readBytes(path) == serializeCsgv(*mem)) << brick;
        EXPECT_FALSE(ignored.bands.empty()) << brick;
    }
    src.labels.assign(src.labels.size(), kInvalidLabel);
    UniformBoxSource reserved(src, {{{{0, 0, 0}}, {{45, 38, 29}}, kInvalidLabel}});
    EncodeOptions o;
    o.brickSize = 16;
    const Status s = encodeToFile(reserved, o, tempDir() + "/uniform-reserved.csgv");
    EXPECT_NE(s.message().find("label 0xFFFFFFFF at voxel (0, 0, 0) is reserved"), std::string::npos) << s.message();
}

TEST(Encoder, ABrickIndexTooLargeIsRefusedBeforeAnyWork) {
    // 65536^3 voxels in bricks of 32: 2^33 bricks, 64 GiB of index. Nothing is read.
    EXPECT_EQ(encoderIndexBytes({65536, 65536, 65536}, 32), uint64_t(64) << 30);
    EXPECT_EQ(encoderIndexBytes({70, 60, 50}, 16), uint64_t(8) * 5 * 4 * 4);
    EXPECT_EQ(encoderIndexBytes({0xFFFFFFFFu, 0xFFFFFFFFu, 0xFFFFFFFFu}, 8), ~uint64_t(0)); // saturates
    const Status s = checkEncoderIndex({65536, 65536, 65536}, 32, uint64_t(16) << 30);
    EXPECT_EQ(s.message(), "a 65536x65536x65536 volume in bricks of 32^3 needs 68719476736 bytes of brick index in "
                           "memory (8 for each of its 8589934592 bricks), more than the limit of 17179869184 bytes "
                           "(the encoder's index limit); bricks of 64^3 need 8589934592 (--brick-size 64)");
    EXPECT_TRUE(checkEncoderIndex({65536, 65536, 65536}, 128, uint64_t(16) << 30).isOk());
    std::string why;
    EXPECT_GT(automaticIndexLimit(&why), 0u);
    EXPECT_EQ(why.rfind("half of ", 0), 0u) << why;
    LabelVolume small = synth(40, 40, 40, 1, 5);
    RowSlabSource slabs(small);
    EncodeToFileOptions fo;
    fo.maxIndexBytes = 100; // 27 bricks of 16: 216 bytes
    EncodeOptions o;
    o.brickSize = 16;
    const std::string path = tempDir() + "/index-refused.csgv";
    const Status refused = encodeToFile(slabs, o, path, fo);
    EXPECT_NE(refused.message().find("needs 216 bytes of brick index"), std::string::npos) << refused.message();
    EXPECT_NE(refused.message().find("bricks of 32^3 need 64 (--brick-size 32)"), std::string::npos) << refused.message();
    EXPECT_TRUE(slabs.bands.empty());
    EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(Encoder, ToFileGivesTheBytesOfTheInMemoryEncoderHeldSpilledAndSplit) {
    const LabelVolume src = synth(70, 60, 50, 9, 7);
    for (int32_t encoding : {kEncodingNibble, kEncodingRans1, kEncodingRans2})
        for (uint64_t held : {uint64_t(256) << 20, uint64_t(0), uint64_t(20000)})
            for (bool split : {false, true}) {
                EncodeOptions o;
                o.brickSize = 16;
                o.encoding = encoding;
                Result<CompressedVolume> mem = encodeVolume(src, o);
                ASSERT_TRUE(mem.isOk()) << mem.message();
                if (split) {
                    o.maxArrayWords = uint32_t(mem->arrays[0].size() / 5);
                    mem = encodeVolume(src, o);
                    ASSERT_TRUE(mem.isOk()) << mem.message();
                    ASSERT_GE(mem->arrays.size(), 5u);
                }
                const std::string path = tempDir() + "/tofile.csgv";
                EncodeToFileOptions fo;
                fo.heldSymbolBytes = held;
                std::vector<double> seen;
                fo.progress = [&](double f) {
                    seen.push_back(f);
                    return true;
                };
                uint64_t size = 0;
                CopySlabSource slabs(src);
                const Status s = encodeToFile(slabs, o, path, fo, &size);
                const std::string what = std::string(encodingName(encoding)) + " held " + std::to_string(held) +
                                         (split ? " split" : "");
                ASSERT_TRUE(s.isOk()) << what << ": " << s.message();
                const std::vector<uint8_t> bytes = readBytes(path);
                EXPECT_EQ(size, bytes.size()) << what;
                EXPECT_TRUE(bytes == serializeCsgv(*mem)) << what;
                ASSERT_FALSE(seen.empty());
                EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end())) << what;
                EXPECT_DOUBLE_EQ(seen.back(), 1.0) << what;
            }
}

TEST(Encoder, ToFileCancelledOrFailingLeavesNothingBehind) {
    const LabelVolume src = synth(64, 64, 64, 3, 5);
    const std::string dir = tempDir() + "/cancel";
    std::filesystem::create_directories(dir);
    const auto listDirectory = [](const std::string& d) {
        std::vector<std::string> names;
        for (const auto& e : std::filesystem::directory_iterator(d)) names.push_back(e.path().filename().string());
        return names;
    };
    for (double stopAt : {0.1, 0.85, 0.95}) {
        EncodeToFileOptions fo;
        fo.heldSymbolBytes = 0;
        fo.progress = [&](double f) { return f < stopAt; };
        CopySlabSource slabs(src);
        EncodeOptions o;
        o.brickSize = 16;
        const Status s = encodeToFile(slabs, o, dir + "/x.csgv", fo);
        ASSERT_FALSE(s.isOk());
        EXPECT_EQ(s.message(), "cancelled");
        EXPECT_TRUE(listDirectory(dir).empty()) << "after cancelling at " << stopAt;
    }
    EncodeToFileOptions small;
    small.maxOutputBytes = 100;
    CopySlabSource slabs(src);
    const Status s = encodeToFile(slabs, EncodeOptions{}, dir + "/x.csgv", small);
    EXPECT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("output limit"), std::string::npos) << s.message();
    EXPECT_TRUE(listDirectory(dir).empty());
}

TEST(Encoder, ToFileTurnsExceptionsIntoErrorsAndLeavesNothingBehind) {
    // Errors are values across Core's boundary: an allocation failure while encoding (here thrown
    // by the source after the symbols began to spill) is a message, and no file is left.
    class ThrowingSlabs : public SlabSource {
    public:
        explicit ThrowingSlabs(const LabelVolume& v) : m_copy(v), m_dim(v.dim) {}
        std::array<uint32_t, 3> dimensions() const override { return m_dim; }
        Status readSlab(uint32_t z0, uint32_t depth, uint32_t* out) override {
            if (z0 >= 32) throw std::bad_alloc();
            return m_copy.readSlab(z0, depth, out);
        }

    private:
        CopySlabSource m_copy;
        std::array<uint32_t, 3> m_dim;
    };
    const LabelVolume src = synth(40, 40, 48, 3, 5);
    const std::string dir = tempDir() + "/encode-throws";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    EncodeToFileOptions fo;
    fo.heldSymbolBytes = 0;
    ThrowingSlabs slabs(src);
    EncodeOptions o;
    o.brickSize = 16;
    const Status s = encodeToFile(slabs, o, dir + "/x.csgv", fo);
    ASSERT_FALSE(s.isOk());
    EXPECT_EQ(s.message(), "out of memory while encoding '" + dir + "/x.csgv'");
    EXPECT_TRUE(std::filesystem::is_empty(dir));
    // The in-memory encoder too.
    ThrowingSlabs again(src);
    Result<CompressedVolume> mem = encodeVolume(again, o);
    ASSERT_FALSE(mem.isOk());
    EXPECT_EQ(mem.message(), "out of memory while encoding a volume in memory");
}

TEST(Encoder, RejectsBadOptionsAndReservedLabels) {
    LabelVolume v;
    v.dim = {4, 4, 4};
    v.labels.assign(64, 1);
    EncodeOptions o;
    o.brickSize = 12;
    EXPECT_NE(encodeVolume(v, o).message().find("brick size"), std::string::npos);
    o.brickSize = 256;
    EXPECT_FALSE(encodeVolume(v, o).isOk());
    o = EncodeOptions{};
    o.encoding = 4;
    EXPECT_NE(encodeVolume(v, o).message().find("encoding"), std::string::npos);
    o = EncodeOptions{};
    v.labels[37] = 0xFFFFFFFFu;
    Result<CompressedVolume> r = encodeVolume(v, o);
    ASSERT_FALSE(r.isOk());
    EXPECT_NE(r.message().find("(1, 1, 2)"), std::string::npos) << r.message();
    EXPECT_NE(r.message().find("reserved"), std::string::npos) << r.message();
    o.fixedTables = true; // a table without the symbols the volume needs
    o.tableA = {};
    o.tableA[0] = kRansTotal;
    o.tableB = o.tableA;
    v.labels[37] = 3;
    EXPECT_NE(encodeVolume(v, o).message().find("lack symbol"), std::string::npos);
}

TEST(Encoder, OperationLetters) {
    EXPECT_EQ(*parseOperationMask("default"), uint32_t(kMaskDefault));
    EXPECT_EQ(*parseOperationMask("all"), uint32_t(kMaskAll));
    EXPECT_EQ(*parseOperationMask("pnls"), uint32_t(kMaskDefault));
    EXPECT_EQ(*parseOperationMask("pnlds"), uint32_t(kMaskAll));
    EXPECT_EQ(*parseOperationMask("pxyzlds"), uint32_t(kMaskAll));
    EXPECT_FALSE(parseOperationMask("pq").isOk());
    EXPECT_FALSE(parseOperationMask("").isOk());
}

TEST(Procedural, AnyBoxGivesTheSameLabels) {
    SynthSpec s = *parseSynthSpec("synth:70x50x40:99");
    EXPECT_EQ(s.dim, (std::array<uint32_t, 3>{70, 50, 40}));
    EXPECT_EQ(s.seed, 99u);
    const LabelVolume whole = *generateVolume(s);
    std::vector<uint32_t> box(13 * 7 * 5);
    generateBox(s, {31, 20, 17}, {13, 7, 5}, box.data());
    for (uint32_t z = 0; z < 5; ++z)
        for (uint32_t y = 0; y < 7; ++y)
            for (uint32_t x = 0; x < 13; ++x) ASSERT_EQ(box[x + 13 * (y + 7 * z)], whole.at(31 + x, 20 + y, 17 + z));
    // Deterministic across calls; seeds differ; a segmentation with background and many cells.
    EXPECT_TRUE(generateVolume(s)->labels == whole.labels);
    EXPECT_FALSE(generateVolume(*parseSynthSpec("synth:70x50x40:98"))->labels == whole.labels);
    std::map<uint32_t, size_t> counts;
    for (uint32_t l : whole.labels) ++counts[l];
    EXPECT_GT(counts.size(), 20u);
    EXPECT_GT(counts[0], whole.labels.size() / 20);
    EXPECT_LT(counts[0], whole.labels.size() / 2);
    EXPECT_EQ(counts.count(0xFFFFFFFFu), 0u);
}

TEST(Procedural, NamesAreParsedStrictly) {
    EXPECT_EQ(parseSynthSpec("synth:256x256x256")->seed, 1u);
    for (const char* bad : {"synth:", "synth:12x12", "synth:0x5x5", "synth:5x5x5:", "synth:5x5x5:x", "synth:axbxc",
                            "synth:5x5x5x5", "synt:5x5x5", "synth:99999999999x1x1"})
        EXPECT_FALSE(parseSynthSpec(bad).isOk()) << bad;
}
