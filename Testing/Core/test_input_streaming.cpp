// SPDX-License-Identifier: MIT
/// @file test_input_streaming.cpp
/// @brief The `.vraw`, NRRD and NIfTI-1 readers as streaming sources (Inputs.h's InputSource
/// contract): fixtures written here byte by byte from labels regenerated deterministically in C++
/// (raw and gzip, attached and detached, both byte orders, signed and float voxels), the AAL
/// atlas of mricron-data against an independent zlib reading, bounded working memory, and the
/// errors a stream meets only partway (a gzip stream that runs out, a float with a fraction).
///
/// Suites:
/// - StreamingSources: expectSourceContract on every kind of file, readNrrd/readNifti agreeing.
/// - StreamingMemory: workingBytes() far below the volume and independent of its size.
/// - StreamingErrors: truncation (at open for raw data, at the slab for gzip), fractions, limits.
/// - StreamingRoundTrip: compressToFile of streamed inputs, decoded and compared exactly.
#include "TestData.h"

#include "csgv/base/FileUtil.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/LabelVolume.h"
#include "csgv/inputs/Compress.h"
#include "csgv/inputs/Inputs.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

using csgv::InputSource;
using csgv::LabelType;
using csgv::Status;

namespace {

using Bytes = std::vector<uint8_t>;
using Dim = std::array<uint32_t, 3>;

std::string tmp(const std::string& name) { return csgvtest::tempDir() + "/streaming-" + name; }

using csgvtest::gzipBytes;
using csgvtest::textBytes;
using csgvtest::writeBytes;
using csgvtest::operator+;

/// How many bytes zlib inflates from a (possibly cut) gzip stream: where the data run out.
uint64_t inflatedSize(const Bytes& gz) {
    z_stream s{};
    EXPECT_EQ(inflateInit2(&s, 31), Z_OK);
    Bytes out(1 << 16);
    s.next_in = const_cast<Bytes::value_type*>(gz.data());
    s.avail_in = uInt(gz.size());
    uint64_t total = 0;
    for (;;) {
        s.next_out = out.data();
        s.avail_out = uInt(out.size());
        const int r = inflate(&s, Z_NO_FLUSH);
        total += out.size() - s.avail_out;
        if (r != Z_OK) break;
    }
    inflateEnd(&s);
    return total;
}

unsigned widthOf(LabelType t) {
    switch (t) {
    case LabelType::U8:
    case LabelType::I8: return 1;
    case LabelType::U16:
    case LabelType::I16: return 2;
    case LabelType::U32:
    case LabelType::I32:
    case LabelType::F32: return 4;
    default: return 8;
    }
}

/// Labels of a segmentation-like volume (blocks of a few voxels, some repeated ids), as a reader
/// must return them at full width: within the type's range, negative ones for signed and float
/// types (sign-extended int64 bits).
std::vector<uint64_t> makeLabels(const Dim& d, LabelType t) {
    std::vector<uint64_t> v;
    v.reserve(size_t(d[0]) * d[1] * d[2]);
    const bool isSigned = csgv::isSignedType(t);
    const unsigned w = widthOf(t);
    for (uint32_t z = 0; z < d[2]; ++z)
        for (uint32_t y = 0; y < d[1]; ++y)
            for (uint32_t x = 0; x < d[0]; ++x) {
                int64_t l = int64_t(x / 4 + 7 * (y / 5) + 31 * (z / 3)) + ((x * y + z) % 13 == 0 ? 100000 : 0);
                if (w == 1) l %= 120;
                else if (w == 2) l %= 30000;
                if (isSigned) l -= (w == 1 ? 60 : 500);
                if (w == 8 && !isSigned && (x + y) % 17 == 0) l += int64_t(1) << 40;
                v.push_back(uint64_t(l));
            }
    return v;
}

/// The stored bytes of full-width `values` as `t` in the given byte order.
Bytes storeAs(const std::vector<uint64_t>& values, LabelType t, bool big) {
    const unsigned w = widthOf(t);
    Bytes out;
    out.reserve(values.size() * w);
    for (uint64_t v : values) {
        uint64_t bits = v;
        if (t == LabelType::F32) {
            const float f = float(int64_t(v));
            uint32_t b;
            std::memcpy(&b, &f, 4);
            bits = b;
        } else if (t == LabelType::F64) {
            const double f = double(int64_t(v));
            std::memcpy(&bits, &f, 8);
        }
        for (unsigned b = 0; b < w; ++b) out.push_back(uint8_t(bits >> (8 * (big ? w - 1 - b : b))));
    }
    return out;
}

std::string nrrdHeader(const char* type, const Dim& d, const std::string& encoding, bool big,
                       const std::string& extra = "") {
    return "NRRD0004\ntype: " + std::string(type) + "\ndimension: 3\nsizes: " + std::to_string(d[0]) + " " +
           std::to_string(d[1]) + " " + std::to_string(d[2]) + "\nencoding: " + encoding +
           "\nendian: " + (big ? "big" : "little") + "\nspacings: 0.5 1 2\n" + extra;
}

/// A NIfTI-1 header (sform off, pixdim spacing) and its extension bytes, up to vox_offset 352.
Bytes niftiHeader(int16_t datatype, int16_t bitpix, const Dim& d, bool big) {
    Bytes h(352, 0);
    const auto put = [&](size_t off, uint64_t bits, unsigned w) {
        for (unsigned b = 0; b < w; ++b) h[off + b] = uint8_t(bits >> (8 * (big ? w - 1 - b : b)));
    };
    const auto putFloat = [&](size_t off, float f) {
        uint32_t b;
        std::memcpy(&b, &f, 4);
        put(off, b, 4);
    };
    put(0, 348, 4);
    const int16_t dims[8] = {3, int16_t(d[0]), int16_t(d[1]), int16_t(d[2]), 1, 1, 1, 1};
    for (size_t i = 0; i < 8; ++i) put(40 + 2 * i, uint16_t(dims[i]), 2);
    put(70, uint16_t(datatype), 2);
    put(72, uint16_t(bitpix), 2);
    const float pixdim[8] = {1, 0.5f, 1, 2, 1, 0, 0, 0};
    for (size_t i = 0; i < 8; ++i) putFloat(76 + 4 * i, pixdim[i]);
    putFloat(108, 352);
    putFloat(112, 1);
    std::memcpy(h.data() + 344, "n+1\0", 4);
    return h;
}

std::unique_ptr<InputSource> open(const std::string& path, const csgv::InputOptions& options = {}) {
    csgv::Result<std::unique_ptr<InputSource>> src = csgv::openInput(path, options);
    EXPECT_TRUE(src.isOk()) << src.message();
    return src ? std::move(*src) : nullptr;
}

bool contains(const std::string& hay, const std::string& needle) { return hay.find(needle) != std::string::npos; }

::testing::AssertionResult failsWith(const Status& s, const std::vector<std::string>& needles) {
    if (s.isOk()) return ::testing::AssertionFailure() << "succeeded, expected an error";
    for (const std::string& n : needles)
        if (!contains(s.message(), n))
            return ::testing::AssertionFailure() << "message '" << s.message() << "' lacks '" << n << "'";
    return ::testing::AssertionSuccess() << s.message();
}

/// Opens `path`, checks what it says about itself and the whole contract against `want`.
void expectStreams(const std::string& path, const Dim& dim, LabelType type, const char* format,
                   const std::vector<uint64_t>& want) {
    SCOPED_TRACE(path);
    std::unique_ptr<InputSource> src = open(path);
    ASSERT_TRUE(src);
    EXPECT_EQ(src->info().dim, dim);
    EXPECT_EQ(src->info().type, type);
    EXPECT_EQ(src->info().format, format);
    csgvtest::expectSourceContract(*src, want);
    EXPECT_LT(src->workingBytes(), uint64_t(1) << 20);
}

const Dim kDim = {{23, 17, 29}}; // odd sizes: slabs and 128 KiB pieces never line up

} // namespace

