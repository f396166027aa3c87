// SPDX-License-Identifier: MIT
/// @file test_input_tiff.cpp
/// @brief Tests of TIFF input: every voxel of multi-page files, folders and globs of slices
/// (types, strips, tiles, compressions) against the values make_tiff.py wrote beside them, the
/// InputSource contract, a compression round trip, and one test per kind of bad input.
#include "TestData.h"

#include "csgv/codec/Container.h"
#include "csgv/codec/Decoder.h"
#include "csgv/inputs/Compress.h"
#include "csgv/inputs/Inputs.h"
#include "csgv/inputs/Relabel.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <sys/resource.h>
#include <unistd.h>
#include <fstream>
#include <iterator>

using namespace csgv;

namespace {

/// The fixtures, written once per test process.
const std::string& tiffDir() {
    static const std::string dir = [] {
        const std::string d = csgvtest::tempDir() + "/tiff";
        EXPECT_EQ(csgvtest::runFixtureScript("make_tiff.py", {d}), 0) << "make_tiff.py failed";
        return d;
    }();
    return dir;
}

std::string at(const std::string& name) { return tiffDir() + "/" + name; }

/// The values make_tiff.py wrote for a fixture (NAME.u64: little-endian uint64, x fastest).
std::vector<uint64_t> expectedValues(const std::string& name) {
    std::ifstream in(at(name) + ".u64", std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::vector<uint64_t> v(bytes.size() / 8);
    for (size_t i = 0; i < v.size(); ++i) {
        uint64_t x = 0;
        for (int b = 7; b >= 0; --b)
            x = (x << 8) | uint8_t(bytes[i * 8 + size_t(b)]);
        v[i] = x;
    }
    return v;
}

std::unique_ptr<InputSource> openOk(const std::string& path) {
    Result<std::unique_ptr<InputSource>> src = openInput(path);
    EXPECT_TRUE(src.isOk()) << src.message();
    return src ? std::move(*src) : nullptr;
}

/// Opens `path`, checks its size, type and format, every voxel, and the source contract.
void expectVolume(const std::string& path, const std::string& expectedName, std::array<uint32_t, 3> dim,
                  LabelType type) {
    SCOPED_TRACE(path);
    std::unique_ptr<InputSource> src = openOk(path);
    ASSERT_TRUE(src);
    EXPECT_EQ(src->info().dim, dim);
    EXPECT_EQ(src->info().type, type) << labelTypeName(src->info().type);
    EXPECT_EQ(src->info().format, "TIFF");
    EXPECT_EQ(src->info().geometry.spacing, (std::array<double, 3>{1, 1, 1}));
    const std::vector<uint64_t> expected = expectedValues(expectedName);
    ASSERT_EQ(expected.size(), src->info().voxelCount());
    Result<InputVolume> all = readAll(*src, path);
    ASSERT_TRUE(all.isOk()) << all.message();
    for (size_t i = 0; i < expected.size(); ++i)
        ASSERT_EQ(all->values[i], expected[i]) << "voxel " << i;
    csgvtest::expectSourceContract(*src, expected);
    EXPECT_LE(src->workingBytes(), uint64_t(1) << 20);
}

std::string detailOf(const std::string& name) {
    std::unique_ptr<InputSource> src = openOk(at(name));
    return src ? src->info().detail : std::string();
}

/// The message of opening and reading `path` whole, which must fail; stderr must stay quiet.
std::string failure(const std::string& path) {
    testing::internal::CaptureStderr();
    std::string message;
    Result<std::unique_ptr<InputSource>> src = openInput(path);
    if (!src) {
        message = src.message();
    } else {
        Result<InputVolume> all = readAll(**src, path);
        message = all ? std::string() : all.message();
    }
    const std::string printed = testing::internal::GetCapturedStderr();
    EXPECT_EQ(printed, "") << "libtiff printed to stderr for " << path;
    EXPECT_NE(message, "") << path << " was accepted";
    EXPECT_EQ(message.rfind(path, 0), 0u) << "message does not start with the input's name: " << message;
    return message;
}

#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

} // namespace

// ---- forms ------------------------------------------------------------------------------------

TEST(InputTiff, ClaimsFilesFoldersAndGlobs) {
    EXPECT_TRUE(isInputPath("a.tif"));
    EXPECT_TRUE(isInputPath("a.TIFF"));
    EXPECT_TRUE(isInputPath("slices/"));
    EXPECT_TRUE(isInputPath("slices/*.tif"));
    EXPECT_TRUE(isInputPath("slices/s_??.tif"));
    EXPECT_TRUE(isInputPath("slices/s[0-9].tif"));
    EXPECT_TRUE(isInputPath(at("slices"))); // an existing folder without a slash
    EXPECT_FALSE(isInputPath("a.png"));
    EXPECT_FALSE(isInputPath(at("no_such_folder")));
}

// ---- good files -------------------------------------------------------------------------------
// (Few TEST()s on purpose: ctest runs each in its own process, which writes the fixtures anew.)

TEST(InputTiff, SampleTypes) {
    expectVolume(at("u16_pages.tif"), "u16_pages.tif", {11, 13, 7}, LabelType::U16);
    expectVolume(at("u8.tif"), "u8.tif", {10, 9, 5}, LabelType::U8);
    expectVolume(at("i8.tif"), "i8.tif", {5, 4, 3}, LabelType::I8);
    expectVolume(at("i32_neg.tif"), "i32_neg.tif", {12, 10, 4}, LabelType::I32);
    expectVolume(at("u32_large.tif"), "u32_large.tif", {9, 8, 3}, LabelType::U32);
    expectVolume(at("u64.tif"), "u64.tif", {6, 5, 2}, LabelType::U64);
    expectVolume(at("i64.tif"), "i64.tif", {6, 5, 2}, LabelType::I64);
    expectVolume(at("f32_int.tif"), "f32_int.tif", {7, 6, 3}, LabelType::F32);
    expectVolume(at("big_endian.tif"), "big_endian.tif", {11, 13, 3}, LabelType::U16);
    expectVolume(at("single.tif"), "single.tif", {8, 9, 1}, LabelType::U16); // one page: depth 1
    EXPECT_EQ(detailOf("u16_pages.tif"), "multi-page, 7 pages, strips of 13 rows, uncompressed");
    EXPECT_EQ(detailOf("single.tif"), "single page, strips of 9 rows, uncompressed");
}

TEST(InputTiff, StripsTilesAndCodecs) {
    // Tiles of 16x16 over 37x40 pages (partial tiles at the right and bottom), deflate.
    expectVolume(at("tiled_deflate.tif"), "tiled_deflate.tif", {37, 40, 6}, LabelType::U16);
    EXPECT_EQ(detailOf("tiled_deflate.tif"), "multi-page, 6 pages, tiles 16x16, deflate");
    // LZW strips of 5 rows over 23 rows: the last strip has 3.
    expectVolume(at("lzw_strips.tif"), "lzw_strips.tif", {19, 23, 5}, LabelType::U32);
    EXPECT_EQ(detailOf("lzw_strips.tif"), "multi-page, 5 pages, strips of 5 rows, LZW");
    // 64x64 bytes of few symbols in one strip: LZW codes of every width, the table cleared.
    expectVolume(at("lzw_long.tif"), "lzw_long.tif", {64, 64, 3}, LabelType::U8);
    expectVolume(at("i16_packbits.tif"), "i16_packbits.tif", {21, 9, 4}, LabelType::I16);
    EXPECT_EQ(detailOf("i16_packbits.tif"), "multi-page, 4 pages, strips of 3 rows, PackBits");

    // Working memory: one tile (16 x 16 x 2 bytes) and its compressed bytes, not a page.
    std::unique_ptr<InputSource> src = openOk(at("tiled_deflate.tif"));
    ASSERT_TRUE(src);
    std::vector<uint64_t> page(37 * 40);
    ASSERT_TRUE(src->readSlab(3, 1, page.data()).isOk());
    EXPECT_GE(src->workingBytes(), 16u * 16 * 2);
    EXPECT_LE(src->workingBytes(), 3u * 16 * 16 * 2);
}

TEST(InputTiff, FolderAndGlobOfSlicesInNaturalOrder) {
    // slice_1 ... slice_12: slice_10 must not come before slice_2; notes.txt is not a slice.
    expectVolume(at("slices"), "slices", {14, 10, 12}, LabelType::U16);
    expectVolume(at("slices/"), "slices", {14, 10, 12}, LabelType::U16);
    EXPECT_EQ(detailOf("slices/"), "folder of 12 slices, strips of 10 rows, uncompressed");
    expectVolume(at("slices/*.tif"), "slices", {14, 10, 12}, LabelType::U16);
    // The glob leaves out other.tif, whose size differs; these slices are deflate strips.
    expectVolume(at("mixed/slice_*.tif"), "slices", {14, 10, 12}, LabelType::U16);
    expectVolume(at("mixed/slice_[0-9]*.ti?"), "slices", {14, 10, 12}, LabelType::U16);
    EXPECT_EQ(detailOf("mixed/slice_*.tif"), "glob of 12 slices, strips of 3 rows, deflate");
}

TEST(InputTiff, ListOfSlicesKeepsTheGivenOrder) {
    // The order a caller gives is the volume's z order (ParaView's file dialog hands a series in
    // its own order): slices 12, 1, 2, ..., 11 put the last slice first.
    const std::vector<uint64_t> sorted = expectedValues("slices");
    const uint64_t slice = 14 * 10;
    std::vector<std::string> files;
    std::vector<uint64_t> expected;
    for (int i : {12, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}) {
        files.push_back(at("slices/slice_" + std::to_string(i) + ".tif"));
        expected.insert(expected.end(), sorted.begin() + (i - 1) * slice, sorted.begin() + i * slice);
    }
    Result<std::unique_ptr<InputSource>> src = openTiffSlices(files);
    ASSERT_TRUE(src.isOk()) << src.message();
    EXPECT_EQ((*src)->info().dim, (std::array<uint32_t, 3>{14, 10, 12}));
    EXPECT_EQ((*src)->info().type, LabelType::U16);
    EXPECT_EQ((*src)->info().format, "TIFF");
    EXPECT_EQ((*src)->info().detail, "list of 12 slices, strips of 10 rows, uncompressed");
    Result<InputVolume> all = readAll(**src, "list");
    ASSERT_TRUE(all.isOk()) << all.message();
    EXPECT_TRUE(all->values == expected);
    csgvtest::expectSourceContract(**src, expected);
    EXPECT_EQ(sliceListName(files), at("slices/slice_12.tif") + " .. slice_11.tif");

    // One file is a volume of depth 1; a compression from the list is exact.
    Result<std::unique_ptr<InputSource>> one = openTiffSlices({at("slices/slice_3.tif")});
    ASSERT_TRUE(one.isOk()) << one.message();
    EXPECT_EQ((*one)->info().dim, (std::array<uint32_t, 3>{14, 10, 1}));
    const std::string output = csgvtest::tempDir() + "/tiff_list.csgv";
    CompressOptions options;
    options.encode.brickSize = 8;
    Status s = compressSourceToFile(**src, sliceListName(files), output, options);
    ASSERT_TRUE(s.isOk()) << s.message();
    Result<CompressedVolume> vol = readCsgv(output);
    ASSERT_TRUE(vol.isOk()) << vol.message();
    Result<LabelVolume> decoded = decodeVolume(*vol, 0);
    ASSERT_TRUE(decoded.isOk()) << decoded.message();
    ASSERT_EQ(decoded->labels.size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i)
        ASSERT_EQ(uint64_t(decoded->labels[i]), expected[i]) << "voxel " << i;
}

TEST(InputTiff, ListOfSlicesNamesTheOneThatDiffers) {
    auto listFailure = [](const std::vector<std::string>& files) {
        testing::internal::CaptureStderr();
        Result<std::unique_ptr<InputSource>> src = openTiffSlices(files);
        EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
        EXPECT_FALSE(src.isOk()) << "the list was accepted";
        if (src) return std::string();
        EXPECT_EQ(src.message().rfind(sliceListName(files), 0), 0u) << src.message();
        return src.message();
    };
    const std::string s2 = at("bad_slice_size/s2.tif");
    EXPECT_CONTAINS(listFailure({at("bad_slice_size/s1.tif"), s2, at("bad_slice_size/s3.tif")}),
                    "slice " + s2 + " (z 1) is 7 x 5 uint16 but the first page is 6 x 5 uint16");
    EXPECT_CONTAINS(listFailure({at("bad_slice_type/s1.tif"), at("bad_slice_type/s2.tif")}),
                    "slice " + at("bad_slice_type/s2.tif") + " (z 1) is 6 x 5 uint8");
    EXPECT_CONTAINS(listFailure({at("multipage_slices/a.tif"), at("multipage_slices/b.tif")}),
                    "slice " + at("multipage_slices/a.tif") +
                        " (z 0) has more than one page; a list of slices takes single-page (2D) TIFF files");
    EXPECT_CONTAINS(listFailure({at("slices/slice_1.tif"), at("text.tif")}),
                    "slice 'text.tif' cannot be opened as TIFF");
    // Names that are no regular file are refused by name before anything is opened.
    const std::string dangling = csgvtest::tempDir() + "/tiff_list_dangling.tif";
    std::remove(dangling.c_str());
    ASSERT_EQ(::symlink((csgvtest::tempDir() + "/nowhere.tif").c_str(), dangling.c_str()), 0);
    EXPECT_CONTAINS(listFailure({at("slices/slice_1.tif"), dangling}),
                    "slice '" + dangling + "' (z 1) is a dangling symbolic link, not a TIFF file");
    EXPECT_CONTAINS(listFailure({at("slices/slice_1.tif"), at("slices")}), "(z 1) is a folder, not a TIFF file");
    EXPECT_CONTAINS(listFailure({at("slices/slice_1.tif"), at("no_such.tif")}),
                    "slice '" + at("no_such.tif") + "' (z 1) does not exist");
    Result<std::unique_ptr<InputSource>> none = openTiffSlices({});
    ASSERT_FALSE(none.isOk());
    EXPECT_CONTAINS(none.message(), "no TIFF slice files given");
}

TEST(InputTiff, CompressRoundTripIsExact) {
    for (const char* name : {"tiled_deflate.tif", "i32_neg.tif", "slices/"}) {
        SCOPED_TRACE(name);
        const std::string input = at(name);
        const std::string output = csgvtest::tempDir() + "/tiff_roundtrip.csgv";
        CompressOptions options;
        options.encode.brickSize = 16;
        CompressReport report;
        Status s = compressToFile(input, output, options, &report);
        ASSERT_TRUE(s.isOk()) << s.message();
        // The expected labels: the fixture's values through the same label preparation
        // (unchanged when they fit, dense ids for int32's negatives).
        std::unique_ptr<InputSource> src = openOk(input);
        ASSERT_TRUE(src);
        InputVolume expected;
        expected.dim = src->info().dim;
        expected.type = src->info().type;
        expected.values = expectedValues(std::string(name) == "slices/" ? "slices" : name);
        LabelMapping mapping;
        Result<LabelVolume> labels = prepareLabels(expected, 16, false, mapping);
        ASSERT_TRUE(labels.isOk()) << labels.message();
        EXPECT_EQ(report.relabelled, mapping.relabelled);
        Result<CompressedVolume> vol = readCsgv(output);
        ASSERT_TRUE(vol.isOk()) << vol.message();
        Result<LabelVolume> decoded = decodeVolume(*vol, 0);
        ASSERT_TRUE(decoded.isOk()) << decoded.message();
        EXPECT_EQ(decoded->dim, expected.dim);
        EXPECT_TRUE(decoded->labels == labels->labels);
    }
}

// ---- bad input --------------------------------------------------------------------------------

TEST(InputTiff, MismatchedPagesAndSlicesAreNamed) {
    EXPECT_CONTAINS(failure(at("bad_page_size.tif")), "page 2 is 11 x 12 uint16 but the first page is 11 x 13 uint16");
    EXPECT_CONTAINS(failure(at("bad_page_type.tif")), "page 1 is 4 x 4 int16 but the first page is 4 x 4 uint16");
    EXPECT_CONTAINS(failure(at("bad_slice_size")),
                    "slice s2.tif (z 1) is 7 x 5 uint16 but the first page is 6 x 5 uint16");
    EXPECT_CONTAINS(failure(at("bad_slice_type/")),
                    "slice s2.tif (z 1) is 6 x 5 uint8 but the first page is 6 x 5 uint16");
    EXPECT_CONTAINS(failure(at("multipage_slices")), "slice a.tif (z 0) has more than one page");
}

TEST(InputTiff, UnsupportedSamplesAreRefused) {
    EXPECT_CONTAINS(failure(at("rgb.tif")), "page 0 has 3 samples per pixel (RGB)");
    EXPECT_CONTAINS(failure(at("bilevel.tif")), "page 0 is a bilevel (1 bit per pixel) image");
    EXPECT_CONTAINS(failure(at("f32_fraction.tif")),
                    "page 1: voxel (x 3, y 2) holds 2.5, which is not an integer label");
}

TEST(InputTiff, TruncatedFiles) {
    // The next page's directory is cut off: found while opening.
    EXPECT_CONTAINS(failure(at("truncated.tif")), "page 1 cannot be read (truncated or corrupt file?): libtiff: ");
    // Directories whole, pixel data cut short: found before libtiff is asked to decode.
    const std::string strips = failure(at("truncated_strips.tif"));
    EXPECT_CONTAINS(strips, "page 0: strip 0 (bytes ");
    EXPECT_CONTAINS(strips, "lies beyond the end of the file");
    const std::string tiles = failure(at("truncated_tiles.tif"));
    EXPECT_CONTAINS(tiles, "page 0: tile ");
    EXPECT_CONTAINS(tiles, "the file is truncated");
}

TEST(InputTiff, NotTiffOrNothingToRead) {
    EXPECT_CONTAINS(failure(at("empty")), "the folder holds no .tif or .tiff slice files");
    EXPECT_CONTAINS(failure(at("slices/*.tiff")), "no file matches the pattern '*.tiff'");
    const std::string text = failure(at("text.tif"));
    EXPECT_CONTAINS(text, "cannot be opened as TIFF: libtiff: ");
    EXPECT_CONTAINS(text, "Not a TIFF");
    EXPECT_CONTAINS(failure(at("zero.tif")), "cannot be opened as TIFF: libtiff: ");
    EXPECT_CONTAINS(failure(at("missing.tif")), "cannot be opened as TIFF");
}

TEST(InputTiff, LimitsAreChecked) {
    InputOptions small;
    small.maxWorkingBytes = 100; // one 16x16 uint16 tile needs 512 bytes, its deflate state 64 KiB
    Result<std::unique_ptr<InputSource>> src = openInput(at("tiled_deflate.tif"), small);
    ASSERT_FALSE(src.isOk());
    EXPECT_CONTAINS(src.message(), "page 0: reading needs ");
    EXPECT_CONTAINS(src.message(), " bytes of working memory (a decoded tile of 512 bytes, ");
    EXPECT_CONTAINS(src.message(), " compressed bytes of one and 65536 bytes of decoder state), more than the "
                                   "working-memory limit of 100 bytes; a file saved with smaller strips or tiles needs less");

    std::unique_ptr<InputSource> u8 = openOk(at("u8.tif"));
    ASSERT_TRUE(u8);
    std::vector<uint64_t> out(10 * 9 * 2);
    EXPECT_FALSE(u8->readSlab(4, 2, out.data()).isOk());
}

// ---- memory -----------------------------------------------------------------------------------

TEST(InputTiff, WorkingMemoryIsKnownWhenOpened) {
    // Pages of strips of 4, 4 and 32 rows of 64 uint8 (uncompressed: a strip's bytes are its
    // pixels): reading needs the largest strip and its bytes, 2048 + 2048, which the third page
    // brings. Refused when opened, before any pixel is decoded, naming that page.
    const std::string path = at("growing_strips.tif");
    InputOptions options;
    options.maxWorkingBytes = 4095;
    Result<std::unique_ptr<InputSource>> refused = openInput(path, options);
    ASSERT_FALSE(refused.isOk());
    EXPECT_EQ(refused.message(), path + ": page 2: reading needs 4096 bytes of working memory (a decoded strip of "
                                        "2048 bytes, 2048 compressed bytes of one and 0 bytes of decoder state), more "
                                        "than the working-memory limit of 4095 bytes; a file saved with smaller "
                                        "strips or tiles needs less");
    // At the limit it opens, reads every voxel exactly and holds no more than it said.
    options.maxWorkingBytes = 4096;
    Result<std::unique_ptr<InputSource>> src = openInput(path, options);
    ASSERT_TRUE(src.isOk()) << src.message();
    const std::vector<uint64_t> expected = expectedValues("growing_strips.tif");
    Result<InputVolume> all = readAll(**src, path);
    ASSERT_TRUE(all.isOk()) << all.message();
    EXPECT_TRUE(all->values == expected);
    EXPECT_LE((*src)->workingBytes(), 4096u);
}

TEST(InputTiff, CraftedBlockSizesAreRefusedByName) {
    EXPECT_CONTAINS(failure(at("huge_tile.tif")), "page 0 has tiles of 1073741824 x 1073741824 for a 64 x 64 image: "
                                                  "a tile far larger than the image (a corrupt or crafted header)");
    EXPECT_CONTAINS(failure(at("strip_claims.tif")),
                    "page 0: strip 0 claims 70000 compressed bytes for 16 decoded ones, far more than any codec "
                    "writes (a corrupt or crafted header)");
}

TEST(InputTiff, ShallowVolumeBandHoldsOnlyItsSlices) {
    // 512 x 384 x 3 uint16 in bricks of 32: the encoder's band is the volume's 3 slices of uint32
    // labels (it was 32 slices, 24 MiB), the adapter's scratch those slices at 64 bits, the
    // source one deflate strip of 16 rows and its bytes.
    const std::string input = at("shallow.tif");
    const std::string output = csgvtest::tempDir() + "/tiff_shallow.csgv";
    const uint64_t volume = 512 * 384 * 3;
    CompressOptions options;
    options.encode.brickSize = 32;
    CompressReport report;
    Status s = compressToFile(input, output, options, &report);
    ASSERT_TRUE(s.isOk()) << s.message();
    EXPECT_GE(report.workingBytes, volume * (4 + 8));
    EXPECT_LE(report.workingBytes, volume * (4 + 8) + (64u << 10));
    Result<CompressedVolume> vol = readCsgv(output);
    ASSERT_TRUE(vol.isOk()) << vol.message();
    Result<LabelVolume> decoded = decodeVolume(*vol, 0);
    ASSERT_TRUE(decoded.isOk()) << decoded.message();
    EXPECT_EQ(decoded->dim, (std::array<uint32_t, 3>{512, 384, 3}));
    const std::vector<uint64_t> expected = expectedValues("shallow.tif");
    ASSERT_EQ(decoded->labels.size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i)
        ASSERT_EQ(uint64_t(decoded->labels[i]), expected[i]) << "voxel " << i;
}

namespace {

/// This process's mapped bytes now (VmSize of /proc/self/status), 0 where unknown.
uint64_t mappedBytes() {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("VmSize:", 0) == 0) return std::stoull(line.substr(7)) * 1024;
    return 0;
}

} // namespace

