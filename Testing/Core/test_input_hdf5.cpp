// SPDX-License-Identifier: MIT
/// @file test_input_hdf5.cpp
/// @brief Tests of HDF5 input (Core/src/inputs/Hdf5.cpp). The fixtures are written at test time
/// by Testing/Core/inputs/make_hdf5.py (h5py), which also writes every readable dataset's
/// expected values (x fastest, full width); each test compares every voxel with them.
///
/// Suites:
/// - Hdf5Input: every integer type, layouts (chunked with filters, contiguous), chunk caches,
///   dataset paths and auto-picking, extra axes of size 1, floats holding integers, geometry
///   attributes, the InputSource contract on each.
/// - Hdf5Compress: compressToFile round trips, plain and relabelled (negative and 64-bit labels
///   mapped back through the `_csgv.db3`).
/// - Hdf5Errors: one test per kind of bad input, checking the message; HDF5 prints nothing.

#include "TestData.h"

#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/inputs/Compress.h"
#include "csgv/inputs/Inputs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

using csgv::InputOptions;
using csgv::InputSource;
using csgv::LabelType;

namespace {

/// The fixture folder, written once per test process.
const std::string& fixtureDir() {
    static const std::string dir = [] {
        const std::string d = csgvtest::tempDir() + "/hdf5";
        EXPECT_EQ(csgvtest::runFixtureScript("make_hdf5.py", {d}), 0) << "make_hdf5.py failed";
        return d;
    }();
    return dir;
}

std::string fx(const std::string& name) { return fixtureDir() + "/" + name; }

/// The values make_hdf5.py wrote for a dataset (little-endian 64-bit words).
std::vector<uint64_t> expected(const std::string& name) {
    std::ifstream in(fx(name + ".expected"), std::ios::binary);
    EXPECT_TRUE(in.good()) << name;
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::vector<uint64_t> values(bytes.size() / 8);
    for (size_t i = 0; i < values.size(); ++i) {
        uint64_t v = 0;
        for (int b = 7; b >= 0; --b) v = (v << 8) | uint8_t(bytes[i * 8 + size_t(b)]);
        values[i] = v;
    }
    return values;
}

std::unique_ptr<InputSource> open(const std::string& path, const InputOptions& options = {}) {
    csgv::Result<std::unique_ptr<InputSource>> r = csgv::openInput(path, options);
    EXPECT_TRUE(r.isOk()) << r.message();
    return r.isOk() ? std::move(*r) : nullptr;
}

/// The message openInput gives for `path` (which must fail).
std::string openError(const std::string& path, const InputOptions& options = {}) {
    csgv::Result<std::unique_ptr<InputSource>> r = csgv::openInput(path, options);
    EXPECT_FALSE(r.isOk()) << path << " opened";
    return r.message();
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

#define EXPECT_CONTAINS(text, part) EXPECT_TRUE(contains((text), (part))) << "message: " << (text)

/// Opens `path`, checks its dimensions and type, and every voxel through the source contract.
void expectVolume(const std::string& path, const std::string& expectedName, std::array<uint32_t, 3> dim, LabelType type) {
    std::unique_ptr<InputSource> s = open(path);
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().dim, dim) << path;
    EXPECT_EQ(s->info().type, type) << path;
    EXPECT_EQ(s->info().format, "HDF5");
    csgvtest::expectSourceContract(*s, expected(expectedName));
}

std::vector<uint64_t> readWhole(InputSource& s) {
    std::vector<uint64_t> v(size_t(s.info().voxelCount()));
    const csgv::Status st = s.readSlab(0, s.info().dim[2], v.data());
    EXPECT_TRUE(st.isOk()) << st.message();
    return v;
}

} // namespace

// ------------------------------------------------------------------------------------------------
// Hdf5Input
// ------------------------------------------------------------------------------------------------

TEST(Hdf5Input, ClaimsItsForms) {
    for (const char* p : {"a.h5", "dir/A.H5", "a.hdf5", "a.HDF5", "a.h5:/labels", "a.hdf5:/g/d", "x.H5:/Y"})
        EXPECT_TRUE(csgv::isInputPath(p)) << p;
    for (const char* p : {"a.h5x", "a.hdf", "a.h5:labels", "a.csgv", "h5"}) EXPECT_FALSE(csgv::isInputPath(p)) << p;
}

TEST(Hdf5Input, ChunkedGzipUint32WithChunksNotDividingTheShape) {
    std::unique_ptr<InputSource> s = open(fx("chunked_gzip.h5"));
    ASSERT_NE(s, nullptr);
    const csgv::InputInfo& info = s->info();
    EXPECT_EQ(info.dim, (std::array<uint32_t, 3>{29, 23, 19}));
    EXPECT_EQ(info.type, LabelType::U32);
    EXPECT_EQ(info.detail, "dataset /labels, chunks 8x10x7, filters shuffle+gzip, spacing from element_size_um");
    // element_size_um is (z, y, x); Geometry is (x, y, z).
    EXPECT_EQ(info.geometry.spacing, (std::array<double, 3>{0.25, 0.5, 2.5}));
    EXPECT_EQ(info.geometry.origin, (std::array<double, 3>{0, 0, 0}));
    // One layer of chunks: ceil(23/10) * ceil(29/7) = 15 chunks of 8*10*7*4 bytes.
    EXPECT_EQ(s->workingBytes(), 15u * 2240u);
    csgvtest::expectSourceContract(*s, expected("chunked_gzip_labels"));

    // The same dataset named explicitly.
    expectVolume(fx("chunked_gzip.h5") + ":/labels", "chunked_gzip_labels", {29, 23, 19}, LabelType::U32);
}

TEST(Hdf5Input, ChunkCacheFollowsTheWorkingMemoryLimit) {
    InputOptions small;
    small.maxWorkingBytes = 15u * 2240u - 1; // a layer no longer fits: one chunk is kept
    std::unique_ptr<InputSource> s = open(fx("chunked_gzip.h5"), small);
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->workingBytes(), 2240u);
    csgvtest::expectSourceContract(*s, expected("chunked_gzip_labels"));

    InputOptions tiny;
    tiny.maxWorkingBytes = 2000;
    EXPECT_CONTAINS(openError(fx("chunked_gzip.h5"), tiny),
                    "dataset /labels has chunks of 2240 bytes, more than the working-memory limit of 2000");
}