// ------------------------------------------------------------------------------------------------
// StreamingSources
// ------------------------------------------------------------------------------------------------

TEST(StreamingSources, VrawPlainAndGzip) {
    for (LabelType stored : {LabelType::U8, LabelType::U16, LabelType::U32}) {
        const std::vector<uint64_t> want = makeLabels(kDim, stored);
        const char* typeName = csgv::labelTypeName(stored);
        const Bytes file = textBytes("23 17 29\n" + std::string(typeName) + "\n") + storeAs(want, stored, false);
        const std::string base = tmp(std::string("v-") + typeName);
        writeBytes(base + ".vraw", file);
        writeBytes(base + ".vraw.gz", gzipBytes(file));
        expectStreams(base + ".vraw", kDim, LabelType::U32, "vraw", want);
        expectStreams(base + ".vraw.gz", kDim, LabelType::U32, "vraw", want);
    }
    // A `.vraw.gz` that is not compressed is read as it is (gzopen's rule), by positioned reads.
    const std::vector<uint64_t> want = makeLabels(kDim, LabelType::U32);
    writeBytes(tmp("plain-content.vraw.gz"), textBytes("23 17 29\nuint32\n") + storeAs(want, LabelType::U32, false));
    expectStreams(tmp("plain-content.vraw.gz"), kDim, LabelType::U32, "vraw", want);
}

