// SPDX-License-Identifier: MIT
// Memory-mapped `.csgv` files (MappedFile, readCsgvMapped, openCsgvMapped) and words at any byte
// address (WordPtr): a mapped file equals the file read, its encoding arrays are views into the
// mapping at odd addresses, hostile files fail with readCsgv's errors, and where a file cannot be
// mapped (a pipe, an empty file, the forced fallback) its bytes are read instead.
#include "TestData.h"

#include "csgv/base/MappedFile.h"
#include "csgv/base/Words.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"

#include <gtest/gtest.h>

#include <atomic>
#include <csignal>
#include <fstream>
#include <random>
#include <sstream>
#include <sys/stat.h>
#include <chrono>
#include <thread>
#include <unistd.h>

using namespace csgv;
using namespace csgvtest;

namespace {

std::string writeTemp(const std::string& name, const std::vector<uint8_t>& bytes) {
    const std::string path = tempDir() + "/" + name;
    writeBytes(path, bytes);
    return path;
}

/// True when this process maps `path` (Linux: /proc/self/maps names mapped files).
bool mappedInThisProcess(const std::string& path) {
    std::ifstream maps("/proc/self/maps");
    std::string line;
    while (std::getline(maps, line))
        if (line.size() >= path.size() && line.compare(line.size() - path.size(), path.size(), path) == 0) return true;
    return false;
}

void expectSameVolume(const CompressedVolume& a, const CompressedVolume& b, const std::string& what) {
    EXPECT_EQ(a.version, b.version) << what;
    EXPECT_EQ(a.brickSize, b.brickSize) << what;
    EXPECT_EQ(a.dim, b.dim) << what;
    EXPECT_EQ(a.encoding, b.encoding) << what;
    EXPECT_EQ(a.randomAccess, b.randomAccess) << what;
    EXPECT_EQ(a.maxPalette, b.maxPalette) << what;
    EXPECT_EQ(a.opMask, b.opMask) << what;
    EXPECT_EQ(a.freqA, b.freqA) << what;
    EXPECT_EQ(a.freqB, b.freqB) << what;
    EXPECT_EQ(a.bricksPerArray, b.bricksPerArray) << what;
    EXPECT_EQ(a.brickStarts, b.brickStarts) << what;
    ASSERT_EQ(a.arrays.size(), b.arrays.size()) << what;
    for (size_t i = 0; i < a.arrays.size(); ++i) {
        ASSERT_EQ(a.arrays[i].size(), b.arrays[i].size()) << what << " array " << i;
        EXPECT_TRUE(std::equal(a.arrays[i].begin(), a.arrays[i].end(), b.arrays[i].begin())) << what << " array " << i;
    }
}

} // namespace

TEST(Words, LoadsAtEveryByteAddress) {
    const uint32_t words[4] = {0x11223344u, 0x55667788u, 0x99AABBCCu, 0xDDEEFF00u};
    unsigned char bytes[32] = {};
    for (size_t phase = 0; phase < 8; ++phase) {
        std::memcpy(bytes + phase, words, sizeof words);
        const WordPtr w(bytes + phase);
        for (size_t i = 0; i < 4; ++i) {
            EXPECT_EQ(w[i], words[i]) << "phase " << phase;
            EXPECT_EQ(loadWord(bytes + phase, i), words[i]);
            EXPECT_EQ(*(w + std::ptrdiff_t(i)), words[i]);
        }
        EXPECT_EQ((w + 4) - w, 4);
        EXPECT_EQ(std::vector<uint32_t>(w, w + 4), std::vector<uint32_t>(words, words + 4));
        std::vector<uint32_t> appended{7u};
        appendWords(appended, w + 1, 3);
        EXPECT_EQ(appended, (std::vector<uint32_t>{7u, words[1], words[2], words[3]}));
    }
}

TEST(Mapped, EveryFixtureEqualsTheFileReadAndDecodesTheSame) {
    for (const std::string& name : allFixtureNames()) {
        const std::string path = fixture(name);
        Result<CompressedVolume> read = readCsgv(path);
        Result<CompressedVolume> mapped = readCsgvMapped(path);
        ASSERT_TRUE(read.isOk()) << read.message();
        ASSERT_TRUE(mapped.isOk()) << name << ": " << mapped.message();
        expectSameVolume(*read, *mapped, name);
        EXPECT_EQ(serializeCsgv(*mapped), fixtureBytes(name)) << name;
        for (uint32_t lod = 0; lod < read->levels(); lod += 2) {
            Result<LabelVolume> a = decodeVolume(*read, lod);
            Result<LabelVolume> b = decodeVolume(*mapped, lod);
            ASSERT_TRUE(a.isOk() && b.isOk()) << name << ": " << b.message();
            EXPECT_EQ(a->labels, b->labels) << name << " lod " << lod;
        }
        EXPECT_TRUE(validateStreams(*mapped, 0).isOk()) << name;
    }
}

