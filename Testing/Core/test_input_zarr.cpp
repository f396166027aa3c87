// SPDX-License-Identifier: MIT
/// @file test_input_zarr.cpp
/// @brief Tests of Zarr v2 and OME-Zarr input. Fixtures are written at test time by
/// Testing/Core/inputs/make_zarr.py (python3-zarr, numcodecs), each good one with the values the
/// reader must return (NAME.expected), so every voxel is compared exactly.
#include "TestData.h"

#include "csgv/codec/Container.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/inputs/Compress.h"
#include "csgv/inputs/Inputs.h"
#include "csgv/inputs/ZarrFormat.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

using namespace csgv;
using csgvtest::expectSourceContract;
using csgvtest::tempDir;

namespace {

/// The fixture folder, written once per test process.
const std::string& fixtures() {
    static const std::string dir = [] {
        const std::string d = tempDir() + "/zarr";
        EXPECT_EQ(csgvtest::runFixtureScript("make_zarr.py", {d}), 0) << "make_zarr.py failed";
        return d;
    }();
    return dir;
}

std::string at(const std::string& name) { return fixtures() + "/" + name; }

/// What make_zarr.py says the reader must return for `name`.
std::vector<uint64_t> expectedValues(const std::string& name) {
    std::ifstream f(at(name) + ".expected", std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    std::vector<uint64_t> v(bytes.size() / 8);
    for (size_t i = 0; i < v.size(); ++i)
        for (int b = 0; b < 8; ++b) v[i] |= uint64_t(uint8_t(bytes[i * 8 + size_t(b)])) << (8 * b);
    return v;
}

std::unique_ptr<InputSource> openOk(const std::string& name, const InputOptions& options = {}) {
    Result<std::unique_ptr<InputSource>> src = openInput(at(name), options);
    EXPECT_TRUE(src.isOk()) << src.message();
    return src ? std::move(*src) : nullptr;
}

/// Opens a good fixture, checks its type, dimensions and detail, and every voxel through the
/// source contract.
void expectFixture(const std::string& name, LabelType type, std::array<uint32_t, 3> dim, const std::string& detailPart) {
    SCOPED_TRACE(name);
    std::unique_ptr<InputSource> src = openOk(name);
    ASSERT_TRUE(src);
    EXPECT_EQ(src->info().format, "Zarr");
    EXPECT_EQ(src->info().type, type);
    EXPECT_EQ(src->info().dim, dim);
    EXPECT_NE(src->info().detail.find(detailPart), std::string::npos) << src->info().detail;
    expectSourceContract(*src, expectedValues(name));
}

/// The message of reading `name` whole (opening or reading fails).
std::string failure(const std::string& name) {
    Result<InputVolume> v = readInput(at(name));
    EXPECT_FALSE(v.isOk()) << name << " was read";
    return v.message();
}

#define EXPECT_HAS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

} // namespace

TEST(ZarrInput, ClaimsZarrPaths) {
    EXPECT_TRUE(isInputPath("/data/seg.zarr"));
    EXPECT_TRUE(isInputPath("/data/SEG.ZARR/"));
    EXPECT_TRUE(isInputPath("/data/seg.zarr/labels/cells/0"));
    EXPECT_TRUE(isInputPath(at("u8_zlib.zarr"))); // a folder holding .zarray
    EXPECT_FALSE(isInputPath("/data/seg.zarray.txt"));
}

TEST(ZarrInput, CompressorsAndTypes) {
    expectFixture("u32_blosc_lz4.zarr", LabelType::U32, {{13, 17, 20}}, "chunks 8x8x5, blosc(lz4, shuffle), C order");
    expectFixture("u8_zlib.zarr", LabelType::U8, {{11, 10, 9}}, "zlib");
    expectFixture("u16_gzip.zarr", LabelType::U16, {{7, 12, 10}}, "gzip");
    expectFixture("i64_zstd.zarr", LabelType::I64, {{11, 9, 7}}, "zstd");
    expectFixture("u64_blosc_zstd.zarr", LabelType::U64, {{10, 6, 8}}, "blosc(zstd, bitshuffle)");
    expectFixture("i32_bigendian.zarr", LabelType::I32, {{6, 7, 5}}, "array i32_bigendian.zarr");
    expectFixture("f32_integers.zarr", LabelType::F32, {{4, 5, 6}}, "none");
    expectFixture("f64_nanfill.zarr", LabelType::F64, {{8, 4, 4}}, "zstd"); // NaN fill, no chunk missing
}

TEST(ZarrInput, NegativeAndLargeValuesAtFullWidth) {
    std::unique_ptr<InputSource> src = openOk("i64_zstd.zarr");
    ASSERT_TRUE(src);
    Result<InputVolume> v = readAll(*src, "i64");
    ASSERT_TRUE(v.isOk()) << v.message();
    EXPECT_EQ(int64_t(v->values[0]), -1);
    EXPECT_EQ(int64_t(v->values[3 + 11 * (2 + 9 * 1)]), INT64_MIN);
    src = openOk("u64_blosc_zstd.zarr");
    ASSERT_TRUE(src);
    v = readAll(*src, "u64");
    ASSERT_TRUE(v.isOk()) << v.message();
    EXPECT_EQ(v->values[0], ~uint64_t(0));
    EXPECT_GT(v->values[1], uint64_t(1) << 32);
}

TEST(ZarrInput, LayoutsFortranOrderAndSlashSeparator) {
    expectFixture("u32_forder.zarr", LabelType::U32, {{9, 11, 6}}, "F order");
    expectFixture("u16_slash.zarr", LabelType::U16, {{7, 8, 9}}, "blosc(lz4, noshuffle)");
}

TEST(ZarrInput, MissingChunksAreFillValue) {
    expectFixture("missing_fill0.zarr", LabelType::U32, {{8, 8, 8}}, "zlib");
    expectFixture("missing_fill7.zarr", LabelType::U32, {{8, 8, 8}}, "zlib");
    EXPECT_EQ(expectedValues("missing_fill7.zarr")[0], 7u);
}

TEST(ZarrInput, MissingChunksAreUniformBoxesThatCompressToTheBytesOfReadingThem) {
    // The chunks with no file are listed as boxes of fill_value (issue 37, item 4: a .zarray that
    // names a huge array and no chunk took time per voxel), and the encoder writes what reading
    // every voxel writes. An array of 32 x 24 x 16 in raw chunks of 8^3, three of its 24 chunks
    // written, fill_value 5, in bricks of 8 (chunks and bricks coincide) and 16 (a brick holds
    // written and missing chunks, or only missing ones).
    std::unique_ptr<InputSource> src = openOk("missing_fill7.zarr");
    ASSERT_TRUE(src);
    std::vector<csgv::UniformBox> boxes;
    src->uniformBoxes(0, 8, 0, 8, boxes);
    uint64_t voxels = 0;
    for (const csgv::UniformBox& b : boxes) {
        EXPECT_EQ(b.value, 7u);
        voxels += b.voxels();
    }
    EXPECT_EQ(voxels, 3u * 64u); // its three missing chunks of 4^3

    const std::string dir = csgvtest::tempDir() + "/zarr-uniform";
    const std::string array = dir + "/sparse.zarr";
    std::filesystem::create_directories(array);
    std::ofstream(array + "/.zarray") << R"({"zarr_format": 2, "shape": [16, 24, 32], "chunks": [8, 8, 8], "dtype": "<u4",
        "compressor": null, "fill_value": 5, "order": "C", "filters": null})";
    std::vector<uint32_t> expected(32 * 24 * 16, 5);
    for (const std::array<uint32_t, 3>& c : {std::array<uint32_t, 3>{0, 0, 0}, {1, 2, 3}, {0, 1, 2}}) { // z, y, x
        std::vector<uint32_t> chunk(512);
        for (uint32_t i = 0; i < 512; ++i) {
            const uint32_t x = c[2] * 8 + i % 8, y = c[1] * 8 + (i / 8) % 8, z = c[0] * 8 + i / 64;
            chunk[i] = (x * 7 + y * 3 + z) % 40 + 1;
            expected[x + 32 * (y + 24 * z)] = chunk[i];
        }
        std::ofstream(array + "/" + std::to_string(c[0]) + "." + std::to_string(c[1]) + "." + std::to_string(c[2]),
                      std::ios::binary)
            .write(reinterpret_cast<const char*>(chunk.data()), std::streamsize(chunk.size() * 4));
    }
    for (uint32_t brick : {8u, 16u}) {
        SCOPED_TRACE("bricks of " + std::to_string(brick));
        std::string bytes[2];
        for (int fast = 0; fast < 2; ++fast) {
            csgv::CompressOptions options;
            options.encode.brickSize = brick;
            options.encode.useUniformBoxes = fast == 1;
            const std::string out = dir + "/sparse" + std::to_string(brick) + (fast ? "-fast" : "-slow") + ".csgv";
            const csgv::Status st = csgv::compressToFile(array, out, options);
            ASSERT_TRUE(st.isOk()) << st.message();
            std::ifstream f(out, std::ios::binary);
            bytes[fast].assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
            if (fast) {
                csgv::Result<csgv::CsgvFile> file = csgv::openCsgv(out);
                ASSERT_TRUE(file.isOk()) << file.message();
                csgv::Result<csgv::LabelVolume> v = csgv::decodeVolume(file->volume, 0, file->decodeOptions());
                ASSERT_TRUE(v.isOk()) << v.message();
                ASSERT_EQ(v->labels.size(), expected.size());
                for (size_t i = 0; i < expected.size(); ++i) ASSERT_EQ(v->labels[i], expected[i]) << "voxel " << i;
            }
        }
        ASSERT_FALSE(bytes[0].empty());
        EXPECT_TRUE(bytes[0] == bytes[1]) << "the missing chunks' boxes changed the bytes";
    }
}

