// SPDX-License-Identifier: MIT
/// @file test_inputs.cpp
/// @brief Input formats other than `.csgv` (Inputs.h): NRRD and NIfTI-1 files written here byte
/// by byte (every voxel type, both byte orders, raw and gzip, detached data, geometry), the real
/// brain atlases of the Debian package mricron-data, and the dispatch by file name.
///
/// Suites:
/// - InputsTypes: type names and signedness.
/// - InputsNrrd / InputsNrrdErrors: values and geometry exactly; malformed headers and data.
/// - InputsNifti / InputsNiftiErrors: the same for NIfTI-1.
/// - InputsAtlas: aal, jhu189, inia19-NeuroMaps and HarvardOxford (skipped when not installed);
///   the expected figures were computed once from the files with an independent Python script.
/// - InputsDispatch: readInput by suffix.
/// - InputsRobustness: seeded random mutations of small NRRD and NIfTI files; every result is a
///   clean error naming the file or a consistent volume (run under the sanitizers to catch more).

#include "TestData.h"

#include "csgv/inputs/Inputs.h"
#include "csgv/inputs/PathGuard.h"
#include "csgv/base/FileUtil.h"
#include "csgv/codec/LabelVolume.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

using csgv::Geometry;
using csgv::InputVolume;
using csgv::LabelType;
using csgv::Status;

namespace {

// ------------------------------------------------------------------------------------------------
// Helpers
// ------------------------------------------------------------------------------------------------

using Bytes = std::vector<uint8_t>;

std::string tmp(const std::string& name) { return csgvtest::tempDir() + "/inputs-" + name; }

using csgvtest::gzipBytes;
using csgvtest::textBytes;
using csgvtest::writeBytes;
using csgvtest::operator+;

/// Appends the low `width` bytes of `bits` in the given byte order.
void putBits(Bytes& out, uint64_t bits, unsigned width, bool big) {
    for (unsigned b = 0; b < width; ++b) {
        const unsigned shift = 8 * (big ? width - 1 - b : b);
        out.push_back(uint8_t(bits >> shift));
    }
}

Bytes packBits(const std::vector<uint64_t>& bits, unsigned width, bool big) {
    Bytes out;
    for (uint64_t v : bits) putBits(out, v, width, big);
    return out;
}

uint64_t floatBits(float f) {
    uint32_t b;
    std::memcpy(&b, &f, 4);
    return b;
}

uint64_t doubleBits(double d) {
    uint64_t b;
    std::memcpy(&b, &d, 8);
    return b;
}

uint64_t i64(int64_t v) { return uint64_t(v); }

bool contains(const std::string& hay, const std::string& needle) { return hay.find(needle) != std::string::npos; }

/// Success when `s` is an error whose message contains every needle.
::testing::AssertionResult failsWith(const Status& s, const std::vector<std::string>& needles) {
    if (s.isOk()) return ::testing::AssertionFailure() << "succeeded, expected an error";
    for (const std::string& n : needles)
        if (!contains(s.message(), n))
            return ::testing::AssertionFailure() << "message '" << s.message() << "' lacks '" << n << "'";
    return ::testing::AssertionSuccess() << s.message();
}

void expectGeometry(const Geometry& g, const std::array<double, 3>& spacing, const std::array<double, 3>& origin,
                    const std::array<double, 9>& direction) {
    for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(g.spacing[a], spacing[a]) << "spacing " << a;
        EXPECT_EQ(g.origin[a], origin[a]) << "origin " << a;
    }
    for (int i = 0; i < 9; ++i) EXPECT_EQ(g.direction[i], direction[i]) << "direction " << i;
}

const std::array<double, 9> kIdentity = {{1, 0, 0, 0, 1, 0, 0, 0, 1}};

// ------------------------------------------------------------------------------------------------
// NRRD helpers
// ------------------------------------------------------------------------------------------------

struct IntType {
    const char* nrrdName;
    LabelType type;
    unsigned width;
    bool isSigned;
};

const IntType kIntTypes[] = {
    {"uint8", LabelType::U8, 1, false},   {"int8", LabelType::I8, 1, true},
    {"uint16", LabelType::U16, 2, false}, {"int16", LabelType::I16, 2, true},
    {"uint32", LabelType::U32, 4, false}, {"int32", LabelType::I32, 4, true},
    {"uint64", LabelType::U64, 8, false}, {"int64", LabelType::I64, 8, true},
};

/// Twelve values (a 3 x 2 x 2 volume) that reach both ends of the type, as the reader must
/// return them (signed ones sign-extended).
std::vector<uint64_t> extremeValues(unsigned width, bool isSigned) {
    const unsigned bits = 8 * width;
    if (isSigned) {
        const int64_t mx = bits == 64 ? std::numeric_limits<int64_t>::max() : (int64_t(1) << (bits - 1)) - 1;
        const int64_t mn = -mx - 1;
        return {i64(0), i64(1), i64(-1), i64(mx), i64(mn), i64(mx - 1), i64(mn + 1), i64(-2), i64(42), i64(-42),
                i64(100), i64(-100)};
    }
    const uint64_t mx = bits == 64 ? ~uint64_t(0) : (uint64_t(1) << bits) - 1;
    return {0, 1, 2, mx, mx - 1, mx / 2, mx / 2 + 1, 7, 42, 100, 127, 128};
}

uint64_t maskTo(uint64_t v, unsigned width) { return width == 8 ? v : v & ((uint64_t(1) << (8 * width)) - 1); }

std::string nrrdHeader(const std::string& type, const std::string& sizes, const std::string& extra,
                       const std::string& encoding = "raw", const std::string& endian = "little") {
    return "NRRD0004\ntype: " + type + "\ndimension: 3\nsizes: " + sizes + "\nencoding: " + encoding +
           "\nendian: " + endian + "\n" + extra;
}

/// Writes an attached NRRD and reads it back.
csgv::Result<InputVolume> nrrdRoundTrip(const std::string& name, const std::string& header, const Bytes& data) {
    const std::string path = tmp(name);
    writeBytes(path, textBytes(header) + textBytes("\n") + data);
    return csgv::readNrrd(path);
}

} // namespace

// ------------------------------------------------------------------------------------------------
// InputsTypes
// ------------------------------------------------------------------------------------------------

TEST(InputsTypes, NamesAndSignedness) {
    const std::pair<LabelType, const char*> names[] = {
        {LabelType::U8, "uint8"},   {LabelType::I8, "int8"},   {LabelType::U16, "uint16"},
        {LabelType::I16, "int16"},  {LabelType::U32, "uint32"}, {LabelType::I32, "int32"},
        {LabelType::U64, "uint64"}, {LabelType::I64, "int64"}, {LabelType::F32, "float32"},
        {LabelType::F64, "float64"}};
    for (const auto& [type, name] : names) EXPECT_STREQ(csgv::labelTypeName(type), name);
    for (LabelType t : {LabelType::U8, LabelType::U16, LabelType::U32, LabelType::U64})
        EXPECT_FALSE(csgv::isSignedType(t)) << csgv::labelTypeName(t);
    for (LabelType t : {LabelType::I8, LabelType::I16, LabelType::I32, LabelType::I64, LabelType::F32, LabelType::F64})
        EXPECT_TRUE(csgv::isSignedType(t)) << csgv::labelTypeName(t);

    InputVolume v;
    v.type = LabelType::I16;
    v.values = {i64(-5), 5};
    EXPECT_TRUE(v.isNegative(0));
    EXPECT_FALSE(v.isNegative(1));
    v.type = LabelType::U64;
    EXPECT_FALSE(v.isNegative(0)); // 2^64 - 5 as an unsigned label
}

// ------------------------------------------------------------------------------------------------
// InputsNrrd
// ------------------------------------------------------------------------------------------------

TEST(InputsNrrd, EveryIntegerTypeEndianAndEncoding) {
    for (const IntType& t : kIntTypes)
        for (bool big : {false, true})
            for (bool gz : {false, true}) {
                SCOPED_TRACE(std::string(t.nrrdName) + (big ? " big" : " little") + (gz ? " gzip" : " raw"));
                const std::vector<uint64_t> want = extremeValues(t.width, t.isSigned);
                std::vector<uint64_t> bits;
                for (uint64_t v : want) bits.push_back(maskTo(v, t.width));
                Bytes data = packBits(bits, t.width, big);
                if (gz) data = gzipBytes(data);
                const std::string header =
                    nrrdHeader(t.nrrdName, "3 2 2", "", gz ? "gzip" : "raw", big ? "big" : "little");
                auto r = nrrdRoundTrip(std::string("int-") + t.nrrdName + (big ? "-be" : "-le") +
                                           (gz ? "-gz" : "") + ".nrrd",
                                       header, data);
                ASSERT_TRUE(r.isOk()) << r.message();
                EXPECT_EQ(r->type, t.type);
                EXPECT_EQ(r->dim, (std::array<uint32_t, 3>{{3, 2, 2}}));
                EXPECT_EQ(r->values, want);
                for (size_t i = 0; i < want.size(); ++i)
                    EXPECT_EQ(r->isNegative(i), t.isSigned && int64_t(want[i]) < 0) << i;
                expectGeometry(r->geometry, {{1, 1, 1}}, {{0, 0, 0}}, kIdentity);
            }
}