TEST(Mapped, ArraysAreViewsIntoTheMappingWhichTheyKeepAlive) {
    // Copied to a name of its own, so that /proc/self/maps shows this test's mapping alone.
    const std::string name = "synthA_b32_rans2.csgv";
    const std::string path = writeTemp("views.csgv", fixtureBytes(name));
    CompressedVolume copy;
    {
        Result<CompressedVolume> mapped = readCsgvMapped(path);
        ASSERT_TRUE(mapped.isOk()) << mapped.message();
        EXPECT_TRUE(mappedInThisProcess(path));
        for (const WordArray& a : mapped->arrays) {
            EXPECT_TRUE(a.isView());
            EXPECT_EQ(a.ownedBytes(), 0u);
            // A mapping starts on a page; the words start at byte 69 + 4k: never on 4 bytes.
            EXPECT_EQ(reinterpret_cast<uintptr_t>(a.bytes()) % 4, 1u);
        }
        copy = *mapped; // a copy of the volume shares the views
    }
    EXPECT_TRUE(mappedInThisProcess(path)) << "the copy keeps the mapping";
    EXPECT_TRUE(copy.arrays[0].isView());
    Result<LabelVolume> labels = decodeVolume(copy, 0);
    ASSERT_TRUE(labels.isOk()) << labels.message();
    EXPECT_EQ(labels->labels, sourceVolume(name).labels);
    copy = CompressedVolume{};
    EXPECT_FALSE(mappedInThisProcess(path)) << "the last view unmaps the file";
}

TEST(Mapped, OwnedCopiesTheViewAndIsAViewNoMore) {
    Result<CompressedVolume> mapped = readCsgvMapped(fixture("synthA_b16_nibble.csgv"));
    ASSERT_TRUE(mapped.isOk()) << mapped.message();
    const std::vector<uint32_t> before(mapped->arrays[0].begin(), mapped->arrays[0].end());
    std::vector<uint32_t>& words = mapped->arrays[0].owned();
    EXPECT_FALSE(mapped->arrays[0].isView());
    EXPECT_EQ(words, before);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(mapped->arrays[0].bytes()) % alignof(uint32_t), 0u);
}

TEST(Mapped, OpenCsgvMappedReadsTheSidecarsAsOpenCsgv) {
    for (const std::string& name : allFixtureNames()) {
        Result<CsgvFile> read = openCsgv(fixture(name));
        Result<CsgvFile> mapped = openCsgvMapped(fixture(name));
        ASSERT_TRUE(read.isOk() && mapped.isOk()) << name << ": " << mapped.message();
        expectSameVolume(read->volume, mapped->volume, name);
        EXPECT_EQ(read->hasAttributes, mapped->hasAttributes) << name;
        EXPECT_EQ(read->idToLabel, mapped->idToLabel) << name;
        EXPECT_EQ(read->hasMetadata, mapped->hasMetadata) << name;
        EXPECT_TRUE(mapped->volume.arrays[0].isView()) << name;
    }
}

TEST(Mapped, TruncatedFilesFailWithTheErrorsOfReadCsgv) {
    const std::vector<uint8_t> file = fixtureBytes("synthA_b32_rans2.csgv");
    std::vector<size_t> cuts;
    for (size_t n = 0; n < 400; n += 7) cuts.push_back(n);
    for (size_t k = 1; k < 40; ++k) cuts.push_back(file.size() * k / 40);
    for (size_t k = 1; k <= 9; ++k) cuts.push_back(file.size() - k);
    for (size_t n : cuts) {
        const std::string path =
            writeTemp("cut.csgv", std::vector<uint8_t>(file.begin(), file.begin() + std::ptrdiff_t(n)));
        Result<CompressedVolume> read = readCsgv(path);
        Result<CompressedVolume> mapped = readCsgvMapped(path);
        ASSERT_FALSE(read.isOk()) << "cut at " << n;
        ASSERT_FALSE(mapped.isOk()) << "cut at " << n;
        EXPECT_EQ(read.message(), mapped.message()) << "cut at " << n;
        EXPECT_NE(mapped.message().find(path), std::string::npos) << mapped.message();
    }
    std::vector<uint8_t> longer = file;
    longer.push_back(0);
    const std::string path = writeTemp("longer.csgv", longer);
    EXPECT_EQ(readCsgv(path).message(), readCsgvMapped(path).message());
    EXPECT_NE(readCsgvMapped(path).message().find("1 unexpected bytes after the last field"), std::string::npos);
}