TEST(ZarrInput, OmeMultiscaleLevelsAndGeometry) {
    expectFixture("ome.zarr", LabelType::U16, {{12, 10, 16}}, "array 0, chunks 8x5x6");
    std::unique_ptr<InputSource> src = openOk("ome.zarr");
    ASSERT_TRUE(src);
    // Dataset scale (z, y, x) = (2, 0.5, 0.25) times the global (1, 1, 2); translation (1, 2, 3)
    // times the global scale. Geometry is (x, y, z).
    const Geometry& g0 = src->info().geometry;
    EXPECT_EQ(g0.spacing, (std::array<double, 3>{{0.5, 0.5, 2.0}}));
    EXPECT_EQ(g0.origin, (std::array<double, 3>{{6.0, 2.0, 1.0}}));

    expectFixture("ome.zarr/1", LabelType::U16, {{6, 5, 8}}, "array 1, chunks 4x5x6, zstd");
    src = openOk("ome.zarr/1");
    ASSERT_TRUE(src);
    const Geometry& g1 = src->info().geometry;
    EXPECT_EQ(g1.spacing, (std::array<double, 3>{{1.0, 1.0, 4.0}}));
    EXPECT_EQ(g1.origin, (std::array<double, 3>{{6.25, 2.25, 2.0}}));
}