TEST(Hdf5Input, BandsOfWholeChunkLayersKeepOnlyTheirChunks) {
    // chunks 8 (z) x 10 (y) x 7 (x) over 19 x 23 x 29: 3 chunk rows of 5 chunks per layer.
    std::unique_ptr<InputSource> s = open(fx("chunked_gzip.h5"));
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().chunkDepth, 8u);
    ASSERT_TRUE(s->readsRows());
    const std::vector<uint64_t> want = expected("chunked_gzip_labels");
    const auto read = [&](uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows) {
        std::vector<uint64_t> band(size_t(29) * rows * depth);
        const csgv::Status st = s->readRows(z0, depth, y0, rows, band.data());
        EXPECT_TRUE(st.isOk()) << st.message();
        for (size_t i = 0; i < band.size(); ++i) {
            const size_t x = i % 29, y = y0 + i / 29 % rows, z = z0 + i / (29 * rows);
            if (band[i] != want[x + 29 * (y + 23 * z)]) {
                ADD_FAILURE() << "voxel (" << x << ", " << y << ", " << z << ")";
                break;
            }
        }
        return s->workingBytes();
    };
    // A band 5 rows tall touches at most 2 chunk rows: 2 * 5 chunks, not the layer's 15.
    EXPECT_EQ(read(0, 8, 0, 5), 10u * 2240u);
    EXPECT_EQ(read(0, 8, 5, 5), 10u * 2240u);
    EXPECT_EQ(read(16, 3, 18, 5), 10u * 2240u); // the last layer is partial: still whole
    EXPECT_EQ(read(0, 16, 0, 5), 20u * 2240u);  // two layers deep
    // Anything else goes back to the layer cache: slabs, bands off the chunk grid, whole slices.
    EXPECT_EQ(read(4, 8, 0, 5), 15u * 2240u);
    EXPECT_EQ(read(8, 8, 0, 5), 10u * 2240u); // bands again
    EXPECT_EQ(read(8, 8, 0, 23), 15u * 2240u);
    csgvtest::expectSourceContract(*s, want);
}

TEST(Hdf5Input, ContiguousUint16) {
    std::unique_ptr<InputSource> s = open(fx("contiguous_u16.h5"));
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().dim, (std::array<uint32_t, 3>{9, 17, 12}));
    EXPECT_EQ(s->info().type, LabelType::U16);
    EXPECT_EQ(s->info().detail, "dataset /data, contiguous");
    EXPECT_EQ(s->info().geometry.spacing, (std::array<double, 3>{1, 1, 1}));
    EXPECT_EQ(s->workingBytes(), 0u);
    csgvtest::expectSourceContract(*s, expected("contiguous_u16_data"));
}

TEST(Hdf5Input, Uint8ChunkedWithoutFiltersAndTheHdf5Extension) {
    expectVolume(fx("small_u8.hdf5"), "small_u8_seg", {5, 6, 7}, LabelType::U8);
    std::unique_ptr<InputSource> s = open(fx("small_u8.hdf5") + ":/seg");
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().detail, "dataset /seg, chunks 3x3x3, no filters");
}

TEST(Hdf5Input, SignedTypesAreSignExtended) {
    expectVolume(fx("i32.h5"), "i32_labels", {12, 11, 10}, LabelType::I32);
    expectVolume(fx("i16be.h5"), "i16be_labels", {7, 6, 5}, LabelType::I16); // big-endian in the file
    expectVolume(fx("i64.h5"), "i64_labels", {13, 8, 9}, LabelType::I64);
    // The fixtures do hold negatives (and int64 values beyond 32 bits).
    const std::vector<uint64_t> i64 = expected("i64_labels");
    bool negative = false, wide = false;
    for (uint64_t v : i64) {
        negative |= int64_t(v) < 0;
        wide |= int64_t(v) > (int64_t(1) << 40);
    }
    EXPECT_TRUE(negative && wide);
}

TEST(Hdf5Input, Int8WithChecksumsAndSzip) {
    expectVolume(fx("i8.h5"), "i8_labels", {9, 7, 6}, LabelType::I8);
    std::unique_ptr<InputSource> s = open(fx("i8.h5"));
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().detail, "dataset /labels, chunks 4x4x4, filters fletcher32");
    if (!std::filesystem::exists(fx("i8_szip.h5"))) GTEST_SKIP() << "this HDF5 cannot write szip";
    expectVolume(fx("i8_szip.h5"), "i8_labels", {9, 7, 6}, LabelType::I8);
    s = open(fx("i8_szip.h5"));
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().detail, "dataset /labels, chunks 4x4x4, filters szip");
}

TEST(Hdf5Input, Uint64AboveTwoToThe32And63) {
    expectVolume(fx("u64.h5"), "u64_labels", {10, 9, 8}, LabelType::U64);
    bool above63 = false;
    for (uint64_t v : expected("u64_labels")) above63 |= v >> 63 != 0;
    EXPECT_TRUE(above63);
}

TEST(Hdf5Input, NestedGroupsNamedExplicitly) {
    expectVolume(fx("nested.h5") + ":/a/b/labels", "nested_a_b_labels", {8, 7, 6}, LabelType::U32);
    std::unique_ptr<InputSource> s = open(fx("nested.h5") + ":/a/b/labels");
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().detail, "dataset /a/b/labels, contiguous");
}

TEST(Hdf5Input, ExtraAxesOfSizeOne) {
    // (1, z, y, x) and (1, z, y, x, 1) hold the same volume as /a/b/labels.
    expectVolume(fx("nested.h5") + ":/a/b/vol4d", "nested_a_b_labels", {8, 7, 6}, LabelType::U32);
    expectVolume(fx("nested.h5") + ":/a/b/vol5d_channel", "nested_a_b_labels", {8, 7, 6}, LabelType::U32);
    EXPECT_CONTAINS(openError(fx("nested.h5") + ":/a/b/vol4d_bad"),
                    "dataset /a/b/vol4d_bad is 4D (shape 2x6x7x8); the axes beyond (z, y, x) must have size 1");
}

TEST(Hdf5Input, FloatsHoldingIntegers) {
    expectVolume(fx("nested.h5") + ":/a/b/float_ints", "nested_a_b_float_ints", {8, 7, 6}, LabelType::F32);

    std::unique_ptr<InputSource> s = open(fx("nested.h5") + ":/a/b/float_frac");
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().type, LabelType::F64);
    std::vector<uint64_t> slab(8 * 7 * 6);
    EXPECT_TRUE(s->readSlab(0, 3, slab.data()).isOk()); // the fraction is at z 3
    const csgv::Status st = s->readSlab(2, 4, slab.data());
    EXPECT_FALSE(st.isOk());
    EXPECT_CONTAINS(st.message(), fx("nested.h5") + ":/a/b/float_frac: voxel (x 5, y 4, z 3) holds 2.5, which is not "
                                                    "an integer label (float64 voxels must hold integers within int64)");
}