TEST(Mapped, CorruptedFilesFailWithTheErrorsOfReadCsgvAndDecodeAlike) {
    // Bytes changed at random (seeded) anywhere in each fixture: the container checks give
    // readCsgv's message; what passes them decodes to the same labels or the same stream error.
    std::mt19937 rng(40);
    size_t refused = 0, streamErrors = 0;
    for (const std::string& name : allFixtureNames()) {
        const std::vector<uint8_t> file = fixtureBytes(name);
        for (int trial = 0; trial < 24; ++trial) {
            std::vector<uint8_t> bad = file;
            // Half the trials in the header and brick starts, half anywhere.
            const size_t span = trial % 2 ? bad.size() : std::min<size_t>(bad.size(), 600);
            for (int k = 0; k < 1 + trial % 3; ++k) bad[rng() % span] ^= uint8_t(1u << (rng() % 8));
            const std::string path = writeTemp("bad.csgv", bad);
            Result<CompressedVolume> read = readCsgv(path);
            Result<CompressedVolume> mapped = readCsgvMapped(path);
            ASSERT_EQ(read.isOk(), mapped.isOk()) << name << " trial " << trial << ": " << read.message();
            if (!read.isOk()) {
                EXPECT_EQ(read.message(), mapped.message()) << name << " trial " << trial;
                ++refused;
                continue;
            }
            const Status a = validateStreams(*read, 0), b = validateStreams(*mapped, 0);
            EXPECT_EQ(a.message(), b.message()) << name << " trial " << trial;
            streamErrors += !a.isOk();
            if (a.isOk()) {
                Result<LabelVolume> la = decodeVolume(*read, 0), lb = decodeVolume(*mapped, 0);
                ASSERT_TRUE(la.isOk() && lb.isOk()) << name << " trial " << trial;
                EXPECT_EQ(la->labels, lb->labels) << name << " trial " << trial;
            }
        }
    }
    EXPECT_GT(refused, 0u);
    EXPECT_GT(streamErrors, 0u);
}

TEST(Mapped, MissingEmptyAndFolderPathsFailClearly) {
    const std::string missing = tempDir() + "/no-such.csgv";
    EXPECT_EQ(readCsgvMapped(missing).message(), readCsgv(missing).message());
    EXPECT_NE(readCsgvMapped(missing).message().find("cannot open '" + missing + "'"), std::string::npos);

    const std::string empty = writeTemp("empty.csgv", {});
    Result<std::shared_ptr<const MappedFile>> none = MappedFile::open(empty);
    ASSERT_TRUE(none.isOk()) << none.message();
    EXPECT_EQ((*none)->size(), 0u);
    EXPECT_FALSE((*none)->isMapped());
    EXPECT_EQ(readCsgvMapped(empty).message(), readCsgv(empty).message());
    EXPECT_NE(readCsgvMapped(empty).message().find("file truncated: field 'magic'"), std::string::npos);

    const std::string folder = tempDir();
    EXPECT_EQ(readCsgvMapped(folder).message(), readCsgv(folder).message());
    EXPECT_NE(readCsgvMapped(folder).message().find("is not a regular file"), std::string::npos);
}

TEST(Mapped, ReadFallbackGivesTheSameBytes) {
    const std::string path = fixture("denseB_b16_rans2_delta.csgv");
    MappedFile::Options read;
    read.read = true;
    Result<std::shared_ptr<const MappedFile>> f = MappedFile::open(path, read);
    Result<std::shared_ptr<const MappedFile>> m = MappedFile::open(path);
    ASSERT_TRUE(f.isOk() && m.isOk()) << f.message() << m.message();
    EXPECT_FALSE((*f)->isMapped());
    EXPECT_EQ((*f)->privateBytes(), (*f)->size());
    EXPECT_TRUE((*m)->isMapped());
    EXPECT_EQ((*m)->privateBytes(), 0u);
    const std::vector<uint8_t> bytes = fixtureBytes("denseB_b16_rans2_delta.csgv");
    ASSERT_EQ((*f)->size(), bytes.size());
    ASSERT_EQ((*m)->size(), bytes.size());
    EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), (*f)->data()));
    EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), (*m)->data()));
    read.maxReadBytes = bytes.size() - 1;
    Result<std::shared_ptr<const MappedFile>> tooLong = MappedFile::open(path, read);
    ASSERT_FALSE(tooLong.isOk());
    EXPECT_NE(tooLong.message().find(path), std::string::npos) << tooLong.message();
}

