// SPDX-License-Identifier: MIT
/// @file test_input_precomputed.cpp
/// @brief Tests of Neuroglancer precomputed input. Fixtures are written at test time by
/// Testing/Core/inputs/make_precomputed.py (numpy, with its own compressed_segmentation encoder
/// written from the specification), together with the exact volume each should read as.
#include "TestData.h"

#include "csgv/base/FileUtil.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/inputs/Compress.h"
#include "csgv/inputs/Inputs.h"
#include "csgv/inputs/PrecomputedFormat.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>

using namespace csgv;
using namespace csgvtest;

namespace {

/// The fixture folder (written once per test process).
const std::string& fixtures() {
    static const std::string dir = [] {
        const std::string d = tempDir() + "/precomputed";
        EXPECT_EQ(runFixtureScript("make_precomputed.py", {d}), 0);
        return d;
    }();
    return dir;
}

std::string volumeDir(const std::string& name) { return fixtures() + "/" + name; }

/// A volume the script wrote as little-endian uint64, x fastest.
std::vector<uint64_t> expectedValues(const std::string& file) {
    Result<std::vector<uint8_t>> bytes = readFile(file, 64 << 20);
    EXPECT_TRUE(bytes.isOk()) << bytes.message();
    std::vector<uint64_t> v(bytes->size() / 8);
    for (size_t i = 0; i < v.size(); ++i)
        for (int k = 0; k < 8; ++k) v[i] |= uint64_t((*bytes)[8 * i + k]) << (8 * k);
    return v;
}

std::unique_ptr<InputSource> openOk(const std::string& path, const InputOptions& options = {}) {
    Result<std::unique_ptr<InputSource>> s = openInput(path, options);
    EXPECT_TRUE(s.isOk()) << path << ": " << s.message();
    return s.isOk() ? std::move(*s) : nullptr;
}

std::vector<uint64_t> readWhole(InputSource& s) {
    Result<InputVolume> v = readAll(s, "precomputed");
    EXPECT_TRUE(v.isOk()) << v.message();
    return v.isOk() ? v->values : std::vector<uint64_t>();
}

/// The message of opening `path` and reading it whole (the first step that fails).
std::string errorOf(const std::string& path) {
    Result<std::unique_ptr<InputSource>> s = openInput(path);
    if (!s) return s.message();
    Result<InputVolume> v = readAll(**s, path);
    EXPECT_FALSE(v.isOk()) << path << " was read without an error";
    return v.message();
}

/// Compresses to `.csgv` and decodes level 0 (original labels, or dense ids when relabelled).
std::vector<uint32_t> roundTrip(const std::string& input, const std::string& name, CompressReport& report) {
    const std::string out = tempDir() + "/" + name + ".csgv";
    Status s = compressToFile(input, out, CompressOptions(), &report);
    EXPECT_TRUE(s.isOk()) << s.message();
    Result<CsgvFile> file = openCsgv(out);
    EXPECT_TRUE(file.isOk()) << file.message();
    if (!file) return {};
    Result<LabelVolume> labels = decodeVolume(file->volume, 0, file->decodeOptions());
    EXPECT_TRUE(labels.isOk()) << labels.message();
    return labels.isOk() ? labels->labels : std::vector<uint32_t>();
}

} // namespace

TEST(Precomputed, RawUint32WithOffsetAndPartialChunks) {
    const std::string dir = volumeDir("raw_u32");
    auto s = openOk(dir);
    ASSERT_TRUE(s);
    const InputInfo& info = s->info();
    EXPECT_EQ(info.format, "precomputed");
    EXPECT_EQ(info.detail, "scale 4_6_40, chunks 16x16x8, raw, uint32");
    EXPECT_EQ(info.type, LabelType::U32);
    EXPECT_EQ(info.dim, (std::array<uint32_t, 3>{{37, 29, 21}}));
    EXPECT_EQ(info.geometry.spacing, (std::array<double, 3>{{4, 6, 40}}));
    // origin = voxel_offset * resolution: the centre of voxel (0, 0, 0).
    EXPECT_EQ(info.geometry.origin, (std::array<double, 3>{{20, -18, 400}}));
    const std::vector<uint64_t> expected = expectedValues(dir + "/expected.u64");
    ASSERT_EQ(expected.size(), info.voxelCount());
    EXPECT_TRUE(readWhole(*s) == expected);
    expectSourceContract(*s, expected);
    CompressReport report;
    const std::vector<uint32_t> labels = roundTrip(dir, "raw_u32", report);
    EXPECT_FALSE(report.relabelled);
    ASSERT_EQ(labels.size(), expected.size());
    for (size_t i = 0; i < labels.size(); ++i) ASSERT_EQ(labels[i], expected[i]) << "voxel " << i;
}