TEST(Hdf5Input, AutoPicksTheOnly3dIntegerDataset) {
    std::unique_ptr<InputSource> s = open(fx("autopick.h5"));
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().detail, "dataset /volume/seg, chunks 5x5x5, filters gzip");
    EXPECT_EQ(s->info().dim, (std::array<uint32_t, 3>{11, 10, 9}));
    csgvtest::expectSourceContract(*s, expected("autopick"));
}

TEST(Hdf5Input, CremiAttributesGiveSpacingAndOrigin) {
    std::unique_ptr<InputSource> s = open(fx("cremi.h5") + ":/volumes/labels/neuron_ids");
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().type, LabelType::U64);
    EXPECT_EQ(s->info().geometry.spacing, (std::array<double, 3>{4, 4, 40}));
    EXPECT_EQ(s->info().geometry.origin, (std::array<double, 3>{8, 12, 80}));
    EXPECT_EQ(s->info().detail,
              "dataset /volumes/labels/neuron_ids, contiguous, spacing from resolution, origin from offset");
    csgvtest::expectSourceContract(*s, expected("cremi_volumes_labels_neuron_ids"));

    // A spacing that is not positive is ignored, and the detail line says so.
    s = open(fx("cremi.h5") + ":/volumes/bad_spacing");
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->info().geometry.spacing, (std::array<double, 3>{1, 1, 1}));
    EXPECT_EQ(s->info().detail,
              "dataset /volumes/bad_spacing, contiguous, attribute resolution ignored (not 3 positive numbers)");
}

TEST(Hdf5Input, SourcesCloseTheirFile) {
    // Opened and closed many times: a leaked handle would keep the file open, which HDF5 reports
    // when the same file is reopened with other settings; here we check values stay right.
    for (int i = 0; i < 50; ++i) {
        std::unique_ptr<InputSource> s = open(fx("small_u8.hdf5"));
        ASSERT_NE(s, nullptr);
        EXPECT_EQ(readWhole(*s), expected("small_u8_seg"));
    }
}

// ------------------------------------------------------------------------------------------------
// Hdf5Compress
// ------------------------------------------------------------------------------------------------

namespace {

struct RoundTrip {
    csgv::CompressReport report;
    csgv::CsgvFile file;
    csgv::LabelVolume decoded;
};

RoundTrip compressAndDecode(const std::string& input, const std::string& name) {
    RoundTrip rt;
    const std::string dir = csgvtest::tempDir() + "/hdf5-out";
    std::filesystem::create_directories(dir);
    const std::string out = dir + "/" + name + ".csgv";
    csgv::CompressOptions options;
    options.encode.brickSize = 8;
    const csgv::Status s = csgv::compressToFile(input, out, options, &rt.report);
    EXPECT_TRUE(s.isOk()) << s.message();
    csgv::Result<csgv::CsgvFile> file = csgv::openCsgv(out);
    EXPECT_TRUE(file.isOk()) << file.message();
    if (!file) return rt;
    rt.file = std::move(*file);
    csgv::Result<csgv::LabelVolume> v = csgv::decodeVolume(rt.file.volume, 0, rt.file.decodeOptions());
    EXPECT_TRUE(v.isOk()) << v.message();
    if (v) rt.decoded = std::move(*v);
    return rt;
}

} // namespace

TEST(Hdf5Compress, ChunkedGzipRoundTripIsExact) {
    RoundTrip rt = compressAndDecode(fx("chunked_gzip.h5"), "chunked");
    EXPECT_FALSE(rt.report.relabelled);
    EXPECT_EQ(rt.report.dim, (std::array<uint32_t, 3>{29, 23, 19}));
    const std::vector<uint64_t> want = expected("chunked_gzip_labels");
    ASSERT_EQ(rt.decoded.labels.size(), want.size());
    for (size_t i = 0; i < want.size(); ++i) ASSERT_EQ(rt.decoded.labels[i], want[i]) << "voxel " << i;
}

TEST(Hdf5Compress, NegativeAnd64BitLabelsAreRelabelledAndMapBack) {
    for (const char* name : {"i64", "u64", "i32"}) {
        RoundTrip rt = compressAndDecode(fx(std::string(name) + ".h5"), name);
        EXPECT_TRUE(rt.report.relabelled) << name;
        ASSERT_TRUE(rt.file.hasAttributes) << name;
        const std::vector<uint64_t> want = expected(std::string(name) + "_labels");
        ASSERT_EQ(rt.decoded.labels.size(), want.size());
        for (size_t i = 0; i < want.size(); ++i)
            ASSERT_EQ(uint64_t(rt.file.originalLabel(rt.decoded.labels[i])), want[i]) << name << " voxel " << i;
    }
}

// ------------------------------------------------------------------------------------------------
// Hdf5Errors
// ------------------------------------------------------------------------------------------------

TEST(Hdf5Errors, SeveralCandidatesAreListed) {
    EXPECT_CONTAINS(openError(fx("ambiguous.h5")),
                    fx("ambiguous.h5") + ": holds several 3D integer datasets (/group/seg2, /seg1); name one as "
                                         "FILE.h5:/group/dataset");
}

TEST(Hdf5Errors, NoCandidateListsWhatItPassedOver) {
    // What the file holds instead, and why each is not a candidate: a user who expected one of
    // them learns what to do (name a float dataset; fix a shape).
    EXPECT_CONTAINS(openError(fx("none.h5")),
                    fx("none.h5") + ": holds no 3D integer dataset; passed over: /flat is 2D (shape 3x4), /raw holds "
                                    "floats (shape 2x3x4; read only when named, where they hold integers); name one as "
                                    "FILE.h5:/group/dataset");
}

TEST(Hdf5Errors, MissingDatasetPath) {
    const std::string path = fx("nested.h5") + ":/a/b/missing";
    const std::string m = openError(path);
    EXPECT_CONTAINS(m, path + ": no dataset /a/b/missing in the file (");
    EXPECT_CONTAINS(m, "doesn't exist"); // HDF5's own words
    EXPECT_CONTAINS(openError(fx("nested.h5") + ":/nowhere/at/all"), "no dataset /nowhere/at/all in the file");
}

TEST(Hdf5Errors, DamagedObjectHeader) {
    const std::string m = openError(fx("damaged_header.h5") + ":/labels");
    EXPECT_CONTAINS(m, fx("damaged_header.h5") + ":/labels: cannot open /labels: unable to open object: ");
    EXPECT_CONTAINS(openError(fx("damaged_header.h5")),
                    fx("damaged_header.h5") + ": holds no 3D integer dataset (HDF5 could not open /labels); name one "
                                              "as FILE.h5:/group/dataset");
}