TEST(Mapped, APipeIsReadToItsEnd) {
    const std::string name = "synthA_b32_rans1.csgv";
    const std::vector<uint8_t> bytes = fixtureBytes(name);
    const std::string fifo = tempDir() + "/pipe.csgv";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    std::thread writer([&] {
        std::ofstream out(fifo, std::ios::binary);
        out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    });
    Result<CompressedVolume> piped = readCsgvMapped(fifo);
    writer.join();
    ASSERT_TRUE(piped.isOk()) << piped.message();
    expectSameVolume(*readCsgv(fixture(name)), *piped, "pipe");
    EXPECT_TRUE(piped->arrays[0].isView()) << "views into the bytes read";
    Result<LabelVolume> labels = decodeVolume(*piped, 0);
    ASSERT_TRUE(labels.isOk()) << labels.message();
    EXPECT_EQ(labels->labels, sourceVolume(name).labels);
    ::unlink(fifo.c_str());
}

TEST(Mapped, ADeviceIsRefusedAtOnce) {
    // /dev/zero never ends: read to its end, it took memory until none was left (3.1 GB in 3 s
    // under a 4 GiB cap).
    const auto t0 = std::chrono::steady_clock::now();
    Result<std::shared_ptr<const MappedFile>> zero = MappedFile::open("/dev/zero");
    ASSERT_FALSE(zero.isOk());
    EXPECT_EQ(zero.message(), "'/dev/zero' is a device, not a file");
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
    EXPECT_FALSE(readCsgvMapped("/dev/zero").isOk());
}

TEST(Mapped, AFileTruncatedUnderItsMappingReadsZerosAndSaysSo) {
    // Without the guard, touching a page past the new end raises SIGBUS and the process dies.
    const size_t page = size_t(::sysconf(_SC_PAGESIZE));
    std::vector<uint8_t> bytes(3 * page);
    for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = uint8_t(1 + i % 251);
    const std::string path = writeTemp("truncated-under.bin", bytes);
    Result<std::shared_ptr<const MappedFile>> m = MappedFile::open(path);
    ASSERT_TRUE(m.isOk()) << m.message();
    const MappedFile& f = **m;
    ASSERT_TRUE(f.isMapped());
    EXPECT_TRUE(MappedFile::mappedAt(f.data() + 5));
    EXPECT_FALSE(MappedFile::mappedAt(bytes.data()));
    EXPECT_FALSE(f.damaged());
    ASSERT_EQ(::truncate(path.c_str(), off_t(page)), 0);
    EXPECT_EQ(f.data()[10], bytes[10]) << "the first page is still the file's";
    volatile const uint8_t* p = f.data();
    EXPECT_EQ(p[2 * page + 7], 0) << "a page past the new end reads zeros";
    EXPECT_TRUE(f.damaged());
    EXPECT_TRUE(MappedFile::damagedAt(f.data(), f.size())) << "the range reaches a page of zeros";
    EXPECT_FALSE(MappedFile::damagedAt(f.data(), 10)) << "bytes before the new end are the file's";
    EXPECT_EQ(p[page + 1], 0);
    // A second mapping of the same (now short) file is sound.
    Result<std::shared_ptr<const MappedFile>> again = MappedFile::open(path);
    ASSERT_TRUE(again.isOk());
    EXPECT_EQ((*again)->size(), page);
    EXPECT_FALSE((*again)->damaged());
}

TEST(Mapped, ASigbusOutsideTheMappingsStillReachesThePreviousHandler) {
    // A SIGBUS sent by kill() is no fault of a mapping: it goes to the handler that was there.
    const std::vector<uint8_t> bytes(100, 7);
    static std::atomic<int> seen{0};
    struct sigaction mine {}, before {};
    mine.sa_handler = [](int) { seen.fetch_add(1); };
    sigemptyset(&mine.sa_mask);
    ASSERT_EQ(::sigaction(SIGBUS, &mine, &before), 0);
    Result<std::shared_ptr<const MappedFile>> m = MappedFile::open(writeTemp("chained.bin", bytes)); // installs the guard over ours
    ASSERT_TRUE(m.isOk() && (*m)->isMapped());
    ::raise(SIGBUS);
    EXPECT_EQ(seen.load(), 1);
    ::sigaction(SIGBUS, &before, nullptr);
}