TEST(Precomputed, PathForms) {
    const std::string dir = volumeDir("raw_u32");
    for (const std::string& p : {dir, dir + "/", dir + "/info", dir + "#0", dir + "/#4_6_40", dir + "/info#0"}) {
        EXPECT_TRUE(isInputPath(p)) << p;
        auto s = openOk(p);
        ASSERT_TRUE(s) << p;
        EXPECT_EQ(s->info().detail, "scale 4_6_40, chunks 16x16x8, raw, uint32") << p;
    }
    EXPECT_FALSE(isInputPath(dir + "/4_6_40"));
    EXPECT_FALSE(isInputPath(fixtures() + "/no_such_volume"));
    const std::string e = errorOf(dir + "#7");
    EXPECT_NE(e.find(dir + "/info: no scale '7' (scales 0..0: '4_6_40')"), std::string::npos) << e;
}

TEST(Precomputed, CompressedSegmentationUint32) {
    const std::string dir = volumeDir("cs_u32");
    auto s = openOk(dir);
    ASSERT_TRUE(s);
    EXPECT_EQ(s->info().detail, "scale 8_8_8, chunks 20x20x12, compressed_segmentation 8x6x6, uint32");
    EXPECT_EQ(s->info().dim, (std::array<uint32_t, 3>{{45, 38, 27}}));
    EXPECT_EQ(s->info().geometry.origin, (std::array<double, 3>{{512, 0, 1024}}));
    const std::vector<uint64_t> expected = expectedValues(dir + "/expected.u64");
    ASSERT_EQ(expected.size(), s->info().voxelCount());
    // The missing chunk (x 20..39, y 0..19, z 0..11) reads as background.
    EXPECT_EQ(expected[20 + 45 * (5 + 38 * 3)], 0u);
    EXPECT_TRUE(readWhole(*s) == expected);
    expectSourceContract(*s, expected);
    CompressReport report;
    const std::vector<uint32_t> labels = roundTrip(dir, "cs_u32", report);
    EXPECT_FALSE(report.relabelled);
    ASSERT_EQ(labels.size(), expected.size());
    for (size_t i = 0; i < labels.size(); ++i) ASSERT_EQ(labels[i], expected[i]) << "voxel " << i;
    // The missing chunk is a uniform box of background (a volume of them compresses per brick,
    // issue 37, item 4), and the encoder writes the bytes of reading it.
    std::vector<csgv::UniformBox> boxes;
    s->uniformBoxes(0, 12, 0, 20, boxes);
    ASSERT_EQ(boxes.size(), 1u);
    EXPECT_EQ(boxes[0].lo, (std::array<uint32_t, 3>{{20, 0, 0}}));
    EXPECT_EQ(boxes[0].hi, (std::array<uint32_t, 3>{{40, 20, 12}}));
    EXPECT_EQ(boxes[0].value, 0u);
    std::string bytes[2];
    for (int fast = 0; fast < 2; ++fast) {
        csgv::CompressOptions options;
        options.encode.brickSize = 8;
        options.encode.useUniformBoxes = fast == 1;
        const std::string out = csgvtest::tempDir() + "/cs_u32_uniform" + std::to_string(fast) + ".csgv";
        const csgv::Status st = csgv::compressToFile(dir, out, options);
        ASSERT_TRUE(st.isOk()) << st.message();
        std::ifstream f(out, std::ios::binary);
        bytes[fast].assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    }
    EXPECT_TRUE(!bytes[0].empty() && bytes[0] == bytes[1]) << "the missing chunk's box changed the bytes";
}

