// SPDX-License-Identifier: MIT
/// @file test_malformed.cpp
/// @brief Malformed `.csgv` input (CSGV-FORMAT.md section 9): every class of broken file is built
/// by corrupting a Volcanite fixture in memory, and must be refused with a message that names the
/// problem. A seeded random-mutation test checks that nothing crashes, hangs or fails silently.
///
/// Suites:
/// - MalformedContainer: header fields, lengths, brick starts, brick headers, frequency tables
///   (refused by parseCsgv / checkContainer).
/// - MalformedStream: operation streams that pass the container checks but break while decoding
///   (refused by BrickDecoder::decode and validateStreams, naming brick, level and node).
/// - MalformedRobustness: ~3000 seeded random mutations of small sub-volumes cut from the fixtures.
///
/// Corruptions of nibble-mode (encoding 0) streams locate their node with walkNibbleBrick(), a
/// small independent walker over a brick's symbols; rANS fixtures are corrupted in their headers.

#include "TestData.h"

#include "csgv/codec/Container.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/codec/Palettes.h"
#include "csgv/base/Morton.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <map>
#include <mutex>
#include <random>
#include <string>
#include <vector>

using csgv::BrickDecoder;
using csgv::BrickWords;
using csgv::CompressedVolume;
using csgv::Status;