TEST(InputsNrrd, TypeSpellings) {
    const std::pair<const char*, LabelType> spellings[] = {
        {"uchar", LabelType::U8},
        {"unsigned char", LabelType::U8},
        {"uint8", LabelType::U8},
        {"uint8_t", LabelType::U8},
        {"signed char", LabelType::I8},
        {"int8", LabelType::I8},
        {"int8_t", LabelType::I8},
        {"short", LabelType::I16},
        {"short int", LabelType::I16},
        {"signed short", LabelType::I16},
        {"signed short int", LabelType::I16},
        {"int16", LabelType::I16},
        {"int16_t", LabelType::I16},
        {"ushort", LabelType::U16},
        {"unsigned short", LabelType::U16},
        {"unsigned short int", LabelType::U16},
        {"uint16", LabelType::U16},
        {"uint16_t", LabelType::U16},
        {"int", LabelType::I32},
        {"signed int", LabelType::I32},
        {"int32", LabelType::I32},
        {"int32_t", LabelType::I32},
        {"uint", LabelType::U32},
        {"unsigned int", LabelType::U32},
        {"uint32", LabelType::U32},
        {"uint32_t", LabelType::U32},
        {"longlong", LabelType::I64},
        {"long long", LabelType::I64},
        {"long long int", LabelType::I64},
        {"signed long long", LabelType::I64},
        {"signed long long int", LabelType::I64},
        {"int64", LabelType::I64},
        {"int64_t", LabelType::I64},
        {"ulonglong", LabelType::U64},
        {"unsigned long long", LabelType::U64},
        {"unsigned long long int", LabelType::U64},
        {"uint64", LabelType::U64},
        {"uint64_t", LabelType::U64},
        {"float", LabelType::F32},
        {"double", LabelType::F64},
    };
    int n = 0;
    for (const auto& [spelling, type] : spellings) {
        SCOPED_TRACE(spelling);
        const bool isFloat = type == LabelType::F32 || type == LabelType::F64;
        const unsigned width = type == LabelType::U8 || type == LabelType::I8     ? 1
                               : type == LabelType::U16 || type == LabelType::I16 ? 2
                               : type == LabelType::U32 || type == LabelType::I32 || type == LabelType::F32 ? 4
                                                                                                            : 8;
        // One voxel holding 3 (as an integer or as a float).
        const uint64_t bits = !isFloat ? 3 : width == 4 ? floatBits(3.0f) : doubleBits(3.0);
        Bytes data;
        putBits(data, bits, width, false);
        auto r = nrrdRoundTrip("spelling-" + std::to_string(n++) + ".nrrd", nrrdHeader(spelling, "1 1 1", ""), data);
        ASSERT_TRUE(r.isOk()) << r.message();
        EXPECT_EQ(r->type, type);
        EXPECT_EQ(r->values, std::vector<uint64_t>{3});
    }
}

TEST(InputsNrrd, FloatsHoldingIntegers) {
    const std::vector<int64_t> want = {0, 1, -1, 255, -32768, 16777216, -16777216, 1000000, 0};
    const std::vector<int64_t> wantD = {0,           1, -1, int64_t(1) << 53, -(int64_t(1) << 53), 123456789012,
                                        -9007199254740991, int64_t(1) << 62, std::numeric_limits<int64_t>::min()};
    for (bool big : {false, true})
        for (bool gz : {false, true}) {
            SCOPED_TRACE(std::string(big ? "big" : "little") + (gz ? " gzip" : " raw"));
            std::vector<uint64_t> fb, db;
            for (int64_t v : want) fb.push_back(floatBits(float(v)));
            fb.back() = floatBits(-0.0f); // negative zero is the integer 0
            for (int64_t v : wantD) db.push_back(doubleBits(double(v)));
            Bytes f = packBits(fb, 4, big), d = packBits(db, 8, big);
            if (gz) {
                f = gzipBytes(f);
                d = gzipBytes(d);
            }
            const std::string suffix = std::string(big ? "-be" : "-le") + (gz ? "-gz" : "") + ".nrrd";
            auto rf = nrrdRoundTrip("float" + suffix,
                                    nrrdHeader("float", "3 3 1", "", gz ? "gzip" : "raw", big ? "big" : "little"), f);
            ASSERT_TRUE(rf.isOk()) << rf.message();
            EXPECT_EQ(rf->type, LabelType::F32);
            std::vector<uint64_t> wf;
            for (int64_t v : want) wf.push_back(uint64_t(v));
            EXPECT_EQ(rf->values, wf);
            EXPECT_TRUE(rf->isNegative(2));

            auto rd = nrrdRoundTrip("double" + suffix,
                                    nrrdHeader("double", "1 3 3", "", gz ? "gzip" : "raw", big ? "big" : "little"), d);
            ASSERT_TRUE(rd.isOk()) << rd.message();
            EXPECT_EQ(rd->type, LabelType::F64);
            std::vector<uint64_t> wd;
            for (int64_t v : wantD) wd.push_back(uint64_t(v));
            EXPECT_EQ(rd->values, wd);
        }
}

TEST(InputsNrrd, DetachedHeaderRelativeAndAbsolute) {
    const std::string dir = tmp("detached");
    std::filesystem::create_directories(dir + "/data");
    const std::vector<uint64_t> want = {10, 20, 30, 40, 50, 60, 70, 80};
    writeBytes(dir + "/data/vol.raw", packBits(want, 2, true));
    const std::string body = "type: ushort\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nendian: big\n";

    // Relative to the header's folder, not to the working directory.
    writeBytes(dir + "/rel.nhdr", textBytes("NRRD0004\n" + body + "data file: data/vol.raw\n"));
    auto r = csgv::readNrrd(dir + "/rel.nhdr");
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, want);
    EXPECT_EQ(r->type, LabelType::U16);

    writeBytes(dir + "/abs.nhdr", textBytes("NRRD0005\n" + body + "data file: " + dir + "/data/vol.raw\n"));
    r = csgv::readNrrd(dir + "/abs.nhdr");
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, want);

    // NRRD0001's spelling "datafile", and a blank line ending the detached header.
    writeBytes(dir + "/old.nhdr", textBytes("NRRD0001\n" + body + "datafile: data/vol.raw\n\n"));
    r = csgv::readNrrd(dir + "/old.nhdr");
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, want);

    // Detached gzip data.
    writeBytes(dir + "/data/vol.raw.gz", gzipBytes(packBits(want, 2, false)));
    writeBytes(dir + "/gz.nhdr", textBytes("NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\nencoding: gz\n"
                                           "endian: little\ndata file: data/vol.raw.gz\n"));
    r = csgv::readNrrd(dir + "/gz.nhdr");
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, want);
}

TEST(InputsNrrd, LineSkipAndByteSkip) {
    const std::string dir = tmp("skip");
    std::filesystem::create_directories(dir);
    const std::vector<uint64_t> want = {1, 2, 3, 4, 5, 6};
    const Bytes data = packBits(want, 4, false);
    const std::string body = "NRRD0004\ntype: uint32\ndimension: 3\nsizes: 3 2 1\nencoding: raw\nendian: little\n";

    // Two text lines, then three bytes, then the data.
    writeBytes(dir + "/a.raw", textBytes("first line\nsecond\nxyz") + data);
    writeBytes(dir + "/a.nhdr", textBytes(body + "data file: a.raw\nline skip: 2\nbyte skip: 3\n"));
    auto r = csgv::readNrrd(dir + "/a.nhdr");
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, want);

    // byte skip -1: the data are the last bytes of the file, whatever precedes them.
    writeBytes(dir + "/b.raw", textBytes("some unknown preamble of 31 b.") + data);
    writeBytes(dir + "/b.nhdr", textBytes(body + "data file: b.raw\nbyte skip: -1\n"));
    r = csgv::readNrrd(dir + "/b.nhdr");
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, want);

    // With gzip, byte skip counts inflated bytes (as teem does).
    writeBytes(dir + "/c.raw.gz", gzipBytes(textBytes("12345") + data));
    writeBytes(dir + "/c.nhdr", textBytes("NRRD0004\ntype: uint32\ndimension: 3\nsizes: 3 2 1\nencoding: gzip\n"
                                          "endian: little\ndata file: c.raw.gz\nbyte skip: 5\n"));
    r = csgv::readNrrd(dir + "/c.nhdr");
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, want);

    // Attached data with a line skip after the blank line.
    r = nrrdRoundTrip("attached-skip.nrrd", body + "line skip: 1\n", textBytes("skip me\n") + data);
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, want);
}

TEST(InputsNrrd, SpacingsGeometry) {
    const Bytes data(8, 7);
    auto r = nrrdRoundTrip("spacings.nrrd", nrrdHeader("uint8", "2 2 2", "spacings: 0.5 2 3\n"), data);
    ASSERT_TRUE(r.isOk()) << r.message();
    expectGeometry(r->geometry, {{0.5, 2, 3}}, {{0, 0, 0}}, kIdentity);
    EXPECT_EQ(r->values, std::vector<uint64_t>(8, 7));

    // A negative spacing runs the axis backwards; nan means "no spacing" (1).
    r = nrrdRoundTrip("spacings-neg.nrrd", nrrdHeader("uint8", "2 2 2", "spacings: -1.25 NaN 4\n"), data);
    ASSERT_TRUE(r.isOk()) << r.message();
    expectGeometry(r->geometry, {{1.25, 1, 4}}, {{0, 0, 0}}, {{-1, 0, 0, 0, 1, 0, 0, 0, 1}});
}

TEST(InputsNrrd, SpaceDirectionsAndOrigin) {
    const Bytes data = {1, 2, 3, 4, 5, 6, 7, 8};
    // Axis 0 runs along world y (length 2), axis 1 along -x (length 3), axis 2 along z (0.25).
    const std::string geo = "space: left-posterior-superior\nspace directions: (0,2,0) ( -3, 0 ,0 ) (0,0,0.25)\n"
                            "space origin: (10.5,-20,30)\n";
    auto r = nrrdRoundTrip("directions.nrrd", nrrdHeader("uint8", "2 2 2", geo), data);
    ASSERT_TRUE(r.isOk()) << r.message();
    expectGeometry(r->geometry, {{2, 3, 0.25}}, {{10.5, -20, 30}}, {{0, -1, 0, 1, 0, 0, 0, 0, 1}});
    EXPECT_EQ(r->values, (std::vector<uint64_t>{1, 2, 3, 4, 5, 6, 7, 8}));

    // `space dimension` instead of `space`, and directions winning over spacings.
    const std::string geo2 = "space dimension: 3\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,-0.5)\n"
                             "spacings: 9 9 9\nspace origin: (-1,-2,-3)\n";
    r = nrrdRoundTrip("directions2.nrrd", nrrdHeader("uint8", "2 2 2", geo2), data);
    ASSERT_TRUE(r.isOk()) << r.message();
    expectGeometry(r->geometry, {{0.5, 0.5, 0.5}}, {{-1, -2, -3}}, {{1, 0, 0, 0, 1, 0, 0, 0, -1}});
}