TEST(Hdf5Errors, GroupInsteadOfDataset) {
    EXPECT_CONTAINS(openError(fx("nested.h5") + ":/a"),
                    ": /a is a group, not a dataset; its 3D integer datasets: /a/b/labels, /a/b/lzf, /a/b/other, "
                    "/a/b/vol4d, /a/b/vol5d_channel");
    EXPECT_CONTAINS(openError(fx("none.h5") + ":/empty_group"),
                    ": /empty_group is a group, not a dataset; it holds no 3D integer dataset");
}

TEST(Hdf5Errors, WrongShapes) {
    EXPECT_CONTAINS(openError(fx("nested.h5") + ":/a/flat"),
                    ": dataset /a/flat is 2D (shape 7x8); labels need 3 axes (z, y, x), or 4 or 5 with the extra "
                    "ones of size 1");
    EXPECT_CONTAINS(openError(fx("nested.h5") + ":/a/b/empty"), ": dataset /a/b/empty is empty (shape 0x4x4)");
}

TEST(Hdf5Errors, UnsupportedTypes) {
    const std::string tail = "; labels must be integers of 1, 2, 4 or 8 bytes (or float32/float64 holding integers)";
    EXPECT_CONTAINS(openError(fx("nested.h5") + ":/a/b/names"), ": dataset /a/b/names has datatype string of 4 bytes" + tail);
    EXPECT_CONTAINS(openError(fx("nested.h5") + ":/a/b/pairs"), ": dataset /a/b/pairs has datatype compound of 8 bytes" + tail);
    EXPECT_CONTAINS(openError(fx("nested.h5") + ":/a/b/half"), ": dataset /a/b/half has datatype float of 2 bytes" + tail);
}

TEST(Hdf5Errors, FilterNotAvailable) {
    // h5py's LZF filter exists only inside h5py.
    EXPECT_CONTAINS(openError(fx("nested.h5") + ":/a/b/lzf"),
                    ": dataset /a/b/lzf needs HDF5 filter 'lzf' (id 32000), which this libhdf5 cannot decode");
}

TEST(Hdf5Errors, TruncatedFile) {
    const std::string m = openError(fx("truncated.h5"));
    EXPECT_CONTAINS(m, fx("truncated.h5") + ": cannot open: ");
    EXPECT_CONTAINS(m, "truncated file"); // HDF5's own words
}

TEST(Hdf5Errors, NotAnHdf5File) {
    EXPECT_CONTAINS(openError(fx("text.h5")), fx("text.h5") + ": not an HDF5 file (no HDF5 signature)");
    EXPECT_CONTAINS(openError(fx("text.h5") + ":/labels"), fx("text.h5") + ":/labels: not an HDF5 file");
    EXPECT_CONTAINS(openError(fx("absent.h5")), fx("absent.h5") + ": no such file");
    const std::string dir = csgvtest::tempDir() + "/folder.h5";
    std::filesystem::create_directories(dir);
    EXPECT_CONTAINS(openError(dir), dir + ": is a directory, not an HDF5 file");
}

TEST(Hdf5Errors, CorruptChunkFailsTheSlabsThatNeedIt) {
    std::unique_ptr<InputSource> s = open(fx("corrupt.h5"));
    ASSERT_NE(s, nullptr);
    const std::vector<uint64_t> want = expected("corrupt_labels");
    std::vector<uint64_t> slab(16 * 16 * 8);
    ASSERT_TRUE(s->readSlab(0, 8, slab.data()).isOk()); // the first chunk is intact
    EXPECT_EQ(slab, std::vector<uint64_t>(want.begin(), want.begin() + 16 * 16 * 8));
    // The chunk is named with its stored size (which depends on zlib's output) and zlib's reason.
    const std::string message = s->readSlab(6, 4, slab.data()).message();
    EXPECT_CONTAINS(message, fx("corrupt.h5") + ": cannot read z 6..9: the chunk at (x 0, y 0, z 8) (");
    EXPECT_CONTAINS(message, " bytes stored): gzip data are corrupt (invalid stored block lengths)");
}