TEST(StreamingSources, NrrdRawAttachedDetachedGzipAndBigEndian) {
    const std::vector<uint64_t> want = makeLabels(kDim, LabelType::U32);
    const Bytes le = storeAs(want, LabelType::U32, false), be = storeAs(want, LabelType::U32, true);

    writeBytes(tmp("attached.nrrd"), textBytes(nrrdHeader("uint32", kDim, "raw", false) + "\n") + le);
    expectStreams(tmp("attached.nrrd"), kDim, LabelType::U32, "NRRD", want);

    // Detached raw data after a line skip and a byte skip.
    writeBytes(tmp("detached.raw"), textBytes("a text line\nxyz") + be);
    const std::string skips = "data file: streaming-detached.raw\nline skip: 1\nbyte skip: 3\n";
    writeBytes(tmp("detached.nhdr"), textBytes(nrrdHeader("uint32", kDim, "raw", true, skips)));
    expectStreams(tmp("detached.nhdr"), kDim, LabelType::U32, "NRRD", want);

    writeBytes(tmp("gzip.nrrd"), textBytes(nrrdHeader("uint32", kDim, "gzip", false) + "\n") + gzipBytes(le));
    expectStreams(tmp("gzip.nrrd"), kDim, LabelType::U32, "NRRD", want);

    // Big-endian gzip with a byte skip counted in inflated bytes.
    writeBytes(tmp("gzip-be.nrrd"), textBytes(nrrdHeader("uint32", kDim, "gzip", true, "byte skip: 5\n") + "\n") +
                                        gzipBytes(textBytes("12345") + be));
    expectStreams(tmp("gzip-be.nrrd"), kDim, LabelType::U32, "NRRD", want);

    // readNrrd is the same source read whole.
    for (const char* name : {"attached.nrrd", "detached.nhdr", "gzip.nrrd", "gzip-be.nrrd"}) {
        csgv::Result<csgv::InputVolume> whole = csgv::readNrrd(tmp(name));
        ASSERT_TRUE(whole.isOk()) << whole.message();
        EXPECT_EQ(whole->values, want) << name;
        EXPECT_EQ(whole->geometry.spacing, (std::array<double, 3>{{0.5, 1, 2}})) << name;
    }
}

TEST(StreamingSources, NrrdSignedAndFloatVoxels) {
    struct Case {
        const char* nrrdType;
        LabelType type;
        bool big;
    };
    for (const Case& c : {Case{"int16", LabelType::I16, false}, Case{"short", LabelType::I16, true},
                          Case{"int8", LabelType::I8, false}, Case{"int64", LabelType::I64, true},
                          Case{"uint64", LabelType::U64, false}, Case{"float", LabelType::F32, true},
                          Case{"double", LabelType::F64, false}})
        for (bool gz : {false, true}) {
            const std::vector<uint64_t> want = makeLabels(kDim, c.type);
            if (csgv::isSignedType(c.type)) {
                ASSERT_TRUE(std::any_of(want.begin(), want.end(), [](uint64_t v) { return int64_t(v) < 0; }))
                    << "negatives are really there";
            }
            const Bytes data = storeAs(want, c.type, c.big);
            const std::string path =
                tmp(std::string("typed-") + c.nrrdType + (c.big ? "-be" : "-le") + (gz ? "-gz" : "") + ".nrrd");
            writeBytes(path, textBytes(nrrdHeader(c.nrrdType, kDim, gz ? "gzip" : "raw", c.big) + "\n") +
                                 (gz ? gzipBytes(data) : data));
            expectStreams(path, kDim, c.type, "NRRD", want);
        }
}

TEST(StreamingSources, NiftiPlainAndGzip) {
    struct Case {
        int16_t datatype, bitpix;
        LabelType type;
        bool big;
    };
    for (const Case& c : {Case{4, 16, LabelType::I16, false}, Case{512, 16, LabelType::U16, true},
                          Case{16, 32, LabelType::F32, false}, Case{1280, 64, LabelType::U64, true}})
        for (bool gz : {false, true}) {
            const std::vector<uint64_t> want = makeLabels(kDim, c.type);
            const Bytes file = niftiHeader(c.datatype, c.bitpix, kDim, c.big) + storeAs(want, c.type, c.big);
            const std::string path =
                tmp("n-" + std::to_string(c.datatype) + (c.big ? "-be" : "-le") + (gz ? ".nii.gz" : ".nii"));
            writeBytes(path, gz ? gzipBytes(file) : file);
            expectStreams(path, kDim, c.type, "NIfTI", want);
            csgv::Result<csgv::InputVolume> whole = csgv::readNifti(path);
            ASSERT_TRUE(whole.isOk()) << whole.message();
            EXPECT_EQ(whole->values, want);
            EXPECT_EQ(whole->geometry.spacing, (std::array<double, 3>{{0.5, 1, 2}}));
        }
}