TEST(Precomputed, CompressedSegmentationUint64AboveTwoTo32IsRelabelled) {
    const std::string dir = volumeDir("cs_u64");
    auto s = openOk(dir);
    ASSERT_TRUE(s);
    EXPECT_EQ(s->info().type, LabelType::U64);
    EXPECT_EQ(s->info().detail, "scale 8_8_8, chunks 20x20x12, compressed_segmentation 8x6x6, uint64");
    const std::vector<uint64_t> expected = expectedValues(dir + "/expected.u64");
    ASSERT_EQ(expected.size(), s->info().voxelCount());
    EXPECT_GT(*std::max_element(expected.begin(), expected.end()), uint64_t(1) << 40);
    EXPECT_TRUE(readWhole(*s) == expected);
    expectSourceContract(*s, expected);
    // Labels above 2^32 become dense ids: the same partition of the voxels, 0 staying 0.
    CompressReport report;
    const std::vector<uint32_t> labels = roundTrip(dir, "cs_u64", report);
    EXPECT_TRUE(report.relabelled);
    ASSERT_EQ(labels.size(), expected.size());
    std::map<uint64_t, uint32_t> forward;
    std::map<uint32_t, uint64_t> backward;
    for (size_t i = 0; i < labels.size(); ++i) {
        EXPECT_EQ(expected[i] == 0, labels[i] == 0) << "voxel " << i;
        const auto f = forward.emplace(expected[i], labels[i]).first;
        const auto b = backward.emplace(labels[i], expected[i]).first;
        ASSERT_EQ(f->second, labels[i]) << "voxel " << i;
        ASSERT_EQ(b->second, expected[i]) << "voxel " << i;
    }
    // Dense ids: 0 and 1..n for the n labels other than 0.
    EXPECT_EQ(*std::max_element(labels.begin(), labels.end()) + size_t(1), forward.size());
}

TEST(Precomputed, ScaleSelectorAndNestedLayout) {
    const std::string dir = volumeDir("two_scales");
    auto full = openOk(dir);
    ASSERT_TRUE(full);
    EXPECT_EQ(full->info().dim, (std::array<uint32_t, 3>{{24, 20, 16}}));
    EXPECT_TRUE(readWhole(*full) == expectedValues(dir + "/expected.u64"));
    const std::vector<uint64_t> expected1 = expectedValues(dir + "/expected1.u64");
    for (const std::string& p : {dir + "#1", dir + "#half", dir + "/info#1"}) {
        auto half = openOk(p);
        ASSERT_TRUE(half) << p;
        EXPECT_EQ(half->info().dim, (std::array<uint32_t, 3>{{12, 10, 8}})) << p;
        EXPECT_EQ(half->info().geometry.spacing, (std::array<double, 3>{{4, 4, 6}})) << p;
        EXPECT_EQ(half->info().geometry.origin, (std::array<double, 3>{{4, 8, 18}})) << p;
        EXPECT_EQ(half->info().detail, "scale half, chunks 8x8x8, compressed_segmentation 4x4x4, uint32") << p;
        EXPECT_TRUE(readWhole(*half) == expected1) << p;
        expectSourceContract(*half, expected1);
    }
}