TEST(ZarrInput, OmeLabelGroups) {
    std::unique_ptr<InputSource> src = openOk("ome.zarr/labels");
    ASSERT_TRUE(src);
    EXPECT_HAS(src->info().detail, "label image 'cells' (first of 2): array labels/cells/0");
    expectSourceContract(*src, expectedValues("ome.zarr/labels/cells"));
    EXPECT_EQ(src->info().geometry.spacing, (std::array<double, 3>{{0.25, 0.5, 2.0}}));
    expectFixture("ome.zarr/labels/nuclei", LabelType::U32, {{12, 10, 16}}, "array labels/nuclei/0");
}

TEST(ZarrInput, OmeFiveDimensionalSingletonAxes) {
    expectFixture("tczyx.zarr", LabelType::U32, {{8, 7, 6}}, "chunks 1x1x4x4x4");
    std::unique_ptr<InputSource> src = openOk("tczyx.zarr");
    ASSERT_TRUE(src);
    EXPECT_EQ(src->info().geometry.spacing, (std::array<double, 3>{{1.5, 2.0, 3.0}}));
}

TEST(ZarrInput, WorkingMemoryBounded) {
    const std::vector<uint64_t> expected = expectedValues("u32_blosc_lz4.zarr");
    // A layer is 3 x 3 chunks of 8x8x5 uint32 (1280 bytes): cached with the default budget.
    std::unique_ptr<InputSource> src = openOk("u32_blosc_lz4.zarr");
    ASSERT_TRUE(src);
    std::vector<uint64_t> slab(13 * 17);
    ASSERT_TRUE(src->readSlab(0, 1, slab.data()).isOk());
    EXPECT_GE(src->workingBytes(), 9u * 1280);
    EXPECT_LT(src->workingBytes(), 9u * 1280 + 16384);
    // A budget of one chunk (plus its compressed file): chunks are decoded per request.
    InputOptions small;
    small.maxWorkingBytes = 8000;
    src = openOk("u32_blosc_lz4.zarr", small);
    ASSERT_TRUE(src);
    expectSourceContract(*src, expected);
    EXPECT_LE(src->workingBytes(), small.maxWorkingBytes);
    // Less than one chunk: refused when opened.
    small.maxWorkingBytes = 2000;
    Result<std::unique_ptr<InputSource>> refused = openInput(at("u32_blosc_lz4.zarr"), small);
    ASSERT_FALSE(refused.isOk());
    EXPECT_HAS(refused.message(), "does not fit the working memory bound");
}

