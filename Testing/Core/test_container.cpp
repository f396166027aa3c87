// SPDX-License-Identifier: MIT
// The container: byte-exact round trips of Volcanite's files, split arrays, version 0015,
// atomic writes and output limits.
#include "TestData.h"

#include "csgv/codec/Container.h"
#include "csgv/codec/Decoder.h"
#include "csgv/base/FileUtil.h"

#include <filesystem>
#include <gtest/gtest.h>
#include <fstream>
#include <unistd.h>
#include <sys/stat.h>

using namespace csgv;
using namespace csgvtest;

namespace {

size_t filesIn(const std::string& dir) {
    size_t n = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) n += e.is_regular_file();
    return n;
}

/// Re-packs a single-array volume into arrays of `perArray` bricks (CSGV-FORMAT.md section 7).
CompressedVolume splitArrays(const CompressedVolume& in, uint32_t perArray) {
    CompressedVolume out = in;
    out.bricksPerArray = perArray;
    out.arrays.clear();
    const uint64_t bricks = in.brickCount();
    out.brickStarts.assign(size_t(bricks + 1), 0);
    for (uint64_t i = 0; i < bricks; ++i) {
        if (i % perArray == 0) {
            if (i > 0) out.brickStarts[size_t(i)] = uint32_t(out.arrays.back().size()); // previous array's length
            out.arrays.emplace_back();
        }
        const BrickWords bw = in.brick(i);
        if (i % perArray != 0) out.brickStarts[size_t(i)] = uint32_t(out.arrays.back().size());
        appendWords(out.arrays.back().owned(), bw.words, bw.size);
    }
    out.brickStarts[size_t(bricks)] = uint32_t(out.arrays.back().size());
    return out;
}

} // namespace

TEST(Container, VolcaniteFilesRoundTripByteExactly) {
    for (const std::string& name : allFixtureNames()) {
        const std::vector<uint8_t> bytes = fixtureBytes(name);
        Result<CompressedVolume> v = parseCsgv(bytes.data(), bytes.size());
        ASSERT_TRUE(v.isOk()) << name << ": " << v.message();
        EXPECT_EQ(v->serializedSize(), bytes.size()) << name;
        EXPECT_EQ(serializeCsgv(*v), bytes) << name;
    }
}

TEST(Container, HeaderFieldsOfTheDefaultFile) {
    const CompressedVolume v = loadFixture("synthA_b32_rans2.csgv");
    EXPECT_EQ(v.version, 16u);
    EXPECT_EQ(v.brickSize, 32u);
    EXPECT_EQ(v.levels(), 6u);
    EXPECT_EQ(v.dim, (std::array<uint32_t, 3>{133, 70, 194}));
    EXPECT_EQ(v.encoding, kEncodingRans2);
    EXPECT_EQ(v.opMask, uint32_t(kMaskDefault));
    EXPECT_EQ(v.brickCount(), 5u * 3u * 7u);
    EXPECT_EQ(v.arrays.size(), 1u);
    EXPECT_EQ(v.bricksPerArray, kSingleArray);
    EXPECT_EQ(operationLetters(v.opMask), "pnls");
    EXPECT_EQ(operationLetters(kMaskAll), "pnlds");
    EXPECT_EQ(std::string(encodingName(v.encoding)), "rans2");
}

TEST(Container, SplitArraysDecodeLikeOneArray) {
    for (const char* name : {"synthA_b16_nibble.csgv", "synthA_b32_rans2.csgv", "denseB_b16_rans2_delta.csgv"}) {
        const CompressedVolume one = loadFixture(name);
        for (uint32_t perArray : {1u, 7u, 64u}) {
            const CompressedVolume split = splitArrays(one, perArray);
            ASSERT_TRUE(checkContainer(split).isOk()) << checkContainer(split).message();
            const std::vector<uint8_t> bytes = serializeCsgv(split);
            Result<CompressedVolume> back = parseCsgv(bytes.data(), bytes.size());
            ASSERT_TRUE(back.isOk()) << name << " per array " << perArray << ": " << back.message();
            EXPECT_EQ(back->arrays.size(), (one.brickCount() + perArray - 1) / perArray);
            Result<LabelVolume> a = decodeVolume(one, 0);
            Result<LabelVolume> b = decodeVolume(*back, 0);
            ASSERT_TRUE(a.isOk() && b.isOk()) << b.message();
            EXPECT_EQ(a->labels, b->labels) << name << " per array " << perArray;
        }
    }
}