TEST(InputsNrrd, FourDimensionsWithOneSizeOneAxis) {
    const std::vector<uint64_t> want = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    const Bytes data = packBits(want, 2, false);
    const std::string leading = "NRRD0005\ntype: uint16\ndimension: 4\nsizes: 1 2 3 2\nencoding: raw\nendian: little\n"
                                "kinds: scalar domain domain domain\nspace: RAS\n"
                                "space directions: none (1,0,0) (0,2,0) (0,0,3)\nspace origin: (1,2,3)\n";
    auto r = nrrdRoundTrip("4d-leading.nrrd", leading, data);
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->dim, (std::array<uint32_t, 3>{{2, 3, 2}}));
    EXPECT_EQ(r->values, want);
    expectGeometry(r->geometry, {{1, 2, 3}}, {{1, 2, 3}}, kIdentity);

    const std::string trailing = "NRRD0004\ntype: uint16\ndimension: 4\nsizes: 2 3 2 1\nencoding: raw\n"
                                 "endian: little\nspacings: 4 5 6 nan\n";
    r = nrrdRoundTrip("4d-trailing.nrrd", trailing, data);
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->dim, (std::array<uint32_t, 3>{{2, 3, 2}}));
    EXPECT_EQ(r->values, want);
    expectGeometry(r->geometry, {{4, 5, 6}}, {{0, 0, 0}}, kIdentity);
}

TEST(InputsNrrd, CommentsKeyValuesAndCrLf) {
    const std::string header = "NRRD0004\r\n# Complete NRRD file format specification at:\r\n"
                               "# http://teem.sourceforge.net/nrrd/format.html\r\ntype: int8\r\n"
                               "my key:=a value: with colons\r\ndimension: 3\r\n"
                               "content: segmentation\r\nsizes: 2 1 1\r\nkinds: domain domain domain\r\n"
                               "encoding: raw\r\nspacings: 2 2 2\r\n\r\n";
    const std::string path = tmp("crlf.nrrd");
    writeBytes(path, textBytes(header) + Bytes{0xFF, 0x7F});
    auto r = csgv::readNrrd(path);
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->type, LabelType::I8);
    EXPECT_EQ(r->values, (std::vector<uint64_t>{i64(-1), 127}));
    expectGeometry(r->geometry, {{2, 2, 2}}, {{0, 0, 0}}, kIdentity);
}

TEST(InputsNrrd, LargerGzipVolume) {
    // Several inflate rounds (more than one input and output chunk).
    const uint32_t w = 96, h = 80, d = 70;
    std::vector<uint64_t> want(size_t(w) * h * d);
    for (size_t i = 0; i < want.size(); ++i) want[i] = (i * 2654435761u) % 1000003u;
    auto r = nrrdRoundTrip("large-gz.nrrd", nrrdHeader("uint32", "96 80 70", "", "gzip", "little"),
                           gzipBytes(packBits(want, 4, false)));
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, want);
}

// ------------------------------------------------------------------------------------------------
// InputsNrrdErrors
// ------------------------------------------------------------------------------------------------

TEST(InputsNrrdErrors, BadMagic) {
    auto r = nrrdRoundTrip("magic-p5.nrrd", "P5\n3 3\n255\n", Bytes(9, 0));
    EXPECT_TRUE(failsWith(r.status(), {"magic-p5.nrrd", "not a NRRD file"}));
    r = nrrdRoundTrip("magic-9.nrrd", "NRRD0009\ntype: uint8\n", Bytes(9, 0));
    EXPECT_TRUE(failsWith(r.status(), {"magic-9.nrrd", "NRRD0009"}));
    writeBytes(tmp("empty.nrrd"), {});
    EXPECT_TRUE(failsWith(csgv::readNrrd(tmp("empty.nrrd")).status(), {"empty.nrrd"}));
    EXPECT_TRUE(failsWith(csgv::readNrrd(tmp("absent.nrrd")).status(), {"absent.nrrd"}));
}

TEST(InputsNrrdErrors, MissingAndMalformedFields) {
    auto r = nrrdRoundTrip("no-sizes.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nencoding: raw\n", Bytes(8, 0));
    EXPECT_TRUE(failsWith(r.status(), {"no-sizes.nrrd", "'sizes'", "missing"}));
    r = nrrdRoundTrip("no-endian.nrrd", "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n",
                      Bytes(2, 0));
    EXPECT_TRUE(failsWith(r.status(), {"no-endian.nrrd", "'endian'", "uint16"}));
    r = nrrdRoundTrip("bad-endian.nrrd", nrrdHeader("uint16", "1 1 1", "", "raw", "middle"), Bytes(2, 0));
    EXPECT_TRUE(failsWith(r.status(), {"bad-endian.nrrd", "'middle'"}));
    r = nrrdRoundTrip("bad-type.nrrd", nrrdHeader("block", "1 1 1", "block size: 4\n"), Bytes(4, 0));
    EXPECT_TRUE(failsWith(r.status(), {"bad-type.nrrd", "type 'block'"}));
    r = nrrdRoundTrip("encoding.nrrd", nrrdHeader("uint8", "1 1 1", "", "bzip2"), Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"encoding.nrrd", "'bzip2'", "not supported"}));
    r = nrrdRoundTrip("ascii.nrrd", nrrdHeader("uint8", "1 1 1", "", "ascii"), textBytes("1\n"));
    EXPECT_TRUE(failsWith(r.status(), {"ascii.nrrd", "'ascii'"}));
    r = nrrdRoundTrip("dim2.nrrd", "NRRD0004\ntype: uint8\ndimension: 2\nsizes: 2 2\nencoding: raw\n", Bytes(4, 0));
    EXPECT_TRUE(failsWith(r.status(), {"dim2.nrrd", "dimension 2"}));
    r = nrrdRoundTrip("dim4.nrrd", "NRRD0004\ntype: uint8\ndimension: 4\nsizes: 2 2 2 2\nencoding: raw\n",
                      Bytes(16, 0));
    EXPECT_TRUE(failsWith(r.status(), {"dim4.nrrd", "dimension 4"}));
    r = nrrdRoundTrip("sizes-count.nrrd", nrrdHeader("uint8", "2 2", ""), Bytes(4, 0));
    EXPECT_TRUE(failsWith(r.status(), {"sizes-count.nrrd", "sizes", "2 values"}));
    r = nrrdRoundTrip("sizes-zero.nrrd", nrrdHeader("uint8", "2 0 2", ""), Bytes(4, 0));
    EXPECT_TRUE(failsWith(r.status(), {"sizes-zero.nrrd", "'0'"}));
    r = nrrdRoundTrip("sizes-big.nrrd", nrrdHeader("uint8", "2 4294967296 2", ""), Bytes(4, 0));
    EXPECT_TRUE(failsWith(r.status(), {"sizes-big.nrrd", "'4294967296'"}));
    r = nrrdRoundTrip("no-colon.nrrd", nrrdHeader("uint8", "1 1 1", "this line has no colon\n"), Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"no-colon.nrrd", "this line has no colon"}));
    r = nrrdRoundTrip("dirs-count.nrrd",
                      nrrdHeader("uint8", "1 1 1", "space: RAS\nspace directions: (1,0,0) (0,1,0)\n"), Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"dirs-count.nrrd", "space directions", "2 entries"}));
    r = nrrdRoundTrip("dirs-none.nrrd",
                      nrrdHeader("uint8", "1 1 1", "space: RAS\nspace directions: (1,0,0) none (0,0,1)\n"),
                      Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"dirs-none.nrrd", "axis 1", "'none'"}));
    r = nrrdRoundTrip("dirs-zero.nrrd",
                      nrrdHeader("uint8", "1 1 1", "space: RAS\nspace directions: (1,0,0) (0,0,0) (0,0,1)\n"),
                      Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"dirs-zero.nrrd", "axis 1"}));
    r = nrrdRoundTrip("dirs-2d.nrrd",
                      nrrdHeader("uint8", "1 1 1", "space dimension: 2\nspace directions: (1,0) (0,1) (1,1)\n"),
                      Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"dirs-2d.nrrd", "only 3D"}));
    r = nrrdRoundTrip("dirs-text.nrrd",
                      nrrdHeader("uint8", "1 1 1", "space: RAS\nspace directions: (1,0,0) (0,x,0) (0,0,1)\n"),
                      Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"dirs-text.nrrd", "'x'"}));
    r = nrrdRoundTrip("space.nrrd", nrrdHeader("uint8", "1 1 1", "space: sideways\n"), Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"space.nrrd", "'sideways'"}));
    r = nrrdRoundTrip("origin.nrrd", nrrdHeader("uint8", "1 1 1", "space: RAS\nspace origin: (1,2)\n"), Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"origin.nrrd", "space origin"}));
    r = nrrdRoundTrip("spacing0.nrrd", nrrdHeader("uint8", "1 1 1", "spacings: 1 0 1\n"), Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"spacing0.nrrd", "spacings", "'0'"}));
    r = nrrdRoundTrip("byteskip.nrrd", nrrdHeader("uint8", "1 1 1", "byte skip: -2\n"), Bytes(1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"byteskip.nrrd", "byte skip '-2'"}));
    r = nrrdRoundTrip("byteskip-gz.nrrd", nrrdHeader("uint8", "1 1 1", "byte skip: -1\n", "gzip"),
                      gzipBytes(Bytes(1, 0)));
    EXPECT_TRUE(failsWith(r.status(), {"byteskip-gz.nrrd", "byte skip -1", "gzip"}));
    r = nrrdRoundTrip("lineskip.nrrd", nrrdHeader("uint8", "1 1 1", "line skip: 3\n"), textBytes("a\nb\n"));
    EXPECT_TRUE(failsWith(r.status(), {"lineskip.nrrd", "line skip 3"}));
}