TEST(ZarrInput, CompressRoundTripExact) {
    for (const char* name : {"u32_blosc_lz4.zarr", "ome.zarr/labels/nuclei", "u16_slash.zarr"}) {
        SCOPED_TRACE(name);
        const std::string out = tempDir() + "/zarr_roundtrip.csgv";
        CompressOptions options;
        ASSERT_TRUE(compressToFile(at(name), out, options).isOk());
        Result<CompressedVolume> vol = readCsgv(out);
        ASSERT_TRUE(vol.isOk()) << vol.message();
        Result<LabelVolume> decoded = decodeVolume(*vol, 0);
        ASSERT_TRUE(decoded.isOk()) << decoded.message();
        const std::vector<uint64_t> expected = expectedValues(name);
        ASSERT_EQ(decoded->labels.size(), expected.size());
        for (size_t i = 0; i < expected.size(); ++i)
            ASSERT_EQ(decoded->labels[i], expected[i]) << "voxel " << i;
    }
}

TEST(ZarrInput, ErrorsNameTheFileAndTheProblem) {
    std::string m = failure("bad_group.zarr");
    EXPECT_HAS(m, "bad_group.zarr");
    EXPECT_HAS(m, "not a Zarr array or OME-Zarr image: found a group (.zgroup)");
    m = failure("nothing_here.zarr");
    EXPECT_HAS(m, "no such Zarr folder");
    m = failure("bad_filter.zarr");
    EXPECT_HAS(m, "bad_filter.zarr/.zarray");
    EXPECT_HAS(m, "unsupported filter \"delta\"");
    m = failure("bad_dtype.zarr");
    EXPECT_HAS(m, "bad_dtype.zarr/.zarray: unsupported dtype \"<c8\"");
    m = failure("bad_channels.zarr");
    EXPECT_HAS(m, "axis 'c' has size 2");
}