TEST(Precomputed, WorkingMemoryStaysWithinTheLimit) {
    const std::string dir = volumeDir("cs_u32");
    const std::vector<uint64_t> expected = expectedValues(dir + "/expected.u64");
    // A layer is 45 * 38 * 12 voxels (164 KB); one chunk 20 * 20 * 12 (38 KB); the layer is cached
    // when it fits beside a chunk and the largest chunk file its encoding allows.
    const uint64_t worstFile =
        csgv::inputs::compressedSegmentationBound(LabelType::U32, {{20, 20, 12}}, {{8, 6, 6}});
    InputOptions cached;
    cached.maxWorkingBytes = 45 * 38 * 12 * 8 + 20 * 20 * 12 * 8 + worstFile;
    InputOptions perRequest;
    perRequest.maxWorkingBytes = 45 * 38 * 12 * 8; // no room for the layer beside a chunk
    for (const InputOptions& o : {cached, perRequest}) {
        auto s = openOk(dir, o);
        ASSERT_TRUE(s);
        expectSourceContract(*s, expected);
        EXPECT_LE(s->workingBytes(), o.maxWorkingBytes);
        EXPECT_GT(s->workingBytes(), 0u);
        if (o.maxWorkingBytes == cached.maxWorkingBytes) {
            EXPECT_GE(s->workingBytes(), 45u * 38 * 12 * 8); // a whole layer is kept
        }
    }
    auto s = openOk(dir, perRequest);
    ASSERT_TRUE(s);
    std::vector<uint64_t> slab(45 * 38);
    ASSERT_TRUE(s->readSlab(26, 1, slab.data()).isOk());
    // One (clipped) chunk, no layer; and the index of the chunk files (12 bytes each, room for 256).
    EXPECT_GE(s->workingBytes(), 20u * 20 * 3 * 8);
    EXPECT_LE(s->workingBytes(), 20u * 20 * 3 * 8 + 256 * 12);
    InputOptions tiny;
    tiny.maxWorkingBytes = 1000;
    const Result<std::unique_ptr<InputSource>> r = openInput(dir, tiny);
    ASSERT_FALSE(r.isOk());
    EXPECT_NE(r.message().find("/info: a decoded 20 x 20 x 12 chunk needs 38400 bytes and its file more, beyond the "
                               "working memory limit of 1000"),
              std::string::npos)
        << r.message();
}

TEST(Precomputed, BadInputsAreClearErrors) {
    struct Case {
        const char* folder;
        std::string expected; ///< after the folder's path
    };
    const std::vector<Case> cases = {
        {"bad_sharded", "/info: scale \"s\": sharded precomputed volumes are not supported"},
        {"bad_jpeg", "/info: scale \"s\": encoding \"jpeg\" is not supported (labels need \"raw\" or "
                     "\"compressed_segmentation\")"},
        {"bad_channels", "/info: \"num_channels\" is 2 (a label volume has 1 channel)"},
        {"bad_no_scales", "/info: missing \"scales\""},
        {"bad_no_size", "/info: scale 0: missing \"size\""},
        {"bad_not_json", "/info: is not valid JSON"},
        {"bad_dtype", "/info: unsupported \"data_type\" \"float32\" (labels must be uint8, uint16, uint32 or uint64)"},
        {"bad_truncated", "/s/0-8_0-8_0-8: raw chunk has 2045 bytes, expected 2048 (8x8x8 voxels of uint32)"},
        {"bad_cs_table", "/s/0-8_0-8_0-8: compressed_segmentation block (1, 1, 0): lookup table offset 16777215 is "
                         "outside the "},
        {"bad_cs_values", "/s/0-8_0-8_0-8: compressed_segmentation block (1, 0, 1): encoded values at word "
                          "2147483647 (4 words) run past the "},
        {"bad_cs_channel", "/s/0-8_0-8_0-8: compressed_segmentation channel offset "},
        {"bad_gz_bomb", "/s/0-8_0-8_0-8.gz: inflates to more than the limit of 2049 bytes"},
        {"bad_cs_block", "/info: scale 0: \"compressed_segmentation_block_size\" 16x8x8 is larger than the chunk "
                         "size 8x8x8"},
        {"bad_deep", "/info: nests arrays or objects more than 64 levels deep"},
        {"bad_huge_chunk", "/info: a decoded 65536 x 32768 x 1073741824 chunk needs more than 2^64 bytes and its "
                           "file more, beyond the working memory limit of "},
    };
    // A scale whose chunk folder is missing (a wrong key, or an incomplete copy).
    const std::string noChunks = tempDir() + "/precomputed_no_chunks";
    std::filesystem::create_directories(noChunks);
    std::filesystem::copy_file(volumeDir("raw_u32") + "/info", noChunks + "/info");
    EXPECT_EQ(errorOf(noChunks), noChunks + "/info: the chunk folder of scale '4_6_40' (" + noChunks +
                                     "/4_6_40) does not exist");
    for (const Case& c : cases) {
        const std::string dir = volumeDir(c.folder);
        const std::string e = errorOf(dir);
        EXPECT_EQ(e.find(dir + c.expected), 0u) << c.folder << ": " << e;
    }
}