TEST(Container, SharedParseViewsTheBytesItWasGivenAndDecodesTheSame) {
    // parseCsgvShared over bytes at each address modulo 4: every encoding array is a view into
    // those bytes (no second copy), whether its words are aligned (kCsgvBytesPhase) or not (a
    // memory-mapped file holds them at 1 modulo 4); the volume equals parseCsgv's word for word,
    // decodes the same and outlives every other owner of the bytes.
    for (const std::string& name : allFixtureNames()) {
        const std::vector<uint8_t> file = fixtureBytes(name);
        Result<CompressedVolume> plain = parseCsgv(file.data(), file.size());
        ASSERT_TRUE(plain.isOk()) << name << ": " << plain.message();
        for (size_t phase = 0; phase < 4; ++phase) {
            std::shared_ptr<uint8_t> bytes = allocateCsgvBytes(file.size() + 4);
            ASSERT_TRUE(bytes);
            ASSERT_EQ(reinterpret_cast<uintptr_t>(bytes.get()) % 4, kCsgvBytesPhase);
            uint8_t* at = bytes.get() + (phase + 4 - kCsgvBytesPhase) % 4; // an address of `phase` modulo 4
            std::copy(file.begin(), file.end(), at);
            Result<CompressedVolume> shared = parseCsgvShared(at, file.size(), bytes);
            ASSERT_TRUE(shared.isOk()) << name << ": " << shared.message();
            bytes.reset(); // the volume keeps them
            ASSERT_EQ(shared->arrays.size(), plain->arrays.size());
            for (size_t a = 0; a < plain->arrays.size(); ++a) {
                EXPECT_TRUE(shared->arrays[a].isView()) << name << " phase " << phase;
                const auto* first = static_cast<const uint8_t*>(shared->arrays[a].bytes());
                EXPECT_TRUE(first > at && first < at + file.size()) << name << ": the view is not into the bytes";
                EXPECT_EQ(reinterpret_cast<uintptr_t>(first) % 4, (phase + 1) % 4) << name; // byte 69 + 4k
                EXPECT_TRUE(std::equal(shared->arrays[a].begin(), shared->arrays[a].end(), plain->arrays[a].begin(),
                                       plain->arrays[a].end()))
                    << name << " array " << a;
            }
            EXPECT_EQ(serializeCsgv(*shared), file) << name << " phase " << phase;
            Result<LabelVolume> a = decodeVolume(*plain, 0);
            Result<LabelVolume> b = decodeVolume(*shared, 0);
            ASSERT_TRUE(a.isOk() && b.isOk()) << b.message();
            EXPECT_EQ(a->labels, b->labels) << name << " phase " << phase;
        }
    }
}

TEST(Container, SharedParseOfHostileBytesFailsLikeTheCopyingOne) {
    // Truncated anywhere: the same error either way, and no view past the end.
    const std::vector<uint8_t> file = fixtureBytes("synthA_b32_rans2.csgv");
    for (size_t cut : {size_t(10), size_t(200), file.size() / 2, file.size() - 5, file.size() - 1}) {
        std::shared_ptr<uint8_t> bytes = allocateCsgvBytes(cut);
        ASSERT_TRUE(bytes);
        std::copy(file.begin(), file.begin() + ptrdiff_t(cut), bytes.get());
        Result<CompressedVolume> plain = parseCsgv(bytes.get(), cut);
        Result<CompressedVolume> shared = parseCsgvShared(bytes.get(), cut, bytes);
        ASSERT_FALSE(plain.isOk());
        ASSERT_FALSE(shared.isOk()) << "cut at " << cut;
        EXPECT_EQ(plain.message(), shared.message()) << "cut at " << cut;
    }
}

TEST(Container, SplitArrayWithWrongArrayCountIsRejected) {
    CompressedVolume split = splitArrays(loadFixture("synthA_b32_rans2.csgv"), 7);
    split.arrays.pop_back();
    const Status s = checkContainer(split);
    ASSERT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("encoding arrays"), std::string::npos) << s.message();
}