TEST(ZarrInput, BadChunksNameTheChunkFile) {
    std::string m = failure("bad_truncated.zarr");
    EXPECT_HAS(m, "bad_truncated.zarr/1.0.1: zlib stream is truncated: it ends after 128 of 256 bytes");
    m = failure("bad_raw_short.zarr");
    EXPECT_HAS(m, "bad_raw_short.zarr/0.0.0: chunk holds 253 bytes, expected 256");
    m = failure("bad_blosc.zarr");
    EXPECT_HAS(m, "bad_blosc.zarr/0.1.0: chunk decodes to 12345 bytes, expected 256");
    m = failure("bad_blosc_data.zarr");
    EXPECT_HAS(m, "bad_blosc_data.zarr/0.0.0: corrupt blosc chunk");
    m = failure("bad_zlib_long.zarr");
    EXPECT_HAS(m, "bad_zlib_long.zarr/0.0.0: chunk decodes to more than 256 bytes");
    m = failure("bad_zlib_short.zarr");
    EXPECT_HAS(m, "bad_zlib_short.zarr/0.0.0: chunk decodes to 200 bytes, expected 256");
    m = failure("bad_zstd_long.zarr");
    EXPECT_HAS(m, "bad_zstd_long.zarr/0.0.0: chunk decodes to more than 256 bytes");
    m = failure("bad_nanfill_missing.zarr");
    EXPECT_HAS(m, "bad_nanfill_missing.zarr/0.0.1: chunk file is missing and the array's fill_value is not an integer label");
    m = failure("bad_fraction.zarr");
    EXPECT_HAS(m, "bad_fraction.zarr/0.0.0: voxel (1, 2, 3) holds 2.5, which is not an integer label");
}

TEST(ZarrInput, DeeplyNestedJsonIsAnErrorNotACrash) {
    // 100000 nested arrays in "shape": any recursive walk of the parsed value (dumping it for a
    // message, copying it) would overflow the stack.
    const std::string deep = std::string(100000, '[') + std::string(100000, ']');
    const std::string dir = tempDir() + "/deep.zarr";
    std::filesystem::create_directories(dir);
    std::ofstream(dir + "/.zarray") << R"({"zarr_format": 2, "shape": )" << deep
                                    << R"(, "chunks": [4, 4, 4], "dtype": "<u4", "compressor": null})";
    const Result<std::unique_ptr<InputSource>> r = openInput(dir);
    ASSERT_FALSE(r.isOk());
    EXPECT_EQ(r.message(), dir + "/.zarray: .zarray nests arrays or objects more than 64 levels deep");
    EXPECT_EQ(inputs::parseZattrs(R"({"multiscales": )" + deep + "}").message(),
              ".zattrs nests arrays or objects more than 64 levels deep");
    // Brackets inside strings do not count; containers are described in messages, not dumped.
    EXPECT_EQ(inputs::parseZarray(R"({"zarr_format": 2, "shape": [[4, 4], [4]], "chunks": [4, 4], "dtype": ")" +
                                  std::string(100, '[') + R"("})")
                  .message(),
              "\"shape\" holds an array of 2 elements, not a size");
}

TEST(ZarrInput, ZstdFrameClaimingAHugeWindowDecodesWithinTheChunk) {
    // A zstd frame whose header claims a 2 GiB window around 256 raw bytes: decoded into the
    // chunk's own buffer, so the claim allocates nothing (a streaming decoder refused it, or
    // would allocate the window).
    inputs::ZarrArray a;
    a.shape = {4, 4, 4};
    a.chunks = {4, 4, 4};
    a.type = LabelType::U32;
    a.itemBytes = 4;
    a.compressor = inputs::ZarrCompressor::Zstd;
    std::vector<uint8_t> frame = {0x28, 0xB5, 0x2F, 0xFD, 0x00, 21 << 3, 0x01 | ((256 << 3) & 0xFF), (256 << 3) >> 8, 0};
    for (int i = 0; i < 256; ++i) frame.push_back(uint8_t(i));
    std::vector<uint8_t> out;
    const Status s = inputs::decodeZarrChunk(a, frame.data(), frame.size(), out);
    ASSERT_TRUE(s.isOk()) << s.message();
    ASSERT_EQ(out.size(), 256u);
    for (int i = 0; i < 256; ++i) EXPECT_EQ(out[size_t(i)], uint8_t(i));
    // The same frame cut short is a clear error.
    frame.resize(100);
    EXPECT_EQ(inputs::decodeZarrChunk(a, frame.data(), frame.size(), out).message(),
              "zstd stream is truncated: it ends before its 256 bytes");
}