TEST(Hdf5Errors, SeededMutationsGiveCleanErrorsOrVolumes) {
    // Bytes of a valid file changed by a fixed sequence (mostly in the first 4 KiB, where the
    // superblock, object headers and chunk index lie): each result is an error naming the file
    // or a volume that reads (libhdf5 parses; we check that its failures reach us as messages).
    std::ifstream in(fx("chunked_gzip.h5"), std::ios::binary);
    const std::vector<char> original((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GT(original.size(), 4096u);
    const std::string path = csgvtest::tempDir() + "/hdf5-mutated.h5";
    uint64_t r = 99;
    const auto next = [&r](uint64_t n) {
        r = r * 6364136223846793005ull + 1442695040888963407ull;
        return (r >> 33) % n;
    };
    int opened = 0, failed = 0;
    for (int round = 0; round < 120; ++round) {
        std::vector<char> bytes = original;
        const size_t span = round % 4 == 3 ? bytes.size() : 4096;
        for (uint64_t k = 0, n = 1 + next(4); k < n; ++k) {
            const size_t at = size_t(next(span));
            bytes[at] = char(next(256));
        }
        std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
        csgv::Result<std::unique_ptr<InputSource>> src = csgv::openInput(path);
        if (!src) {
            EXPECT_EQ(src.message().rfind(path + ": ", 0), 0u) << src.message();
            ++failed;
            continue;
        }
        const csgv::InputInfo& info = (*src)->info();
        if (uint64_t(info.dim[0]) * info.dim[1] > (1u << 20)) continue; // a claimed shape we will not allocate for
        std::vector<uint64_t> slice(size_t(info.dim[0]) * info.dim[1]);
        for (uint32_t z = 0; z < info.dim[2] && z < 32; ++z) {
            const csgv::Status st = (*src)->readSlab(z, 1, slice.data());
            if (!st) {
                EXPECT_EQ(st.message().rfind(path + ": cannot read z ", 0), 0u) << st.message();
                ++failed;
                break;
            }
        }
        ++opened;
    }
    EXPECT_GT(failed, 10);
}

TEST(Hdf5Errors, SlabBeyondTheVolume) {
    std::unique_ptr<InputSource> s = open(fx("small_u8.hdf5"));
    ASSERT_NE(s, nullptr);
    std::vector<uint64_t> slab(5 * 6 * 8);
    EXPECT_CONTAINS(s->readSlab(5, 3, slab.data()).message(), "slab z 5 to 8 is beyond the volume's depth");
}

TEST(Hdf5Errors, HdfPrintsNothingToStderr) {
    fixtureDir();
    std::fflush(stderr);
    const std::string capture = csgvtest::tempDir() + "/hdf5-stderr.txt";
    std::FILE* f = std::fopen(capture.c_str(), "w");
    ASSERT_NE(f, nullptr);
    const int saved = dup(2);
    dup2(fileno(f), 2);
    // Every kind of failure, at open and while reading (a damaged chunk, a fraction).
    for (const std::string& p : {fx("truncated.h5"), fx("text.h5"), fx("nested.h5") + ":/a/b/missing",
                                fx("nested.h5") + ":/a/b/lzf", fx("ambiguous.h5")})
        csgv::openInput(p);
    std::vector<uint64_t> slab(16 * 16 * 16);
    if (std::unique_ptr<InputSource> c = open(fx("corrupt.h5"))) c->readSlab(8, 8, slab.data());
    if (std::unique_ptr<InputSource> c = open(fx("nested.h5") + ":/a/b/float_frac")) c->readSlab(0, 6, slab.data());
    std::fflush(stderr);
    dup2(saved, 2);
    close(saved);
    std::fclose(f);
    EXPECT_EQ(std::filesystem::file_size(capture), 0u) << "HDF5 wrote to stderr";
}

// ------------------------------------------------------------------------------------------------
// Hdf5Hostile: chunks we decode ourselves (gzip and shuffle), fill values, external storage
// ------------------------------------------------------------------------------------------------

TEST(Hdf5Hostile, GzipChunksAreInflatedWithinTheChunksSize) {
    // Each dataset is one 16^3 uint16 chunk of 8192 bytes; the message names the chunk and sizes.
    const std::string file = fx("hostile_chunks.h5");
    std::vector<uint64_t> slab(16 * 16 * 16);
    const auto readError = [&](const std::string& name) {
        std::unique_ptr<InputSource> s = open(file + ":/" + name);
        if (!s) return std::string("did not open");
        const csgv::Status st = s->readSlab(0, 16, slab.data());
        EXPECT_FALSE(st.isOk()) << name;
        EXPECT_LE(s->workingBytes(), 8192u) << name;
        return st.message();
    };
    EXPECT_EQ(readError("bomb"), file + ":/bomb: cannot read z 0..15: the chunk at (x 0, y 0, z 0) (4086 bytes "
                                        "stored): gzip data inflate to more than the chunk's 8192 bytes");
    EXPECT_EQ(readError("oversized"), file + ":/oversized: cannot read z 0..15: the chunk at (x 0, y 0, z 0) stores "
                                             "20031 bytes, more than the 8211 a chunk of 8192 bytes can need");
    EXPECT_EQ(readError("short"), file + ":/short: cannot read z 0..15: the chunk at (x 0, y 0, z 0) (26 bytes "
                                         "stored): gzip data inflate to 4096 bytes, less than the chunk's 8192");
}

TEST(Hdf5Hostile, GzipChunksOfPipelinesLeftToLibhdf5AreCheckedFirst) {
    // scaleoffset + gzip: libhdf5 decodes it, after we have inflated its gzip streams within the
    // chunk's size (and a KiB of filter headers).
    const std::string file = fx("hostile_chunks.h5");
    expectVolume(file + ":/scaleoffset", "hostile_chunks_scaleoffset", {16, 16, 16}, LabelType::U16);
    std::unique_ptr<InputSource> s = open(file + ":/bomb_scaleoffset");
    ASSERT_NE(s, nullptr);
    std::vector<uint64_t> slab(16 * 16 * 16);
    EXPECT_EQ(s->readSlab(0, 16, slab.data()).message(),
              file + ":/bomb_scaleoffset: cannot read z 0..15: the chunk at (x 0, y 0, z 0) (4086 bytes stored): gzip "
                     "data inflate to more than 9216 bytes (a chunk's and a KiB of filter headers)");
}

TEST(Hdf5Hostile, SzipChunksMayNotStateMoreThanTheChunk) {
    if (!std::filesystem::exists(fx("i8_szip.h5"))) GTEST_SKIP() << "this HDF5 cannot write szip";
    const std::string file = fx("hostile_chunks.h5");
    std::unique_ptr<InputSource> s = open(file + ":/szip_claims");
    ASSERT_NE(s, nullptr);
    std::vector<uint64_t> slab(16 * 16 * 16);
    EXPECT_EQ(s->readSlab(0, 16, slab.data()).message(),
              file + ":/szip_claims: cannot read z 0..15: the chunk at (x 0, y 0, z 0) (64 bytes stored): szip data "
                     "state 1073741824 bytes, more than the chunk's 8192");
}

TEST(Hdf5Hostile, ChecksummedChunksAreDecodedAndChecked) {
    expectVolume(fx("checksummed.h5"), "checksummed_labels", {12, 11, 10}, LabelType::U64);
    expectVolume(fx("i8.h5"), "i8_labels", {9, 7, 6}, LabelType::I8); // fletcher32 alone
    std::unique_ptr<InputSource> s = open(fx("checksum_bad.h5"));
    ASSERT_NE(s, nullptr);
    std::vector<uint64_t> slab(12 * 11 * 10);
    const std::string message = s->readSlab(0, 10, slab.data()).message();
    EXPECT_CONTAINS(message, fx("checksum_bad.h5") + ": cannot read z 0..9: the chunk at (x 7, y 6, z 5) (");
    EXPECT_CONTAINS(message, " bytes stored): its fletcher32 checksum does not match (stored ");
}

TEST(Hdf5Hostile, UnwrittenChunksAreTheFillValue) {
    expectVolume(fx("fill.h5") + ":/some", "fill_some", {22, 21, 20}, LabelType::U32);
    expectVolume(fx("fill.h5") + ":/negative", "fill_negative", {9, 9, 9}, LabelType::I16);
}

TEST(Hdf5Hostile, AVolumeWithoutChunksIsReadWithoutReadingAnyChunk) {
    // 4096^3 voxels in a 10 KiB file: bands of it cost their copying only, and the cache holds
    // nothing the size of the volume's chunks.
    std::unique_ptr<InputSource> s = open(fx("fill.h5") + ":/none");
    ASSERT_NE(s, nullptr);
    EXPECT_CONTAINS(s->info().detail, "no chunk written (every voxel is the fill value)");
    EXPECT_EQ(s->info().chunkDepth, 1u); // nothing to decode once per chunk layer
    std::vector<uint64_t> band(size_t(4096) * 32 * 32);
    for (uint32_t z : {0u, 1000u, 4064u}) {
        ASSERT_TRUE(s->readRows(z, 32, 2048, 32, band.data()).isOk());
        EXPECT_EQ(std::count(band.begin(), band.end(), 7u), std::ptrdiff_t(band.size())) << z;
    }
    EXPECT_LT(s->workingBytes(), uint64_t(64) << 20);
}

TEST(Hdf5Hostile, ExternalStorageOutsideTheFileFolderIsRefused) {
    const std::string beside = fx("external/beside.h5"), outside = fx("external/outside.h5");
    // Named relatively, the raw data are found beside the file, whatever the working directory.
    expectVolume(beside, "external_labels", {4, 5, 6}, LabelType::U8);
    const std::string message = openError(outside);
    EXPECT_CONTAINS(message, outside + ": dataset /labels keeps its data in the external file '" +
                                 std::filesystem::absolute(fx("outside.raw")).string() + "'");
    EXPECT_CONTAINS(message, "outside the HDF5 file's folder");
    EXPECT_CONTAINS(message, "--allow-outside-paths");
    InputOptions allow;
    allow.allowOutsidePaths = true;
    std::unique_ptr<InputSource> s = open(outside, allow);
    ASSERT_NE(s, nullptr);
    csgvtest::expectSourceContract(*s, expected("external_labels"));
}

TEST(Hdf5Hostile, ExternalStorageThatIsNoRegularFileIsRefusedEvenWhenAllowed) {
    // /dev/zero never ends (a FIFO would block for good): what the user allowed is files.
    InputOptions allow;
    allow.allowOutsidePaths = true;
    for (const InputOptions& options : {InputOptions{}, allow})
        EXPECT_CONTAINS(openError(fx("external/device.h5"), options),
                        "dataset /labels keeps its data in the external file '/dev/zero' (/dev/zero), which is not a "
                        "regular file");
}

TEST(Hdf5Hostile, ExternalLinksAndVirtualSourcesOutsideTheFileFolderAreRefused) {
    // Beside the file they are read (relative names are found there, whatever the working
    // directory), and a virtual dataset that is its own source neither loops nor is refused.
    expectVolume(fx("links/elink_beside.h5") + ":/d", "link_labels", {4, 5, 6}, LabelType::U16);
    expectVolume(fx("links/vds_beside.h5"), "link_labels", {4, 5, 6}, LabelType::U16);
    EXPECT_NE(open(fx("links/vds_self.h5")), nullptr);
    // Found by the search too (no name given), by the same rules (found by a GUI pass: a file
    // whose only dataset is behind an external link "held no 3D integer dataset").
    expectVolume(fx("links/elink_beside.h5"), "link_labels", {4, 5, 6}, LabelType::U16);
    const std::string searched = openError(fx("links/elink_relative_outside.h5"));
    EXPECT_CONTAINS(searched, "holds no 3D integer dataset; passed over: /d is an external link, and an external link in "
                              "'/' leads to '/labels' in '../outside_target.h5'");
    EXPECT_CONTAINS(searched, "; pass --allow-outside-paths to read it");
    // Sources named by a pattern are opened by libhdf5 without our checks (src0 leads outside).
    EXPECT_CONTAINS(openError(fx("links/vds_pattern_self.h5")),
                    "virtual dataset /labels names its sources by a pattern ('.', 'src%b'), which libhdf5 opens "
                    "without our checks; pass --allow-outside-paths");

    const std::string outside = std::filesystem::weakly_canonical(fx("outside_target.h5")).string();
    const std::string nested = std::filesystem::weakly_canonical(fx("links/vds_outside.h5")).string();
    const std::string link = "an external link in '/' leads to ";
    struct Case {
        std::string path, says;
    };
    InputOptions allow;
    allow.allowOutsidePaths = true;
    for (const Case& c : {
             Case{"links/elink_outside.h5:/d", link + "'/labels' in '" + outside + "' (" + outside + ")"},
             Case{"links/elink_outside.h5:/g/labels", link + "'/g' in '" + outside + "'"}, // a group on the way
             Case{"links/elink_outside.h5:/s", link + "'/labels' in '" + outside + "'"},   // behind a soft link
             Case{"links/elink_relative_outside.h5:/d", link + "'/labels' in '../outside_target.h5' (" + outside + ")"},
             Case{"links/vds_outside.h5", "virtual dataset /labels takes voxels from 'labels' in '" + outside + "'"},
             Case{"links/vds_relative_outside.h5",
                  "virtual dataset /labels takes voxels from 'labels' in '../outside_target.h5' (" + outside + ")"},
             Case{"links/vds_nested.h5", "virtual dataset " + nested + ":labels takes voxels from 'labels' in '" +
                                             outside + "'"},
             Case{"links/vds_through_link.h5:/labels", // /e, the link, is a dataset too
                  "the source '/e' of virtual dataset /labels: " + link + "'/labels' in '" + outside + "'"},
         }) {
        const std::string message = openError(fx(c.path));
        EXPECT_CONTAINS(message, c.says);
        EXPECT_CONTAINS(message, ", outside the HDF5 file's folder ");
        EXPECT_CONTAINS(message, "; pass --allow-outside-paths");
        std::unique_ptr<InputSource> s = open(fx(c.path), allow);
        ASSERT_NE(s, nullptr) << c.path;
        csgvtest::expectSourceContract(*s, expected("link_labels"));
    }
}

TEST(Hdf5Hostile, EveryPlaceLibhdf5MayOpenIsChecked) {
    // libhdf5 goes on to the working directory when it cannot open the file beside the HDF5 file
    // (one that only looks like HDF5), and it finds a relative external link's target there:
    // a file of that name in the working directory must pass the rules too.
    namespace fs = std::filesystem;
    const std::string cwd = csgvtest::tempDir() + "/hdf5_cwd";
    fs::create_directories(cwd);
    fs::copy_file(fx("links/target.h5"), cwd + "/target.h5", fs::copy_options::overwrite_existing);
    const fs::path before = fs::current_path();
    fs::current_path(cwd);
    const std::string message = openError(fx("links/elink_beside.h5") + ":/d");
    const std::string vds = openError(fx("links/vds_beside.h5"));
    fs::current_path(before);
    const std::string shown = fs::weakly_canonical(cwd + "/target.h5").string();
    EXPECT_CONTAINS(message, "an external link in '/' leads to '/labels' in 'target.h5' (" + shown + "), outside");
    EXPECT_CONTAINS(vds, "virtual dataset /labels takes voxels from 'labels' in 'target.h5' (" + shown + "), outside");
    // An environment prefix is a place too, ${ORIGIN} expanded as libhdf5 expands it.
    ::setenv("HDF5_VDS_PREFIX", "${ORIGIN}/..", 1);
    fs::copy_file(fx("links/target.h5"), fx("target.h5"), fs::copy_options::overwrite_existing);
    const std::string prefixed = openError(fx("links/vds_beside.h5"));
    ::unsetenv("HDF5_VDS_PREFIX");
    fs::remove(fx("target.h5"));
    EXPECT_CONTAINS(prefixed, "takes voxels from 'labels' in 'target.h5' (" + fs::weakly_canonical(fx("target.h5")).string() +
                                  "), outside");
}

TEST(Hdf5Hostile, ADatasetAtTheEndOfDeeplyNestedGroupsIsFoundAtOnce) {
    // 1500 groups deep: 0.2 s, where looking each object up by its path from the root took 30 s
    // (the bound leaves room for a loaded machine; the fixture is written before the clock starts).
    const std::string file = fx("deep_groups.h5");
    std::string named;
    for (int i = 0; i < 1500; ++i) named += "/g";
    named += "/labels";
    const auto start = std::chrono::steady_clock::now();
    std::unique_ptr<InputSource> found = open(file);
    ASSERT_NE(found, nullptr);
    EXPECT_CONTAINS(found->info().detail, "dataset " + named + ",");
    csgvtest::expectSourceContract(*found, expected("link_labels"));
    std::unique_ptr<InputSource> byName = open(file + ":" + named);
    ASSERT_NE(byName, nullptr);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 8.0);
}

TEST(Hdf5Hostile, AFifoALinkOrAVirtualDatasetNamesIsRefusedAtOnce) {
    // libhdf5 would open the FIFO and wait for a writer for good.
    namespace fs = std::filesystem;
    const std::string dir = csgvtest::tempDir() + "/hdf5_pipe";
    fs::create_directories(dir);
    for (const char* name : {"elink_pipe.h5", "vds_pipe.h5", "vds_pattern_pipe.h5"})
        fs::copy_file(fx(std::string("links/") + name), dir + "/" + name, fs::copy_options::overwrite_existing);
    const std::string pipe = dir + "/pipe.h5", patternPipe = dir + "/pipe0.h5";
    for (const std::string& fifo : {pipe, patternPipe}) {
        ::unlink(fifo.c_str());
        ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    }
    const std::string shown = fs::weakly_canonical(pipe).string();
    InputOptions allow;
    allow.allowOutsidePaths = true;
    for (const InputOptions& options : {InputOptions{}, allow}) {
        EXPECT_CONTAINS(openError(dir + "/elink_pipe.h5:/d", options),
                        "an external link in '/' leads to '/labels' in 'pipe.h5' (" + shown + "), which is not a regular file");
        EXPECT_CONTAINS(openError(dir + "/vds_pipe.h5", options),
                        "virtual dataset /labels takes voxels from 'labels' in 'pipe.h5' (" + shown +
                            "), which is not a regular file");
        // Sources named by a pattern are opened by libhdf5 with the dataset, before any check:
        // the metadata probe's child is found waiting on the FIFO and ended.
        EXPECT_CONTAINS(openError(dir + "/vds_pattern_pipe.h5", options), "libhdf5 blocked on a FIFO (named pipe)");
    }
}

TEST(Hdf5Hostile, CompressingFillValuesProgressesWithinTheFirstSlabAndCancels) {
    // 4096^3 voxels of one label: the encoder reports once per slab of bricks (128 slabs of
    // 4096^2 x 32 here, 0.8 / 128 of the whole each), and a slab of chunks never written is not
    // read (its bricks are made constant: milliseconds), so a cancel at the first report after
    // the start is seen at the end of the first slab at the latest.
    csgv::CompressOptions options;
    options.encode.threads = 2;
    double first = 0;
    int calls = 0;
    options.progress = [&](double fraction, const char*) {
        ++calls;
        if (fraction <= 0) return true;
        first = fraction;
        return false;
    };
    const std::string out = csgvtest::tempDir() + "/hdf5-fill-cancel.csgv";
    const csgv::Status s = csgv::compressToFile(fx("fill.h5") + ":/none", out, options);
    EXPECT_EQ(s.message(), "compression of '" + fx("fill.h5") + ":/none' cancelled");
    EXPECT_GT(first, 0.0);
    EXPECT_LE(first, 0.8 / 128 + 1e-12);
    EXPECT_FALSE(std::filesystem::exists(out));
}

// ------------------------------------------------------------------------------------------------
// Hdf5Uniform: chunks never written are uniform boxes of the fill value (InputSource::uniformBoxes),
// which the encoder writes as constant bricks without reading them; the bytes are those of
// reading every voxel.
// ------------------------------------------------------------------------------------------------

namespace {

/// The uniform.h5 datasets of make_hdf5.py: chunks that do and do not divide the bricks, fill
/// values 0, 7, negative (relabelled) and float, our decoding and libhdf5's, fill time "never".
const char* kUniformSets[] = {"aligned0", "odd7",         "big7",       "negative",          "float4",
                              "scaleoffset5", "never7", "never_scaleoffset7", "contiguous11"};

/// @brief An InputSource that forwards to another and counts the voxels read.
class CountingSource : public InputSource {
public:
    explicit CountingSource(std::unique_ptr<InputSource> s) : m_s(std::move(s)) { m_info = m_s->info(); }
    csgv::Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) override {
        voxels += uint64_t(m_info.dim[0]) * m_info.dim[1] * depth;
        return m_s->readSlab(z0, depth, out);
    }
    bool readsRows() const override { return m_s->readsRows(); }
    csgv::Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) override {
        voxels += uint64_t(m_info.dim[0]) * rows * depth;
        return m_s->readRows(z0, depth, y0, rows, out);
    }
    void uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows,
                      std::vector<csgv::UniformBox>& out) override {
        m_s->uniformBoxes(z0, depth, y0, rows, out);
    }
    uint64_t workingBytes() const override { return m_s->workingBytes(); }
    uint64_t voxels = 0;