TEST(Container, Version0015IsWrittenAs0016WithLegacyDelta) {
    // A 0015 file always uses single-symbol distances; written as 0016 it must keep them (bit 64).
    CompressedVolume v = loadFixture("denseB_b32_rans2_legacydelta.csgv");
    v.version = 15;
    v.opMask &= ~uint32_t(kMaskLegacyDelta);
    const std::vector<uint8_t> bytes = serializeCsgv(v);
    Result<CompressedVolume> back = parseCsgv(bytes.data(), bytes.size());
    ASSERT_TRUE(back.isOk()) << back.message();
    EXPECT_EQ(back->version, 16u);
    EXPECT_TRUE(back->opMask & kMaskLegacyDelta);
    Result<LabelVolume> a = decodeVolume(v, 0);
    Result<LabelVolume> b = decodeVolume(*back, 0);
    ASSERT_TRUE(a.isOk()) << a.message();
    ASSERT_TRUE(b.isOk()) << b.message();
    EXPECT_EQ(a->labels, sourceVolume("denseB").labels);
    EXPECT_EQ(a->labels, b->labels);
}

TEST(Container, WriteIsAtomicAndReadsBack) {
    const std::string dir = tempDir() + "/write";
    std::filesystem::create_directories(dir);
    const CompressedVolume v = loadFixture("synthA_b64_rans2_delta.csgv");
    const std::string path = dir + "/out.csgv";
    ASSERT_TRUE(writeCsgv(path, v).isOk());
    EXPECT_EQ(filesIn(dir), 1u); // no temporary left behind
    Result<CompressedVolume> back = readCsgv(path);
    ASSERT_TRUE(back.isOk()) << back.message();
    EXPECT_EQ(serializeCsgv(*back), fixtureBytes("synthA_b64_rans2_delta.csgv"));
    // Overwriting replaces the file as a whole.
    const CompressedVolume other = loadFixture("synthA_b8_nibble_delta.csgv");
    ASSERT_TRUE(writeCsgv(path, other).isOk());
    EXPECT_EQ(serializeCsgv(*readCsgv(path)), fixtureBytes("synthA_b8_nibble_delta.csgv"));
    EXPECT_EQ(filesIn(dir), 1u);
}

TEST(Container, FailedWritesLeaveNothingBehind) {
    const std::string dir = tempDir() + "/fail";
    std::filesystem::create_directories(dir);
    const CompressedVolume v = loadFixture("synthA_b32_rans2.csgv");
    Limits small;
    small.maxOutputBytes = 1000;
    Status s = writeCsgv(dir + "/big.csgv", v, small);
    ASSERT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("limit"), std::string::npos) << s.message();
    s = writeCsgv(dir + "/no/such/folder/x.csgv", v);
    ASSERT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("cannot create"), std::string::npos) << s.message();
    CompressedVolume broken = v;
    broken.brickStarts.pop_back();
    s = writeCsgv(dir + "/broken.csgv", broken);
    ASSERT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("refusing"), std::string::npos) << s.message();
    EXPECT_EQ(filesIn(dir), 0u);
    // A write that fails half way (disk full) must not replace an existing file either.
    if (std::filesystem::exists("/dev/full")) {
        AtomicFile f;
        EXPECT_FALSE(f.open("/dev/full/x").isOk()); // not a directory: clean error
    }
}