TEST(Precomputed, FormatFunctionsRejectBadBytes) {
    using namespace csgv::inputs;
    std::vector<uint64_t> out(8);
    const std::array<uint32_t, 3> e{{2, 2, 2}}, b{{2, 2, 2}};
    // Too short for the one block header; not whole words; a bit width the format does not have.
    const uint8_t headerOnly[] = {1, 0, 0, 0};
    EXPECT_EQ(decodeCompressedSegmentation(headerOnly, 4, LabelType::U32, e, b, out.data()).message(),
              "compressed_segmentation channel offset 1 is outside the 1 words of data");
    const uint8_t odd[] = {1, 0, 0};
    EXPECT_EQ(decodeCompressedSegmentation(odd, 3, LabelType::U32, e, b, out.data()).message(),
              "compressed_segmentation data of 3 bytes is not a whole number of 32-bit words");
    const uint8_t bits3[] = {1, 0, 0, 0, 2, 0, 0, 3, 3, 0, 0, 0, 7, 0, 0, 0};
    EXPECT_EQ(decodeCompressedSegmentation(bits3, sizeof bits3, LabelType::U32, e, b, out.data()).message(),
              "compressed_segmentation block (0, 0, 0) has 3 encoded bits (must be 0, 1, 2, 4, 8, 16 or 32)");
    // A block of one value (0 bits): table at word 2 of the channel.
    const uint8_t one[] = {1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 7, 0, 0, 0};
    ASSERT_TRUE(decodeCompressedSegmentation(one, sizeof one, LabelType::U32, e, b, out.data()).isOk());
    EXPECT_EQ(out, std::vector<uint64_t>(8, 7));
    // The same table read as uint64 needs two words: only one is there.
    EXPECT_NE(decodeCompressedSegmentation(one, sizeof one, LabelType::U64, e, b, out.data()).message().find(
                  "lookup table offset 2 is outside the 3 words of data"),
              std::string::npos);
    EXPECT_EQ(parsePrecomputedInfo(nullptr, 0).message(), "is not valid JSON");
    const auto parse = [](const std::string& text) {
        return parsePrecomputedInfo(reinterpret_cast<const uint8_t*>(text.data()), text.size());
    };
    const std::string scale = R"({"key": "k", "size": [4, 5.0, 6], "resolution": [1, 2.5, 3], "chunk_sizes": [[4, 4, 4]], )";
    // An integer image is read as labels; sizes written as 5.0 are integers.
    Result<PrecomputedInfo> image =
        parse(R"({"type": "image", "data_type": "UINT16", "num_channels": 1, "scales": [)" + scale + R"("encoding": "raw"}]})");
    ASSERT_TRUE(image.isOk()) << image.message();
    EXPECT_EQ(image->type, LabelType::U16);
    EXPECT_EQ(image->scales[0].size, (std::array<uint32_t, 3>{{4, 5, 6}}));
    EXPECT_EQ(image->scales[0].resolution, (std::array<double, 3>{{1, 2.5, 3}}));
    EXPECT_EQ(image->scales[0].voxelOffset, (std::array<int64_t, 3>{{0, 0, 0}}));
    // compressed_segmentation of uint16 is refused when the scale is used, not when parsed.
    Result<PrecomputedInfo> cs16 = parse(R"({"type": "segmentation", "data_type": "uint16", "num_channels": 1, "scales": [)" +
                                         scale + R"("encoding": "compressed_segmentation",
                                                    "compressed_segmentation_block_size": [4, 4, 4]}]})");
    ASSERT_TRUE(cs16.isOk()) << cs16.message();
    EXPECT_EQ(checkPrecomputedScale(*cs16, cs16->scales[0]).message(),
              "scale \"k\": compressed_segmentation needs uint32 or uint64 labels, not uint16");
    EXPECT_EQ(parse(R"({"type": "segmentation", "data_type": "uint32", "num_channels": 1, "scales": [)" + scale +
                    R"("encoding": "compressed_segmentation"}]})")
                  .message(),
              "scale 0: missing \"compressed_segmentation_block_size\"");
    EXPECT_EQ(parse(R"({"type": "segmentation", "data_type": "uint32", "num_channels": 1, "scales": [)"
                    R"({"key": "k", "size": [4, 0, 6], "resolution": [1, 1, 1], "chunk_sizes": [[4, 4, 4]], "encoding": "raw"}]})")
                  .message(),
              "scale 0: \"size\" element 1 is 0, not an integer in 1..2147483647");
    EXPECT_EQ(parse(R"({"type": "mesh", "data_type": "uint32"})").message(),
              "\"type\" is \"mesh\" (must be \"segmentation\" or \"image\")");
    const std::string notObject = "[1, 2]";
    EXPECT_EQ(parsePrecomputedInfo(reinterpret_cast<const uint8_t*>(notObject.data()), notObject.size()).message(),
              "is an array of 2 elements, not a JSON object");
}