TEST(StreamingSources, AalAtlasAgainstZlib) {
    const std::string path = "/usr/share/mricron/templates/aal.nii.gz";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not found; install the Debian package mricron-data";
    // The voxels as zlib's gzread gives them: uint8 after the 352-byte header and extension.
    gzFile gz = gzopen(path.c_str(), "rb");
    ASSERT_NE(gz, nullptr);
    Bytes all;
    Bytes piece(1 << 20);
    for (int n; (n = gzread(gz, piece.data(), unsigned(piece.size()))) > 0;)
        all.insert(all.end(), piece.begin(), piece.begin() + n);
    gzclose(gz);
    const Dim dim = {{181, 217, 181}};
    ASSERT_EQ(all.size(), 352 + size_t(dim[0]) * dim[1] * dim[2]);
    const std::vector<uint64_t> want(all.begin() + 352, all.end());
    std::unique_ptr<InputSource> src = open(path);
    ASSERT_TRUE(src);
    EXPECT_EQ(src->info().dim, dim);
    EXPECT_EQ(src->info().type, LabelType::U8);
    // The whole volume in increasing z (as compression reads it), then slabs out of order, each
    // compared exactly. (expectSourceContract's reversed depth-1 passes would restart the 7 MB
    // stream some 700 times: half a minute; the small fixtures above cover that contract.)
    std::vector<std::pair<uint32_t, uint32_t>> slabs;
    for (uint32_t z = 0; z < dim[2]; z += 7) slabs.push_back({z, std::min(7u, dim[2] - z)});
    for (auto zd : {std::pair<uint32_t, uint32_t>{180, 1}, {0, 2}, {90, 5}, {89, 1}, {178, 3}, {45, 1}})
        slabs.push_back(zd);
    const uint64_t slice = uint64_t(dim[0]) * dim[1];
    std::vector<uint64_t> got;
    for (const auto& [z0, depth] : slabs) {
        got.assign(size_t(slice * depth), ~uint64_t(0));
        ASSERT_TRUE(src->readSlab(z0, depth, got.data()).isOk()) << z0;
        ASSERT_TRUE(std::equal(got.begin(), got.end(), want.begin() + long(slice * z0))) << "slab at z " << z0;
    }
    EXPECT_LT(src->workingBytes(), want.size() / 8);
    // readNifti (the ParaView reader's path) is the same source read whole.
    csgv::Result<csgv::InputVolume> whole = csgv::readNifti(path);
    ASSERT_TRUE(whole.isOk()) << whole.message();
    EXPECT_TRUE(whole->values == want);
}

// ------------------------------------------------------------------------------------------------
// StreamingMemory
// ------------------------------------------------------------------------------------------------

TEST(StreamingMemory, WorkingBytesFarBelowTheVolumeAndIndependentOfItsSize) {
    // Two volumes of 64 x 64 x D uint32 labels in every form; after reading each whole, slab by
    // slab, the source holds the same bounded buffers for both sizes.
    const auto write = [](const std::string& stem, const Dim& d) {
        const std::vector<uint64_t> want = makeLabels(d, LabelType::U32);
        const Bytes le = storeAs(want, LabelType::U32, false);
        const std::string dims = std::to_string(d[0]) + " " + std::to_string(d[1]) + " " + std::to_string(d[2]);
        writeBytes(tmp(stem + ".vraw"), textBytes(dims + "\nuint32\n") + le);
        writeBytes(tmp(stem + ".vraw.gz"), gzipBytes(textBytes(dims + "\nuint32\n") + le));
        writeBytes(tmp(stem + "-raw.nrrd"), textBytes(nrrdHeader("uint32", d, "raw", false) + "\n") + le);
        writeBytes(tmp(stem + "-gz.nrrd"), textBytes(nrrdHeader("uint32", d, "gzip", false) + "\n") + gzipBytes(le));
        const Bytes nii = niftiHeader(768, 32, d, false) + le;
        writeBytes(tmp(stem + ".nii"), nii);
        writeBytes(tmp(stem + ".nii.gz"), gzipBytes(nii));
        return want;
    };
    const Dim big = {{64, 64, 64}}, small = {{64, 64, 40}};
    const std::vector<uint64_t> want = write("mem64", big);
    write("mem40", small);
    for (const std::string suffix : {".vraw", ".vraw.gz", "-raw.nrrd", "-gz.nrrd", ".nii", ".nii.gz"}) {
        SCOPED_TRACE(suffix);
        uint64_t held[2] = {0, 0};
        for (int i = 0; i < 2; ++i) {
            std::unique_ptr<InputSource> src = open(tmp((i == 0 ? "mem64" : "mem40") + suffix));
            ASSERT_TRUE(src);
            const Dim& d = src->info().dim;
            const uint64_t slice = uint64_t(d[0]) * d[1];
            std::vector<uint64_t> slab(slice * 4);
            for (uint32_t z = 0; z < d[2]; z += 4) {
                ASSERT_TRUE(src->readSlab(z, 4, slab.data()).isOk());
                if (i == 0) {
                    ASSERT_TRUE(std::equal(slab.begin(), slab.end(), want.begin() + long(slice * z))) << z;
                }
            }
            held[i] = src->workingBytes();
            EXPECT_GT(held[i], 0u); // it does report its buffers
            const bool gz = contains(suffix, "gz");
            // No whole-volume buffer: at 64^3, less than a byte a voxel for raw data, and for gzip
            // (whose stream alone keeps a 256 KiB input buffer) less than a quarter of the volume
            // at 8 bytes a voxel.
            if (i == 0) {
                EXPECT_LT(held[i], gz ? 2 * src->info().voxelCount() : src->info().voxelCount());
            }
        }
        EXPECT_EQ(held[0], held[1]);
    }
}