private:
    std::unique_ptr<InputSource> m_s;
};

std::vector<uint8_t> fileBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

} // namespace

TEST(Hdf5Uniform, ChunksNeverWrittenAreTheFillValueOnEveryPath) {
    // Every voxel, through slabs and bands read into buffers that held something else (libhdf5
    // leaves voxels never written alone under fill time "never"), and every uniform box listed.
    const std::array<uint32_t, 3> dim = {70, 50, 45};
    for (const char* name : kUniformSets) {
        SCOPED_TRACE(name);
        std::unique_ptr<InputSource> s = open(fx("uniform.h5") + ":/" + name);
        ASSERT_NE(s, nullptr);
        EXPECT_EQ(s->info().dim, dim);
        csgvtest::expectSourceContract(*s, expected(std::string("uniform_") + name));
    }
}

TEST(Hdf5Uniform, TheBoxesAreTheChunksNeverWritten) {
    // aligned0: 60 chunks of 16^3 (the last ones cut), 15 written; a band of rows 16..31 of
    // slices 16..31 holds 5 chunks, 3 of them never written, listed as runs along x.
    std::unique_ptr<InputSource> s = open(fx("uniform.h5") + ":/aligned0");
    ASSERT_NE(s, nullptr);
    std::vector<csgv::UniformBox> boxes;
    s->uniformBoxes(0, 45, 0, 50, boxes);
    uint64_t voxels = 0;
    for (const csgv::UniformBox& b : boxes) {
        voxels += b.voxels();
        EXPECT_EQ(b.value, 0u);
    }
    const std::vector<uint64_t> want = expected("uniform_aligned0");
    EXPECT_GT(voxels, uint64_t(want.size()) / 2);
    EXPECT_LT(voxels, uint64_t(want.size()));
    s->uniformBoxes(16, 16, 16, 16, boxes);
    ASSERT_EQ(boxes.size(), 2u); // written: the chunk at x 32 (the fill value) and none other here
    EXPECT_EQ(boxes[0].lo, (std::array<uint32_t, 3>{0, 16, 16}));
    EXPECT_EQ(boxes[0].hi, (std::array<uint32_t, 3>{32, 32, 32}));
    EXPECT_EQ(boxes[1].lo, (std::array<uint32_t, 3>{48, 16, 16}));
    EXPECT_EQ(boxes[1].hi, (std::array<uint32_t, 3>{70, 32, 32}));
    // A fill value that is no label (2.5) lists nothing: the read names the voxel.
    s = open(fx("uniform.h5") + ":/fill_fraction");
    ASSERT_NE(s, nullptr);
    s->uniformBoxes(0, 45, 0, 50, boxes);
    EXPECT_TRUE(boxes.empty());
    std::vector<uint64_t> slab(size_t(70) * 50 * 16);
    EXPECT_CONTAINS(s->readSlab(0, 16, slab.data()).message(), "lies in a chunk never written, and the fill value");
}