TEST(Mapped, ReleasedPagesReadTheSameAndLeaveTheProcess) {
    const size_t page = size_t(::sysconf(_SC_PAGESIZE));
    std::vector<uint8_t> bytes(64 * page);
    std::mt19937 rng(5);
    for (auto& b : bytes) b = uint8_t(rng());
    const std::string path = writeTemp("released.bin", bytes);
    Result<std::shared_ptr<const MappedFile>> m = MappedFile::open(path);
    ASSERT_TRUE(m.isOk() && (*m)->isMapped());
    const MappedFile& f = **m;
    EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), f.data()));
    EXPECT_EQ(MappedFile::absentBytesAt(f.data(), f.size()), 0u) << "just written and read: in the page cache";
    MappedFile::releaseAt(f.data(), f.size());
    MappedFile::willNeedAt(f.data(), f.size());
    MappedFile::releaseAt(f.data() + 3, 10);
    EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), f.data())) << "released pages are read again from the file";
    EXPECT_EQ(MappedFile::absentBytesAt(f.data(), f.size()), 0u);
    // Anonymous memory is never released (it would read as zeros).
    std::vector<uint8_t> mine(bytes.begin(), bytes.end());
    MappedFile::releaseAt(mine.data(), mine.size());
    EXPECT_EQ(mine, bytes);
    EXPECT_EQ(MappedFile::absentBytesAt(mine.data(), mine.size()), 0u);
}

TEST(Mapped, ACopyOnWriteMappingTakesWritesAndLeavesTheFile) {
    std::vector<uint8_t> bytes(10000, 3);
    const std::string path = writeTemp("cow.bin", bytes);
    MappedFile::Options o;
    o.copyOnWrite = true;
    Result<std::shared_ptr<const MappedFile>> m = MappedFile::open(path, o);
    ASSERT_TRUE(m.isOk() && (*m)->isMapped()) << m.message();
    uint8_t* p = const_cast<uint8_t*>((*m)->data()); // what a VTK array over it allows
    p[5000] = 9;
    EXPECT_EQ((*m)->data()[5000], 9);
    std::ifstream in(path, std::ios::binary);
    std::vector<uint8_t> onDisk((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(onDisk, bytes) << "the file is unchanged";
    EXPECT_TRUE(MappedFile::mappedAt(p));
}

TEST(Mapped, ABrickOfAFileWrittenOverUnderItsMappingFailsToDecodeNamingTheCause) {
    // Written over in place (same inode) by another volume: the mapping reads the new bytes; the
    // error says the file changed (an attack pass saw only "level 0 start is 3465706103").
    const std::vector<uint8_t> bytes = fixtureBytes("synthA_b32_rans2.csgv");
    const std::string path = writeTemp("written-over.csgv", bytes);
    Result<CompressedVolume> mapped = readCsgvMapped(path);
    ASSERT_TRUE(mapped.isOk()) << mapped.message();
    EXPECT_FALSE(MappedFile::rewrittenAt(mapped->brick(0).words.bytes()));
    const std::vector<uint8_t> other = fixtureBytes("denseB_b32_rans1.csgv");
    std::this_thread::sleep_for(std::chrono::milliseconds(20)); // a modification time of its own
    {
        std::fstream out(path, std::ios::in | std::ios::out | std::ios::binary);
        out.write(reinterpret_cast<const char*>(other.data()), std::streamsize(std::min(other.size(), bytes.size())));
    }
    EXPECT_TRUE(MappedFile::rewrittenAt(mapped->brick(0).words.bytes()));
    BrickDecoder d(*mapped);
    Status failed = Status::ok();
    for (uint64_t b = 0; b < mapped->brickCount() && failed; ++b) failed = d.decode(b, 0);
    ASSERT_FALSE(failed.isOk()) << "some brick of another volume's bytes fails";
    EXPECT_NE(failed.message().find("changed on disk while it was open (it was written over)"), std::string::npos)
        << failed.message();
}

TEST(Mapped, ABrickOfAFileCutShortUnderItsMappingFailsToDecodeNamingTheCause) {
    // Zeros may even decode; the decoder refuses a brick that reached a page of zeros.
    const std::string name = "synthA_b32_rans2.csgv";
    const std::vector<uint8_t> bytes = fixtureBytes(name);
    const std::string path = writeTemp("cut-under-decoder.csgv", bytes);
    Result<CompressedVolume> mapped = readCsgvMapped(path);
    ASSERT_TRUE(mapped.isOk()) << mapped.message();
    ASSERT_EQ(::truncate(path.c_str(), off_t(bytes.size() / 2)), 0);
    Result<LabelVolume> labels = decodeVolume(*mapped, 0);
    ASSERT_FALSE(labels.isOk());
    EXPECT_NE(labels.message().find("the file changed on disk while it was open"), std::string::npos) << labels.message();
    // The bricks before the cut still decode (the first brick lies in the first half).
    BrickDecoder d(*mapped);
    EXPECT_TRUE(d.decode(0, 0).isOk());
}