TEST(Precomputed, HugeGridsAndContainersInMessagesAreSafe) {
    using namespace csgv::inputs;
    // 2^22 * 2^21 * 2^21 blocks of one voxel: the product wraps to 0 in 64 bits, which once let
    // the header check pass and the decoder read past the 4 words.
    std::vector<uint64_t> out(8);
    const uint8_t data[] = {1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 7, 0, 0, 0};
    const std::array<uint32_t, 3> extent{{1u << 22, 1u << 21, 1u << 21}}, block{{1, 1, 1}};
    EXPECT_EQ(decodeCompressedSegmentation(data, sizeof data, LabelType::U32, extent, block, out.data()).message(),
              "compressed_segmentation data of 3 words is too short for the 18446744073709551615 block headers of a "
              "4194304x2097152x2097152 chunk in blocks of 1x1x1");
    EXPECT_EQ(compressedSegmentationBound(LabelType::U64, extent, block), std::numeric_limits<uint64_t>::max());
    // A container where a scalar belongs is described, never dumped (dumping recurses).
    const std::string text = R"({"type": "segmentation", "data_type": "uint32", "num_channels": [[1, 2], [3]],
                                 "scales": []})";
    EXPECT_EQ(parsePrecomputedInfo(reinterpret_cast<const uint8_t*>(text.data()), text.size()).message(),
              "\"num_channels\" is an array of 2 elements, not an integer in 0..9223372036854775807");
}

TEST(Precomputed, SlabsOutsideTheVolumeAreRefusedEvenEmpty) {
    // InputCommon's checkSlab, as every format: an empty slab may start at the end, not beyond.
    const std::string dir = volumeDir("raw_u32");
    auto s = openOk(dir);
    ASSERT_TRUE(s);
    std::vector<uint64_t> slab(37 * 29 * 2);
    EXPECT_TRUE(s->readSlab(21, 0, slab.data()).isOk());
    EXPECT_EQ(s->readSlab(22, 0, slab.data()).message(), dir + "/4_6_40: slab z 22 to 22 is beyond the volume's depth 21");
    EXPECT_EQ(s->readSlab(20, 2, slab.data()).message(), dir + "/4_6_40: slab z 20 to 22 is beyond the volume's depth 21");
}