TEST(StreamingMemory, GzipBandsOfRowsKeepOneSlabInAScratchFileBeyondTheLimit) {
    // A gzip source reads rows through one inflated slab at the file's width: in memory within
    // the limit, else in a scratch file that is unlinked at once (the folder stays empty).
    const Dim d = {{40, 36, 10}};
    const std::vector<uint64_t> want = makeLabels(d, LabelType::U16);
    const Bytes nii = niftiHeader(512, 16, d, false) + storeAs(want, LabelType::U16, false);
    writeBytes(tmp("rows.nii.gz"), gzipBytes(nii));
    const std::string scratch = tmp("scratch");
    std::filesystem::remove_all(scratch);
    std::filesystem::create_directories(scratch);
    // VoxelFileSource's gzip stream (304 KiB) and decode buffer (the whole data here, being
    // smaller than its 128 KiB), then room for a slab of 4 slices or for less than one slice.
    const uint64_t fixed = (uint64_t(304) << 10) + 40 * 36 * 10 * 2, slab = 40 * 36 * 4 * 2;
    for (const bool spill : {false, true}) {
        SCOPED_TRACE(spill ? "scratch file" : "memory");
        csgv::InputOptions options;
        options.scratchDirectory = scratch;
        options.maxWorkingBytes = fixed + (spill ? 100 : slab);
        std::unique_ptr<InputSource> src = open(tmp("rows.nii.gz"), options);
        ASSERT_TRUE(src);
        ASSERT_TRUE(src->readsRows());
        std::vector<uint64_t> band(40 * 5 * 4);
        ASSERT_TRUE(src->readRows(4, 4, 30, 5, band.data()).isOk());
        for (size_t i = 0; i < band.size(); ++i)
            ASSERT_EQ(band[i], want[i % 40 + 40 * (30 + i / 40 % 5 + 36 * (4 + i / 200))]) << i;
        EXPECT_EQ(src->workingBytes(), fixed + (spill ? 0 : slab));
        EXPECT_TRUE(std::filesystem::is_empty(scratch));
        csgvtest::expectSourceContract(*src, want);
    }
}

// ------------------------------------------------------------------------------------------------
// StreamingErrors
// ------------------------------------------------------------------------------------------------