TEST(Hdf5Uniform, CompressingSkipsChunksNeverWrittenAndGivesTheBytesOfReadingThem) {
    // Bricks of 16 on every set, and of 8 and 32 on chunks of 16 (dividing them or divided) and of
    // 12 x 20 x 24 (dividing none): the fast path reads no more voxels (fewer, but where every band
    // holds a chunk written: big7's 40^3 chunks, bricks of 32) and writes the very bytes of the slow one, whose
    // decoding is the volume (relabelled labels mapped back).
    const std::string dir = csgvtest::tempDir() + "/hdf5-uniform";
    std::filesystem::create_directories(dir);
    for (const char* name : kUniformSets)
        for (uint32_t brick : {8u, 16u, 32u}) {
            if (brick != 16 && std::string(name) != "aligned0" && std::string(name) != "odd7") continue;
            const std::string what = std::string(name) + " bricks " + std::to_string(brick);
            SCOPED_TRACE(what);
            const std::string input = fx("uniform.h5") + ":/" + name;
            std::vector<uint8_t> bytes[2];
            uint64_t read[2] = {0, 0};
            for (int fast = 0; fast < 2; ++fast) {
                csgv::CompressOptions options;
                options.encode.brickSize = brick;
                options.encode.threads = 2;
                options.encode.useUniformBoxes = fast == 1;
                CountingSource counted(open(input));
                const std::string out = dir + "/" + name + (fast ? "-fast" : "-slow") + ".csgv";
                const csgv::Status st = csgv::compressSourceToFile(counted, input, out, options);
                ASSERT_TRUE(st.isOk()) << st.message();
                bytes[fast] = fileBytes(out);
                read[fast] = counted.voxels;
            }
            ASSERT_FALSE(bytes[0].empty());
            EXPECT_TRUE(bytes[0] == bytes[1]) << "the fast path changed the bytes";
            if (std::string(name) == "big7" || brick == 32) EXPECT_LE(read[1], read[0]);
            else EXPECT_LT(read[1], read[0]) << "the fast path read every voxel";
            csgv::Result<csgv::CsgvFile> file = csgv::openCsgv(dir + "/" + name + "-fast.csgv");
            ASSERT_TRUE(file.isOk()) << file.message();
            csgv::Result<csgv::LabelVolume> v = csgv::decodeVolume(file->volume, 0, file->decodeOptions());
            ASSERT_TRUE(v.isOk()) << v.message();
            const std::vector<uint64_t> want = expected(std::string("uniform_") + name);
            ASSERT_EQ(v->labels.size(), want.size());
            for (size_t i = 0; i < want.size(); ++i)
                ASSERT_EQ(uint64_t(file->originalLabel(v->labels[i])), want[i]) << "voxel " << i;
        }
}