TEST(InputsNrrdErrors, TruncatedAndCorruptData) {
    auto r = nrrdRoundTrip("truncated.nrrd", nrrdHeader("uint32", "4 4 4", ""), Bytes(4 * 64 - 1, 0));
    EXPECT_TRUE(failsWith(r.status(), {"truncated.nrrd", "truncated", "255", "256"}));

    const Bytes gz = gzipBytes(packBits(std::vector<uint64_t>(4096, 5), 4, false));
    r = nrrdRoundTrip("truncated-gz.nrrd", nrrdHeader("uint32", "16 16 16", "", "gzip"),
                      Bytes(gz.begin(), gz.begin() + long(gz.size() / 2)));
    EXPECT_TRUE(failsWith(r.status(), {"truncated-gz.nrrd", "truncated gzip"}));
    // A complete stream that holds fewer voxels than the sizes say.
    r = nrrdRoundTrip("short-gz.nrrd", nrrdHeader("uint32", "16 16 17", "", "gzip"), gz);
    EXPECT_TRUE(failsWith(r.status(), {"short-gz.nrrd", "truncated gzip", "16384", "17408"}));
    Bytes bad = gz;
    for (size_t i = 10; i < bad.size(); ++i) bad[i] ^= 0x5A;
    r = nrrdRoundTrip("corrupt-gz.nrrd", nrrdHeader("uint32", "16 16 16", "", "gzip"), bad);
    EXPECT_TRUE(failsWith(r.status(), {"corrupt-gz.nrrd", "gzip"}));
    r = nrrdRoundTrip("garbage-gz.nrrd", nrrdHeader("uint32", "16 16 16", "", "gzip"), textBytes("not gzip at all"));
    EXPECT_TRUE(failsWith(r.status(), {"garbage-gz.nrrd", "corrupt gzip"}));

    // No blank line and no data file: there is no data.
    writeBytes(tmp("nodata.nrrd"), textBytes(nrrdHeader("uint8", "1 1 1", "")));
    EXPECT_TRUE(failsWith(csgv::readNrrd(tmp("nodata.nrrd")).status(), {"nodata.nrrd", "no data"}));
}

TEST(InputsNrrdErrors, FloatsThatAreNotIntegers) {
    std::vector<uint64_t> bits(8, floatBits(2.0f));
    bits[5] = floatBits(1.5f);
    auto r = nrrdRoundTrip("frac.nrrd", nrrdHeader("float", "2 2 2", ""), packBits(bits, 4, false));
    EXPECT_TRUE(failsWith(r.status(), {"frac.nrrd", "voxel 5 (x 1, y 0, z 1)", "1.5", "not an integer"}));

    bits[5] = floatBits(std::numeric_limits<float>::quiet_NaN());
    r = nrrdRoundTrip("nan.nrrd", nrrdHeader("float", "2 2 2", ""), packBits(bits, 4, false));
    EXPECT_TRUE(failsWith(r.status(), {"nan.nrrd", "voxel 5", "nan"}));

    bits[5] = floatBits(-std::numeric_limits<float>::infinity());
    r = nrrdRoundTrip("inf.nrrd", nrrdHeader("float", "2 2 2", ""), packBits(bits, 4, false));
    EXPECT_TRUE(failsWith(r.status(), {"inf.nrrd", "voxel 5", "inf"}));

    std::vector<uint64_t> dbits(8, doubleBits(2.0));
    dbits[7] = doubleBits(9223372036854775808.0); // 2^63, one past int64
    r = nrrdRoundTrip("big-double.nrrd", nrrdHeader("double", "2 2 2", "", "raw", "big"), packBits(dbits, 8, true));
    EXPECT_TRUE(failsWith(r.status(), {"big-double.nrrd", "voxel 7", "9.2233720368547758e+18"}));
}

TEST(InputsNrrdErrors, HugeSizesFailBeforeAllocating) {
    // 2^90 voxels: must be refused from the header alone.
    auto r = nrrdRoundTrip("huge.nrrd", nrrdHeader("uint8", "1073741824 1073741824 1073741824", ""), Bytes(16, 0));
    EXPECT_TRUE(failsWith(r.status(), {"huge.nrrd", "1073741824 x 1073741824 x 1073741824", "more than 2^64"}));
    // 2^48 voxels fit in 64 bits but not in the default limit.
    r = nrrdRoundTrip("big.nrrd", nrrdHeader("uint8", "65536 65536 65536", "", "gzip"), gzipBytes(Bytes(16, 0)));
    EXPECT_TRUE(failsWith(r.status(), {"big.nrrd", "more than the limit"}));
    // An explicit limit.
    const std::string path = tmp("limit.nrrd");
    writeBytes(path, textBytes(nrrdHeader("uint8", "4 4 4", "") + "\n") + Bytes(64, 1));
    EXPECT_TRUE(failsWith(csgv::readNrrd(path, 511).status(), {"limit.nrrd", "512", "511"}));
    EXPECT_TRUE(csgv::readNrrd(path, 512).isOk());
    // Sizes within the limit but far more than the file holds: refused by the size check, not a read.
    r = nrrdRoundTrip("claims.nrrd", nrrdHeader("uint8", "1024 1024 1024", ""), Bytes(16, 0));
    EXPECT_TRUE(failsWith(r.status(), {"claims.nrrd", "truncated"}));
    r = nrrdRoundTrip("claims-gz.nrrd", nrrdHeader("uint64", "1024 1024 1024", "", "gzip"), gzipBytes(Bytes(64, 0)));
    EXPECT_TRUE(failsWith(r.status(), {"claims-gz.nrrd", "truncated", "cannot hold"}));
}

TEST(InputsNrrdErrors, DataFileProblems) {
    const std::string dir = tmp("datafile-errors");
    std::filesystem::create_directories(dir);
    const std::string body = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n";
    writeBytes(dir + "/missing.nhdr", textBytes(body + "data file: nowhere.raw\n"));
    EXPECT_TRUE(failsWith(csgv::readNrrd(dir + "/missing.nhdr").status(), {"missing.nhdr", "nowhere.raw"}));
    writeBytes(dir + "/list.nhdr", textBytes(body + "data file: LIST\nslice0.raw\nslice1.raw\n"));
    EXPECT_TRUE(failsWith(csgv::readNrrd(dir + "/list.nhdr").status(), {"list.nhdr", "LIST", "not supported"}));
    writeBytes(dir + "/format.nhdr", textBytes(body + "data file: slice%03d.raw 0 1 1\n"));
    EXPECT_TRUE(
        failsWith(csgv::readNrrd(dir + "/format.nhdr").status(), {"format.nhdr", "slice%03d.raw", "not supported"}));
    writeBytes(dir + "/short.raw", Bytes(7, 0));
    writeBytes(dir + "/short.nhdr", textBytes(body + "data file: short.raw\n"));
    EXPECT_TRUE(failsWith(csgv::readNrrd(dir + "/short.nhdr").status(), {"short.raw", "short.nhdr", "truncated"}));
}

// ------------------------------------------------------------------------------------------------
// NIfTI helpers
// ------------------------------------------------------------------------------------------------

namespace {

/// The NIfTI-1 header fields the reader looks at, defaults for a 3D uint8 volume.
struct NiftiSpec {
    int32_t sizeofHdr = 348;
    std::array<int16_t, 8> dim{{3, 1, 1, 1, 1, 1, 1, 1}};
    int16_t datatype = 2;
    int16_t bitpix = 8;
    std::array<float, 8> pixdim{{1, 1, 1, 1, 0, 0, 0, 0}};
    float voxOffset = 352;
    float sclSlope = 1, sclInter = 0;
    int16_t qformCode = 0, sformCode = 0;
    std::array<float, 3> quatern{{0, 0, 0}};
    std::array<float, 3> qoffset{{0, 0, 0}};
    std::array<float, 12> srow{{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0}};
    std::string magic = std::string("n+1\0", 4);
    bool big = false;
};

/// The header and its 4-byte extension field, padded with zeros to vox_offset.
Bytes niftiHeader(const NiftiSpec& s) {
    Bytes h(std::max<size_t>(352, size_t(s.voxOffset)), 0);
    const auto put = [&](size_t off, uint64_t bits, unsigned width) {
        Bytes b;
        putBits(b, bits, width, s.big);
        std::copy(b.begin(), b.end(), h.begin() + long(off));
    };
    put(0, uint32_t(s.sizeofHdr), 4);
    for (size_t i = 0; i < 8; ++i) put(40 + 2 * i, uint16_t(s.dim[i]), 2);
    put(70, uint16_t(s.datatype), 2);
    put(72, uint16_t(s.bitpix), 2);
    for (size_t i = 0; i < 8; ++i) put(76 + 4 * i, floatBits(s.pixdim[i]), 4);
    put(108, floatBits(s.voxOffset), 4);
    put(112, floatBits(s.sclSlope), 4);
    put(116, floatBits(s.sclInter), 4);
    put(252, uint16_t(s.qformCode), 2);
    put(254, uint16_t(s.sformCode), 2);
    for (size_t i = 0; i < 3; ++i) put(256 + 4 * i, floatBits(s.quatern[i]), 4);
    for (size_t i = 0; i < 3; ++i) put(268 + 4 * i, floatBits(s.qoffset[i]), 4);
    for (size_t i = 0; i < 12; ++i) put(280 + 4 * i, floatBits(s.srow[i]), 4);
    std::copy(s.magic.begin(), s.magic.begin() + 4, h.begin() + 344);
    return h;
}

csgv::Result<InputVolume> niftiRoundTrip(const std::string& name, const NiftiSpec& spec, const Bytes& data,
                                         bool gz = false) {
    const std::string path = tmp(name);
    const Bytes file = niftiHeader(spec) + data;
    writeBytes(path, gz ? gzipBytes(file) : file);
    return csgv::readNifti(path);
}

NiftiSpec niftiSpec(int16_t datatype, int16_t bitpix, int16_t x, int16_t y, int16_t z, bool big = false) {
    NiftiSpec s;
    s.datatype = datatype;
    s.bitpix = bitpix;
    s.dim = {{3, x, y, z, 1, 1, 1, 1}};
    s.big = big;
    return s;
}

} // namespace

// ------------------------------------------------------------------------------------------------
// InputsNifti
// ------------------------------------------------------------------------------------------------