TEST(StreamingErrors, TruncatedGzipFailsAtTheSlabWhereItRunsOut) {
    const Dim d = {{64, 64, 64}};
    const std::vector<uint64_t> want = makeLabels(d, LabelType::U32);
    const Bytes le = storeAs(want, LabelType::U32, false);
    const uint64_t slice = uint64_t(d[0]) * d[1];
    struct Case {
        std::string name;
        Bytes whole;           // the uncompressed file
        uint64_t dataStart;    // of the voxels in it
        std::vector<std::string> needles;
    };
    const std::string nh = nrrdHeader("uint32", d, "gzip", false) + "\n";
    const std::vector<Case> cases = {
        {"cut.vraw.gz", textBytes("64 64 64\nuint32\n") + le, 16, {"cut.vraw.gz", "bytes of labels, expected 1048576"}},
        {"cut.nii.gz", niftiHeader(768, 32, d, false) + le, 352, {"cut.nii.gz", "truncated", "vox_offset 352"}},
        {"cut.nrrd", {}, 0, {"cut.nrrd", "truncated gzip data", "1048576"}},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        Bytes gz = c.name == "cut.nrrd" ? gzipBytes(le) : gzipBytes(c.whole);
        gz.resize(gz.size() * 3 / 5);
        const uint64_t available = inflatedSize(gz) - c.dataStart;
        ASSERT_LT(available, le.size());
        const uint32_t lastZ = uint32_t(available / 4 / slice); // the slice in which the data end
        writeBytes(tmp(c.name), c.name == "cut.nrrd" ? textBytes(nh) + gz : gz);
        std::unique_ptr<InputSource> src = open(tmp(c.name)); // the header is fine: it opens
        ASSERT_TRUE(src);
        std::vector<uint64_t> slab(slice * 8);
        uint32_t failedAt = d[2];
        Status failure;
        for (uint32_t z = 0; z < d[2]; z += 8) {
            Status s = src->readSlab(z, 8, slab.data());
            if (!s) {
                failedAt = z;
                failure = s;
                break;
            }
            ASSERT_TRUE(std::equal(slab.begin(), slab.end(), want.begin() + long(slice * z))) << z;
        }
        EXPECT_EQ(failedAt, lastZ / 8 * 8); // every slab before it was read
        std::vector<std::string> needles = c.needles;
        needles.push_back("in slice z " + std::to_string(lastZ));
        EXPECT_TRUE(failsWith(failure, needles));
        // Asking again, or for an earlier slab first, gives the same answers.
        EXPECT_TRUE(src->readSlab(0, 1, slab.data()).isOk());
        EXPECT_TRUE(failsWith(src->readSlab(lastZ, 1, slab.data()), needles));
    }
}

TEST(StreamingErrors, InflatingASlabAsksWhetherToGoOn) {
    // 1024 x 1024 x 16 uint8 labels (16 MiB inflated): the first band of rows inflates the slab,
    // asking keepGoing every 8 MiB; a "no" ends the read, and the next read starts afresh.
    writeBytes(tmp("ask.vraw.gz"), gzipBytes(textBytes("1024 1024 16\nuint8\n") + Bytes(size_t(16) << 20, 3)));
    std::unique_ptr<InputSource> src = open(tmp("ask.vraw.gz"));
    ASSERT_TRUE(src);
    int asked = 0;
    src->setKeepGoing([&] { return ++asked < 2; });
    std::vector<uint64_t> band(1024 * 4 * 16);
    EXPECT_EQ(src->readRows(0, 16, 0, 4, band.data()).message(), tmp("ask.vraw.gz") + ": cancelled");
    EXPECT_EQ(asked, 2);
    src->setKeepGoing(nullptr);
    ASSERT_TRUE(src->readRows(0, 16, 1020, 4, band.data()).isOk());
    EXPECT_EQ(std::count(band.begin(), band.end(), 3u), std::ptrdiff_t(band.size()));
}

TEST(StreamingErrors, AGzipHeaderClaimingMoreThanTheFileCanHoldIsRefusedBeforeItsSlab) {
    // 4000 x 4000 x 32 uint32 labels claimed by a file of a few hundred bytes: a band of rows
    // would hold the slab (2 GB at the file's width); the file cannot inflate to that.
    writeBytes(tmp("claims.vraw.gz"), gzipBytes(textBytes("4000 4000 32\nuint32\n") + Bytes(1000, 1)));
    std::unique_ptr<InputSource> src = open(tmp("claims.vraw.gz"));
    ASSERT_TRUE(src);
    std::vector<uint64_t> band(4000 * 2 * 32);
    EXPECT_TRUE(failsWith(src->readRows(0, 32, 0, 2, band.data()),
                          {tmp("claims.vraw.gz") + ": slices z 0..31 need 2048000000 bytes, more than the ",
                           "the rest of the file can inflate to (the header claims more voxels than the file holds)"}));
    EXPECT_LT(src->workingBytes(), uint64_t(1) << 20);
}