TEST(ZarrInput, VolumesOfTwoTo64BytesAreRefusedWhenOpened) {
    // 2^22 x 2^21 x 2^21 voxels: 2^64 voxels at 8 bytes wrap voxelCount() * 8 to 0. Any format
    // can claim this; openInput refuses it once the format has opened it.
    const std::string dir = tempDir() + "/huge.zarr";
    std::filesystem::create_directories(dir);
    std::ofstream(dir + "/.zarray") << R"({"zarr_format": 2, "shape": [2097152, 2097152, 4194304],
                                          "chunks": [1, 1, 1], "dtype": "|u1", "compressor": null})";
    const Result<std::unique_ptr<InputSource>> r = openInput(dir);
    ASSERT_FALSE(r.isOk());
    EXPECT_EQ(r.message(), dir + ": 4194304 x 2097152 x 2097152 voxels need 2^64 bytes or more as 64-bit labels; "
                                 "no input can be that large");
    InputInfo info;
    info.dim = {{1u << 22, 1u << 21, 1u << 21}};
    EXPECT_EQ(info.voxelCount(), kSaturated);
}

namespace {

/// Writes a raw (uncompressed) uint16 Zarr array of `shape` (z, y, x) in chunks of `chunks`,
/// fill_value `fill`, with dimension_separator `sep`, and one chunk file for each of `written`
/// (chunk grid positions z, y, x; each voxel of chunk i holds 100 + i + its index in the chunk).
/// Returns the volume the reader must give (empty when it would pass 2^24 voxels).
std::vector<uint64_t> writeSparseArray(const std::string& dir, std::array<uint32_t, 3> shape, std::array<uint32_t, 3> chunks,
                                       uint16_t fill, char sep, const std::vector<std::array<uint32_t, 3>>& written) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    std::ofstream(dir + "/.zarray") << "{\"zarr_format\": 2, \"shape\": [" << shape[0] << ", " << shape[1] << ", " << shape[2]
                                    << "], \"chunks\": [" << chunks[0] << ", " << chunks[1] << ", " << chunks[2]
                                    << "], \"dtype\": \"<u2\", \"compressor\": null, \"fill_value\": " << fill
                                    << ", \"order\": \"C\", \"filters\": null, \"dimension_separator\": \"" << sep << "\"}";
    const uint64_t X = shape[2], Y = shape[1];
    const bool small = X * Y * shape[0] <= (uint64_t(1) << 24);
    std::vector<uint64_t> expected(small ? size_t(X * Y * shape[0]) : 0, fill);
    for (size_t i = 0; i < written.size(); ++i) {
        const std::array<uint32_t, 3>& c = written[i];
        std::vector<uint16_t> chunk(size_t(chunks[0]) * chunks[1] * chunks[2]);
        for (size_t e = 0; e < chunk.size(); ++e) {
            chunk[e] = uint16_t(100 + i + e);
            const uint64_t x = c[2] * chunks[2] + e % chunks[2], y = c[1] * chunks[1] + (e / chunks[2]) % chunks[1],
                           z = c[0] * chunks[0] + e / (uint64_t(chunks[2]) * chunks[1]);
            if (small && x < X && y < Y && z < shape[0]) expected[size_t(x + X * (y + Y * z))] = chunk[e];
        }
        const std::string a = std::to_string(c[0]), b = std::to_string(c[1]);
        if (sep == '/') std::filesystem::create_directories(dir + "/" + a + "/" + b);
        std::ofstream(dir + "/" + a + sep + b + sep + std::to_string(c[2]), std::ios::binary)
            .write(reinterpret_cast<const char*>(chunk.data()), std::streamsize(chunk.size() * 2));
    }
    return expected;
}