TEST(InputsNifti, Int16WithNegativesAndPixdimSpacing) {
    NiftiSpec s = niftiSpec(4, 16, 3, 2, 2);
    s.pixdim = {{0, 0.5f, 0.75f, 2, 1, 0, 0, 0}};
    const std::vector<uint64_t> want = {0, 1, i64(-1), i64(-32768), 32767, 12, i64(-12), 300, i64(-300), 7, 8, 9};
    std::vector<uint64_t> bits;
    for (uint64_t v : want) bits.push_back(v & 0xFFFF);
    auto r = niftiRoundTrip("int16.nii", s, packBits(bits, 2, false));
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->type, LabelType::I16);
    EXPECT_EQ(r->dim, (std::array<uint32_t, 3>{{3, 2, 2}}));
    EXPECT_EQ(r->values, want);
    EXPECT_TRUE(r->isNegative(3));
    expectGeometry(r->geometry, {{0.5, 0.75, 2}}, {{0, 0, 0}}, kIdentity);
}

TEST(InputsNifti, Uint8WithSform) {
    NiftiSpec s = niftiSpec(2, 8, 2, 2, 1);
    s.sformCode = 4;
    s.qformCode = 1; // the sform wins over a different qform
    s.quatern = {{1, 0, 0}};
    s.qoffset = {{7, 7, 7}};
    // Axis 0 along -x (2 mm), axis 1 along z (3 mm), axis 2 along y (1.5 mm).
    s.srow = {{-2, 0, 0, 10, 0, 0, 1.5f, -20, 0, 3, 0, 30}};
    auto r = niftiRoundTrip("uint8-sform.nii", s, Bytes{0, 255, 128, 1});
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->type, LabelType::U8);
    EXPECT_EQ(r->values, (std::vector<uint64_t>{0, 255, 128, 1}));
    expectGeometry(r->geometry, {{2, 3, 1.5}}, {{10, -20, 30}}, {{-1, 0, 0, 0, 0, 1, 0, 1, 0}});
}

TEST(InputsNifti, FloatsHoldingIntegers) {
    NiftiSpec s = niftiSpec(16, 32, 2, 2, 1);
    std::vector<uint64_t> bits = {floatBits(0), floatBits(-5), floatBits(16777216), floatBits(3)};
    auto r = niftiRoundTrip("float32.nii", s, packBits(bits, 4, false));
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->type, LabelType::F32);
    EXPECT_EQ(r->values, (std::vector<uint64_t>{0, i64(-5), 16777216, 3}));

    s = niftiSpec(64, 64, 2, 1, 1, true);
    bits = {doubleBits(-123456789012.0), doubleBits(4.0)};
    r = niftiRoundTrip("float64-be.nii", s, packBits(bits, 8, true));
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->type, LabelType::F64);
    EXPECT_EQ(r->values, (std::vector<uint64_t>{i64(-123456789012), 4}));

    s = niftiSpec(16, 32, 2, 2, 1);
    bits = {floatBits(0), floatBits(1), floatBits(2), floatBits(0.25f)};
    r = niftiRoundTrip("float32-frac.nii", s, packBits(bits, 4, false));
    EXPECT_TRUE(failsWith(r.status(), {"float32-frac.nii", "voxel 3 (x 1, y 1, z 0)", "0.25"}));
}

TEST(InputsNifti, EveryDatatype) {
    const struct {
        int16_t code;
        int16_t bitpix;
        LabelType type;
    } types[] = {{2, 8, LabelType::U8},       {4, 16, LabelType::I16},    {8, 32, LabelType::I32},
                 {16, 32, LabelType::F32},    {64, 64, LabelType::F64},   {256, 8, LabelType::I8},
                 {512, 16, LabelType::U16},   {768, 32, LabelType::U32},  {1024, 64, LabelType::I64},
                 {1280, 64, LabelType::U64}};
    for (const auto& t : types)
        for (bool big : {false, true}) {
            SCOPED_TRACE(std::to_string(t.code) + (big ? " big" : " little"));
            const unsigned width = unsigned(t.bitpix / 8);
            const bool isFloat = t.type == LabelType::F32 || t.type == LabelType::F64;
            std::vector<uint64_t> want;
            std::vector<uint64_t> bits;
            if (isFloat) {
                want = {0, 1, i64(-2), 100};
                for (uint64_t v : want)
                    bits.push_back(width == 4 ? floatBits(float(int64_t(v))) : doubleBits(double(int64_t(v))));
            } else {
                const std::vector<uint64_t> ext = extremeValues(width, csgv::isSignedType(t.type));
                want.assign(ext.begin() + 1, ext.begin() + 5);
                for (uint64_t v : want) bits.push_back(maskTo(v, width));
            }
            auto r = niftiRoundTrip("type-" + std::to_string(t.code) + (big ? "-be" : "-le") + ".nii",
                                    niftiSpec(t.code, t.bitpix, 2, 2, 1, big), packBits(bits, width, big));
            ASSERT_TRUE(r.isOk()) << r.message();
            EXPECT_EQ(r->type, t.type);
            EXPECT_EQ(r->values, want);
        }
}

TEST(InputsNifti, QformOnly) {
    // 180 degrees about x (b = 1) and qfac -1: direction diag(1, -1, 1).
    NiftiSpec s = niftiSpec(2, 8, 2, 2, 2);
    s.qformCode = 1;
    s.quatern = {{1, 0, 0}};
    s.qoffset = {{1.5f, -2.5f, 3.5f}};
    s.pixdim = {{-1, 2, 3, 4, 0, 0, 0, 0}};
    auto r = niftiRoundTrip("qform.nii", s, Bytes{1, 2, 3, 4, 5, 6, 7, 8});
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, (std::vector<uint64_t>{1, 2, 3, 4, 5, 6, 7, 8}));
    expectGeometry(r->geometry, {{2, 3, 4}}, {{1.5, -2.5, 3.5}}, {{1, 0, 0, 0, -1, 0, 0, 0, 1}});

    // 90 degrees about z (d = sin 45): axis 0 along +y, axis 1 along -x; float precision.
    s.quatern = {{0, 0, float(std::sqrt(0.5))}};
    s.pixdim = {{1, 0.5f, 0.5f, 1, 0, 0, 0, 0}};
    r = niftiRoundTrip("qform-rot.nii", s, Bytes(8, 9));
    ASSERT_TRUE(r.isOk()) << r.message();
    const std::array<double, 9> want = {{0, -1, 0, 1, 0, 0, 0, 0, 1}};
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(r->geometry.direction[i], want[i], 1e-6) << i;
    EXPECT_EQ(r->geometry.spacing, (std::array<double, 3>{{0.5, 0.5, 1}}));
    EXPECT_EQ(r->geometry.origin, (std::array<double, 3>{{1.5, -2.5, 3.5}}));

    // No qform, no sform: pixdim spacing (non-positive counts as 1), origin 0.
    s.qformCode = 0;
    s.pixdim = {{1, 0, -3, 2, 0, 0, 0, 0}};
    r = niftiRoundTrip("noform.nii", s, Bytes(8, 9));
    ASSERT_TRUE(r.isOk()) << r.message();
    expectGeometry(r->geometry, {{1, 1, 2}}, {{0, 0, 0}}, kIdentity);
}

TEST(InputsNifti, BigEndianGzipAndShapes) {
    NiftiSpec s = niftiSpec(8, 32, 2, 1, 2, true);
    s.sformCode = 2;
    s.srow = {{1, 0, 0, -90, 0, 1, 0, -126, 0, 0, 1, -72}};
    const std::vector<uint64_t> want = {i64(-100000), 100000, 0, i64(std::numeric_limits<int32_t>::min())};
    std::vector<uint64_t> bits;
    for (uint64_t v : want) bits.push_back(v & 0xFFFFFFFFu);
    const Bytes data = packBits(bits, 4, true);
    for (bool gz : {false, true}) {
        auto r = niftiRoundTrip(gz ? "be.nii.gz" : "be.nii", s, data, gz);
        ASSERT_TRUE(r.isOk()) << r.message();
        EXPECT_EQ(r->type, LabelType::I32);
        EXPECT_EQ(r->dim, (std::array<uint32_t, 3>{{2, 1, 2}}));
        EXPECT_EQ(r->values, want);
        expectGeometry(r->geometry, {{1, 1, 1}}, {{-90, -126, -72}}, kIdentity);
    }

    // 4D with one volume, a larger vox_offset (extensions), and a 2D slice.
    NiftiSpec four = niftiSpec(512, 16, 2, 2, 1);
    four.dim = {{4, 2, 2, 1, 1, 1, 1, 1}};
    four.voxOffset = 400;
    auto r = niftiRoundTrip("4d.nii", four, packBits({1, 2, 3, 65535}, 2, false));
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->type, LabelType::U16);
    EXPECT_EQ(r->values, (std::vector<uint64_t>{1, 2, 3, 65535}));

    NiftiSpec two = niftiSpec(2, 8, 3, 2, 0);
    two.dim = {{2, 3, 2, 0, 0, 0, 0, 0}}; // dims beyond dim[0] are ignored
    r = niftiRoundTrip("2d.nii", two, Bytes{1, 2, 3, 4, 5, 6});
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->dim, (std::array<uint32_t, 3>{{3, 2, 1}}));

    // Unscaled by the standard's rules: slope 0 (any inter), or slope 1 with inter 0.
    NiftiSpec zero = niftiSpec(2, 8, 1, 1, 1);
    zero.sclSlope = 0;
    zero.sclInter = 5;
    r = niftiRoundTrip("slope0.nii", zero, Bytes{3});
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values, std::vector<uint64_t>{3});
}

// ------------------------------------------------------------------------------------------------
// InputsNiftiErrors
// ------------------------------------------------------------------------------------------------