TEST(StreamingErrors, TruncatedRawDataIsRefusedAtOpen) {
    const Dim d = {{8, 8, 8}};
    const Bytes le = storeAs(makeLabels(d, LabelType::U16), LabelType::U16, false);
    const Bytes cut(le.begin(), le.end() - 1);
    writeBytes(tmp("short.vraw"), textBytes("8 8 8\nuint16\n") + cut);
    EXPECT_TRUE(
        failsWith(csgv::openInput(tmp("short.vraw")).status(), {"short.vraw", "1023 bytes of labels, expected 1024"}));
    writeBytes(tmp("short.nrrd"), textBytes(nrrdHeader("uint16", d, "raw", false) + "\n") + cut);
    EXPECT_TRUE(failsWith(csgv::openInput(tmp("short.nrrd")).status(), {"short.nrrd", "truncated", "1023", "1024"}));
    writeBytes(tmp("short.nii"), niftiHeader(512, 16, d, false) + cut);
    EXPECT_TRUE(failsWith(csgv::openInput(tmp("short.nii")).status(), {"short.nii", "truncated", "1023", "1024"}));
    // A gzip NRRD whose compressed bytes cannot hold the sizes at deflate's best ratio.
    writeBytes(tmp("tiny-gz.nrrd"),
               textBytes(nrrdHeader("uint32", {{1000, 1000, 1000}}, "gzip", false) + "\n") + gzipBytes(cut));
    EXPECT_TRUE(failsWith(csgv::openInput(tmp("tiny-gz.nrrd")).status(), {"tiny-gz.nrrd", "truncated", "cannot hold"}));
}

TEST(StreamingErrors, FloatWithAFractionNamesTheVoxel) {
    const Dim d = {{5, 4, 12}};
    std::vector<uint64_t> want = makeLabels(d, LabelType::F32);
    Bytes data = storeAs(want, LabelType::F32, false);
    const uint64_t bad = 2 + 5 * (3 + 4 * 9); // x 2, y 3, z 9
    const float frac = 2.5f;
    std::memcpy(data.data() + 4 * bad, &frac, 4);
    for (bool gz : {false, true}) {
        const std::string name = gz ? "frac-gz.nrrd" : "frac.nrrd";
        const Bytes nrrdData = gz ? gzipBytes(data) : data;
        writeBytes(tmp(name), textBytes(nrrdHeader("float", d, gz ? "gzip" : "raw", false) + "\n") + nrrdData);
        const std::string nii = gz ? "frac.nii.gz" : "frac.nii";
        const Bytes niiBytes = niftiHeader(16, 32, d, false) + data;
        writeBytes(tmp(nii), gz ? gzipBytes(niiBytes) : niiBytes);
        for (const std::string& n : {name, nii}) {
            SCOPED_TRACE(n);
            std::unique_ptr<InputSource> src = open(tmp(n));
            ASSERT_TRUE(src);
            std::vector<uint64_t> slab(5 * 4 * 4);
            EXPECT_TRUE(src->readSlab(0, 4, slab.data()).isOk()); // slices before it are fine
            EXPECT_TRUE(src->readSlab(4, 4, slab.data()).isOk());
            EXPECT_TRUE(failsWith(src->readSlab(8, 4, slab.data()),
                                  {n, "voxel " + std::to_string(bad) + " (x 2, y 3, z 9)", "2.5", "not an integer"}));
            EXPECT_TRUE(src->readSlab(4, 4, slab.data()).isOk());
        }
    }
}

TEST(StreamingErrors, SlabsBeyondTheVolumeAndTooLittleWorkingMemory) {
    const Dim d = {{4, 4, 4}};
    writeBytes(tmp("small.nrrd"), textBytes(nrrdHeader("uint8", d, "gzip", false) + "\n") + gzipBytes(Bytes(64, 1)));
    std::unique_ptr<InputSource> src = open(tmp("small.nrrd"));
    ASSERT_TRUE(src);
    std::vector<uint64_t> slab(64);
    EXPECT_TRUE(failsWith(src->readSlab(2, 3, slab.data()), {"small.nrrd", "beyond", "depth 4"}));
    EXPECT_TRUE(src->readSlab(0, 4, slab.data()).isOk());
    EXPECT_EQ(slab, std::vector<uint64_t>(64, 1));

    csgv::InputOptions tight;
    tight.maxWorkingBytes = 100000; // less than a gzip stream's input buffer
    EXPECT_TRUE(
        failsWith(csgv::openInput(tmp("small.nrrd"), tight).status(), {"small.nrrd", "working memory", "100000"}));
    // Raw data need only a voxel's bytes; the buffer shrinks to the limit.
    writeBytes(tmp("small-raw.nrrd"), textBytes(nrrdHeader("uint8", d, "raw", false) + "\n") + Bytes(64, 2));
    tight.maxWorkingBytes = 10;
    std::unique_ptr<InputSource> raw = open(tmp("small-raw.nrrd"), tight);
    ASSERT_TRUE(raw);
    EXPECT_TRUE(raw->readSlab(0, 4, slab.data()).isOk());
    EXPECT_EQ(slab, std::vector<uint64_t>(64, 2));
    EXPECT_LE(raw->workingBytes(), 10u);
}