namespace {

/// @brief A chunk of a sparse raw uint32 scale and how its file is named.
struct SparseChunk {
    std::array<uint32_t, 3> g; ///< grid position x, y, z
    enum class Name { Flat, Gzip, Nested } name;
};

/// Writes a raw uint32 precomputed volume of `size` (x, y, z) in `chunk`-sized chunks with
/// `offset` as voxel_offset, scale key "s", and a file for each of `written` (each voxel of chunk
/// i holds 1000 * (i + 1) + its index in the chunk). Returns the volume the reader must give
/// (empty when it would pass 2^24 voxels).
std::vector<uint64_t> writeSparseScale(const std::string& dir, std::array<uint32_t, 3> size, std::array<uint32_t, 3> chunk,
                                       std::array<int64_t, 3> offset, const std::vector<SparseChunk>& written) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir + "/s");
    std::ofstream(dir + "/info") << "{\"type\": \"segmentation\", \"data_type\": \"uint32\", \"num_channels\": 1, "
                                    "\"scales\": [{\"key\": \"s\", \"size\": ["
                                 << size[0] << ", " << size[1] << ", " << size[2] << "], \"chunk_sizes\": [[" << chunk[0]
                                 << ", " << chunk[1] << ", " << chunk[2] << "]], \"encoding\": \"raw\", \"voxel_offset\": ["
                                 << offset[0] << ", " << offset[1] << ", " << offset[2]
                                 << "], \"resolution\": [1, 1, 1]}]}";
    const bool small = uint64_t(size[0]) * size[1] * size[2] <= (uint64_t(1) << 24);
    std::vector<uint64_t> expected(small ? size_t(uint64_t(size[0]) * size[1] * size[2]) : 0, 0);
    for (size_t i = 0; i < written.size(); ++i) {
        std::array<uint32_t, 3> lo{}, extent{};
        std::array<std::string, 3> range;
        for (size_t a = 0; a < 3; ++a) {
            lo[a] = written[i].g[a] * chunk[a];
            extent[a] = std::min(chunk[a], size[a] - lo[a]);
            range[a] = std::to_string(offset[a] + lo[a]) + "-" + std::to_string(offset[a] + lo[a] + extent[a]);
        }
        Bytes bytes;
        for (uint32_t e = 0; e < extent[0] * extent[1] * extent[2]; ++e) {
            const uint32_t v = uint32_t(1000 * (i + 1) + e);
            for (int k = 0; k < 4; ++k) bytes.push_back(uint8_t(v >> (8 * k)));
            const uint64_t x = lo[0] + e % extent[0], y = lo[1] + (e / extent[0]) % extent[1], z = lo[2] + e / (extent[0] * extent[1]);
            if (small) expected[size_t(x + size[0] * (y + uint64_t(size[1]) * z))] = v;
        }
        const std::string flat = dir + "/s/" + range[0] + "_" + range[1] + "_" + range[2];
        switch (written[i].name) {
        case SparseChunk::Name::Flat: writeBytes(flat, bytes); break;
        case SparseChunk::Name::Gzip: writeBytes(flat + ".gz", gzipBytes(bytes)); break;
        case SparseChunk::Name::Nested:
            std::filesystem::create_directories(dir + "/s/" + range[0] + "/" + range[1]);
            writeBytes(dir + "/s/" + range[0] + "/" + range[1] + "/" + range[2], bytes);
            break;
        }
    }
    return expected;
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