TEST(InputsNiftiErrors, HeaderProblems) {
    NiftiSpec s = niftiSpec(2, 8, 2, 2, 2);
    s.magic = "abc";
    s.magic.resize(4);
    EXPECT_TRUE(failsWith(niftiRoundTrip("magic.nii", s, Bytes(8, 0)).status(), {"magic.nii", "magic 'abc"}));
    s.magic = std::string("ni1\0", 4);
    EXPECT_TRUE(failsWith(niftiRoundTrip("pair.nii", s, Bytes(8, 0)).status(), {"pair.nii", ".hdr/.img"}));

    s = niftiSpec(2, 8, 2, 2, 2);
    s.sizeofHdr = 540;
    EXPECT_TRUE(failsWith(niftiRoundTrip("nifti2.nii", s, Bytes(8, 0)).status(), {"nifti2.nii", "NIfTI-2"}));
    s.sizeofHdr = 1234;
    EXPECT_TRUE(failsWith(niftiRoundTrip("sizeof.nii", s, Bytes(8, 0)).status(), {"sizeof.nii", "sizeof_hdr", "1234"}));

    s = niftiSpec(2, 8, 2, 2, 2);
    s.sclSlope = 2;
    EXPECT_TRUE(
        failsWith(niftiRoundTrip("scaled.nii", s, Bytes(8, 0)).status(), {"scaled.nii", "scaled", "scl_slope 2"}));
    s.sclSlope = 1;
    s.sclInter = -1024;
    EXPECT_TRUE(failsWith(niftiRoundTrip("inter.nii", s, Bytes(8, 0)).status(), {"inter.nii", "scl_inter -1024"}));

    s = niftiSpec(128, 24, 2, 2, 2);
    EXPECT_TRUE(failsWith(niftiRoundTrip("rgb.nii", s, Bytes(24, 0)).status(), {"rgb.nii", "datatype 128", "RGB24"}));
    s = niftiSpec(32, 64, 2, 2, 2);
    EXPECT_TRUE(failsWith(niftiRoundTrip("complex.nii", s, Bytes(64, 0)).status(), {"complex.nii", "datatype 32"}));

    s = niftiSpec(2, 8, 2, 2, 2);
    s.dim = {{4, 2, 2, 2, 3, 1, 1, 1}};
    EXPECT_TRUE(failsWith(niftiRoundTrip("4d-many.nii", s, Bytes(24, 0)).status(), {"4d-many.nii", "dim[4] is 3"}));
    s.dim = {{1, 8, 1, 1, 1, 1, 1, 1}};
    EXPECT_TRUE(failsWith(niftiRoundTrip("1d.nii", s, Bytes(8, 0)).status(), {"1d.nii", "dim[0] is 1"}));
    s.dim = {{3, 2, -2, 2, 1, 1, 1, 1}};
    EXPECT_TRUE(failsWith(niftiRoundTrip("negdim.nii", s, Bytes(8, 0)).status(), {"negdim.nii", "dim[2] is -2"}));

    s = niftiSpec(2, 8, 2, 2, 2);
    s.voxOffset = 100;
    EXPECT_TRUE(
        failsWith(niftiRoundTrip("voxoffset.nii", s, Bytes(8, 0)).status(), {"voxoffset.nii", "vox_offset 100"}));

    s = niftiSpec(2, 8, 2, 2, 2);
    s.sformCode = 1;
    s.srow = {{1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0}};
    EXPECT_TRUE(failsWith(niftiRoundTrip("sform0.nii", s, Bytes(8, 0)).status(), {"sform0.nii", "sform", "column 1"}));

    writeBytes(tmp("short-header.nii"), Bytes(100, 0));
    EXPECT_TRUE(failsWith(csgv::readNifti(tmp("short-header.nii")).status(), {"short-header.nii", "100 bytes"}));
    EXPECT_TRUE(failsWith(csgv::readNifti(tmp("absent.nii.gz")).status(), {"absent.nii.gz"}));
}

TEST(InputsNiftiErrors, BitpixThatDisagreesWithTheDatatype) {
    // uint16 (datatype 512) with bitpix 8: one reader would read bytes, another pairs of them.
    NiftiSpec s = niftiSpec(512, 8, 2, 2, 2);
    EXPECT_TRUE(failsWith(niftiRoundTrip("bitpix.nii", s, Bytes(16, 1)).status(),
                          {"bitpix.nii", "bitpix 8 disagrees with datatype 512", "16 bits a voxel", "damaged"}));
    s.bitpix = 16;
    EXPECT_TRUE(niftiRoundTrip("bitpix_ok.nii", s, Bytes(16, 1)).isOk());
}

TEST(InputsNiftiErrors, TruncatedAndHuge) {
    NiftiSpec s = niftiSpec(4, 16, 4, 4, 4);
    EXPECT_TRUE(failsWith(niftiRoundTrip("truncated.nii", s, Bytes(127, 0)).status(),
                          {"truncated.nii", "truncated", "127", "128"}));
    EXPECT_TRUE(failsWith(niftiRoundTrip("truncated.nii.gz", s, Bytes(100, 0), true).status(),
                          {"truncated.nii.gz", "truncated", "100", "128"}));

    // A gzip stream cut in the middle.
    const std::string path = tmp("cut.nii.gz");
    const Bytes gz = gzipBytes(niftiHeader(s) + Bytes(128, 3));
    writeBytes(path, Bytes(gz.begin(), gz.begin() + long(gz.size() - 12)));
    EXPECT_TRUE(failsWith(csgv::readNifti(path).status(), {"cut.nii.gz"}));

    // 32767^3 int64 voxels claim 2^48 bytes: refused from the header.
    s = niftiSpec(1024, 64, 32767, 32767, 32767);
    EXPECT_TRUE(failsWith(niftiRoundTrip("huge.nii", s, Bytes(64, 0)).status(), {"huge.nii", "more than the limit"}));
    const std::string limited = tmp("limit.nii");
    writeBytes(limited, niftiHeader(niftiSpec(2, 8, 64, 64, 64)) + Bytes(64 * 64 * 64, 1));
    EXPECT_TRUE(csgv::readNifti(limited, 8 * 64 * 64 * 64).isOk());
    EXPECT_TRUE(
        failsWith(csgv::readNifti(limited, 8 * 64 * 64 * 64 - 1).status(), {"limit.nii", "more than the limit"}));
}

// ------------------------------------------------------------------------------------------------
// InputsAtlas: the brain atlases of mricron-data
// ------------------------------------------------------------------------------------------------

namespace {

const char* const kTemplates = "/usr/share/mricron/templates/";

struct AtlasFacts {
    const char* file;
    std::array<uint32_t, 3> dim;
    LabelType type;
    std::array<double, 3> spacing;
    std::array<double, 3> origin;
    double xDirection; // the direction matrix is diag(xDirection, 1, 1) in all four
    size_t distinct;   // labels including background 0
    uint64_t maxLabel;
    uint64_t nonzero;
    uint64_t sum;
    uint64_t firstNonzero; // voxel index
    uint64_t firstLabel;
};

// Figures from the headers (sform) and from an independent Python reading of the voxels.
const AtlasFacts kAtlases[] = {
    {"aal.nii.gz", {{181, 217, 181}}, LabelType::U8, {{1, 1, 1}}, {{-90, -125, -71}}, 1, 117, 116, 1479969, 76656511,
     403749, 104},
    {"jhu189.nii.gz", {{157, 189, 136}}, LabelType::U8, {{1, 1, 1}}, {{78, -112, -50}}, -1, 190, 189, 1771330,
     106507886, 3820, 95},
    {"inia19-NeuroMaps.nii.gz", {{168, 206, 128}}, LabelType::I16, {{0.5, 0.5, 0.5}}, {{-42, -57.5, -30}}, 1, 725,
     1605, 801388, 502525881, 112647, 1379},
    {"HarvardOxford-cort-maxprob-thr0-1mm.nii.gz", {{182, 218, 182}}, LabelType::U8, {{1, 1, 1}}, {{90, -126, -72}},
     -1, 49, 48, 1689547, 32581128, 617030, 15},
};

} // namespace

TEST(InputsAtlas, MricronTemplates) {
    if (!std::filesystem::is_directory(kTemplates))
        GTEST_SKIP() << kTemplates << " not found; install the Debian package mricron-data";
    for (const AtlasFacts& a : kAtlases) {
        const std::string path = std::string(kTemplates) + a.file;
        SCOPED_TRACE(path);
        if (!std::filesystem::exists(path)) {
            ADD_FAILURE() << path << " is missing although " << kTemplates << " exists";
            continue;
        }
        auto r = csgv::readInput(path);
        ASSERT_TRUE(r.isOk()) << r.message();
        const InputVolume& v = *r;
        EXPECT_EQ(v.dim, a.dim);
        EXPECT_EQ(v.type, a.type);
        expectGeometry(v.geometry, a.spacing, a.origin, {{a.xDirection, 0, 0, 0, 1, 0, 0, 0, 1}});
        ASSERT_EQ(v.values.size(), v.voxelCount());

        std::vector<uint8_t> seen(65536, 0);
        uint64_t maxLabel = 0, nonzero = 0, sum = 0, first = ~uint64_t(0);
        bool negative = false;
        for (size_t i = 0; i < v.values.size(); ++i) {
            const uint64_t x = v.values[i];
            negative = negative || v.isNegative(i);
            if (x < seen.size()) seen[x] = 1;
            maxLabel = std::max(maxLabel, x);
            if (x != 0) {
                ++nonzero;
                if (first == ~uint64_t(0)) first = i;
            }
            sum += x;
        }
        EXPECT_FALSE(negative);
        EXPECT_EQ(size_t(std::count(seen.begin(), seen.end(), 1)), a.distinct);
        EXPECT_EQ(maxLabel, a.maxLabel);
        EXPECT_EQ(nonzero, a.nonzero);
        EXPECT_EQ(sum, a.sum);
        EXPECT_EQ(first, a.firstNonzero);
        if (first < v.values.size()) {
            EXPECT_EQ(v.values[first], a.firstLabel);
        }
    }
}

// ------------------------------------------------------------------------------------------------
// InputsDispatch
// ------------------------------------------------------------------------------------------------