TEST(InputTiff, BandBeyondTheMemoryAllowedIsRefusedBeforeReading) {
    // 4096 x 4096 x 33 pages of zeros (one shared deflate strip, 20 KB): bricks of 32 need a band of
    // 2 GiB of labels. Under an address-space limit 768 MiB above what is mapped now, the
    // compression is refused before the band is allocated, with the bytes, the limit and a brick
    // size that fits; the limit is restored after.
    struct rlimit old {};
    ASSERT_EQ(getrlimit(RLIMIT_AS, &old), 0);
    const uint64_t mapped = mappedBytes();
    ASSERT_GT(mapped, 0u);
    const rlim_t limit = rlim_t(mapped + (uint64_t(768) << 20));
    if (old.rlim_max != RLIM_INFINITY && old.rlim_max < limit) GTEST_SKIP() << "the hard address-space limit is lower";
    struct rlimit lowered = old;
    lowered.rlim_cur = limit;
    ASSERT_EQ(setrlimit(RLIMIT_AS, &lowered), 0);
    const std::string output = csgvtest::tempDir() + "/tiff_deep_wide.csgv";
    CompressOptions options;
    options.encode.brickSize = 32;
    options.encode.threads = 1;
    Status s = compressToFile(at("deep_wide.tif"), output, options);
    ASSERT_EQ(setrlimit(RLIMIT_AS, &old), 0);
    ASSERT_FALSE(s.isOk());
    EXPECT_CONTAINS(s.message(), "a band of 4096 x 4096 x 32 labels (bricks of 32^3) needs 2147483648 bytes of memory, "
                                 "more than the process's address-space limit of " +
                                     std::to_string(limit >> 20) + " MiB; bricks of ");
    EXPECT_CONTAINS(s.message(), "(--brick-size ");
    EXPECT_FALSE(std::ifstream(output).good()) << "the refused compression left " << output;
}