TEST(Precomputed, OneVoxelChunksAreFoundByListingTheFolderNotByAStatEach) {
    // A scale of 1-voxel chunks cost three stats a voxel to find the missing ones (attack pass:
    // `csgv info` 4.4 s at 64^3, minutes at 256^3). The folder is listed once: chunks without a
    // file are boxes merged across rows and layers, and reads zero a row of voxels at a time.
    // 128^3 in 1-voxel chunks with a negative voxel_offset, three files: flat, gzip, nested.
    using N = SparseChunk::Name;
    const std::string dir = tempDir() + "/pc-voxel-chunks";
    const std::vector<uint64_t> expected = writeSparseScale(dir, {{128, 128, 128}}, {{1, 1, 1}}, {{-5, 7, -300}},
                                                            {{{{0, 0, 0}}, N::Flat}, {{{70, 3, 64}}, N::Gzip},
                                                             {{{127, 127, 127}}, N::Nested}});
    const auto t0 = std::chrono::steady_clock::now();
    auto s = openOk(dir);
    ASSERT_TRUE(s);
    std::vector<UniformBox> boxes;
    s->uniformBoxes(0, 128, 0, 128, boxes);
    uint64_t voxels = 0;
    for (const UniformBox& b : boxes) {
        EXPECT_EQ(b.value, 0u);
        voxels += b.voxels();
    }
    EXPECT_EQ(voxels, 128u * 128 * 128 - 3);
    EXPECT_LE(boxes.size(), 3u * 5 + 2); // one per chunk row before: 16384
    const std::vector<uint64_t> values = readWhole(*s);
    EXPECT_TRUE(values == expected);
    EXPECT_EQ(values[70 + 128 * (3 + 128 * 64)], 2000u);
    EXPECT_LT(secondsSince(t0), 10.0); // 0.1 s; a stat per chunk name took seconds

    // A small one through the whole source contract, its layers cached (read in bands of rows).
    const std::string small = tempDir() + "/pc-voxel-chunks-small";
    const std::vector<uint64_t> smallExpected =
        writeSparseScale(small, {{11, 10, 9}}, {{1, 2, 3}}, {{0, -4, 3}},
                         {{{{0, 0, 0}}, N::Flat}, {{{5, 1, 2}}, N::Gzip}, {{{6, 1, 2}}, N::Nested}, {{{10, 4, 2}}, N::Flat}});
    s = openOk(small);
    ASSERT_TRUE(s);
    EXPECT_TRUE(s->readsRows());
    expectSourceContract(*s, smallExpected);
    // Uncached (a budget of one chunk, its file and the index): slabs only, the same values.
    InputOptions tight;
    tight.maxWorkingBytes = 6 * 8 + 6 * 4 + 1 + 4 * 24;
    s = openOk(small, tight);
    ASSERT_TRUE(s);
    EXPECT_FALSE(s->readsRows());
    expectSourceContract(*s, smallExpected);
    EXPECT_LE(s->workingBytes(), tight.maxWorkingBytes);
}

TEST(Precomputed, AGridOfABillionChunkNamesCostsWhatItsFilesCost) {
    // 1024^3 in 1-voxel chunks (2^30 names, 3 * 2^30 file names), two files: compressed in about
    // a second, not hours.
    using N = SparseChunk::Name;
    const std::string dir = tempDir() + "/pc-billion";
    writeSparseScale(dir, {{1024, 1024, 1024}}, {{1, 1, 1}}, {{0, 0, 0}}, {{{{7, 6, 5}}, N::Flat}, {{{1002, 1001, 1000}}, N::Nested}});
    const auto t0 = std::chrono::steady_clock::now();
    auto s = openOk(dir);
    ASSERT_TRUE(s);
    std::vector<uint64_t> slice(1024 * 1024, 77);
    ASSERT_TRUE(s->readSlab(1000, 1, slice.data()).isOk());
    EXPECT_EQ(slice[1002 + 1024 * 1001], 2000u);
    EXPECT_EQ(std::count(slice.begin(), slice.end(), 0u), 1024 * 1024 - 1);
    const std::string out = tempDir() + "/pc-billion.csgv";
    const Status st = compressToFile(dir, out, CompressOptions());
    ASSERT_TRUE(st.isOk()) << st.message();
    EXPECT_LT(secondsSince(t0), 30.0);
}

TEST(Precomputed, TooManyChunkFilesToIndexAreRefusedForAHugeGrid) {
    // No room beside one chunk and its file for the index of two files: a grid of 2^25 chunk
    // names would be looked up one by one, which is refused with the counts and the limits.
    using N = SparseChunk::Name;
    const std::string dir = tempDir() + "/pc-unindexed";
    writeSparseScale(dir, {{256, 256, 512}}, {{1, 1, 1}}, {{0, 0, 0}}, {{{{0, 0, 0}}, N::Flat}, {{{1, 2, 3}}, N::Gzip}});
    InputOptions tight;
    tight.maxWorkingBytes = 8 + 4 + 1 + 24; // a decoded chunk, its raw file (+1), one indexed chunk
    const Result<std::unique_ptr<InputSource>> r = openInput(dir, tight);
    ASSERT_FALSE(r.isOk());
    EXPECT_EQ(r.message(), dir + "/s: its chunk grid has 33554432 chunks and the folder 2 chunk files, more than the 1 "
                                 "that the working memory bound lets this reader list; looking each chunk up by name "
                                 "is refused beyond 16 per chunk file (or 16777216 in all)");
}