TEST(InputsDispatch, BySuffix) {
    csgv::LabelVolume lv;
    lv.dim = {{2, 2, 1}};
    lv.labels = {1, 0xFFFFFFFFu, 3, 4};
    ASSERT_TRUE(csgv::writeVraw(tmp("d.vraw"), lv).isOk());
    writeBytes(tmp("d.vraw.gz"), gzipBytes(csgv::serializeVraw(lv)));
    const std::vector<uint64_t> want = {1, 0xFFFFFFFFu, 3, 4};
    for (const char* name : {"d.vraw", "d.vraw.gz"}) {
        auto r = csgv::readInput(tmp(name));
        ASSERT_TRUE(r.isOk()) << name << ": " << r.message();
        EXPECT_EQ(r->type, LabelType::U32);
        EXPECT_EQ(r->dim, lv.dim);
        EXPECT_EQ(r->values, want);
        expectGeometry(r->geometry, {{1, 1, 1}}, {{0, 0, 0}}, kIdentity);
    }

    const Bytes nrrd = textBytes(nrrdHeader("uint8", "1 1 1", "spacings: 2 2 2\n") + "\n") + Bytes{9};
    writeBytes(tmp("d.NRRD"), nrrd);
    writeBytes(tmp("d.raw"), Bytes{8});
    writeBytes(tmp("d.nhdr"), textBytes(nrrdHeader("uint8", "1 1 1", "data file: inputs-d.raw\n")));
    const Bytes nii = niftiHeader(niftiSpec(2, 8, 1, 1, 1)) + Bytes{7};
    writeBytes(tmp("d.nii"), nii);
    writeBytes(tmp("d.Nii.Gz"), gzipBytes(nii));
    const std::pair<const char*, uint64_t> cases[] = {{"d.NRRD", 9}, {"d.nhdr", 8}, {"d.nii", 7}, {"d.Nii.Gz", 7}};
    for (const auto& [name, value] : cases) {
        auto r = csgv::readInput(tmp(name));
        ASSERT_TRUE(r.isOk()) << name << ": " << r.message();
        EXPECT_EQ(r->values, std::vector<uint64_t>{value}) << name;
    }

    // The limit applies to vraw input too (8 bytes a voxel once widened).
    EXPECT_TRUE(failsWith(csgv::readInput(tmp("d.vraw"), 31).status(), {"d.vraw", "more than the limit"}));

    auto r = csgv::readInput(tmp("d.png"));
    EXPECT_TRUE(failsWith(r.status(), {"d.png", ".vraw", ".vraw.gz", ".nrrd", ".nhdr", ".nii", ".nii.gz"}));
    EXPECT_TRUE(failsWith(csgv::readInput(tmp("missing.vraw")).status(), {"missing.vraw"}));
    // Content that is not what the name says is an error, not a guess.
    writeBytes(tmp("wrong.nii"), nrrd);
    EXPECT_TRUE(failsWith(csgv::readInput(tmp("wrong.nii")).status(), {"wrong.nii"}));
}

// ------------------------------------------------------------------------------------------------
// InputsRobustness
// ------------------------------------------------------------------------------------------------

TEST(InputsRobustness, SeededMutations) {
    struct Base {
        std::string suffix;
        Bytes bytes;
        size_t headerEnd; // text header bytes (NRRD) or binary header (NIfTI) that mutations favour
        bool gzipAfterMutation;
    };
    std::vector<Base> bases;
    {
        std::vector<uint64_t> v(64);
        for (size_t i = 0; i < v.size(); ++i) v[i] = (i * 37) % 300;
        const std::string h1 = nrrdHeader("uint16", "4 4 4",
                                          "space: RAS\nspace directions: (1,0,0) (0,2,0) (0,0,3)\n"
                                          "space origin: (1,2,3)\nbyte skip: 0\nline skip: 0\n") + "\n";
        bases.push_back({".nrrd", textBytes(h1) + packBits(v, 2, false), h1.size(), false});
        const std::string h2 = nrrdHeader("int32", "4 4 4", "spacings: 1 2 3\n", "gzip", "big") + "\n";
        bases.push_back({".nrrd", textBytes(h2) + gzipBytes(packBits(v, 4, true)), h2.size(), false});
        const std::string h3 = "NRRD0005\ntype: double\ndimension: 4\nsizes: 1 4 4 4\nencoding: raw\n"
                               "endian: little\nspace dimension: 3\n"
                               "space directions: none (1,0,0) (0,1,0) (0,0,1)\n\n";
        std::vector<uint64_t> d;
        for (uint64_t x : v) d.push_back(doubleBits(double(x)));
        bases.push_back({".nrrd", textBytes(h3) + packBits(d, 8, false), h3.size(), false});

        NiftiSpec le = niftiSpec(4, 16, 4, 4, 4);
        le.sformCode = 1;
        le.srow = {{2, 0, 0, -1, 0, 2, 0, -2, 0, 0, 2, -3}};
        bases.push_back({".nii", niftiHeader(le) + packBits(v, 2, false), 352, false});
        NiftiSpec be = niftiSpec(16, 32, 4, 4, 4, true);
        be.qformCode = 1;
        be.quatern = {{0, 1, 0}};
        be.pixdim = {{-1, 1, 1, 1, 0, 0, 0, 0}};
        std::vector<uint64_t> f;
        for (uint64_t x : v) f.push_back(floatBits(float(x)));
        bases.push_back({".nii", niftiHeader(be) + packBits(f, 4, true), 352, false});
        bases.push_back({".nii.gz", niftiHeader(le) + packBits(v, 2, false), 352, true});
    }
    for (const Base& b : bases) {
        const std::string path = tmp("mut-base" + b.suffix);
        writeBytes(path, b.gzipAfterMutation ? gzipBytes(b.bytes) : b.bytes);
        auto r = csgv::readInput(path);
        ASSERT_TRUE(r.isOk()) << r.message();
    }

    std::mt19937 rng(20240607);
    const uint64_t maxBytes = uint64_t(1) << 20;
    int ok = 0, failed = 0;
    for (int iter = 0; iter < 1500; ++iter) {
        const Base& b = bases[rng() % bases.size()];
        Bytes m = b.bytes;
        const int edits = 1 + int(rng() % 3);
        for (int e = 0; e < edits && !m.empty(); ++e) {
            const unsigned kind = rng() % 4;
            const size_t inHeader = rng() % b.headerEnd;
            if (kind == 0) {
                m[inHeader] = uint8_t(rng()); // any byte of the header
            } else if (kind == 1) {
                m[inHeader] = uint8_t('0' + rng() % 10); // digits make sizes, skips and offsets large
            } else if (kind == 2) {
                m[rng() % m.size()] ^= uint8_t(1u << (rng() % 8)); // anywhere
            } else {
                m.resize(rng() % m.size()); // truncation
            }
        }
        const std::string path = tmp("mut-" + std::to_string(iter % 8) + b.suffix);
        writeBytes(path, b.gzipAfterMutation ? gzipBytes(m) : m);
        auto r = csgv::readInput(path, maxBytes);
        if (r.isOk()) {
            ++ok;
            ASSERT_EQ(r->values.size(), r->voxelCount()) << iter;
            ASSERT_LE(r->voxelCount() * 8, maxBytes) << iter;
            for (int a = 0; a < 3; ++a) ASSERT_GT(r->geometry.spacing[a], 0) << iter;
        } else {
            ++failed;
            ASSERT_TRUE(contains(r.message(), path)) << iter << ": " << r.message();
        }
    }
    // Both outcomes occur: mutations that hit voxel data are still valid volumes.
    EXPECT_GT(ok, 100);
    EXPECT_GT(failed, 100);
}

// ------------------------------------------------------------------------------------------------
// InputStream: the one reader of plain and gzip content under every format
// ------------------------------------------------------------------------------------------------

namespace {

/// Everything a stream delivers, read in small pieces so that chunk edges are crossed.
Bytes drain(csgv::InputStream& in, Status& status) {
    Bytes all, piece(1000);
    for (;;) {
        csgv::Result<size_t> n = in.read(piece.data(), piece.size());
        if (!n) {
            status = n.status();
            return all;
        }
        all.insert(all.end(), piece.begin(), piece.begin() + long(*n));
        if (*n < piece.size()) return all;
    }
}

Bytes pattern(size_t n) {
    Bytes b(n);
    for (size_t i = 0; i < n; ++i) b[i] = uint8_t((i * 131) >> 3);
    return b;
}

} // namespace

TEST(InputStream, AutoPassesPlainContentAndInflatesGzip) {
    const Bytes raw = pattern(700000);
    for (bool gz : {false, true}) {
        const std::string path = tmp(gz ? "stream.gz" : "stream.raw");
        writeBytes(path, gz ? gzipBytes(raw) : raw);
        csgv::InputStream in;
        ASSERT_TRUE(in.open(path).isOk());
        EXPECT_EQ(in.compressed(), gz);
        Status s;
        EXPECT_EQ(drain(in, s), raw);
        EXPECT_TRUE(s.isOk()) << s.message();
        EXPECT_EQ(in.position(), raw.size());
    }
}

TEST(InputStream, FollowsGzipMembersAndIgnoresTrailingBytesInAutoMode) {
    const Bytes a = pattern(5000), b = textBytes("second member");
    const std::string path = tmp("members.gz");
    writeBytes(path, gzipBytes(a) + gzipBytes(b) + textBytes("trailing garbage"));
    csgv::InputStream in;
    ASSERT_TRUE(in.open(path).isOk());
    Status s;
    EXPECT_EQ(drain(in, s), a + b);
    EXPECT_TRUE(s.isOk()) << s.message();
    // Inflate mode (NRRD's gzip encoding) calls the same trailing bytes corrupt.
    csgv::InputStream strict;
    ASSERT_TRUE(strict.open(path, csgv::InputStream::Mode::Inflate).isOk());
    drain(strict, s);
    EXPECT_FALSE(s.isOk());
    EXPECT_EQ(strict.failure(), csgv::InputStream::Failure::Corrupt);
}

TEST(InputStream, InflateModeReadsZlibFromAnOffsetAndSkips) {
    const Bytes raw = pattern(3000);
    uLongf packedSize = compressBound(uLong(raw.size()));
    Bytes packed(packedSize);
    ASSERT_EQ(compress2(packed.data(), &packedSize, raw.data(), uLong(raw.size()), 6), Z_OK);
    packed.resize(packedSize);
    const std::string path = tmp("zlib.bin");
    writeBytes(path, textBytes("HEADER") + packed);
    csgv::InputStream in;
    ASSERT_TRUE(in.open(path, csgv::InputStream::Mode::Inflate, 6).isOk());
    csgv::Result<uint64_t> skipped = in.skip(1000);
    ASSERT_TRUE(skipped.isOk());
    EXPECT_EQ(*skipped, 1000u);
    Status s;
    EXPECT_EQ(drain(in, s), Bytes(raw.begin() + 1000, raw.end()));
    EXPECT_TRUE(s.isOk()) << s.message();
}