std::unique_ptr<InputSource> openPath(const std::string& path, const InputOptions& options = {}) {
    Result<std::unique_ptr<InputSource>> src = openInput(path, options);
    EXPECT_TRUE(src.isOk()) << src.message();
    return src ? std::move(*src) : nullptr;
}

std::string failureAt(const std::string& path) {
    Result<InputVolume> v = readInput(path);
    EXPECT_FALSE(v.isOk()) << path << " was read";
    return v.message();
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

TEST(ZarrInput, OneVoxelChunksAreFoundByListingTheFolderNotByAStatEach) {
    // A grid of 1-voxel chunks cost a stat per voxel to find the missing ones (attack pass: 52 s
    // to compress 256^3, an hour for 1024^3 without a chunk file). The folder is listed once: the
    // chunks without a file are boxes merged across rows and layers, and reads write fill_value a
    // row at a time. 128^3 in 1-voxel chunks, three written (one at the far corner), both
    // separators; then a small one through the whole source contract.
    for (char sep : {'.', '/'}) {
        SCOPED_TRACE(std::string("separator ") + sep);
        const std::string dir = tempDir() + "/zarr-voxel-chunks.zarr";
        const std::vector<uint64_t> expected =
            writeSparseArray(dir, {{128, 128, 128}}, {{1, 1, 1}}, 9, sep, {{{0, 0, 0}}, {{64, 3, 70}}, {{127, 127, 127}}});
        const auto t0 = std::chrono::steady_clock::now();
        std::unique_ptr<InputSource> src = openPath(dir);
        ASSERT_TRUE(src);
        std::vector<UniformBox> boxes;
        src->uniformBoxes(0, 128, 0, 128, boxes);
        uint64_t voxels = 0;
        for (const UniformBox& b : boxes) {
            EXPECT_EQ(b.value, 9u);
            voxels += b.voxels();
        }
        EXPECT_EQ(voxels, 128u * 128 * 128 - 3);
        // Merged: a few boxes around each written chunk (one per chunk row before: 16384).
        EXPECT_LE(boxes.size(), 3u * 5 + 2);
        Result<InputVolume> v = readAll(*src, dir);
        ASSERT_TRUE(v.isOk()) << v.message();
        EXPECT_TRUE(v->values == expected);
        EXPECT_LT(secondsSince(t0), 10.0); // 0.1 s; a stat per chunk took seconds
    }
    const std::string dir = tempDir() + "/zarr-voxel-chunks-small.zarr";
    const std::vector<uint64_t> expected =
        writeSparseArray(dir, {{9, 10, 11}}, {{1, 2, 1}}, 4, '.', {{{0, 0, 0}}, {{2, 1, 5}}, {{2, 1, 6}}, {{8, 4, 10}}});
    std::unique_ptr<InputSource> src = openPath(dir);
    ASSERT_TRUE(src);
    EXPECT_TRUE(src->readsRows()); // its layers (at most two chunks with a file) are cached
    expectSourceContract(*src, expected);
}

TEST(ZarrInput, AGridOfABillionChunkNamesCostsWhatItsFilesCost) {
    // 1024^3 in 1-voxel chunks (2^30 names), two files: compressed in about a second (an hour at
    // "progress 0.0%" before), and a column of 4096 x 1 x 1 chunks over 1024^3, one file.
    const std::string dir = tempDir() + "/zarr-billion.zarr";
    writeSparseArray(dir, {{1024, 1024, 1024}}, {{1, 1, 1}}, 0, '.', {{{5, 6, 7}}, {{1000, 1001, 1002}}});
    auto t0 = std::chrono::steady_clock::now();
    std::unique_ptr<InputSource> src = openPath(dir);
    ASSERT_TRUE(src);
    std::vector<uint64_t> slice(1024 * 1024, 77);
    ASSERT_TRUE(src->readSlab(5, 1, slice.data()).isOk());
    EXPECT_EQ(slice[7 + 1024 * 6], 100u);
    EXPECT_EQ(std::count(slice.begin(), slice.end(), 0u), 1024 * 1024 - 1);
    const std::string out = tempDir() + "/zarr-billion.csgv";
    Status s = compressToFile(dir, out, CompressOptions());
    ASSERT_TRUE(s.isOk()) << s.message();
    EXPECT_LT(secondsSince(t0), 30.0);

    const std::string column = tempDir() + "/zarr-column.zarr";
    writeSparseArray(column, {{1024, 1024, 1024}}, {{1024, 1, 1}}, 0, '.', {{{0, 0, 0}}});
    t0 = std::chrono::steady_clock::now();
    s = compressToFile(column, out, CompressOptions());
    ASSERT_TRUE(s.isOk()) << s.message();
    EXPECT_LT(secondsSince(t0), 30.0);
    Result<CompressedVolume> vol = readCsgv(out);
    ASSERT_TRUE(vol.isOk()) << vol.message();
    EXPECT_EQ(vol->dim, (std::array<uint32_t, 3>{{1024, 1024, 1024}}));
}

TEST(ZarrInput, TooManyChunkFilesToIndexAreLookedUpByNameOrRefused) {
    // The index holds what the working memory bound leaves beside one chunk and its file (24
    // bytes a chunk while it grows). Room for one chunk and five files: each chunk is looked up by
    // name as before, with the same values; a grid of more than 2^24 names is then refused.
    const std::string dir = tempDir() + "/zarr-unindexed.zarr";
    const std::vector<uint64_t> expected =
        writeSparseArray(dir, {{6, 7, 8}}, {{2, 2, 2}}, 3, '/', {{{0, 0, 0}}, {{1, 2, 3}}, {{2, 3, 3}}, {{0, 3, 1}}, {{2, 0, 0}}});
    InputOptions tight;
    tight.maxWorkingBytes = 16 + (16 + 1 + 4096) + 24; // chunk, its file, one indexed chunk
    std::unique_ptr<InputSource> src = openPath(dir, tight);
    ASSERT_TRUE(src);
    expectSourceContract(*src, expected);
    EXPECT_LE(src->workingBytes(), tight.maxWorkingBytes);
    InputOptions roomy; // and indexed, the same
    src = openPath(dir, roomy);
    ASSERT_TRUE(src);
    expectSourceContract(*src, expected);

    writeSparseArray(dir, {{512, 256, 256}}, {{1, 1, 1}}, 3, '.', {{{0, 0, 0}}, {{1, 2, 3}}});
    tight.maxWorkingBytes = 2 + (2 + 4096) + 24;
    const Result<std::unique_ptr<InputSource>> refused = openInput(dir, tight);
    ASSERT_FALSE(refused.isOk());
    EXPECT_EQ(refused.message(), dir + ": its chunk grid has 33554432 chunks and the folder 2 chunk files, more than the 1 "
                                       "that the working memory bound lets this reader list; looking each chunk up by name "
                                       "is refused beyond 16 per chunk file (or 16777216 in all)");
}

TEST(ZarrInput, ListedChunksThatAreNoFilesAreStillRefusedByName) {
    // Listing finds the names; each is still checked when read: a dangling link in the nested
    // layout is an error naming it, not fill_value.
    const std::string dir = tempDir() + "/zarr-dangling.zarr";
    writeSparseArray(dir, {{4, 4, 4}}, {{2, 2, 2}}, 0, '/', {{{0, 0, 0}}});
    std::filesystem::create_directories(dir + "/1/1");
    std::filesystem::create_symlink(dir + "/nowhere", dir + "/1/1/1");
    std::string m = failureAt(dir);
    EXPECT_HAS(m, dir + "/1/1/1: chunk is a dangling symbolic link, not a regular file");
}