TEST(Hdf5Uniform, AVolumeOfFillValuesIsNeverRead) {
    // fill.h5:/none, 4096^3 voxels, no chunk written, in bricks of 128 (32768 bricks): no voxel
    // read, and every brick the constant brick of the fill value.
    csgv::CompressOptions options;
    options.encode.brickSize = 128;
    options.encode.threads = 2;
    CountingSource counted(open(fx("fill.h5") + ":/none"));
    const std::string out = csgvtest::tempDir() + "/hdf5-fill-none.csgv";
    const csgv::Status st = csgv::compressSourceToFile(counted, fx("fill.h5") + ":/none", out, options);
    ASSERT_TRUE(st.isOk()) << st.message();
    EXPECT_EQ(counted.voxels, 0u);
    csgv::Result<csgv::CsgvFile> file = csgv::openCsgv(out);
    ASSERT_TRUE(file.isOk()) << file.message();
    const csgv::CompressedVolume& vol = file->volume;
    ASSERT_EQ(vol.brickCount(), 32768u);
    for (uint64_t b : {uint64_t(0), uint64_t(12345), uint64_t(32767)}) {
        const csgv::BrickWords w = vol.brick(b);
        EXPECT_EQ(w.words[vol.levels()], 1u) << "palette of brick " << b; // one entry: the fill value
        EXPECT_EQ(w.words[w.size - 1], 7u) << "brick " << b;
    }
    std::filesystem::remove(out);
}