TEST(InputStream, CutStreamsEndShortAndChecksumsAreVerified) {
    const Bytes raw = pattern(100000);
    const Bytes gz = gzipBytes(raw);
    const std::string cut = tmp("cut.gz");
    writeBytes(cut, Bytes(gz.begin(), gz.begin() + long(gz.size() / 2)));
    csgv::InputStream in;
    ASSERT_TRUE(in.open(cut).isOk());
    Status s;
    const Bytes got = drain(in, s);
    EXPECT_TRUE(s.isOk()) << s.message(); // a cut stream just ends, as gzread reports it
    EXPECT_GT(got.size(), 0u);
    EXPECT_LT(got.size(), raw.size());
    EXPECT_TRUE(std::equal(got.begin(), got.end(), raw.begin()));

    // A wrong CRC-32 in the trailer: the bytes read fine, the member's end does not.
    Bytes bad = gz;
    bad[bad.size() - 8] ^= 0xFF;
    const std::string crc = tmp("crc.gz");
    writeBytes(crc, bad);
    csgv::InputStream c;
    ASSERT_TRUE(c.open(crc).isOk());
    Bytes first(1000);
    ASSERT_TRUE(c.read(first.data(), first.size()).isOk());
    EXPECT_FALSE(c.checkMemberEnd().isOk());
    EXPECT_EQ(c.failure(), csgv::InputStream::Failure::Corrupt);
}

TEST(InputStream, RemainingBoundCoversWhatTheFileCanHold) {
    const Bytes raw = pattern(10000);
    const std::string plain = tmp("bound.raw");
    writeBytes(plain, raw);
    csgv::InputStream in;
    ASSERT_TRUE(in.open(plain, csgv::InputStream::Mode::Plain, 100).isOk());
    EXPECT_EQ(in.remainingBound(), raw.size() - 100);
    const std::string gz = tmp("bound.gz");
    writeBytes(gz, gzipBytes(raw));
    csgv::InputStream z;
    ASSERT_TRUE(z.open(gz).isOk());
    EXPECT_GE(z.remainingBound(), raw.size());
}

TEST(InputStream, OpenFailureSaysSo) {
    csgv::InputStream in;
    EXPECT_FALSE(in.open(tmp("absent.gz")).isOk());
    EXPECT_EQ(in.failure(), csgv::InputStream::Failure::Open);
}

TEST(InputsNiftiErrors, GzipChecksumIsVerifiedAfterTheVoxels) {
    // The voxels inflate fine; only the member's CRC-32 is wrong.
    const NiftiSpec s = niftiSpec(2, 8, 4, 4, 4);
    Bytes gz = gzipBytes(niftiHeader(s) + pattern(64));
    gz[gz.size() - 8] ^= 0xFF;
    const std::string path = tmp("badcrc.nii.gz");
    writeBytes(path, gz);
    EXPECT_TRUE(failsWith(csgv::readNifti(path).status(), {"cannot inflate", "badcrc.nii.gz", "incorrect data check"}));
}

TEST(InputsNrrdErrors, GzipSurplusIsProbedNotInflatedToItsEnd) {
    const Bytes voxels = pattern(64);
    // A little surplus (padding) is read to the stream's end, checksum and all, and accepted.
    auto r = nrrdRoundTrip("surplus-small.nrrd", nrrdHeader("uint8", "4 4 4", "", "gzip"), gzipBytes(voxels + Bytes(1000, 0)));
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_EQ(r->values[63], uint64_t(voxels[63]));
    // More than 64 KiB is refused where the probe stops (the test's ceiling on gigabytes is in
    // Testing/Core/hostile/test_hostile_paths.sh).
    r = nrrdRoundTrip("surplus-large.nrrd", nrrdHeader("uint8", "4 4 4", "", "gzip"), gzipBytes(voxels + Bytes(70000, 0)));
    EXPECT_TRUE(failsWith(r.status(), {"surplus-large.nrrd", "inflate to more than the 64 bytes", "over 65536 bytes more"}));
}

// ------------------------------------------------------------------------------------------------
// PathGuard: what a dataset names must stay inside its folder; nothing named is opened blocking
// ------------------------------------------------------------------------------------------------

TEST(PathGuard, NamedPathsStayInsideTheFolderAfterDotsAndLinks) {
    namespace fs = std::filesystem;
    const std::string root = tmp("pathguard");
    fs::remove_all(root);
    const std::string set = root + "/set";
    for (const std::string& d : {set + "/data", root + "/set2"}) fs::create_directories(d);
    writeBytes(set + "/data/vol.raw", Bytes(4, 1));
    writeBytes(root + "/set2/a.raw", Bytes(4, 2));
    writeBytes(root + "/secret.raw", Bytes(4, 3));
    fs::create_directory_symlink(set, root + "/alias");     // the dataset reached through a link
    fs::create_symlink(root + "/secret.raw", set + "/out.raw"); // a link inside pointing out
    auto guard = [](const std::string& named, const std::string& folder, bool allow = false) {
        return csgv::inputs::resolveInside({named, folder, "data file", "the header's folder"}, allow);
    };
    for (const std::string& inside : {std::string("data/vol.raw"), std::string("data/../data/vol.raw"),
                                      std::string("./data/vol.raw"), set + "/data/vol.raw", std::string("missing.raw")}) {
        csgv::Result<std::string> r = guard(inside, set);
        EXPECT_TRUE(r.isOk()) << inside << ": " << r.message();
    }
    EXPECT_EQ(*guard("data/vol.raw", set), set + "/data/vol.raw");
    EXPECT_TRUE(guard("data/vol.raw", root + "/alias").isOk());
    const csgv::Result<std::string> up = guard("../secret.raw", set);
    EXPECT_TRUE(failsWith(up.status(), {"data file '../secret.raw' lies outside the header's folder '" +
                                            fs::canonical(set).string() + "'",
                                        "pass --allow-outside-paths"}));
    // Component-wise: `set2` is not inside `set`; through a link or a missing folder is still out.
    for (const std::string& outside : {std::string("../set2/a.raw"), root + "/secret.raw", std::string("out.raw"),
                                       std::string("missing/../../secret.raw"), std::string("/")}) {
        EXPECT_FALSE(guard(outside, set).isOk()) << outside;
        EXPECT_FALSE(guard(outside, root + "/alias").isOk()) << outside;
    }
    ASSERT_TRUE(guard("../secret.raw", set, true).isOk());
    EXPECT_EQ(*guard("../secret.raw", set, true), set + "/../secret.raw");
}

TEST(PathGuard, OpenRegularFileRefusesFifosWithoutBlocking) {
    const std::string fifo = tmp("pathguard-fifo");
    std::remove(fifo.c_str());
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    csgv::Result<int> fd = csgv::inputs::openRegularFile(fifo); // would block without O_NONBLOCK
    EXPECT_TRUE(failsWith(fd.status(), {"FIFO"}));
    EXPECT_EQ(csgv::inputs::notRegularFile(fifo), "a FIFO (named pipe)");
    std::remove(fifo.c_str());
    const std::string dangling = tmp("pathguard-dangling");
    std::remove(dangling.c_str());
    ASSERT_EQ(::symlink("/nonexistent/target", dangling.c_str()), 0);
    EXPECT_EQ(csgv::inputs::notRegularFile(dangling), "a dangling symbolic link");
    EXPECT_EQ(csgv::inputs::notRegularFile(tmp("pathguard-nothing")), "missing");
    writeBytes(tmp("pathguard-file"), Bytes(3, 0));
    EXPECT_EQ(csgv::inputs::notRegularFile(tmp("pathguard-file")), "");
    fd = csgv::inputs::openRegularFile(tmp("pathguard-file"));
    ASSERT_TRUE(fd.isOk()) << fd.message();
    ::close(*fd);
}

TEST(InputsErrors, AFifoOrAFolderIsSaidAsSuch) {
    // Found by an attack pass: a FIFO named .nii, .nii.gz or .vraw.gz was "no such file".
    for (const char* name : {"fifo.nii", "fifo.nii.gz", "fifo.vraw.gz"}) {
        const std::string path = tmp(name);
        ::unlink(path.c_str());
        ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0);
        csgv::Result<std::unique_ptr<csgv::InputSource>> r = csgv::openInput(path, {});
        EXPECT_FALSE(r.isOk());
        EXPECT_NE(r.message().find("'" + path + "' is a FIFO (named pipe), not a file"), std::string::npos) << r.message();
        ::unlink(path.c_str());
    }
    const std::string missing = tmp("missing.nii");
    csgv::Result<std::unique_ptr<csgv::InputSource>> r = csgv::openInput(missing, {});
    EXPECT_NE(r.message().find("cannot open '" + missing + "': no such file"), std::string::npos) << r.message();
}

TEST(InputsErrors, MetadataThatIsNoFileIsSaidAsSuch) {
    // Found by an attack pass: a precomputed `info` that is a FIFO was taken for a TIFF folder
    // ("holds no .tif slices"), a Zarr `.zarray` that is one for "no .zarray".
    const std::string pc = tmp("fifo_info"), zarr = tmp("fifo_meta.zarr");
    for (const std::string& dir : {pc, zarr}) std::filesystem::create_directories(dir);
    const std::string info = pc + "/info", zarray = zarr + "/.zarray";
    for (const std::string& fifo : {info, zarray}) {
        ::unlink(fifo.c_str());
        ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    }
    csgv::Result<std::unique_ptr<csgv::InputSource>> r = csgv::openInput(pc, {});
    EXPECT_NE(r.message().find("'" + info + "' is a FIFO (named pipe), not a file"), std::string::npos) << r.message();
    r = csgv::openInput(zarr, {});
    EXPECT_NE(r.message().find("('" + zarray + "' is a FIFO (named pipe), not a file)"), std::string::npos) << r.message();
}