namespace {

// Fixtures by encoding mode (see shared/data/volcanite-0.6/README.md).
const char* const kNibble = "synthA_b16_nibble.csgv";            // mode 0, default mask
const char* const kNibbleDelta = "synthA_b8_nibble_delta.csgv";  // mode 0, PALETTE_D
const char* const kNibbleDeltaB = "denseB_b32_nibble_delta.csgv"; // mode 0, PALETTE_D, dense palettes
const char* const kRans1 = "synthA_b32_rans1.csgv";              // mode 1
const char* const kRans2 = "synthA_b32_rans2.csgv";              // mode 2, default mask

// ------------------------------------------------------------------------------------------------
// Helpers
// ------------------------------------------------------------------------------------------------

bool contains(const std::string& hay, const std::string& needle) { return hay.find(needle) != std::string::npos; }

/// Success when `s` is an error whose message contains every needle.
::testing::AssertionResult failsWith(const Status& s, const std::vector<std::string>& needles) {
    std::string want;
    for (const auto& n : needles) want += " '" + n + "'";
    if (s.isOk()) return ::testing::AssertionFailure() << "accepted; expected an error containing" << want;
    for (const auto& n : needles)
        if (!contains(s.message(), n))
            return ::testing::AssertionFailure() << "message \"" << s.message() << "\" lacks '" << n << "'";
    return ::testing::AssertionSuccess() << s.message();
}

/// Success when `s` is an error whose message contains at least one of the alternatives.
::testing::AssertionResult failsWithAny(const Status& s, const std::vector<std::string>& alternatives) {
    std::string want;
    for (const auto& n : alternatives) want += " '" + n + "'";
    if (s.isOk()) return ::testing::AssertionFailure() << "accepted; expected an error containing one of" << want;
    for (const auto& n : alternatives)
        if (contains(s.message(), n)) return ::testing::AssertionSuccess() << s.message();
    return ::testing::AssertionFailure() << "message \"" << s.message() << "\" contains none of" << want;
}

/// The bytes at an address of `phase` modulo 4, kept by the returned owner (a `.csgv`'s words
/// lie at byte 69 + 4k: phase 0 puts them at 1 modulo 4, as in a memory-mapped file).
std::shared_ptr<const uint8_t> bytesAtPhase(const std::vector<uint8_t>& bytes, size_t phase, const uint8_t** at) {
    std::shared_ptr<uint8_t> block(new uint8_t[bytes.size() + 8], std::default_delete<uint8_t[]>());
    uint8_t* p = block.get() + (phase + 4 - reinterpret_cast<uintptr_t>(block.get()) % 4) % 4;
    std::copy(bytes.begin(), bytes.end(), p);
    *at = p;
    return block;
}

/// The status of parsing `bytes` (copied), which parsing them as unaligned views
/// (parseCsgvShared, as readCsgvMapped parses a mapped file) must equal.
Status parseStatus(const std::vector<uint8_t>& bytes) {
    const Status copied = csgv::parseCsgv(bytes.data(), bytes.size()).status();
    const uint8_t* at = nullptr;
    std::shared_ptr<const uint8_t> keeper = bytesAtPhase(bytes, 0, &at);
    const Status viewed = csgv::parseCsgvShared(at, bytes.size(), keeper).status();
    EXPECT_EQ(copied.isOk(), viewed.isOk());
    EXPECT_EQ(copied.message(), viewed.message()) << "a view parses unlike a copy";
    return copied;
}

/// Writes a (corrupted) volume and parses it back: the status of the container checks. A parse
/// checks the layout only (checkLayout); a brick's header words are checked when the brick is
/// reached: then the first unsound brick's decoder must refuse it with checkBrick's message, which
/// is the status returned, and checkContainer must say the same.
Status reparse(const CompressedVolume& v) {
    const std::vector<uint8_t> bytes = csgv::serializeCsgv(v);
    const Status parsed = parseStatus(bytes);
    if (!parsed) return parsed;
    const CompressedVolume back = *csgv::parseCsgv(bytes.data(), bytes.size());
    const std::vector<uint64_t> unsound = csgv::summarizePalettes(back, 0).unsound;
    const Status whole = csgv::checkContainer(back);
    EXPECT_EQ(whole.isOk(), unsound.empty());
    if (unsound.empty()) return whole;
    const Status brick = csgv::checkBrick(back, unsound.front());
    csgv::BrickDecoder dec(back);
    const Status decoded = dec.decode(unsound.front(), 0);
    EXPECT_FALSE(decoded.isOk());
    EXPECT_EQ(decoded.message(), brick.message()) << "the decoder refuses an unsound brick as checkBrick does";
    EXPECT_EQ(whole.message(), brick.message());
    return brick;
}

/// Parsed fixtures, read once per process; tests copy them before corrupting.
const CompressedVolume& fixtureVolume(const std::string& name) {
    static std::mutex mutex;
    static std::map<std::string, CompressedVolume> cache;
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(name);
    if (it == cache.end()) it = cache.emplace(name, csgvtest::loadFixture(name)).first;
    return it->second;
}

/// Byte offsets of the variable part of a serialised container (CSGV-FORMAT.md section 7).
struct Layout {
    size_t bricksPerArray, startCount, starts, arrayCount, firstArrayLength, firstArray;
};
Layout layoutOf(const CompressedVolume& v) {
    Layout l{};
    l.bricksPerArray = 41 + (v.encoding == 1 ? 64 : v.encoding == 2 ? 128 : 0);
    l.startCount = l.bricksPerArray + 4;
    l.starts = l.startCount + 8;
    l.arrayCount = l.starts + 4 * v.brickStarts.size();
    l.firstArrayLength = l.arrayCount + 8;
    l.firstArray = l.firstArrayLength + 8;
    return l;
}
constexpr size_t kOffVersion = 8, kOffBrickSize = 12, kOffDim = 16, kOffEncoding = 28, kOffRandomAccess = 32;

template <typename T>
void poke(std::vector<uint8_t>& b, size_t offset, T value) {
    ASSERT_LE(offset + sizeof(T), b.size());
    std::memcpy(b.data() + offset, &value, sizeof(T));
}

/// Writable words of brick i (the fixtures hold one encoding array).
struct MutableBrick {
    uint32_t* w;
    uint32_t size;
};
MutableBrick mutableBrick(CompressedVolume& v, uint64_t i) {
    EXPECT_EQ(v.bricksPerArray, csgv::kSingleArray);
    EXPECT_EQ(v.arrays.size(), 1u);
    const uint32_t begin = v.brickStarts[size_t(i)];
    return MutableBrick{v.arrays[0].owned().data() + begin, v.brickStarts[size_t(i) + 1] - begin};
}

/// First word of brick i's palette.
uint32_t paletteStart(const CompressedVolume& v, uint64_t i) {
    const BrickWords bw = v.brick(i);
    return bw.size - bw.words[v.levels()];
}

/// Nibble-mode symbol access: symbol k of a word is in bits 31-4k .. 28-4k.
uint32_t getSym(csgv::WordPtr w, uint64_t pos) { return (w[pos >> 3] >> (28 - 4 * (pos & 7))) & 15u; }
void setSym(uint32_t* w, uint64_t pos, uint32_t s) {
    const uint32_t shift = 28 - 4 * uint32_t(pos & 7);
    w[pos >> 3] = (w[pos >> 3] & ~(15u << shift)) | ((s & 15u) << shift);
}

std::array<uint32_t, 3> brickOrigin(const CompressedVolume& v, uint64_t i) {
    const auto g = v.brickGrid();
    return {uint32_t(i % g[0]) * v.brickSize, uint32_t((i / g[0]) % g[1]) * v.brickSize,
            uint32_t(i / (uint64_t(g[0]) * g[1])) * v.brickSize};
}

uint32_t coordOf(uint32_t morton, int axis) { return csgv::mortonCompact(morton >> axis); }

/// One visited node of a nibble-mode brick.
struct VisitedNode {
    uint32_t level = 0;
    uint32_t node = 0;            ///< Morton index within its level
    uint64_t pos = 0;             ///< symbol position of its operation, counted from the brick start
    uint32_t sym = 0;             ///< the operation symbol
    uint32_t appendedBefore = 0;  ///< palette entries appended before this node
    std::vector<uint64_t> groups; ///< symbol positions of a PALETTE_D distance
};

/// Walks the symbols of a (valid) nibble-mode brick as a decoder visits them (CSGV-FORMAT.md
/// sections 2 and 5): levels coarsest first, each level from its start header[l], nodes in Morton
/// order; children of stopped nodes and nodes whose minimum corner lies outside the volume are
/// not visited; PALETTE_D is followed by its distance (one symbol in legacy mode, otherwise 3-bit
/// groups while bit 3 is set). Labels are not computed: this only locates nodes to corrupt.
std::vector<VisitedNode> walkNibbleBrick(const CompressedVolume& v, uint64_t brick) {
    const uint32_t L = v.levels();
    const BrickWords bw = v.brick(brick);
    const auto origin = brickOrigin(v, brick);
    std::vector<VisitedNode> out;
    std::vector<uint8_t> open{1}, nextOpen;
    uint32_t appended = 0;
    for (uint32_t l = 0; l < L; ++l) {
        uint64_t pos = bw.words[l];
        const uint32_t width = v.brickSize >> l;
        const uint32_t count = 1u << (3 * l);
        nextOpen.assign(count, 0);
        for (uint32_t m = 0; m < count; ++m) {
            if (l > 0 && !open[m >> 3]) continue;
            bool inVolume = true;
            for (int a = 0; a < 3; ++a) inVolume = inVolume && origin[a] + coordOf(m, a) * width < v.dim[a];
            if (!inVolume) continue;
            VisitedNode n;
            n.level = l;
            n.node = m;
            n.pos = pos;
            n.sym = getSym(bw.words, pos++);
            n.appendedBefore = appended;
            if ((n.sym & 7) == csgv::kOpPaletteAdv) ++appended;
            if ((n.sym & 7) == csgv::kOpPaletteD) {
                if (v.legacyDelta()) {
                    n.groups.push_back(pos++);
                } else {
                    uint32_t g = 0;
                    do {
                        n.groups.push_back(pos);
                        g = getSym(bw.words, pos++);
                    } while (g & 8);
                }
            }
            nextOpen[m] = (n.sym & csgv::kStopBit) ? 0 : 1;
            out.push_back(std::move(n));
        }
        open.swap(nextOpen);
    }
    return out;
}

/// Symbol position one past the last symbol of `level` in a walked brick (0 when none visited).
uint64_t levelEndPos(const std::vector<VisitedNode>& nodes, uint32_t level) {
    uint64_t end = 0;
    for (const auto& n : nodes)
        if (n.level == level) end = std::max<uint64_t>(end, (n.groups.empty() ? n.pos : n.groups.back()) + 1);
    return end;
}

std::string brickTag(uint64_t b) { return "brick " + std::to_string(b) + ","; }
std::string levelTag(uint32_t l) { return "level " + std::to_string(l) + " "; }
std::string nodeTag(uint32_t m) { return "node " + std::to_string(m) + ":"; }

/// The corrupted volume must pass the container checks (the damage is inside a stream); then
/// decoding `brick` and validating the whole volume must both fail with every needle.
void expectStreamError(const CompressedVolume& bad, uint64_t brick, const std::vector<std::string>& needles,
                       const std::vector<std::string>& anyOf = {}) {
    const std::vector<uint8_t> bytes = csgv::serializeCsgv(bad);
    csgv::Result<CompressedVolume> parsed = csgv::parseCsgv(bytes.data(), bytes.size());
    ASSERT_TRUE(parsed.isOk()) << "container checks refused a stream corruption: " << parsed.message();
    BrickDecoder decoder(*parsed);
    const Status s = decoder.decode(brick, 0);
    EXPECT_TRUE(failsWith(s, needles));
    if (!anyOf.empty()) { EXPECT_TRUE(failsWithAny(s, anyOf)); }
    const Status all = csgv::validateStreams(*parsed, 0);
    EXPECT_FALSE(all.isOk());
    EXPECT_EQ(all.message(), s.message()) << "validateStreams must report the only broken brick";
    // The same error from the words read where a mapped file holds them (1 modulo 4).
    const uint8_t* at = nullptr;
    std::shared_ptr<const uint8_t> keeper = bytesAtPhase(bytes, 0, &at);
    csgv::Result<CompressedVolume> viewed = csgv::parseCsgvShared(at, bytes.size(), keeper);
    ASSERT_TRUE(viewed.isOk()) << viewed.message();
    ASSERT_TRUE(viewed->arrays[0].isView());
    BrickDecoder viewDecoder(*viewed);
    EXPECT_EQ(viewDecoder.decode(brick, 0).message(), s.message()) << "an unaligned view decodes unlike a copy";
    EXPECT_EQ(csgv::validateStreams(*viewed, 0).message(), s.message());
}

constexpr uint64_t kNoBrick = ~uint64_t(0);

/// First brick (in index order) for which pred(brick) holds, or kNoBrick.
template <typename Pred>
uint64_t findBrick(const CompressedVolume& v, Pred pred) {
    for (uint64_t b = 0; b < v.brickCount(); ++b)
        if (pred(b)) return b;
    return kNoBrick;
}

bool rootOpen(const CompressedVolume& v, uint64_t b) {
    const BrickWords bw = v.brick(b);
    return (getSym(bw.words, bw.words[0]) & csgv::kStopBit) == 0;
}

/// Cuts the bricks [first, first + count) per axis out of a volume as a new, valid volume: bricks
/// keep their encodings, which stay valid because a brick's in-volume nodes do not change (the
/// new dimensions are whole bricks except where the cut reaches the original border).
CompressedVolume cropBricks(const CompressedVolume& v, std::array<uint32_t, 3> first, std::array<uint32_t, 3> count) {
    const auto g = v.brickGrid();
    CompressedVolume out = v;
    out.arrays.assign(1, {});
    out.brickStarts.assign(1, 0);
    out.bricksPerArray = csgv::kSingleArray;
    for (int a = 0; a < 3; ++a) {
        first[a] = std::min(first[a], g[a] - 1);
        count[a] = std::max(1u, std::min(count[a], g[a] - first[a]));
        out.dim[a] = std::min(v.dim[a] - first[a] * v.brickSize, count[a] * v.brickSize);
    }
    for (uint32_t z = 0; z < count[2]; ++z)
        for (uint32_t y = 0; y < count[1]; ++y)
            for (uint32_t x = 0; x < count[0]; ++x) {
                const uint64_t i = (first[0] + x) + uint64_t(g[0]) * ((first[1] + y) + uint64_t(g[1]) * (first[2] + z));
                const BrickWords bw = v.brick(i);
                out.arrays[0].owned().insert(out.arrays[0].owned().end(), bw.words, bw.words + bw.size);
                out.brickStarts.push_back(uint32_t(out.arrays[0].size()));
            }
    return out;
}

// ------------------------------------------------------------------------------------------------
// Helper self-checks: the walker and the cropping agree with the fixtures.
// ------------------------------------------------------------------------------------------------

TEST(MalformedHelpers, NibbleWalkerMatchesFixtureHeaders) {
    for (const char* name : {kNibble, kNibbleDelta, kNibbleDeltaB}) {
        const CompressedVolume& v = fixtureVolume(name);
        ASSERT_EQ(v.encoding, csgv::kEncodingNibble) << name;
        const uint32_t L = v.levels();
        for (uint64_t b = 0; b < v.brickCount(); b += 7) {
            const BrickWords bw = v.brick(b);
            const auto nodes = walkNibbleBrick(v, b);
            ASSERT_FALSE(nodes.empty());
            uint32_t appended = 0;
            for (const auto& n : nodes) appended += (n.sym & 7) == csgv::kOpPaletteAdv;
            EXPECT_EQ(appended, bw.words[L]) << name << " brick " << b << ": PALETTE_ADV count vs palette size";
            for (uint32_t l = 0; l + 1 < L; ++l) {
                const uint64_t end = levelEndPos(nodes, l);
                if (end) { EXPECT_LE(end, bw.words[l + 1]) << name << " brick " << b << " level " << l; }
            }
            EXPECT_LE(levelEndPos(nodes, L - 1), uint64_t(paletteStart(v, b)) * 8);
        }
    }
}

TEST(MalformedHelpers, CroppedVolumesDecodeToTheSourceRegion) {
    struct Case {
        const char* name;
        std::array<uint32_t, 3> first, count;
    };
    for (const Case& c : {Case{kNibble, {6, 2, 10}, {3, 3, 3}}, Case{kRans2, {1, 1, 1}, {2, 2, 2}},
                          Case{kNibbleDeltaB, {1, 0, 0}, {2, 1, 1}}}) {
        const CompressedVolume& v = fixtureVolume(c.name);
        const CompressedVolume crop = cropBricks(v, c.first, c.count);
        ASSERT_TRUE(csgv::checkContainer(crop).isOk()) << c.name;
        csgv::Result<csgv::LabelVolume> dec = csgv::decodeVolume(crop, 0);
        ASSERT_TRUE(dec.isOk()) << dec.message();
        const csgv::LabelVolume& src = csgvtest::sourceVolume(c.name);
        const auto g = v.brickGrid();
        size_t mismatches = 0;
        for (uint32_t z = 0; z < crop.dim[2]; ++z)
            for (uint32_t y = 0; y < crop.dim[1]; ++y)
                for (uint32_t x = 0; x < crop.dim[0]; ++x) {
                    const uint32_t ox = std::min(c.first[0], g[0] - 1) * v.brickSize;
                    const uint32_t oy = std::min(c.first[1], g[1] - 1) * v.brickSize;
                    const uint32_t oz = std::min(c.first[2], g[2] - 1) * v.brickSize;
                    mismatches += dec->at(x, y, z) != src.at(ox + x, oy + y, oz + z);
                }
        EXPECT_EQ(mismatches, 0u) << c.name;
    }
}

// ------------------------------------------------------------------------------------------------
// 1. Truncation
// ------------------------------------------------------------------------------------------------

class MalformedTruncation : public ::testing::TestWithParam<const char*> {};

TEST_P(MalformedTruncation, EveryPrefixIsRefused) {
    const std::vector<uint8_t> bytes = csgvtest::fixtureBytes(GetParam());
    ASSERT_GT(bytes.size(), 1000u);
    ASSERT_TRUE(parseStatus(bytes).isOk());
    std::vector<size_t> lengths;
    for (size_t n = 0; n < 300; ++n) lengths.push_back(n);
    const size_t rest = bytes.size() - 300;
    for (size_t k = 0; k < 300; ++k) lengths.push_back(300 + k * rest / 300 + (k * 7919) % 97 % std::max<size_t>(1, rest / 300));
    for (size_t k = 1; k <= 8; ++k) lengths.push_back(bytes.size() - k); // the last fields
    // Every cut around the brick-start count, the array count and the first array's length.
    const Layout layout = layoutOf(fixtureVolume(GetParam()));
    for (size_t n = layout.startCount - 1; n <= layout.starts + 4; ++n) lengths.push_back(n);
    for (size_t n = layout.arrayCount - 4; n <= layout.firstArray + 8; ++n) lengths.push_back(n);
    for (size_t n : lengths) {
        ASSERT_LT(n, bytes.size());
        // A copy of exactly n bytes, so that a sanitizer sees any read past the prefix.
        const std::vector<uint8_t> prefix(bytes.begin(), bytes.begin() + std::ptrdiff_t(n));
        const Status s = csgv::parseCsgv(prefix.data(), prefix.size()).status();
        // A prefix ending inside the first array's length field leaves 0..7 bytes for it: the
        // array count (1) is then reported as more than "the file can hold".
        ASSERT_TRUE(failsWithAny(s, {"truncated", "cannot hold"})) << "prefix of " << n << " bytes";
    }
}

TEST_P(MalformedTruncation, TrailingByteIsRefused) {
    std::vector<uint8_t> bytes = csgvtest::fixtureBytes(GetParam());
    bytes.push_back(0);
    EXPECT_TRUE(failsWith(parseStatus(bytes), {"1 unexpected bytes after the last field"}));
    bytes.insert(bytes.end(), 15, 0xAB);
    EXPECT_TRUE(failsWith(parseStatus(bytes), {"16 unexpected bytes"}));
}

INSTANTIATE_TEST_SUITE_P(Malformed, MalformedTruncation,
                         ::testing::Values(kNibble, kNibbleDelta, kRans1, kRans2, "denseB_b16_rans2_delta.csgv"),
                         [](const ::testing::TestParamInfo<const char*>& info) {
                             std::string n = info.param;
                             n = n.substr(0, n.find('.'));
                             for (char& c : n)
                                 if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                             return n;
                         });

// ------------------------------------------------------------------------------------------------
// 2. Magic and version
// ------------------------------------------------------------------------------------------------

TEST(MalformedContainer, WrongMagic) {
    const std::vector<uint8_t> good = csgvtest::fixtureBytes(kRans2);
    for (size_t i : {size_t(0), size_t(3), size_t(7)}) {
        std::vector<uint8_t> b = good;
        b[i] ^= 0x20;
        EXPECT_TRUE(failsWith(parseStatus(b), {"magic"})) << "byte " << i;
    }
    std::vector<uint8_t> zeros(good.size(), 0);
    EXPECT_TRUE(failsWith(parseStatus(zeros), {"magic"}));
    const char text[] = "W H D\n";
    EXPECT_TRUE(failsWith(csgv::parseCsgv(reinterpret_cast<const uint8_t*>(text), 6).status(), {"truncated", "magic"}));
}

TEST(MalformedContainer, WrongVersion) {
    const std::vector<uint8_t> good = csgvtest::fixtureBytes(kRans2);
    for (const char* version : {"0017", "abcd", "0014", "0160", "\x01\x02\x03\x04"}) {
        std::vector<uint8_t> b = good;
        std::memcpy(b.data() + kOffVersion, version, 4);
        const std::string shown = "'" + (version[0] == '\x01' ? std::string(4, '?') : std::string(version)) + "'";
        EXPECT_TRUE(failsWith(parseStatus(b), {"version", shown})) << version;
    }
}

/// "0015" has the layout of "0016" with the legacy single-symbol PALETTE_D. A file that never uses
/// PALETTE_D therefore decodes identically when relabelled 0015.
TEST(MalformedContainer, Version0015WithoutPaletteDStillDecodes) {
    for (const char* name : {kNibble, kRans2}) {
        std::vector<uint8_t> b = csgvtest::fixtureBytes(name);
        std::memcpy(b.data() + kOffVersion, "0015", 4);
        csgv::Result<CompressedVolume> v = csgv::parseCsgv(b.data(), b.size());
        ASSERT_TRUE(v.isOk()) << name << ": " << v.message();
        EXPECT_EQ(v->version, 15u);
        EXPECT_TRUE(v->legacyDelta());
        EXPECT_EQ(v->opMask & csgv::kMaskPaletteD, 0u) << name << " must not use PALETTE_D for this check";
        csgv::Result<csgv::LabelVolume> dec = csgv::decodeVolume(*v, 0);
        ASSERT_TRUE(dec.isOk()) << dec.message();
        const csgv::LabelVolume& src = csgvtest::sourceVolume(name);
        EXPECT_EQ(dec->dim, src.dim);
        EXPECT_TRUE(dec->labels == src.labels) << name << " relabelled 0015 decodes differently";
    }
}

// ------------------------------------------------------------------------------------------------
// 3. Brick starts
// ------------------------------------------------------------------------------------------------

TEST(MalformedContainer, BrickStartsOutOfOrder) {
    for (const char* name : {kNibble, kRans2}) {
        CompressedVolume v = fixtureVolume(name);
        v.brickStarts[3] = v.brickStarts[2] - 1; // brick 2 ends before it begins
        EXPECT_TRUE(failsWith(reparse(v), {"brick 2:", "out of order"})) << name;
        v = fixtureVolume(name);
        std::swap(v.brickStarts[10], v.brickStarts[11]); // brick 10 then runs backwards
        EXPECT_TRUE(failsWith(reparse(v), {"brick 10:", "out of order"})) << name;
    }
}

TEST(MalformedContainer, BrickStartPastArrayEnd) {
    for (const char* name : {kNibble, kRans1, kRans2}) {
        CompressedVolume v = fixtureVolume(name);
        const uint32_t len = uint32_t(v.arrays[0].size());
        v.brickStarts.back() = len + 1;
        const std::string last = "brick " + std::to_string(v.brickCount() - 1) + ":";
        EXPECT_TRUE(failsWith(reparse(v), {last, "past the end of encoding array 0"})) << name;
        v = fixtureVolume(name);
        v.brickStarts[5] = 0xFFFFFFF0u;
        EXPECT_TRUE(failsWith(reparse(v), {"brick 4:", "past the end of encoding array 0"})) << name;
    }
}

TEST(MalformedContainer, BadBrickStartCount) {
    const CompressedVolume& good = fixtureVolume(kRans2);
    CompressedVolume v = good;
    v.brickStarts.push_back(v.brickStarts.back());
    EXPECT_TRUE(failsWith(reparse(v), {"brick start count", std::to_string(good.brickCount() + 2)}));
    v = good;
    v.brickStarts.pop_back();
    EXPECT_TRUE(failsWith(reparse(v), {"brick start count", std::to_string(good.brickCount())}));
    // A count far beyond the file: refused before anything is allocated.
    std::vector<uint8_t> b = csgv::serializeCsgv(good);
    poke<uint64_t>(b, layoutOf(good).startCount, uint64_t(1) << 60);
    EXPECT_TRUE(failsWith(parseStatus(b), {"brick start count"}));
    poke<uint64_t>(b, layoutOf(good).startCount, 0);
    EXPECT_TRUE(failsWith(parseStatus(b), {"brick start count"}));
}

TEST(MalformedContainer, BrickSmallerThanMinimal) {
    for (const char* name : {kNibble, kRans2}) {
        CompressedVolume v = fixtureVolume(name);
        const uint32_t minWords = csgv::minimalBrickWords(v.levels(), v.encoding);
        v.brickStarts[8] = v.brickStarts[7] + minWords - 1;
        EXPECT_TRUE(failsWith(reparse(v), {"brick 7:", "less than the minimal brick"})) << name;
        v = fixtureVolume(name);
        v.brickStarts[8] = v.brickStarts[7]; // empty brick
        EXPECT_TRUE(failsWith(reparse(v), {"brick 7:", "0 words"})) << name;
    }
}

TEST(MalformedContainer, EncodingArrays) {
    const CompressedVolume& good = fixtureVolume(kNibble);
    CompressedVolume v = good;
    v.bricksPerArray = 0;
    EXPECT_TRUE(failsWith(reparse(v), {"bricks per encoding array"}));
    v = good;
    v.arrays.push_back(std::vector<uint32_t>{1, 2, 3});
    EXPECT_TRUE(failsWith(reparse(v), {"2 encoding arrays, expected 1"}));
    std::vector<uint8_t> b = csgv::serializeCsgv(good);
    const Layout l = layoutOf(good);
    std::vector<uint8_t> c = b;
    poke<uint64_t>(c, l.arrayCount, 0);
    EXPECT_TRUE(failsWith(parseStatus(c), {"encoding array count"}));
    c = b;
    poke<uint64_t>(c, l.arrayCount, ~uint64_t(0));
    EXPECT_TRUE(failsWith(parseStatus(c), {"encoding array count"}));
    c = b;
    poke<uint64_t>(c, l.firstArrayLength, (uint64_t(1) << 29) + 1);
    EXPECT_TRUE(failsWith(parseStatus(c), {"more than 2^29"}));
    c = b;
    poke<uint64_t>(c, l.firstArrayLength, uint64_t(1) << 28);
    EXPECT_TRUE(failsWith(parseStatus(c), {"truncated", "encoding array"}));
}

/// Rewrites a single-array volume with `perArray` bricks per encoding array (CSGV-FORMAT.md
/// section 7: the first brick of every array but the first starts at word 0 and its stored start
/// holds the previous array's length).
CompressedVolume splitArrays(const CompressedVolume& v, uint32_t perArray) {
    CompressedVolume out = v;
    out.bricksPerArray = perArray;
    out.arrays.clear();
    out.brickStarts.assign(size_t(v.brickCount()) + 1, 0);
    for (uint64_t i = 0; i < v.brickCount(); ++i) {
        if (i % perArray == 0) {
            if (i > 0) out.brickStarts[size_t(i)] = uint32_t(out.arrays.back().size());
            out.arrays.emplace_back();
        } else {
            out.brickStarts[size_t(i)] = uint32_t(out.arrays.back().size());
        }
        const BrickWords bw = v.brick(i);
        out.arrays.back().owned().insert(out.arrays.back().owned().end(), bw.words, bw.words + bw.size);
    }
    out.brickStarts.back() = uint32_t(out.arrays.back().size());
    return out;
}

TEST(MalformedContainer, SplitArrays) {
    const CompressedVolume& good = fixtureVolume(kRans1);
    constexpr uint32_t kPer = 7;
    const CompressedVolume split = splitArrays(good, kPer);
    ASSERT_GT(split.arrays.size(), 3u);
    {
        // The split volume itself is valid and decodes like the original.
        const std::vector<uint8_t> b = csgv::serializeCsgv(split);
        csgv::Result<CompressedVolume> r = csgv::parseCsgv(b.data(), b.size());
        ASSERT_TRUE(r.isOk()) << r.message();
        csgv::Result<csgv::LabelVolume> d = csgv::decodeVolume(*r, 0);
        ASSERT_TRUE(d.isOk()) << d.message();
        EXPECT_TRUE(d->labels == csgvtest::sourceVolume(kRans1).labels);
    }
    CompressedVolume v = split;
    v.brickStarts[kPer] = uint32_t(v.arrays[0].size()) + 1; // end of the first array's last brick
    EXPECT_TRUE(failsWith(reparse(v), {"brick " + std::to_string(kPer - 1) + ":", "past the end of encoding array 0"}));
    v = split;
    v.brickStarts[kPer + 3] = uint32_t(v.arrays[1].size()) + 5;
    EXPECT_TRUE(failsWith(reparse(v), {"brick " + std::to_string(kPer + 2) + ":", "past the end of encoding array 1"}));
    v = split;
    v.brickStarts[kPer + 1] = 0; // the second brick of array 1 would start inside the first
    EXPECT_TRUE(failsWith(reparse(v), {"brick " + std::to_string(kPer) + ":"}));
    v = split;
    v.arrays.pop_back();
    EXPECT_TRUE(failsWith(reparse(v), {"encoding arrays, expected " + std::to_string(split.arrays.size())}));
    v = split;
    v.bricksPerArray = kPer + 1;
    EXPECT_FALSE(reparse(v).isOk());
    v = split;
    v.arrays[2].owned().resize(v.arrays[2].size() / 2);
    EXPECT_TRUE(failsWith(reparse(v), {"past the end of encoding array 2"}));
}

// ------------------------------------------------------------------------------------------------
// 4. Level starts
// ------------------------------------------------------------------------------------------------

TEST(MalformedContainer, LevelZeroStart) {
    for (const char* name : {kNibble, kRans1, kRans2}) {
        for (int delta : {-8, 1, 8}) {
            CompressedVolume v = fixtureVolume(name);
            const uint32_t L = v.levels();
            mutableBrick(v, 4).w[0] = (L + 1) * 8 + uint32_t(delta);
            EXPECT_TRUE(failsWith(reparse(v), {"brick 4:", "level 0 start", std::to_string((L + 1) * 8)})) << name;
        }
    }
}

TEST(MalformedContainer, NibbleLevelStartsDescending) {
    CompressedVolume v = fixtureVolume(kNibble);
    const uint32_t L = v.levels();
    const uint64_t b = findBrick(v, [&](uint64_t i) { return v.brick(i).words[2] > v.brick(i).words[1]; });
    ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
    MutableBrick mb = mutableBrick(v, b);
    mb.w[2] = mb.w[1] - 1;
    EXPECT_TRUE(failsWith(reparse(v), {brickTag(b), "level 2:", "before level 1"}));
    v = fixtureVolume(kNibble);
    mb = mutableBrick(v, b);
    mb.w[1] = mb.w[0] - 1; // before the stream start
    EXPECT_TRUE(failsWith(reparse(v), {brickTag(b), "level 1:", "before level 0"}));
    v = fixtureVolume(kNibble);
    mb = mutableBrick(v, b);
    mb.w[L - 1] = mb.w[L - 2] - 1;
    EXPECT_TRUE(failsWith(reparse(v), {brickTag(b), "level " + std::to_string(L - 1) + ":", "before level"}));
}

TEST(MalformedContainer, NibbleLevelStartInPalette) {
    CompressedVolume v = fixtureVolume(kNibble);
    const uint32_t L = v.levels();
    const uint64_t b = 11;
    MutableBrick mb = mutableBrick(v, b);
    const uint32_t ps = paletteStart(v, b);
    mb.w[L - 1] = ps * 8 + 1;
    EXPECT_TRUE(failsWith(reparse(v), {brickTag(b), "level " + std::to_string(L - 1) + ":", "lies in the palette"}));
    // Every start past the palette (ascending): still the finest start is the one reported.
    for (uint32_t l = 1; l < L; ++l) mb.w[l] = ps * 8 + 64 * l;
    EXPECT_TRUE(failsWith(reparse(v), {brickTag(b), "lies in the palette"}));
    // A start past the brick itself.
    v = fixtureVolume(kNibble);
    mb = mutableBrick(v, b);
    mb.w[L - 1] = 0xFFFFFFF0u;
    EXPECT_TRUE(failsWith(reparse(v), {brickTag(b), "lies in the palette"}));
}

TEST(MalformedContainer, Rans2StreamBStart) {
    const CompressedVolume& good = fixtureVolume(kRans2);
    const uint32_t L = good.levels();
    const uint64_t b = 20;
    const std::string lev = "level " + std::to_string(L - 1) + ":";
    auto check = [&](uint32_t value, const char* what) {
        CompressedVolume v = good;
        mutableBrick(v, b).w[L - 1] = value;
        EXPECT_TRUE(failsWith(reparse(v), {brickTag(b), lev, "stream B start " + std::to_string(value)})) << what;
    };
    const uint32_t s = good.brick(b).words[L - 1];
    const uint32_t ps = paletteStart(good, b);
    check(s + 4, "not a multiple of 8");
    check(s - 1, "not a multiple of 8");
    check((L + 1) * 8, "empty stream A");
    check((L + 1) * 8 - 8, "before stream A");
    check(0, "zero");
    check(ps * 8, "the palette's first word");
    check((ps + 3) * 8, "inside the palette");
    check(0xFFFFFFF8u, "far past the brick");
}

// ------------------------------------------------------------------------------------------------
// 5. Palette size
// ------------------------------------------------------------------------------------------------

TEST(MalformedContainer, PaletteSizeZero) {
    for (const char* name : {kNibble, kRans1, kRans2}) {
        CompressedVolume v = fixtureVolume(name);
        mutableBrick(v, 9).w[v.levels()] = 0;
        EXPECT_TRUE(failsWith(reparse(v), {"brick 9:", "palette size is 0"})) << name;
    }
}

TEST(MalformedContainer, ADamagedBrickOfAPieceKeepsItsPlaceInItsVolume) {
    // MPI ranks draw their piece in the whole volume's index space (embedPiece). A brick of the
    // piece whose header words are wrong made embedPiece refuse the piece, which was then drawn
    // as a volume of its own, its warning numbering the brick within the piece (brick 1 where the
    // file says brick 3; attack pass 8). It is placed now, the one brick unsound, named by its
    // place in the volume.
    for (const char* name : {kNibble, kRans1, kRans2}) {
        const CompressedVolume& whole = fixtureVolume(name);
        const csgv::BrickBox box = csgv::brickPartition(whole.brickGrid(), 2, 1);
        csgv::Result<CompressedVolume> piece = csgv::extractPiece(whole, box);
        ASSERT_TRUE(piece.isOk()) << name << ": " << piece.message();
        const uint64_t own = 1;
        mutableBrick(*piece, own).w[0] = 1015160900u; // a level-0 start far past the brick
        csgv::Result<CompressedVolume> embedded = csgv::embedPiece(*piece, box, whole.dim);
        ASSERT_TRUE(embedded.isOk()) << name << ": " << embedded.message();
        const uint64_t pw = box.hi[0] - box.lo[0], ph = box.hi[1] - box.lo[1];
        const std::array<uint32_t, 3> grid = whole.brickGrid();
        const uint64_t at = (box.lo[0] + own % pw) +
                            grid[0] * ((box.lo[1] + own / pw % ph) + uint64_t(grid[1]) * (box.lo[2] + own / pw / ph));
        uint64_t unsound = 0;
        for (uint64_t b = 0; b < embedded->brickCount(); ++b) unsound += csgv::brickSound(*embedded, b) ? 0 : 1;
        EXPECT_EQ(unsound, 1u) << name;
        EXPECT_FALSE(csgv::brickSound(*embedded, at)) << name;
        EXPECT_TRUE(failsWith(csgv::checkBrick(*embedded, at), {"brick " + std::to_string(at) + ":", "level 0 start"}))
            << name << ": " << csgv::checkBrick(*embedded, at).message();
    }
}

TEST(MalformedContainer, BrickHeadersAreCheckedWhenReached) {
    // Opening reads no brick (O(header + brick starts)): a brick whose header words are wrong
    // opens, is refused by name when reached, and every other brick decodes as before.
    for (const char* name : {kNibble, kRans1, kRans2}) {
        const CompressedVolume& good = fixtureVolume(name);
        CompressedVolume v = good;
        const uint64_t bad = good.brickCount() / 2;
        mutableBrick(v, bad).w[v.levels()] = v.maxPalette + 7;
        const std::vector<uint8_t> bytes = csgv::serializeCsgv(v);
        csgv::Result<CompressedVolume> back = csgv::parseCsgv(bytes.data(), bytes.size());
        ASSERT_TRUE(back.isOk()) << name << ": " << back.message();
        EXPECT_EQ(csgv::summarizePalettes(*back, 0).unsound, std::vector<uint64_t>{bad}) << name;
        EXPECT_FALSE(csgv::brickSound(*back, bad));
        csgv::BrickDecoder dec(*back), ref(good);
        for (uint64_t b = 0; b < good.brickCount(); ++b) {
            const Status s = dec.decode(b, 0);
            if (b == bad) {
                EXPECT_TRUE(failsWith(s, {"brick " + std::to_string(bad) + ":", "exceeds the file's largest palette"}));
                continue;
            }
            ASSERT_TRUE(s.isOk()) << name << " brick " << b << ": " << s.message();
            ASSERT_TRUE(ref.decode(b, 0).isOk());
            const uint64_t n = uint64_t(good.brickSize) * good.brickSize * good.brickSize;
            ASSERT_TRUE(std::equal(dec.labels(), dec.labels() + n, ref.labels())) << name << " brick " << b;
        }
        // A writer refuses it: no file carries the bad brick on.
        const std::string out = ::testing::TempDir() + "/reached_" + name + ".csgv";
        EXPECT_TRUE(failsWith(csgv::writeCsgv(out, *back), {"brick " + std::to_string(bad) + ":"}));
        std::FILE* f = std::fopen(out.c_str(), "rb");
        EXPECT_EQ(f, nullptr) << "a refused write leaves no file";
        if (f) std::fclose(f);
    }
}

TEST(MalformedContainer, APieceCarriesABadBrickOnToBeNamedWhenReached) {
    // An MPI rank reads its piece alone (readCsgvPiece, extractPiece): a bad brick header in it
    // stays bad in the piece (the piece's largest palette ignores it) and is named when reached;
    // the piece's other bricks decode.
    const CompressedVolume& good = fixtureVolume(kRans2);
    CompressedVolume v = good;
    const auto grid = good.brickGrid();
    const uint32_t bx = grid[0] / 2, by = grid[1] / 2, bz = grid[2] / 2;
    const uint64_t bad = bx + uint64_t(grid[0]) * (by + uint64_t(grid[1]) * bz);
    mutableBrick(v, bad).w[v.levels()] = v.maxPalette + 1;
    const std::string path = ::testing::TempDir() + "/piece_bad_header.csgv";
    const std::vector<uint8_t> bytes = csgv::serializeCsgv(v);
    std::FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    ASSERT_EQ(std::fwrite(bytes.data(), 1, bytes.size(), f), bytes.size());
    std::fclose(f);
    csgv::BrickBox box;
    box.lo = {bx, by, bz};
    box.hi = {bx + 1, by + 1, grid[2]};
    const csgv::Result<CompressedVolume> whole = csgv::parseCsgv(bytes.data(), bytes.size());
    ASSERT_TRUE(whole.isOk()) << whole.message();
    for (int from = 0; from < 2; ++from) {
        csgv::Result<CompressedVolume> piece = from ? csgv::extractPiece(*whole, box) : csgv::readCsgvPiece(path, box);
        ASSERT_TRUE(piece.isOk()) << piece.message();
        EXPECT_EQ(csgv::summarizePalettes(*piece, 0).unsound, std::vector<uint64_t>{0}) << "the box's first brick";
        csgv::BrickDecoder dec(*piece);
        EXPECT_TRUE(failsWith(dec.decode(0, 0), {"brick 0:", "exceeds the file's largest palette"}));
        for (uint64_t b = 1; b < piece->brickCount(); ++b) EXPECT_TRUE(dec.decode(b, 0).isOk()) << b;
    }
    std::remove(path.c_str());
}

TEST(MalformedContainer, PaletteSizeLargerThanFileMaximum) {
    for (const char* name : {kNibble, kRans1, kRans2}) {
        CompressedVolume v = fixtureVolume(name);
        mutableBrick(v, 6).w[v.levels()] = v.maxPalette + 1;
        EXPECT_TRUE(failsWith(reparse(v), {"brick 6:", "palette size " + std::to_string(v.maxPalette + 1),
                                           "exceeds the file's largest palette"}))
            << name;
        // The largest palette field itself shrunk below a brick's palette.
        v = fixtureVolume(name);
        v.maxPalette = 0;
        EXPECT_TRUE(failsWith(reparse(v), {"brick 0:", "exceeds the file's largest palette 0"})) << name;
    }
}

TEST(MalformedContainer, PaletteSizeLargerThanBrick) {
    for (const char* name : {kNibble, kRans1, kRans2}) {
        CompressedVolume v = fixtureVolume(name);
        v.maxPalette = 0xFFFFFFFFu;
        MutableBrick mb = mutableBrick(v, 12);
        const uint32_t L = v.levels();
        const uint32_t streamWords = v.encoding == csgv::kEncodingRans2 ? 2 : 1;
        for (uint32_t p : {mb.size, mb.size - L - streamWords, mb.size + 100, 0xFFFFFFFFu}) {
            mb.w[L] = p;
            EXPECT_TRUE(failsWith(reparse(v), {"brick 12:", "palette size " + std::to_string(p), "does not fit"}))
                << name << " palette " << p;
        }
    }
}

// ------------------------------------------------------------------------------------------------
// 11. Frequency tables
// ------------------------------------------------------------------------------------------------

TEST(MalformedContainer, FrequenciesNotSummingTo16384) {
    CompressedVolume v = fixtureVolume(kRans2);
    v.freqA[4] += 1;
    EXPECT_TRUE(failsWith(reparse(v), {"frequency table A", "16385"}));
    v = fixtureVolume(kRans2);
    *std::max_element(v.freqB.begin(), v.freqB.end()) -= 1;
    EXPECT_TRUE(failsWith(reparse(v), {"frequency table B", "16383"}));
    v = fixtureVolume(kRans2);
    v.freqB.fill(0);
    EXPECT_TRUE(failsWith(reparse(v), {"frequency table B", "sums to 0"}));
    v = fixtureVolume(kRans1);
    v.freqA[15] += 100;
    EXPECT_TRUE(failsWith(reparse(v), {"frequency table of mode 1", "16484"}));
    // Sums that reach 16384 only modulo 2^32 are refused too.
    v = fixtureVolume(kRans1);
    v.freqA.fill(0);
    v.freqA[0] = 0xFFFFFFFFu;
    v.freqA[1] = 16385;
    EXPECT_TRUE(failsWith(reparse(v), {"frequency table of mode 1"}));
    v = fixtureVolume(kRans2);
    v.freqA.fill(0x10000000u); // 16 * 2^28 = 2^32
    v.freqA[0] += 16384;
    EXPECT_TRUE(failsWith(reparse(v), {"frequency table A"}));
}

// ------------------------------------------------------------------------------------------------
// 14. Header fields: encoding mode, brick size, dimensions, huge volumes
// ------------------------------------------------------------------------------------------------

TEST(MalformedContainer, EncodingModes) {
    const std::vector<uint8_t> good = csgvtest::fixtureBytes(kRans2);
    for (int32_t mode : {4, 8}) {
        std::vector<uint8_t> b = good;
        poke<int32_t>(b, kOffEncoding, mode);
        EXPECT_TRUE(failsWith(parseStatus(b), {"encoding mode " + std::to_string(mode), "not supported"}));
    }
    for (int32_t mode : {3, -1, 5, 16, 0x7FFFFFFF}) {
        std::vector<uint8_t> b = good;
        poke<int32_t>(b, kOffEncoding, mode);
        EXPECT_TRUE(failsWith(parseStatus(b), {"encoding mode' is " + std::to_string(mode), "expected 0, 1 or 2"}));
    }
}

TEST(MalformedContainer, BrickSize) {
    const std::vector<uint8_t> good = csgvtest::fixtureBytes(kNibble);
    for (uint32_t size : {7u, 256u, 0u, 4u, 1u, 96u, 0x80000000u}) {
        std::vector<uint8_t> b = good;
        poke<uint32_t>(b, kOffBrickSize, size);
        EXPECT_TRUE(failsWith(parseStatus(b), {"brick size' is " + std::to_string(size)}));
    }
    // A valid brick size that does not match the data: the brick count no longer fits.
    std::vector<uint8_t> b = good;
    poke<uint32_t>(b, kOffBrickSize, 32u);
    EXPECT_TRUE(failsWith(parseStatus(b), {"brick start count"}));
}

TEST(MalformedContainer, ZeroDimension) {
    const std::vector<uint8_t> good = csgvtest::fixtureBytes(kRans1);
    for (int a = 0; a < 3; ++a) {
        std::vector<uint8_t> b = good;
        poke<uint32_t>(b, kOffDim + 4 * size_t(a), 0u);
        EXPECT_TRUE(failsWith(parseStatus(b), {"dimension " + std::to_string(a) + " is 0"}));
    }
}

TEST(MalformedContainer, RandomAccessFlag) {
    std::vector<uint8_t> b = csgvtest::fixtureBytes(kRans1);
    b[kOffRandomAccess] = 2;
    EXPECT_TRUE(failsWith(parseStatus(b), {"random access"}));
}

/// A huge claimed volume is refused from the header alone: either its brick count is beyond any
/// real volume, or the brick starts it needs are not in the file; nothing is allocated for them.
TEST(MalformedContainer, HugeVolumeClaimedByHeader) {
    const CompressedVolume& good = fixtureVolume(kNibble);
    const std::vector<uint8_t> bytes = csgv::serializeCsgv(good);
    // 2^31 voxels per axis: 2^81 bricks of 16^3.
    {
        std::vector<uint8_t> b = bytes;
        for (int a = 0; a < 3; ++a) poke<uint32_t>(b, kOffDim + 4 * size_t(a), 1u << 31);
        EXPECT_TRUE(failsWithAny(parseStatus(b), {"bricks", "brick start count"}));
    }
    // Largest dimensions.
    {
        std::vector<uint8_t> b = bytes;
        for (int a = 0; a < 3; ++a) poke<uint32_t>(b, kOffDim + 4 * size_t(a), 0xFFFFFFFFu);
        EXPECT_TRUE(failsWithAny(parseStatus(b), {"bricks", "brick start count"}));
    }
    // A brick start count that matches a huge volume (2^17 x 2^17 x 2^5 bricks of 8^3, 2^60
    // voxels): refused because the starts are not in the file, before anything is allocated.
    {
        std::vector<uint8_t> b = bytes;
        poke<uint32_t>(b, kOffBrickSize, 8u);
        poke<uint32_t>(b, kOffDim + 0, 1u << 20);
        poke<uint32_t>(b, kOffDim + 4, 1u << 20);
        poke<uint32_t>(b, kOffDim + 8, 1u << 8);
        poke<uint64_t>(b, layoutOf(good).startCount, (uint64_t(1) << 39) + 1);
        EXPECT_TRUE(failsWith(parseStatus(b), {"truncated", "brick starts"}));
    }
}

/// Volume dimensions whose brick count overflows 64 bits: 2^31 voxels per axis in bricks of 32
/// are 2^78 bricks, which must not wrap around to a small count (here 0, with one brick start)
/// that the rest of the file can then satisfy. Decoding such a volume would try to visit 2^78
/// bricks and allocate a list of them; it must be refused when parsed.
TEST(MalformedContainer, HugeVolumeWithWrappingBrickCount) {
    CompressedVolume v = fixtureVolume(kRans2);
    ASSERT_EQ(v.brickSize, 32u);
    v.dim = {1u << 31, 1u << 31, 1u << 31};
    v.brickStarts.assign(1, 0); // "bricks + 1" starts for a brick count that wrapped to 0
    v.arrays.assign(1, std::vector<uint32_t>(16, 0));
    const std::vector<uint8_t> b = csgv::serializeCsgv(v);
    csgv::Result<CompressedVolume> r = csgv::parseCsgv(b.data(), b.size());
    // Never decode it here if accepted: decodeVolume would enumerate 2^78 bricks.
    EXPECT_TRUE(failsWith(r.status(), {"volume dimensions"})) << "a 2^93-voxel volume with 0 bricks";
    EXPECT_TRUE(failsWith(csgv::checkContainer(v), {"volume dimensions"}));
    // Same with a brick count that would wrap to exactly 2^64 - 1 + 1 = 0 starts.
    v.brickStarts.clear();
    EXPECT_FALSE(csgv::checkContainer(v).isOk());
    const std::vector<uint8_t> b2 = csgv::serializeCsgv(v);
    EXPECT_FALSE(parseStatus(b2).isOk());
}

// ------------------------------------------------------------------------------------------------
// 15. Detail separation
// ------------------------------------------------------------------------------------------------

TEST(MalformedContainer, DetailSeparatedByte) {
    for (const char* name : {kNibble, kRans2}) {
        std::vector<uint8_t> b = csgvtest::fixtureBytes(name);
        b.back() = 1;
        EXPECT_TRUE(failsWith(parseStatus(b), {"detail separated' is 1"})) << name;
        b.back() = 0xFF;
        EXPECT_TRUE(failsWith(parseStatus(b), {"detail separated' is 255"})) << name;
    }
}

// ------------------------------------------------------------------------------------------------
// Stream errors (nibble streams corrupted at located nodes; rANS streams through their headers)
// ------------------------------------------------------------------------------------------------

/// 7. An operation symbol with (s & 7) == 7.
TEST(MalformedStream, OperationSymbol7) {
    const CompressedVolume& good = fixtureVolume(kNibble);
    const uint32_t L = good.levels();
    const uint64_t b = findBrick(good, [&](uint64_t i) {
        return rootOpen(good, i) && levelEndPos(walkNibbleBrick(good, i), L - 1) > 0;
    });
    ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
    {
        CompressedVolume v = good;
        const auto nodes = walkNibbleBrick(v, b);
        const VisitedNode& n = nodes[1]; // the first level-1 node
        ASSERT_EQ(n.level, 1u);
        setSym(mutableBrick(v, b).w, n.pos, 7);
        expectStreamError(v, b, {brickTag(b), levelTag(1), nodeTag(n.node), "operation symbol 7"});
    }
    {
        // With the stop bit (15) at a level above the finest.
        CompressedVolume v = good;
        const auto nodes = walkNibbleBrick(v, b);
        auto it = std::find_if(nodes.begin(), nodes.end(), [&](const VisitedNode& n) { return n.level == L - 2; });
        ASSERT_NE(it, nodes.end());
        setSym(mutableBrick(v, b).w, it->pos, 15);
        expectStreamError(v, b, {brickTag(b), levelTag(L - 2), nodeTag(it->node), "operation symbol 7"});
    }
    {
        // At the finest level without the stop bit.
        CompressedVolume v = good;
        const auto nodes = walkNibbleBrick(v, b);
        const VisitedNode& n = nodes.back();
        ASSERT_EQ(n.level, L - 1);
        setSym(mutableBrick(v, b).w, n.pos, 7);
        expectStreamError(v, b, {brickTag(b), levelTag(L - 1), nodeTag(n.node), "operation symbol 7"});
    }
}

/// 8. The root must be PALETTE_ADV.
TEST(MalformedStream, RootOperationNotPaletteAdv) {
    for (const char* name : {kNibble, kNibbleDelta}) {
        const CompressedVolume& good = fixtureVolume(name);
        for (uint32_t sym : {0u, 1u, 2u, 3u, 5u, 6u, 7u, 8u, 13u}) {
            CompressedVolume v = good;
            MutableBrick mb = mutableBrick(v, 3);
            setSym(mb.w, mb.w[0], sym);
            expectStreamError(v, 3, {brickTag(3), levelTag(0), nodeTag(0),
                                     "root operation " + std::to_string(sym & 7) + " is not PALETTE_ADV"});
        }
    }
}

/// 9a. A neighbour across the brick boundary: -1 of the first level-1 node along each axis, and
/// +1 of level-1 nodes whose child bit is 1.
TEST(MalformedStream, NeighbourOutsideBrick) {
    const CompressedVolume& good = fixtureVolume(kNibble);
    // An interior brick with an open root: all 8 level-1 nodes are visited.
    const uint64_t b = findBrick(good, [&](uint64_t i) {
        const auto o = brickOrigin(good, i);
        for (int a = 0; a < 3; ++a)
            if (o[a] + good.brickSize > good.dim[a]) return false;
        return rootOpen(good, i);
    });
    ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
    const auto nodes = walkNibbleBrick(good, b);
    ASSERT_GE(nodes.size(), 9u);
    for (int axis = 0; axis < 3; ++axis) {
        const char letter = char('x' + axis);
        {
            CompressedVolume v = good;
            const VisitedNode& n = nodes[1]; // level-1 node 0
            ASSERT_EQ(n.node, 0u);
            setSym(mutableBrick(v, b).w, n.pos, uint32_t(1 + axis));
            expectStreamError(v, b, {brickTag(b), levelTag(1), nodeTag(0),
                                     std::string("neighbour ") + letter + "-1 is outside the brick"});
        }
        {
            CompressedVolume v = good;
            const VisitedNode& n = nodes[1 + (1u << axis)]; // level-1 node with only the axis bit set
            ASSERT_EQ(n.node, 1u << axis);
            setSym(mutableBrick(v, b).w, n.pos, uint32_t(1 + axis) | (n.sym & csgv::kStopBit));
            expectStreamError(v, b, {brickTag(b), levelTag(1), nodeTag(n.node),
                                     std::string("neighbour ") + letter + "+1 is outside the brick"});
        }
    }
}

/// 9b. A +1 neighbour whose parent-level node lies inside the brick but outside the volume
/// (synthA is 133 x 70 x 194: y and z border bricks of 8^3 hold 6 and 2 voxel layers).
TEST(MalformedStream, NeighbourNotInVolume) {
    for (const char* name : {kNibbleDelta, kNibble}) {
        const CompressedVolume& good = fixtureVolume(name);
        uint64_t brick = ~uint64_t(0);
        VisitedNode target;
        int axis = -1;
        for (uint64_t b = 0; b < good.brickCount() && axis < 0; ++b) {
            const auto o = brickOrigin(good, b);
            bool border = false;
            for (int a = 0; a < 3; ++a) border = border || o[a] + good.brickSize > good.dim[a];
            if (!border) continue;
            for (const VisitedNode& n : walkNibbleBrick(good, b)) {
                if (n.level == 0) continue;
                const uint32_t width = good.brickSize >> n.level;
                for (int a = 0; a < 3 && axis < 0; ++a) {
                    const uint32_t c = coordOf(n.node, a);
                    if ((c & 1) == 0) continue;             // a +1 neighbour needs child bit 1
                    const uint32_t pc = (c >> 1) + 1;       // the parent-level node it reads
                    if (pc >= (1u << (n.level - 1))) continue; // that one is outside the brick
                    if (o[a] + pc * 2 * width < good.dim[a]) continue; // that one is in the volume
                    brick = b;
                    target = n;
                    axis = a;
                }
                if (axis >= 0) break;
            }
        }
        ASSERT_GE(axis, 0) << name << ": no node with a +1 neighbour outside the volume";
        CompressedVolume v = good;
        setSym(mutableBrick(v, brick).w, target.pos, uint32_t(1 + axis) | (target.sym & csgv::kStopBit));
        expectStreamError(v, brick, {brickTag(brick), levelTag(target.level), nodeTag(target.node),
                                     std::string("neighbour ") + char('x' + axis) + "+1 is not in the volume"});
    }
}

/// 10. A stop bit at the finest level.
TEST(MalformedStream, StopBitAtFinestLevel) {
    for (const char* name : {kNibble, kNibbleDeltaB}) {
        const CompressedVolume& good = fixtureVolume(name);
        const uint32_t L = good.levels();
        for (uint64_t b : {uint64_t(0), good.brickCount() / 2, good.brickCount() - 1}) {
            const auto nodes = walkNibbleBrick(good, b);
            auto it = std::find_if(nodes.begin(), nodes.end(), [&](const VisitedNode& n) { return n.level == L - 1; });
            if (it == nodes.end()) continue; // a constant brick
            CompressedVolume v = good;
            setSym(mutableBrick(v, b).w, it->pos, it->sym | csgv::kStopBit);
            expectStreamError(v, b, {brickTag(b), levelTag(L - 1), nodeTag(it->node), "stop bit at the finest level"});
        }
    }
}

/// 6. PALETTE_D pointing past the entries appended so far, and with more than 11 groups.
class MalformedPaletteD : public ::testing::TestWithParam<const char*> {};

TEST_P(MalformedPaletteD, DistancePastPalette) {
    const CompressedVolume& good = fixtureVolume(GetParam());
    ASSERT_NE(good.opMask & csgv::kMaskPaletteD, 0u);
    ASSERT_FALSE(good.legacyDelta());
    int done = 0;
    for (uint64_t b = 0; b < good.brickCount() && done < 3; ++b) {
        for (const VisitedNode& n : walkNibbleBrick(good, b)) {
            if ((n.sym & 7) != csgv::kOpPaletteD) continue;
            // Largest distance with the same number of groups: 8^k - 1.
            const uint64_t k = n.groups.size();
            const uint64_t v = (uint64_t(1) << (3 * k)) - 1;
            if (v + 2 <= n.appendedBefore) continue;
            CompressedVolume bad = good;
            MutableBrick mb = mutableBrick(bad, b);
            for (size_t g = 0; g < n.groups.size(); ++g) setSym(mb.w, n.groups[g], g + 1 < n.groups.size() ? 15 : 7);
            expectStreamError(bad, b, {brickTag(b), levelTag(n.level), nodeTag(n.node),
                                       "PALETTE_D distance " + std::to_string(v) + " points past the palette",
                                       "(" + std::to_string(n.appendedBefore) + " entries appended)"});
            ++done;
            break;
        }
    }
    EXPECT_EQ(done, 3) << "not enough PALETTE_D nodes found";
}

TEST_P(MalformedPaletteD, MoreThan11Groups) {
    const CompressedVolume& good = fixtureVolume(GetParam());
    const uint32_t L = good.levels();
    bool done = false;
    for (uint64_t b = 0; b < good.brickCount() && !done; ++b) {
        const BrickWords bw = good.brick(b);
        for (const VisitedNode& n : walkNibbleBrick(good, b)) {
            if ((n.sym & 7) != csgv::kOpPaletteD) continue;
            const uint64_t levelEnd =
                n.level + 1 < L ? uint64_t(bw.words[n.level + 1]) : uint64_t(paletteStart(good, b)) * 8;
            if (n.pos + 12 > levelEnd) continue;
            CompressedVolume bad = good;
            MutableBrick mb = mutableBrick(bad, b);
            for (uint64_t p = n.pos + 1; p <= n.pos + 11; ++p) setSym(mb.w, p, 15);
            expectStreamError(bad, b, {brickTag(b), levelTag(n.level), nodeTag(n.node), "more than 11 groups"});
            done = true;
            break;
        }
    }
    EXPECT_TRUE(done);
}

INSTANTIATE_TEST_SUITE_P(Malformed, MalformedPaletteD, ::testing::Values(kNibbleDelta, kNibbleDeltaB),
                         [](const ::testing::TestParamInfo<const char*>& info) {
                             return std::string(info.param).substr(0, 6);
                         });

/// 12. A stream running past its end.
TEST(MalformedStream, NibbleLevelRunsIntoNextLevel) {
    const CompressedVolume& good = fixtureVolume(kNibble);
    const uint64_t b = findBrick(good, [&](uint64_t i) {
        if (!rootOpen(good, i)) return false;
        const auto nodes = walkNibbleBrick(good, i);
        return std::count_if(nodes.begin(), nodes.end(), [](const VisitedNode& n) { return n.level == 1; }) >= 2;
    });
    ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
    CompressedVolume v = good;
    MutableBrick mb = mutableBrick(v, b);
    mb.w[2] = mb.w[1] + 1; // level 1 now holds one symbol
    const auto nodes = walkNibbleBrick(good, b);
    expectStreamError(v, b, {brickTag(b), levelTag(1), nodeTag(nodes[2].node), "runs past its end"});
}

TEST(MalformedStream, NibbleFinestLevelRunsIntoPalette) {
    const CompressedVolume& good = fixtureVolume(kNibble);
    const uint32_t L = good.levels();
    // Brick whose finest level has more than 16 symbols.
    const uint64_t b = findBrick(good, [&](uint64_t i) {
        return levelEndPos(walkNibbleBrick(good, i), L - 1) > uint64_t(good.brick(i).words[L - 1]) + 16;
    });
    ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
    const auto nodes = walkNibbleBrick(good, b);
    const VisitedNode& firstFinest =
        *std::find_if(nodes.begin(), nodes.end(), [&](const VisitedNode& n) { return n.level == L - 1; });
    {
        // The finest level's start moved onto the palette: no symbol left for it.
        CompressedVolume v = good;
        MutableBrick mb = mutableBrick(v, b);
        mb.w[L - 1] = paletteStart(v, b) * 8;
        expectStreamError(v, b, {brickTag(b), levelTag(L - 1), nodeTag(firstFinest.node), "runs past its end"});
    }
    {
        // The palette enlarged over the stream's last words: the finest level hits the palette.
        CompressedVolume v = good;
        MutableBrick mb = mutableBrick(v, b);
        const uint32_t streamEndWord = uint32_t((levelEndPos(nodes, L - 1) + 7) / 8);
        const uint32_t newPaletteStart = (mb.w[L - 1] + 8 + 7) / 8; // keeps >= 8 finest symbols
        ASSERT_LT(newPaletteStart, streamEndWord);
        mb.w[L] = mb.size - newPaletteStart;
        v.maxPalette = std::max(v.maxPalette, mb.w[L]);
        expectStreamError(v, b, {brickTag(b), levelTag(L - 1), "runs past its end"});
    }
}

TEST(MalformedStream, Rans2StreamAShortened) {
    const CompressedVolume& good = fixtureVolume(kRans2);
    const uint32_t L = good.levels();
    // A brick whose stream A has at least 4 words.
    const uint64_t b = findBrick(good, [&](uint64_t i) { return good.brick(i).words[L - 1] / 8 >= L + 1 + 4; });
    ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
    for (uint32_t newStart : {(L + 2) * 8, good.brick(b).words[L - 1] - 8}) {
        CompressedVolume v = good;
        mutableBrick(v, b).w[L - 1] = newStart;
        expectStreamError(v, b, {brickTag(b)}, {"runs past its end", "stream A fails its end-of-stream check"});
    }
}

TEST(MalformedStream, Rans2PaletteEnlargedIntoStreamB) {
    const CompressedVolume& good = fixtureVolume(kRans2);
    const uint32_t L = good.levels();
    const uint64_t b = findBrick(good, [&](uint64_t i) {
        return paletteStart(good, i) >= good.brick(i).words[L - 1] / 8 + 3; // stream B of >= 3 words
    });
    ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
    for (uint32_t grow : {1u, 2u}) {
        CompressedVolume v = good;
        MutableBrick mb = mutableBrick(v, b);
        mb.w[L] += grow;
        v.maxPalette = std::max(v.maxPalette, mb.w[L]);
        expectStreamError(v, b, {brickTag(b), levelTag(L - 1)},
                          {"runs past its end", "stream B fails its end-of-stream check"});
    }
}

TEST(MalformedStream, Rans1PaletteEnlargedIntoStream) {
    const CompressedVolume& good = fixtureVolume(kRans1);
    const uint32_t L = good.levels();
    const uint64_t b = findBrick(good, [&](uint64_t i) { return paletteStart(good, i) >= L + 1 + 3; });
    ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
    for (uint32_t grow : {1u, 2u}) {
        CompressedVolume v = good;
        MutableBrick mb = mutableBrick(v, b);
        mb.w[L] += grow;
        v.maxPalette = std::max(v.maxPalette, mb.w[L]);
        expectStreamError(v, b, {brickTag(b)}, {"runs past its end", "rANS stream fails its end-of-stream check"});
    }
}

TEST(MalformedStream, RansStateWordCorrupted) {
    for (const char* name : {kRans1, kRans2}) {
        const CompressedVolume& good = fixtureVolume(name);
        const uint32_t L = good.levels();
        CompressedVolume v = good;
        MutableBrick mb = mutableBrick(v, 5);
        mb.w[L + 1] ^= 0x00100000u; // the initial state of the (first) stream
        expectStreamError(v, 5, {brickTag(5)}, {"runs past its end", "end-of-stream check", "is not PALETTE_ADV",
                                                "operation symbol 7", "outside the brick", "not in the volume",
                                                "PALETTE_ADV than the palette size", "stop bit",
                                                "points past the palette", "more than 11 groups"});
    }
}

/// The reserved label 0xFFFFFFFF in a palette entry that the stream appends.
TEST(MalformedStream, ReservedLabelInPalette) {
    for (const char* name : {kNibble, kRans2}) {
        const CompressedVolume& good = fixtureVolume(name);
        const uint32_t L = good.levels();
        {
            CompressedVolume v = good;
            MutableBrick mb = mutableBrick(v, 2);
            mb.w[mb.size - 1] = csgv::kInvalidLabel; // entry 0, the root label
            expectStreamError(v, 2, {brickTag(2), levelTag(0), "palette entry 0", "reserved"});
        }
        {
            const uint64_t b = findBrick(good, [&](uint64_t i) { return good.brick(i).words[L] >= 3; });
            ASSERT_NE(b, kNoBrick);
            CompressedVolume v = good;
            MutableBrick mb = mutableBrick(v, b);
            mb.w[mb.size - 3] = csgv::kInvalidLabel; // entry 2
            expectStreamError(v, b, {brickTag(b), "palette entry 2", "reserved"});
        }
    }
}

/// 13. More PALETTE_ADV than the palette size.
TEST(MalformedStream, MorePaletteAdvThanPaletteSize) {
    {
        const CompressedVolume& good = fixtureVolume(kNibble);
        const uint32_t L = good.levels();
        const uint64_t b = findBrick(good, [&](uint64_t i) { return good.brick(i).words[L] >= 4; });
        ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
        const auto nodes = walkNibbleBrick(good, b);
        for (uint32_t newSize : {1u, 3u}) {
            auto adv = std::find_if(nodes.begin(), nodes.end(), [&](const VisitedNode& n) {
                return (n.sym & 7) == csgv::kOpPaletteAdv && n.appendedBefore == newSize;
            });
            ASSERT_NE(adv, nodes.end());
            CompressedVolume v = good;
            mutableBrick(v, b).w[L] = newSize;
            expectStreamError(v, b, {brickTag(b), levelTag(adv->level), nodeTag(adv->node),
                                     "more PALETTE_ADV than the palette size " + std::to_string(newSize)});
        }
    }
    for (const char* name : {kRans1, kRans2, "denseB_b16_rans2_delta.csgv"}) {
        const CompressedVolume& good = fixtureVolume(name);
        const uint32_t L = good.levels();
        const uint64_t b = findBrick(good, [&](uint64_t i) { return good.brick(i).words[L] >= 3; });
        ASSERT_NE(b, kNoBrick) << "no brick fits the corruption";
        CompressedVolume v = good;
        mutableBrick(v, b).w[L] = 1;
        expectStreamError(v, b, {brickTag(b), "more PALETTE_ADV than the palette size 1"});
    }
}

// ------------------------------------------------------------------------------------------------
// Robustness: seeded random mutations; every call must return, every failure must say why.
// ------------------------------------------------------------------------------------------------

struct MutationStats {
    int runs = 0, parsed = 0, valid = 0;
};

/// Applies one random corruption to a volume's encoding arrays, brick starts or tables.
void mutateVolume(CompressedVolume& v, std::mt19937& rng) {
    auto uni = [&](uint64_t n) { return n ? uint64_t(rng() % n) : 0; };
    std::vector<uint32_t>& arr = v.arrays[0].owned();
    const uint32_t L = v.levels();
    const uint64_t b = uni(v.brickCount());
    const uint32_t begin = v.brickStarts[size_t(b)];
    const uint32_t end = v.brickStarts[size_t(b) + 1];
    const uint32_t size = end - begin;
    // Earlier mutations may have broken the brick starts: then only whole-array mutations apply.
    const bool brickUsable = begin <= end && end <= arr.size() && size >= L + 1;
    switch (brickUsable ? uni(9) : uni(2)) {
    case 0: arr[size_t(uni(arr.size()))] = uint32_t(rng()); break; // a random word
    case 1: arr[size_t(uni(arr.size()))] ^= 1u << uni(32); break;   // a bit flip
    case 2:
    case 3: {
        // One symbol in a brick's stream area (between the header and the palette).
        const uint32_t ps = size - std::min(size, arr[begin + L]);
        const uint64_t lo = uint64_t(L + 1) * 8, hi = std::max<uint64_t>(lo + 1, uint64_t(ps) * 8);
        const uint64_t pos = lo + uni(hi - lo);
        if (pos / 8 < size) setSym(arr.data() + begin, pos, uint32_t(uni(16)));
        break;
    }
    case 4: arr[begin + uni(L + 1)] += uint32_t(int32_t(uni(33)) - 16); break; // a header word nudged
    case 5: arr[begin + uni(L + 1)] = uint32_t(uni(uint64_t(size) * 8 + 16)); break;
    case 6: {
        // A palette word: either a random label or the reserved 0xFFFFFFFF.
        const uint32_t p = std::min(size, arr[begin + L]);
        if (p) arr[begin + size - 1 - uni(p)] = uni(4) ? uint32_t(rng()) : 0xFFFFFFFFu;
        break;
    }
    case 7: v.brickStarts[size_t(uni(v.brickStarts.size()))] += uint32_t(int32_t(uni(9)) - 4); break;
    case 8: {
        // Frequencies moved between symbols (the sum stays 16384; zero frequencies appear).
        if (v.encoding == csgv::kEncodingNibble) {
            v.opMask ^= 1u << uni(9);
            break;
        }
        auto& t = (v.encoding == csgv::kEncodingRans2 && uni(2)) ? v.freqB : v.freqA;
        const size_t s = size_t(uni(16)), d = size_t(uni(16));
        const uint32_t amount = uint32_t(uni(uint64_t(t[s]) + 1));
        t[s] -= amount;
        t[d] += amount;
        break;
    }
    }
}

void exerciseBytes(const std::vector<uint8_t>& bytes, MutationStats& stats) {
    ++stats.runs;
    csgv::Result<CompressedVolume> r = csgv::parseCsgv(bytes.data(), bytes.size());
    if (!r.isOk()) {
        EXPECT_FALSE(r.message().empty()) << "parse failure without a message";
        return;
    }
    ++stats.parsed;
    const CompressedVolume& v = *r;
    const Status all = csgv::validateStreams(v, 1);
    if (!all.isOk()) { EXPECT_FALSE(all.message().empty()) << "validateStreams failure without a message"; }
    stats.valid += all.isOk();
    csgv::DecodeOptions options;
    options.threads = 1;
    options.maxOutputBytes = uint64_t(64) << 20;
    for (uint32_t lod = 0; lod < v.levels(); ++lod) {
        csgv::Result<csgv::LabelVolume> d = csgv::decodeVolume(v, lod, options);
        if (!d.isOk()) {
            EXPECT_FALSE(d.message().empty()) << "decodeVolume failure without a message";
            // Coarser levels read a prefix of the same symbols: a valid volume decodes at every lod.
            EXPECT_FALSE(all.isOk()) << "validateStreams accepted what decodeVolume(lod " << lod
                                     << ") refuses: " << d.message();
            continue;
        }
        if (lod == 0) { EXPECT_TRUE(all.isOk()) << "decodeVolume(lod 0) accepted what validateStreams refuses"; }
        // 0xFFFFFFFF is reserved: it may never reach an output voxel.
        EXPECT_TRUE(std::find(d->labels.begin(), d->labels.end(), csgv::kInvalidLabel) == d->labels.end())
            << "an output voxel holds the reserved label at lod " << lod;
    }
    // One brick decoded at every lod with a reused decoder.
    if (v.brickCount() == 0) return;
    BrickDecoder decoder(v);
    for (uint32_t lod = v.levels(); lod-- > 0;) {
        const Status s = decoder.decode(v.brickCount() - 1, lod);
        if (!s.isOk()) { EXPECT_FALSE(s.message().empty()); }
    }
}

TEST(MalformedRobustness, RandomMutationsNeverCrash) {
    struct Source {
        const char* name;
        std::array<uint32_t, 3> first, count;
    };
    // Small sub-volumes (a few bricks, border bricks included) of fixtures of every mode and mask.
    const Source sources[] = {
        {kNibble, {6, 3, 10}, {3, 2, 3}},                         // mode 0, pnls, volume border
        {kNibbleDelta, {14, 6, 21}, {3, 3, 4}},                   // mode 0, PALETTE_D, border
        {kNibbleDeltaB, {1, 0, 0}, {2, 2, 1}},                    // mode 0, PALETTE_D, dense palettes
        {kRans1, {2, 1, 5}, {3, 2, 2}},                           // mode 1
        {"denseB_b32_rans1.csgv", {2, 1, 1}, {1, 1, 1}},          // mode 1, dense
        {kRans2, {3, 1, 4}, {2, 2, 3}},                           // mode 2
        {"synthA_b32_rans2_nostop.csgv", {1, 1, 2}, {2, 1, 1}},   // mode 2, no stop bits
        {"synthA_b16_rans2_legacydelta.csgv", {6, 2, 10}, {3, 3, 3}}, // mode 2, legacy PALETTE_D
        {"denseB_b16_rans2_delta.csgv", {3, 2, 1}, {2, 2, 2}},    // mode 2, PALETTE_D
        {"synthA_b64_rans2_delta.csgv", {1, 0, 2}, {2, 1, 2}},    // mode 2, 64^3 bricks
    };
    // CSGV_MALFORMED_MUTATIONS and CSGV_MALFORMED_SEED override the defaults for longer local runs.
    const char* envCount = std::getenv("CSGV_MALFORMED_MUTATIONS");
    const char* envSeed = std::getenv("CSGV_MALFORMED_SEED");
    const int total = envCount ? std::max(10, std::atoi(envCount)) : 3000;
    const uint32_t seed = envSeed ? uint32_t(std::strtoul(envSeed, nullptr, 10)) : 20240611u;
    const int perSource = total / int(sizeof(sources) / sizeof(sources[0]));
    std::mt19937 rng(seed);
    const auto t0 = std::chrono::steady_clock::now();
    MutationStats stats;
    for (const Source& src : sources) {
        const CompressedVolume base = cropBricks(fixtureVolume(src.name), src.first, src.count);
        ASSERT_TRUE(csgv::validateStreams(base, 1).isOk()) << src.name;
        const std::vector<uint8_t> baseBytes = csgv::serializeCsgv(base);
        for (int i = 0; i < perSource; ++i) {
            std::vector<uint8_t> bytes;
            if (rng() % 8 == 0) {
                // Byte-level damage anywhere in the file, biased to the header and brick starts.
                bytes = baseBytes;
                const int flips = 1 + int(rng() % 3);
                for (int f = 0; f < flips; ++f) {
                    const size_t span = rng() % 2 ? std::min<size_t>(bytes.size(), 256) : bytes.size();
                    const size_t at = rng() % span;
                    if (rng() % 2) bytes[at] ^= uint8_t(1u << (rng() % 8));
                    else bytes[at] = uint8_t(rng());
                }
            } else {
                CompressedVolume v = base;
                const int count = 1 + int(rng() % 3);
                for (int m = 0; m < count; ++m) mutateVolume(v, rng);
                bytes = csgv::serializeCsgv(v);
            }
            exerciseBytes(bytes, stats);
            if (::testing::Test::HasFailure()) {
                ADD_FAILURE() << src.name << ": mutation " << i << " with seed " << seed << " (see above)";
                return;
            }
        }
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::cout << "[ INFO     ] " << stats.runs << " mutations: " << stats.parsed << " parsed, " << stats.valid
              << " decoded without error, " << seconds << " s\n";
    EXPECT_EQ(stats.runs, perSource * int(sizeof(sources) / sizeof(sources[0])));
    EXPECT_GT(stats.parsed, stats.runs / 4) << "mutations should mostly reach the stream decoder";
}

} // namespace