TEST(Container, OutputsNeverReplaceDevicesFifosLinksOrProtectedFiles) {
    // Found by an attack pass: the rename that publishes an output replaced whatever the name
    // held (`csgv render x.csgv /dev/null` as root replaced the system's /dev/null).
    namespace fs = std::filesystem;
    const std::string dir = tempDir() + "/targets";
    fs::remove_all(dir);
    fs::create_directories(dir);
    const CompressedVolume v = loadFixture("synthA_b32_rans2.csgv");
    const auto bytes = [](const std::string& p) {
        std::ifstream in(p, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    ASSERT_EQ(::mkfifo((dir + "/fifo.csgv").c_str(), 0644), 0);
    fs::create_directories(dir + "/folder.csgv");
    std::ofstream(dir + "/target.csgv") << "the link's target";
    fs::create_symlink("target.csgv", dir + "/link.csgv");
    std::ofstream(dir + "/protected.csgv") << "protected";
    fs::permissions(dir + "/protected.csgv", fs::perms::owner_read | fs::perms::group_read);
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"fifo.csgv", "FIFO"}, {"folder.csgv", "folder"}, {"link.csgv", "symbolic link"},
        {"protected.csgv", "write-protected"}};
    for (const auto& [name, why] : cases) {
        const std::string path = dir + "/" + name;
        Status s = writeCsgv(path, v);
        ASSERT_FALSE(s.isOk()) << name;
        EXPECT_NE(s.message().find(why), std::string::npos) << s.message();
        EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
        AtomicFile f;
        EXPECT_FALSE(f.open(path).isOk()) << name;
    }
    EXPECT_TRUE(fs::is_fifo(dir + "/fifo.csgv"));
    EXPECT_TRUE(fs::is_symlink(dir + "/link.csgv"));
    EXPECT_EQ(bytes(dir + "/target.csgv"), "the link's target");
    EXPECT_EQ(bytes(dir + "/protected.csgv"), "protected");
    // A name that becomes a FIFO while the file is written is not replaced either.
    {
        AtomicFile f;
        ASSERT_TRUE(f.open(dir + "/late.bin").isOk());
        ASSERT_TRUE(f.write("x", 1).isOk());
        ASSERT_EQ(::mkfifo((dir + "/late.bin").c_str(), 0644), 0);
        EXPECT_FALSE(f.commit().isOk());
        EXPECT_TRUE(fs::is_fifo(dir + "/late.bin"));
    }
    // A file that is replaced keeps its permission bits.
    const std::string kept = dir + "/kept.csgv";
    std::ofstream(kept) << "old";
    fs::permissions(kept, fs::perms::owner_read | fs::perms::owner_write | fs::perms::others_read);
    ASSERT_TRUE(writeCsgv(kept, v).isOk());
    EXPECT_EQ(fs::status(kept).permissions(), fs::perms::owner_read | fs::perms::owner_write | fs::perms::others_read);
    size_t temporaries = 0;
    for (const auto& e : fs::directory_iterator(dir)) temporaries += e.path().string().find(".tmp-") != std::string::npos;
    EXPECT_EQ(temporaries, 0u);
}

TEST(Container, MissingFileAndDirectoryAreErrors) {
    Result<CompressedVolume> r = readCsgv(tempDir() + "/does-not-exist.csgv");
    ASSERT_FALSE(r.isOk());
    EXPECT_NE(r.message().find("does-not-exist.csgv"), std::string::npos) << r.message();
    r = readCsgv(tempDir());
    ASSERT_FALSE(r.isOk());
    EXPECT_NE(r.message().find("not a regular file"), std::string::npos) << r.message();
}

TEST(Vraw, ParsesAndRejectsCleanly) {
    LabelVolume v;
    v.dim = {3, 2, 1};
    v.labels = {1, 2, 3, 4, 5, 0xFFFFFFFEu};
    Result<LabelVolume> back = parseVraw(serializeVraw(v));
    ASSERT_TRUE(back.isOk()) << back.message();
    EXPECT_EQ(back->labels, v.labels);
    auto bad = [](const std::string& text) {
        std::vector<uint8_t> b(text.begin(), text.end());
        Result<LabelVolume> r = parseVraw(b);
        EXPECT_FALSE(r.isOk()) << text;
        return r.message();
    };
    EXPECT_NE(bad("3 2 1\nuint32\n1234").find("expected 24"), std::string::npos);
    EXPECT_NE(bad("3 2\nuint32\n").find("W H D"), std::string::npos);
    EXPECT_NE(bad("3 2 1\nfloat\n").find("float"), std::string::npos);
    EXPECT_NE(bad("0 2 1\nuint32\n").find("out of range"), std::string::npos);
    EXPECT_NE(bad("4294967295 4294967295 4294967295\nuint32\n").find("expected"), std::string::npos);
    EXPECT_NE(bad("").find("missing"), std::string::npos);
    std::vector<uint8_t> u8 = {'2', ' ', '1', ' ', '1', '\n', 'u', 'i', 'n', 't', '8', '\n', 7, 255};
    Result<LabelVolume> small = parseVraw(u8);
    ASSERT_TRUE(small.isOk()) << small.message();
    EXPECT_EQ(small->labels, (std::vector<uint32_t>{7, 255}));
}