TEST(StreamingErrors, GzipSurplusAndChecksumAfterTheLastVoxel) {
    const Dim d = {{4, 4, 4}};
    const Bytes labels = storeAs(makeLabels(d, LabelType::U32), LabelType::U32, false);
    // More labels than the header claims: readVraw's exact-count message, at the last slab.
    writeBytes(tmp("surplus.vraw.gz"), gzipBytes(textBytes("4 4 4\nuint32\n") + labels + Bytes(8, 0)));
    std::unique_ptr<InputSource> src = open(tmp("surplus.vraw.gz"));
    ASSERT_TRUE(src);
    std::vector<uint64_t> slab(64);
    EXPECT_TRUE(src->readSlab(0, 2, slab.data()).isOk());
    EXPECT_TRUE(failsWith(src->readSlab(2, 2, slab.data()), {"surplus.vraw.gz", "264 bytes of labels, expected 256"}));
    // A wrong CRC-32: the voxels inflate, the member's end does not.
    Bytes gz = gzipBytes(niftiHeader(768, 32, d, false) + labels);
    gz[gz.size() - 8] ^= 0xFF;
    writeBytes(tmp("badcrc.nii.gz"), gz);
    src = open(tmp("badcrc.nii.gz"));
    ASSERT_TRUE(src);
    EXPECT_TRUE(failsWith(src->readSlab(0, 4, slab.data()), {"badcrc.nii.gz", "incorrect data check"}));
}

// ------------------------------------------------------------------------------------------------
// StreamingRoundTrip
// ------------------------------------------------------------------------------------------------

/// The .csgv at `out` decodes to `want`, voxel for voxel, as original labels.
void expectOriginalLabels(const std::string& out, const std::vector<uint64_t>& want) {
    csgv::Result<csgv::CsgvFile> f = csgv::openCsgv(out);
    ASSERT_TRUE(f.isOk()) << f.message();
    csgv::Result<csgv::LabelVolume> v = csgv::decodeVolume(f->volume, 0, f->decodeOptions());
    ASSERT_TRUE(v.isOk()) << v.message();
    ASSERT_EQ(v->labels.size(), want.size());
    for (size_t i = 0; i < want.size(); ++i) ASSERT_EQ(uint64_t(f->originalLabel(v->labels[i])), want[i]) << i;
}

TEST(StreamingRoundTrip, CompressedGzipInputsDecodeExactly) {
    const std::vector<uint64_t> want = makeLabels(kDim, LabelType::I16);
    const Bytes be = storeAs(want, LabelType::I16, true);
    writeBytes(tmp("rt.nrrd"), textBytes(nrrdHeader("int16", kDim, "gzip", true) + "\n") + gzipBytes(be));
    writeBytes(tmp("rt.nii.gz"), gzipBytes(niftiHeader(4, 16, kDim, true) + be));
    for (const char* name : {"rt.nrrd", "rt.nii.gz"}) {
        SCOPED_TRACE(name);
        const std::string out = tmp(std::string(name) + ".csgv");
        Status s = csgv::compressToFile(tmp(name), out, csgv::CompressOptions{});
        ASSERT_TRUE(s.isOk()) << s.message();
        expectOriginalLabels(out, want);
    }
}

TEST(StreamingRoundTrip, WideGzipSlicesAreRelabelledInBandsOfRows) {
    // A slice of 2100 x 2100 voxels is 35 MB at 8 bytes a voxel, more than the relabelling pass's
    // scratch: it observes bands of rows (through the gzip slab) and the result is still exact.
    const Dim d = {{2100, 2100, 2}};
    std::vector<uint64_t> want(size_t(d[0]) * d[1] * d[2]);
    for (size_t i = 0; i < want.size(); ++i) {
        const size_t x = i % d[0], y = i / d[0] % d[1], z = i / (size_t(d[0]) * d[1]);
        want[i] = ((x / 40) * 131 + (y / 40) * 17 + z) % 1000 * 1000003u; // beyond uint16, some 0
    }
    writeBytes(tmp("wide.vraw.gz"), gzipBytes(textBytes("2100 2100 2\nuint32\n") + storeAs(want, LabelType::U32, false)));
    csgv::CompressOptions options;
    options.relabel = true;
    csgv::CompressReport report;
    const std::string out = tmp("wide-relabelled.csgv");
    Status s = csgv::compressToFile(tmp("wide.vraw.gz"), out, options, &report);
    ASSERT_TRUE(s.isOk()) << s.message();
    EXPECT_TRUE(report.relabelled);
    expectOriginalLabels(out, want);
}
