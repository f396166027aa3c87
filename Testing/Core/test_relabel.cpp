// SPDX-License-Identifier: MIT
// Relabelling, the attribute database we write, the metadata sidecar, and the compress pipeline
// end to end: labels that do not fit the format come back as the original values.
#include "TestData.h"

#include "csgv/attributes/AttributeDb.h"
#include "csgv/inputs/Compress.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/base/Cancel.h"
#include "csgv/base/FileUtil.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Procedural.h"
#include "csgv/inputs/Relabel.h"
#include "csgv/base/Morton.h"
#include "csgv/codec/Partition.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <cmath>
#include <unordered_map>
#include <unordered_set>
#include <filesystem>
#include <pthread.h>
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <csignal>
#include <fstream>
#include <gtest/gtest.h>
#include <new>
#include <stdexcept>

using namespace csgv;
using namespace csgvtest;

namespace {

InputVolume inputOf(const LabelVolume& v) {
    InputVolume in;
    in.dim = v.dim;
    in.values.assign(v.labels.begin(), v.labels.end());
    return in;
}

std::string freshDir(const std::string& name) {
    const std::string d = tempDir() + "/" + name;
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
}

} // namespace

TEST(Relabel, ReproducesVolcanitesRelabelledFileAndDatabase) {
    // Volcanite's _attr file holds dense ids in first-appearance order (bricks and voxels in
    // Morton order); with its tables our relabelling and encoder give its exact bytes.
    const CompressedVolume theirs = loadFixture("synthA_b32_rans2_attr.csgv");
    LabelMapping mapping;
    Result<LabelVolume> ids = prepareLabels(inputOf(sourceVolume("synthA")), 32, true, mapping);
    ASSERT_TRUE(ids.isOk()) << ids.message();
    EncodeOptions o;
    o.fixedTables = true;
    o.tableA = theirs.freqA;
    o.tableB = theirs.freqB;
    Result<CompressedVolume> ours = encodeVolume(*ids, o);
    ASSERT_TRUE(ours.isOk()) << ours.message();
    EXPECT_TRUE(serializeCsgv(*ours) == fixtureBytes("synthA_b32_rans2_attr.csgv"));
    Result<AttributeDatabase> db = readAttributeDb(fixture("synthA_b32_rans2_attr_csgv.db3"));
    ASSERT_TRUE(db.isOk()) << db.message();
    ASSERT_EQ(mapping.originalBits.size(), db->labels.size());
    for (size_t i = 0; i < db->labels.size(); ++i) EXPECT_EQ(int64_t(mapping.originalBits[i]), db->labels[i]) << i;
}

TEST(Relabel, ZeroStaysZeroAndOrderIsFirstAppearance) {
    LabelVolume v;
    v.dim = {3, 1, 1};
    v.labels = {9, 0, 9};
    const std::vector<uint64_t> map = relabelDense(v, 8);
    EXPECT_EQ(map, (std::vector<uint64_t>{0, 9}));
    EXPECT_EQ(v.labels, (std::vector<uint32_t>{1, 0, 1}));
    // Bricks in Morton order of their coordinates: brick (1,0,0) comes before brick (0,1,0).
    LabelVolume w;
    w.dim = {16, 16, 1};
    for (uint32_t y = 0; y < 16; ++y)
        for (uint32_t x = 0; x < 16; ++x) w.labels.push_back(100 + (x / 8) + 2 * (y / 8));
    EXPECT_EQ(relabelDense(w, 8), (std::vector<uint64_t>{0, 100, 101, 102, 103}));
    EXPECT_EQ(morton3x21(1, 0, 0), 1u);
    EXPECT_EQ(morton3x21(0, 1, 0), 2u);
    EXPECT_EQ(morton3x21(0, 0, 1), 4u);
    EXPECT_EQ(morton3x21(0x1FFFFF, 0, 0), 0x1249249249249249ull);
}

TEST(Relabel, WideAndNegativeLabelsRoundTripThroughTheDatabase) {
    const std::string dir = freshDir("wide");
    for (LabelType type : {LabelType::I64, LabelType::U64, LabelType::I16}) {
        InputVolume in;
        in.dim = {21, 13, 9};
        in.type = type;
        const uint64_t big[] = {0, uint64_t(-5), 0xFFFFFFFFull, 0x123456789ABCDEFull, uint64_t(INT64_MIN),
                                0xFFFFFFFFFFFFFFFEull, 7};
        for (uint64_t i = 0; i < in.voxelCount(); ++i) {
            uint64_t v = big[(i / 17 + i % 5) % 7];
            if (type == LabelType::I16) v = uint64_t(int64_t(int16_t(v & 0xFFFF))); // negative int16 values
            in.values.push_back(v);
        }
        LabelMapping mapping;
        Result<LabelVolume> ids = prepareLabels(in, 8, false, mapping);
        ASSERT_TRUE(ids.isOk()) << ids.message();
        ASSERT_TRUE(mapping.relabelled); // these labels never fit the format as they are
        const std::string path = dir + "/wide_" + labelTypeName(type) + ".csgv";
        Result<CompressedVolume> vol = encodeVolume(*ids, EncodeOptions{});
        ASSERT_TRUE(vol.isOk());
        ASSERT_TRUE(writeCsgv(path, *vol).isOk());
        const Status ws = writeAttributeDb(attributeDbPathFor(path), in.dim, mapping.originalBits, isSignedType(type));
        ASSERT_TRUE(ws.isOk()) << ws.message();
        Result<CsgvFile> f = openCsgv(path);
        ASSERT_TRUE(f.isOk()) << f.message();
        ASSERT_TRUE(f->hasAttributes);
        EXPECT_TRUE(f->wideLabels);
        EXPECT_EQ(f->attributes.labelsUnsigned64, type == LabelType::U64);
        Result<LabelVolume> d = decodeVolume(f->volume, 0, f->decodeOptions());
        ASSERT_TRUE(d.isOk()) << d.message();
        for (size_t i = 0; i < in.values.size(); ++i)
            ASSERT_EQ(uint64_t(f->originalLabel(d->labels[i])), in.values[i]) << labelTypeName(type) << " voxel " << i;
    }
}

TEST(Relabel, LabelsThatFitAreKeptUnlessRelabellingIsAsked) {
    InputVolume in;
    in.dim = {4, 1, 1};
    in.type = LabelType::I32;
    in.values = {5, 0, 5, 0xFFFFFFFEull};
    LabelMapping m;
    Result<LabelVolume> kept = prepareLabels(in, 8, false, m);
    ASSERT_TRUE(kept.isOk());
    EXPECT_FALSE(m.relabelled);
    EXPECT_EQ(kept->labels, (std::vector<uint32_t>{5, 0, 5, 0xFFFFFFFEu}));
    in.values[1] = 0xFFFFFFFFull; // the reserved value forces relabelling
    Result<LabelVolume> re = prepareLabels(in, 8, false, m);
    ASSERT_TRUE(re.isOk());
    EXPECT_TRUE(m.relabelled);
    EXPECT_EQ(re->labels, (std::vector<uint32_t>{1, 2, 1, 3}));
    EXPECT_FALSE(prepareLabels(in, 12, false, m).isOk());
}

TEST(AttributeDbWriter, TextNumericAndNullColumnsRoundTrip) {
    const std::string path = freshDir("db") + "/x_csgv.db3";
    AttributeColumn name{"region name", false, {}, {"background", "Precentral_L", "O'Brien \"quoted\""}};
    AttributeColumn volume{"volume", true, {0.0, 12.5, std::nan("")}, {}};
    ASSERT_TRUE(writeAttributeDb(path, {3, 4, 5}, {0, 2001, 2002}, false, {name, volume}).isOk());
    Result<AttributeDatabase> db = readAttributeDb(path);
    ASSERT_TRUE(db.isOk()) << db.message();
    EXPECT_EQ(db->volumeDim, (std::array<uint32_t, 3>{3, 4, 5}));
    EXPECT_EQ(db->labels, (std::vector<int64_t>{0, 2001, 2002}));
    ASSERT_EQ(db->columns.size(), 2u);
    EXPECT_FALSE(db->columns[0].numeric);
    EXPECT_EQ(db->columns[0].text, name.text);
    EXPECT_TRUE(db->columns[1].numeric);
    EXPECT_EQ(db->columns[1].values[1], 12.5);
    EXPECT_TRUE(std::isnan(db->columns[1].values[2]));
    // A column of the wrong length is refused and nothing is written.
    const std::string bad = tempDir() + "/db/bad_csgv.db3";
    AttributeColumn shortColumn{"short", true, {1.0}, {}};
    EXPECT_FALSE(writeAttributeDb(bad, {1, 1, 1}, {0, 1}, false, {shortColumn}).isOk());
    EXPECT_FALSE(fileExists(bad));
    EXPECT_FALSE(fileExists(bad + ".tmp-db"));
}

TEST(AttributeDbReader, BrokenDatabasesAreClearErrors) {
    const std::string dir = freshDir("dbbad");
    const std::string notDb = dir + "/not_csgv.db3";
    {
        AtomicFile f;
        ASSERT_TRUE(f.open(notDb).isOk());
        ASSERT_TRUE(f.write("this is not sqlite", 18).isOk());
        ASSERT_TRUE(f.commit().isOk());
    }
    Result<AttributeDatabase> r = readAttributeDb(notDb);
    ASSERT_FALSE(r.isOk());
    EXPECT_NE(r.message().find(notDb), std::string::npos) << r.message();
    EXPECT_FALSE(readAttributeDb(dir + "/missing_csgv.db3").isOk());
    // A database for another volume size is refused when opening the .csgv beside it.
    const std::string csgv = dir + "/vol.csgv";
    ASSERT_TRUE(writeCsgv(csgv, loadFixture("synthA_b32_rans2.csgv")).isOk());
    ASSERT_TRUE(writeAttributeDb(attributeDbPathFor(csgv), {1, 2, 3}, {0, 1}, false).isOk());
    Result<CsgvFile> f = openCsgv(csgv);
    ASSERT_FALSE(f.isOk());
    EXPECT_NE(f.message().find("describes a 1x2x3 volume"), std::string::npos) << f.message();
}

TEST(Metadata, RoundTripAndStrictTypes) {
    const std::string dir = freshDir("md");
    VolumeMetadata md;
    md.dim = {3, 4, 5};
    md.geometry.spacing = {0.5, 1.25, 2};
    md.geometry.origin = {-90.5, -126, 3.25};
    md.geometry.direction = {-1, 0, 0, 0, -1, 0, 0, 0, 1};
    md.originalType = "int16";
    md.relabelled = true;
    md.source = "aal.nii.gz";
    const std::string path = dir + "/a.csgv.json";
    ASSERT_TRUE(writeMetadata(path, md).isOk());
    Result<VolumeMetadata> back = readMetadata(path);
    ASSERT_TRUE(back.isOk()) << back.message();
    EXPECT_EQ(back->dim, md.dim);
    EXPECT_EQ(back->geometry.spacing, md.geometry.spacing);
    EXPECT_EQ(back->geometry.origin, md.geometry.origin);
    EXPECT_EQ(back->geometry.direction, md.geometry.direction);
    EXPECT_EQ(back->originalType, "int16");
    EXPECT_TRUE(back->relabelled);
    auto bad = [&](const std::string& text) {
        AtomicFile f;
        EXPECT_TRUE(f.open(path).isOk());
        EXPECT_TRUE(f.write(text.data(), text.size()).isOk());
        EXPECT_TRUE(f.commit().isOk());
        Result<VolumeMetadata> r = readMetadata(path);
        EXPECT_FALSE(r.isOk()) << text;
        return r.message();
    };
    EXPECT_NE(bad("{\"spacing\": [1, 0, 1]}").find("positive"), std::string::npos);
    EXPECT_NE(bad("{\"spacing\": [1, 1]}").find("3 numbers"), std::string::npos);
    EXPECT_NE(bad("{\"origin\": \"here\"}").find("origin"), std::string::npos);
    EXPECT_NE(bad("{\"version\": 2}").find("version"), std::string::npos);
    EXPECT_NE(bad("[1, 2]").find("object"), std::string::npos);
    EXPECT_NE(bad("{\"relabelled\": 1}").find("relabelled"), std::string::npos);
    EXPECT_NE(bad("{not json").find("object"), std::string::npos);
    // Voxel centres at integer points become corners half a voxel back along each direction.
    Geometry centred = md.geometry;
    const Geometry corner = cellGeometryFromPointGeometry(centred);
    EXPECT_DOUBLE_EQ(corner.origin[0], -90.5 + 0.25);
    EXPECT_DOUBLE_EQ(corner.origin[1], -126 + 0.625);
    EXPECT_DOUBLE_EQ(corner.origin[2], 3.25 - 1);
}

TEST(Compress, StreamedAndInMemoryPathsGiveTheSameFile) {
    const std::string dir = freshDir("compress");
    // synth: streamed slab by slab; the same labels via a .vraw.gz read whole; and via .vraw streamed.
    CompressOptions o;
    CompressReport r;
    ASSERT_TRUE(compressToFile("synth:70x45x33:4", dir + "/a.csgv", o, &r).isOk());
    Result<CsgvFile> a = openCsgv(dir + "/a.csgv");
    ASSERT_TRUE(a.isOk()) << a.message();
    Result<LabelVolume> labels = decodeVolume(a->volume, 0);
    ASSERT_TRUE(labels.isOk());
    ASSERT_TRUE(writeVraw(dir + "/a.vraw", *labels).isOk());
    ASSERT_TRUE(compressToFile(dir + "/a.vraw", dir + "/b.csgv", o, &r).isOk());
    EXPECT_TRUE(*readFile(dir + "/a.csgv", 1 << 30) == *readFile(dir + "/b.csgv", 1 << 30));
    // Forced relabelling writes the database; compressing again without it removes the stale one.
    o.relabel = true;
    ASSERT_TRUE(compressToFile(dir + "/a.vraw", dir + "/c.csgv", o, &r).isOk());
    EXPECT_TRUE(r.relabelled);
    EXPECT_TRUE(fileExists(dir + "/c_csgv.db3"));
    Result<CsgvFile> c = openCsgv(dir + "/c.csgv");
    ASSERT_TRUE(c.isOk()) << c.message();
    EXPECT_TRUE(c->hasAttributes && c->hasMetadata && c->metadata.relabelled);
    Result<LabelVolume> cl = decodeVolume(c->volume, 0, c->decodeOptions());
    ASSERT_TRUE(cl.isOk());
    EXPECT_TRUE(cl->labels == labels->labels);
    o.relabel = false;
    ASSERT_TRUE(compressToFile(dir + "/a.vraw", dir + "/c.csgv", o, &r).isOk());
    EXPECT_FALSE(fileExists(dir + "/c_csgv.db3"));
    // Errors leave nothing behind.
    EXPECT_FALSE(compressToFile(dir + "/missing.vraw", dir + "/d.csgv", o).isOk());
    EXPECT_FALSE(compressToFile("synth:10x10x10", dir + "/d.vraw", o).isOk());
    EXPECT_FALSE(compressToFile("synth:10x10x10", dir + "/no/such/dir/d.csgv", o).isOk());
    for (const auto& e : std::filesystem::directory_iterator(dir))
        EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
    EXPECT_FALSE(fileExists(dir + "/d.csgv"));
}

TEST(Compress, NrrdWithNegativeAndWideLabelsComesBackExactly) {
    const std::string dir = freshDir("nrrd");
    const std::array<uint32_t, 3> dim = {17, 11, 6};
    std::vector<int64_t> values;
    for (uint32_t i = 0; i < dim[0] * dim[1] * dim[2]; ++i)
        values.push_back(i % 3 == 0 ? 0 : (i % 3 == 1 ? -int64_t(i / 40) - 1 : int64_t(1) << (33 + i / 300)));
    Geometry g;
    g.spacing = {0.5, 0.5, 2};
    g.origin = {10, 20, 30};
    ASSERT_TRUE(writeNrrd(dir + "/in.nrrd", dim, "int64", values.data(), 8, g).isOk());
    CompressReport r;
    Status s = compressToFile(dir + "/in.nrrd", dir + "/out.csgv", CompressOptions{}, &r);
    ASSERT_TRUE(s.isOk()) << s.message();
    EXPECT_TRUE(r.relabelled);
    EXPECT_EQ(r.originalType, "int64");
    Result<CsgvFile> f = openCsgv(dir + "/out.csgv");
    ASSERT_TRUE(f.isOk()) << f.message();
    EXPECT_TRUE(f->wideLabels);
    EXPECT_EQ(f->metadata.geometry.spacing, g.spacing);
    EXPECT_DOUBLE_EQ(f->metadata.geometry.origin[0], 10 - 0.25); // centre -> corner
    EXPECT_DOUBLE_EQ(f->metadata.geometry.origin[2], 30 - 1);
    Result<LabelVolume> d = decodeVolume(f->volume, 0, f->decodeOptions());
    ASSERT_TRUE(d.isOk());
    for (size_t i = 0; i < values.size(); ++i) ASSERT_EQ(f->originalLabel(d->labels[i]), values[i]) << i;
}

namespace {
std::atomic<bool> g_publishingHeld{false};
std::atomic<int> g_signalsInHold{0}, g_signalsAfterHold{0};
void countSignal(int) { (g_publishingHeld ? g_signalsInHold : g_signalsAfterHold)++; }
} // namespace

// The thread that holds the publishing lock takes no SIGINT, SIGTERM or SIGHUP: one sent to it waits until
// the hold ends (the lock given back first). A handler run inside the hold could not wait for the
// lock: Ctrl-C in pvpython left the old volume beside the new one as '<name>.tmp-...-old', once in
// six saves of test_writer_interrupt.py. The thread's mask is as it was afterwards.
TEST(Compress, SignalsToThePublishingThreadWaitForTheHoldToEnd) {
    struct sigaction ours {}, previousInt {}, previousTerm {}, previousHup {};
    ours.sa_handler = countSignal;
    sigemptyset(&ours.sa_mask);
    ASSERT_EQ(sigaction(SIGINT, &ours, &previousInt), 0);
    ASSERT_EQ(sigaction(SIGTERM, &ours, &previousTerm), 0);
    ASSERT_EQ(sigaction(SIGHUP, &ours, &previousHup), 0);
    {
        const PublishingHold held = holdPublishing();
        g_publishingHeld = true;
        pthread_kill(pthread_self(), SIGINT);
        pthread_kill(pthread_self(), SIGTERM);
        pthread_kill(pthread_self(), SIGHUP);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        EXPECT_EQ(g_signalsInHold.load(), 0) << "a signal was taken inside the hold";
        g_publishingHeld = false;
    }
    EXPECT_EQ(g_signalsAfterHold.load(), 3) << "the signals sent in the hold were lost";
    pthread_kill(pthread_self(), SIGINT);
    EXPECT_EQ(g_signalsAfterHold.load(), 4) << "SIGINT stays blocked after the hold";
    // A thread that blocked SIGINT itself keeps it blocked after a hold.
    sigset_t intOnly, now;
    sigemptyset(&intOnly);
    sigaddset(&intOnly, SIGINT);
    ASSERT_EQ(pthread_sigmask(SIG_BLOCK, &intOnly, nullptr), 0);
    { const PublishingHold held = holdPublishing(); }
    ASSERT_EQ(pthread_sigmask(SIG_UNBLOCK, &intOnly, &now), 0);
    EXPECT_TRUE(sigismember(&now, SIGINT));
    EXPECT_FALSE(sigismember(&now, SIGTERM));
    sigaction(SIGINT, &previousInt, nullptr);
    sigaction(SIGTERM, &previousTerm, nullptr);
    sigaction(SIGHUP, &previousHup, nullptr);
}

// An interrupt watchdog holds the publishing lock before it removes temporaries and ends the
// process (Tools/Interrupt.h): a set being published waits for it with what it wrote complete
// under temporary names (every rename, of a file or a set, takes the lock), and no rename of the
// set happens meanwhile (none lands half published).
TEST(Compress, PublishingWaitsForTheLockWithTheFilesComplete) {
    const std::string dir = freshDir("publish_lock");
    std::atomic<bool> done{false};
    Status result;
    std::thread writer;
    {
        const PublishingHold held = holdPublishing();
        writer = std::thread([&] {
            result = compressToFile("synth:24x20x16:3", dir + "/v.csgv", CompressOptions{});
            done = true;
        });
        // Encoding 24x20x16 takes milliseconds; the set then waits at its renames.
        std::this_thread::sleep_for(std::chrono::milliseconds(700));
        EXPECT_FALSE(done.load());
        std::vector<std::string> names;
        for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
        EXPECT_TRUE(std::none_of(names.begin(), names.end(), [](const std::string& n) { return n == "v.csgv" || n == "v.csgv.json"; }));
        // The volume complete under a temporary name.
        EXPECT_GE(std::count_if(names.begin(), names.end(), [](const std::string& n) { return n.find(".tmp-") != std::string::npos; }), 1)
            << names.size();
    }
    writer.join();
    ASSERT_TRUE(result.isOk()) << result.message();
    EXPECT_TRUE(openCsgv(dir + "/v.csgv").isOk());
    EXPECT_TRUE(std::filesystem::exists(dir + "/v.csgv.json"));
}

// Another process publishing into the folder (here: a flock of its own open file description)
// holds a set's renames back until it is done, so two writers of one name never leave a mix of
// their sets (two `csgv compress` runs of one output: one's metadata beside the other's volume in
// 5 of 500 runs); a lock held past 2 s is published past.
TEST(Compress, ASetWaitsForAnotherProcessPublishingIntoItsFolder) {
    const std::string dir = freshDir("publish_folder");
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
    std::atomic<bool> done{false};
    Status result;
    std::thread writer([&] {
        result = compressToFile("synth:24x20x16:3", dir + "/v.csgv", CompressOptions{});
        done = true;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(600));
    EXPECT_FALSE(done.load()) << "published while another process held the folder";
    EXPECT_FALSE(std::filesystem::exists(dir + "/v.csgv.json"));
    ::close(fd);
    writer.join();
    ASSERT_TRUE(result.isOk()) << result.message();
    EXPECT_TRUE(openCsgv(dir + "/v.csgv").isOk());
    EXPECT_TRUE(std::filesystem::exists(dir + "/v.csgv.json"));
}

// What finishes writing after the `csgv` tool's Ctrl-C (cancelRequested) is not published: the
// tool says it wrote nothing, and an old set stays as it was (found by a review: a volume encoded
// in the watchdog's grace could be renamed in before it said "no output written").
TEST(Compress, WorkInterruptedWhileItWaitsToPublishPublishesNothing) {
    const std::string dir = freshDir("publish_cancel");
    { std::ofstream(dir + "/v.csgv") << "OLD"; }
    Status result;
    std::thread writer;
    {
        const PublishingHold held = holdPublishing();
        writer = std::thread([&] { result = compressToFile("synth:24x20x16:3", dir + "/v.csgv", CompressOptions{}); });
        std::this_thread::sleep_for(std::chrono::milliseconds(300));
        requestCancel();
    }
    writer.join();
    resetCancel();
    EXPECT_FALSE(result.isOk());
    EXPECT_NE(result.message().find("interrupted"), std::string::npos) << result.message();
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
    EXPECT_EQ(names, std::vector<std::string>{"v.csgv"}) << "temporaries or a sidecar left";
    std::ifstream in(dir + "/v.csgv");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text, "OLD");
}

// The tool's Ctrl-C reaches work without a progress callback: a decode skips its remaining bricks
// and a file being written stops between pieces and before its fsync, removing its temporary (csgv
// decompress of 2 GiB ended 0.55-1.3 s after Ctrl-C, at the watchdog's deadline; now 0.16-0.25 s).
TEST(Compress, DecodingAndWritingStopOnTheToolsCancel) {
    Result<LabelVolume> labels = generateVolume(parseSynthSpec("synth:40x40x40:5").value());
    ASSERT_TRUE(labels.isOk());
    Result<CompressedVolume> vol = encodeVolume(*labels, EncodeOptions{});
    ASSERT_TRUE(vol.isOk());
    ASSERT_TRUE(decodeVolume(*vol, 0, DecodeOptions{}).isOk());
    const std::string dir = freshDir("write_cancel");
    { std::ofstream(dir + "/v.nrrd") << "OLD"; }
    requestCancel();
    Result<LabelVolume> decoded = decodeVolume(*vol, 0, DecodeOptions{});
    AtomicFile f;
    Status opened = f.open(dir + "/v.nrrd");
    Status wrote = opened ? f.write(labels->labels.data(), labels->labels.size() * 4) : opened;
    AtomicFile g; // written before the cancel, committed after it
    resetCancel();
    Status gOpened = g.open(dir + "/w.nrrd");
    Status gWrote = gOpened ? g.write("data", 4) : gOpened;
    requestCancel();
    Status committed = g.commit();
    resetCancel();
    f.discard();
    EXPECT_FALSE(decoded.isOk());
    EXPECT_NE(decoded.message().find("interrupted"), std::string::npos) << decoded.message();
    EXPECT_TRUE(opened.isOk()) << opened.message();
    EXPECT_FALSE(wrote.isOk());
    EXPECT_NE(wrote.message().find("cancelled"), std::string::npos) << wrote.message();
    EXPECT_TRUE(gWrote.isOk()) << gWrote.message();
    EXPECT_FALSE(committed.isOk());
    g.discard();
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
    EXPECT_EQ(names, std::vector<std::string>{"v.nrrd"}) << "temporaries or a new file left";
    std::ifstream in(dir + "/v.nrrd");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text, "OLD");
    ASSERT_TRUE(decodeVolume(*vol, 0, DecodeOptions{}).isOk()) << "a reset cancel decodes again";
}

TEST(Metadata, DeeplyNestedJsonIsRefusedNotAStackOverflow) {
    const std::string path = freshDir("mddeep") + "/a.csgv.json";
    {
        std::ofstream f(path);
        f << "{\"version\": 1, \"spacing\": " << std::string(200000, '[') << std::string(200000, ']') << "}";
    }
    Result<VolumeMetadata> back = readMetadata(path);
    ASSERT_FALSE(back.isOk());
    EXPECT_NE(back.message().find("nests arrays or objects more than 64 levels deep"), std::string::npos) << back.message();
}

TEST(Metadata, CornerAndCentreGeometryAreInverses) {
    Geometry g;
    g.spacing = {0.5, 2, 1.5};
    g.origin = {3, -4, 5};
    g.direction = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    const Geometry back = pointGeometryFromCellGeometry(cellGeometryFromPointGeometry(g));
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(back.origin[a], g.origin[a], 1e-12);
    const Geometry corner = cellGeometryFromPointGeometry(g);
    EXPECT_DOUBLE_EQ(corner.origin[0], 3 + 1);    // index y (spacing 2) runs along world -x
    EXPECT_DOUBLE_EQ(corner.origin[1], -4 - 0.25); // index x (spacing 0.5) runs along world +y
}

TEST(Compress, StreamedVrawOfNarrowLabelsAndItsErrors) {
    const std::string dir = freshDir("vraw16");
    // uint16 .vraw streamed slab by slab equals the same labels read whole.
    const std::string header = "9 7 40\nuint16\n";
    std::vector<uint8_t> bytes(header.begin(), header.end());
    LabelVolume expected;
    expected.dim = {9, 7, 40};
    for (uint32_t i = 0; i < 9 * 7 * 40; ++i) {
        const uint16_t v = uint16_t((i / 13) * 977);
        expected.labels.push_back(v);
        bytes.push_back(uint8_t(v & 0xFF));
        bytes.push_back(uint8_t(v >> 8));
    }
    auto write = [&](const std::string& path, const std::vector<uint8_t>& b) {
        AtomicFile f;
        ASSERT_TRUE(f.open(path).isOk());
        ASSERT_TRUE(f.write(b.data(), b.size()).isOk());
        ASSERT_TRUE(f.commit().isOk());
    };
    write(dir + "/a.vraw", bytes);
    CompressOptions o;
    o.encode.brickSize = 8;
    CompressReport r;
    ASSERT_TRUE(compressToFile(dir + "/a.vraw", dir + "/a.csgv", o, &r).isOk());
    Result<CsgvFile> f = openCsgv(dir + "/a.csgv");
    ASSERT_TRUE(f.isOk());
    EXPECT_TRUE(decodeVolume(f->volume, 0)->labels == expected.labels);
    // A truncated file gets the same clear message on the streamed path as when read whole.
    bytes.resize(bytes.size() - 3);
    write(dir + "/t.vraw", bytes);
    Status s = compressToFile(dir + "/t.vraw", dir + "/t.csgv", o);
    ASSERT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("t.vraw"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("expected 5040"), std::string::npos) << s.message();
    Result<LabelVolume> whole = parseVraw(bytes);
    ASSERT_FALSE(whole.isOk());
    EXPECT_NE(whole.message().find("expected 5040"), std::string::npos) << whole.message();
    write(dir + "/h.vraw", std::vector<uint8_t>{'9', ' ', '7', '\n'});
    EXPECT_NE(compressToFile(dir + "/h.vraw", dir + "/h.csgv", o).message().find("W H D"), std::string::npos);
    EXPECT_FALSE(fileExists(dir + "/t.csgv"));
}

// ---- Out-of-core relabelling and the streaming compress pipeline -------------------------------

namespace {

/// @brief A volume in memory as an InputSource; counts the reads so tests can see the passes.
class VectorSource : public InputSource {
public:
    VectorSource(const std::array<uint32_t, 3>& dim, LabelType type, std::vector<uint64_t> values)
        : m_values(std::move(values)) {
        m_info.dim = dim;
        m_info.type = type;
        m_info.format = "memory";
    }
    Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) override {
        const uint64_t slice = uint64_t(m_info.dim[0]) * m_info.dim[1];
        if (uint64_t(z0) + depth > m_info.dim[2]) return Status::error("slab beyond the volume");
        std::copy_n(m_values.data() + slice * z0, size_t(slice * depth), out);
        slicesRead += depth;
        maxDepth = std::max(maxDepth, depth);
        return Status::ok();
    }
    uint64_t slicesRead = 0;
    uint32_t maxDepth = 0;

private:
    std::vector<uint64_t> m_values;
};

/// The relabelling order as it was first defined (before streaming): every brick in Morton order
/// of its coordinates, every voxel of it in Morton order, ids by first appearance. Kept here as
/// the independent reference the streaming relabeller must reproduce exactly.
std::vector<uint64_t> referenceRelabel(const std::array<uint32_t, 3>& dim, const std::vector<uint64_t>& values,
                                       uint32_t B, std::vector<uint32_t>& ids) {
    std::array<uint32_t, 3> grid{};
    for (int a = 0; a < 3; ++a) grid[a] = (dim[a] - 1) / B + 1;
    std::vector<std::pair<uint64_t, std::array<uint32_t, 3>>> bricks;
    for (uint32_t z = 0; z < grid[2]; ++z)
        for (uint32_t y = 0; y < grid[1]; ++y)
            for (uint32_t x = 0; x < grid[0]; ++x) bricks.push_back({morton3x21(x, y, z), {x, y, z}});
    std::sort(bricks.begin(), bricks.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<uint64_t> original{0};
    std::unordered_map<uint64_t, uint32_t> idOf{{0, 0}};
    ids.assign(values.size(), 0);
    for (const auto& br : bricks)
        for (uint32_t m = 0; m < B * B * B; ++m) {
            const uint32_t x = br.second[0] * B + mortonX(m), y = br.second[1] * B + mortonY(m),
                           z = br.second[2] * B + mortonZ(m);
            if (x >= dim[0] || y >= dim[1] || z >= dim[2]) continue;
            const size_t i = size_t(x + uint64_t(dim[0]) * (y + uint64_t(dim[1]) * z));
            auto it = idOf.find(values[i]);
            if (it == idOf.end()) {
                it = idOf.emplace(values[i], uint32_t(original.size())).first;
                original.push_back(values[i]);
            }
            ids[i] = it->second;
        }
    return original;
}

struct TestVolume {
    std::string name;
    std::array<uint32_t, 3> dim;
    LabelType type;
    std::vector<uint64_t> values;
};

/// Volumes whose labels do not fit the format, with bricks partly outside (no dimension is a
/// multiple of 8), runs, repeats far apart and a nonzero label at voxel (0, 0, 0).
std::vector<TestVolume> wideVolumes() {
    std::vector<TestVolume> out;
    const std::array<uint32_t, 3> dim = {21, 13, 19};
    const uint64_t n = uint64_t(dim[0]) * dim[1] * dim[2];
    auto make = [&](const char* name, LabelType type, auto valueOf) {
        TestVolume t{name, dim, type, {}};
        for (uint64_t i = 0; i < n; ++i) t.values.push_back(valueOf(i));
        out.push_back(std::move(t));
    };
    make("int16", LabelType::I16, [](uint64_t i) { return uint64_t(int64_t(int16_t((i / 7) % 23) - 11)); });
    make("int32", LabelType::I32, [](uint64_t i) {
        return i % 11 == 0 ? 0 : uint64_t(int64_t((i * 2654435761u) % 97) - 40) * 100000;
    });
    make("uint64", LabelType::U64, [](uint64_t i) { return ((i / 5) % 31 + 1) << 40 | (i % 3); });
    make("uint32", LabelType::U32, [](uint64_t i) { return (i / 9) % 5 == 0 ? 0xFFFFFFFFull : (i / 13) % 40; });
    return out;
}

/// The volume written as NRRD of its type (the compress pipeline's input).
void writeTypedNrrd(const std::string& path, const TestVolume& t) {
    Status s;
    auto write = [&](auto sample, const char* name) {
        using T = decltype(sample);
        std::vector<T> v(t.values.size());
        for (size_t i = 0; i < v.size(); ++i) v[i] = T(t.values[i]);
        s = writeNrrd(path, t.dim, name, v.data(), sizeof(T), Geometry{});
    };
    switch (t.type) {
    case LabelType::I16: write(int16_t(0), "int16"); break;
    case LabelType::I32: write(int32_t(0), "int32"); break;
    case LabelType::U32: write(uint32_t(0), "uint32"); break;
    case LabelType::U64: write(uint64_t(0), "uint64"); break;
    default: write(int64_t(0), "int64"); break;
    }
    ASSERT_TRUE(s.isOk()) << s.message();
}

/// Pass 1 over slabs of `depth` slices in the order given by `reverse`.
StreamingRelabeller streamRelabel(VectorSource& src, uint32_t brick, uint32_t depth, bool reverse) {
    const auto& dim = src.info().dim;
    StreamingRelabeller r(dim, brick);
    std::vector<uint32_t> starts;
    for (uint32_t z = 0; z < dim[2]; z += depth) starts.push_back(z);
    if (reverse) std::reverse(starts.begin(), starts.end());
    std::vector<uint64_t> buf;
    for (uint32_t z : starts) {
        const uint32_t d = std::min(depth, dim[2] - z);
        buf.resize(size_t(uint64_t(dim[0]) * dim[1] * d));
        EXPECT_TRUE(src.readSlab(z, d, buf.data()).isOk());
        r.observe(z, d, buf.data());
    }
    EXPECT_TRUE(r.finish().isOk());
    return r;
}

} // namespace

TEST(StreamingRelabel, IdsEqualTheReferenceOrderForAnySlabOrder) {
    std::vector<TestVolume> volumes = wideVolumes();
    // synthA with forced relabelling (fits, 133 x 70 x 194: bricks partly outside on every axis).
    const LabelVolume& a = sourceVolume("synthA");
    volumes.push_back({"synthA", a.dim, LabelType::U32, std::vector<uint64_t>(a.labels.begin(), a.labels.end())});
    for (const TestVolume& t : volumes)
        for (uint32_t brick : {8u, 16u, 32u}) {
            std::vector<uint32_t> refIds;
            const std::vector<uint64_t> ref = referenceRelabel(t.dim, t.values, brick, refIds);
            for (uint32_t depth : {1u, 3u, brick}) {
                VectorSource src(t.dim, t.type, t.values);
                StreamingRelabeller r = streamRelabel(src, brick, depth, depth == 3);
                ASSERT_EQ(r.originalBits(), ref) << t.name << " brick " << brick << " depth " << depth;
                // Memory: one map entry per distinct non-zero label, nothing per voxel.
                std::unordered_set<uint64_t> distinct(t.values.begin(), t.values.end());
                distinct.erase(0);
                EXPECT_EQ(r.mapSize(), distinct.size());
                EXPECT_EQ(r.originalBits().size(), distinct.size() + 1);
                std::vector<uint32_t> ids(t.values.size());
                ASSERT_TRUE(r.toIds(t.values.data(), t.values.size(), ids.data()));
                ASSERT_EQ(ids, refIds) << t.name << " brick " << brick;
            }
            // prepareLabels (the in-memory API) gives the same ids and mapping.
            InputVolume in;
            in.dim = t.dim;
            in.type = t.type;
            in.values = t.values;
            LabelMapping m;
            Result<LabelVolume> p = prepareLabels(in, brick, true, m);
            ASSERT_TRUE(p.isOk()) << p.message();
            EXPECT_EQ(p->labels, refIds);
            EXPECT_EQ(m.originalBits, ref);
        }
}

TEST(StreamingRelabel, PiecesRelabelledApartGetTheIdsOfTheWholeVolume) {
    // The parallel writer: every process observes its whole-brick piece, one relabeller merges
    // the first visits and finishes, each piece maps its values with the shared table.
    std::vector<TestVolume> volumes = wideVolumes();
    const LabelVolume& a = sourceVolume("synthA");
    volumes.push_back({"synthA", a.dim, LabelType::U32, std::vector<uint64_t>(a.labels.begin(), a.labels.end())});
    for (const TestVolume& t : volumes)
        for (uint32_t brick : {8u, 32u})
            for (uint32_t n : {2u, 5u}) {
                std::vector<uint32_t> refIds;
                const std::vector<uint64_t> ref = referenceRelabel(t.dim, t.values, brick, refIds);
                const std::array<uint32_t, 3> grid = {(t.dim[0] + brick - 1) / brick, (t.dim[1] + brick - 1) / brick,
                                                      (t.dim[2] + brick - 1) / brick};
                std::vector<StreamingRelabeller> pieces;
                std::vector<std::array<uint32_t, 3>> los, sizes;
                std::vector<std::vector<uint64_t>> values;
                StreamingRelabeller merged(t.dim, brick);
                for (uint32_t p = 0; p < n; ++p) {
                    const BrickBox box = brickPartition(grid, n, p);
                    if (box.empty()) continue;
                    std::array<uint32_t, 3> lo{}, size{};
                    for (int k = 0; k < 3; ++k) {
                        lo[k] = box.lo[k] * brick;
                        size[k] = std::min(box.hi[k] * brick, t.dim[k]) - lo[k];
                    }
                    std::vector<uint64_t> v;
                    for (uint32_t z = 0; z < size[2]; ++z)
                        for (uint32_t y = 0; y < size[1]; ++y)
                            for (uint32_t x = 0; x < size[0]; ++x)
                                v.push_back(t.values[size_t(lo[0] + x + uint64_t(t.dim[0]) *
                                                                        (lo[1] + y + uint64_t(t.dim[1]) * (lo[2] + z)))]);
                    pieces.emplace_back(t.dim, brick);
                    pieces.back().observeBox(lo, size, v.data());
                    for (const auto& fv : pieces.back().firstVisits()) merged.takeFirstVisit(fv.first, fv.second);
                    los.push_back(lo);
                    sizes.push_back(size);
                    values.push_back(std::move(v));
                }
                ASSERT_TRUE(merged.finish().isOk());
                ASSERT_EQ(merged.originalBits(), ref) << t.name << " brick " << brick << ", " << n << " pieces";
                for (size_t p = 0; p < pieces.size(); ++p) {
                    ASSERT_TRUE(pieces[p].useIds(merged.originalBits()).isOk());
                    std::vector<uint32_t> ids(values[p].size());
                    ASSERT_TRUE(pieces[p].toIds(values[p].data(), ids.size(), ids.data()));
                    size_t i = 0;
                    bool same = true;
                    for (uint32_t z = 0; z < sizes[p][2]; ++z)
                        for (uint32_t y = 0; y < sizes[p][1]; ++y)
                            for (uint32_t x = 0; x < sizes[p][0]; ++x)
                                same &= ids[i++] == refIds[size_t(los[p][0] + x + uint64_t(t.dim[0]) *
                                                                            (los[p][1] + y + uint64_t(t.dim[1]) *
                                                                                                 (los[p][2] + z)))];
                    EXPECT_TRUE(same) << t.name << " piece " << p;
                }
            }
    // A table that lacks one of the piece's labels is an error naming it.
    StreamingRelabeller r({4, 1, 1}, 8);
    const uint64_t v[4] = {0, 7, 9, 7};
    r.observeBox({0, 0, 0}, {4, 1, 1}, v);
    const Status lacking = r.useIds({0, 7});
    ASSERT_FALSE(lacking.isOk());
    EXPECT_NE(lacking.message().find("label 9"), std::string::npos) << lacking.message();
    EXPECT_FALSE(r.useIds({5, 7, 9}).isOk()) << "id 0 is label 0";
}

TEST(StreamingRelabel, AdapterChecksFitMapsIdsAndReadsInBoundedSubSlabs) {
    const TestVolume t = wideVolumes()[3]; // uint32 holding 0xFFFFFFFF
    const uint64_t slice = uint64_t(t.dim[0]) * t.dim[1];
    VectorSource src(t.dim, t.type, t.values);
    // Values that do not fit fail the read with the voxel named and misfit() set.
    LabelSlabAdapter check(src, nullptr);
    std::vector<uint32_t> slab(size_t(slice * 8));
    Status s = check.readSlab(0, 8, slab.data());
    ASSERT_FALSE(s.isOk());
    EXPECT_TRUE(check.misfit());
    EXPECT_NE(s.message().find("voxel (0, 0, 0)"), std::string::npos) << s.message();
    // Relabelled slabs equal the reference ids; a scratch of 2 slices reads 2 slices at a time.
    std::vector<uint32_t> refIds;
    referenceRelabel(t.dim, t.values, 8, refIds);
    StreamingRelabeller r = streamRelabel(src, 8, 8, false);
    src.maxDepth = 0;
    LabelSlabAdapter mapped(src, &r, 2 * slice * 8);
    for (uint32_t z = 0; z < t.dim[2]; z += 8) {
        const uint32_t d = std::min(8u, t.dim[2] - z);
        ASSERT_TRUE(mapped.readSlab(z, d, slab.data()).isOk());
        for (size_t i = 0; i < slice * d; ++i) ASSERT_EQ(slab[i], refIds[size_t(slice * z + i)]) << z << " " << i;
    }
    EXPECT_EQ(src.maxDepth, 2u);
    EXPECT_EQ(mapped.scratchBytes(), 2 * slice * 8);
    EXPECT_EQ(subSlabDepth(slice, 8, 1), 1u);       // at least one slice
    EXPECT_EQ(subSlabDepth(slice, 3, 1u << 30), 3u); // never more than asked
}

TEST(StreamingRelabel, CompressWritesTheReferenceIdsAndDatabase) {
    const std::string dir = freshDir("streamrelabel");
    for (const TestVolume& t : wideVolumes()) {
        const std::string in = dir + "/" + t.name + ".nrrd", out = dir + "/" + t.name + ".csgv";
        writeTypedNrrd(in, t);
        CompressOptions o;
        o.encode.brickSize = 16;
        CompressReport r;
        Status s = compressToFile(in, out, o, &r);
        ASSERT_TRUE(s.isOk()) << s.message();
        EXPECT_TRUE(r.relabelled);
        EXPECT_EQ(r.inputFormat, "NRRD");
        EXPECT_EQ(r.originalType, labelTypeName(t.type));
        // Optimistic one pass met a misfit and restarted with two: three reads in all.
        EXPECT_TRUE(r.restarted);
        EXPECT_EQ(r.passes, 3);
        std::vector<uint32_t> refIds;
        const std::vector<uint64_t> ref = referenceRelabel(t.dim, t.values, 16, refIds);
        EXPECT_EQ(r.labelCount, ref.size());
        // The database maps exactly the reference originalBits, as the in-memory path wrote it.
        Result<AttributeDatabase> db = readAttributeDb(attributeDbPathFor(out));
        ASSERT_TRUE(db.isOk()) << db.message();
        ASSERT_EQ(db->labels.size(), ref.size());
        for (size_t i = 0; i < ref.size(); ++i) EXPECT_EQ(uint64_t(db->labels[i]), ref[i]) << t.name << " id " << i;
        const std::string inMemoryDb = dir + "/" + t.name + "_mem.db3";
        LabelMapping m;
        InputVolume iv;
        iv.dim = t.dim;
        iv.type = t.type;
        iv.values = t.values;
        ASSERT_TRUE(prepareLabels(iv, 16, false, m).isOk());
        ASSERT_TRUE(writeAttributeDb(inMemoryDb, t.dim, m.originalBits, isSignedType(t.type)).isOk());
        Result<AttributeDatabase> memDb = readAttributeDb(inMemoryDb);
        ASSERT_TRUE(memDb.isOk());
        EXPECT_EQ(memDb->labels, db->labels);
        EXPECT_EQ(memDb->labelsUnsigned64, db->labelsUnsigned64);
        // The file decodes to the reference ids.
        Result<CsgvFile> f = openCsgv(out);
        ASSERT_TRUE(f.isOk()) << f.message();
        EXPECT_TRUE(f->metadata.relabelled);
        Result<LabelVolume> d = decodeVolume(f->volume, 0);
        ASSERT_TRUE(d.isOk());
        EXPECT_EQ(d->labels, refIds) << t.name;
        // Forced relabelling goes straight to two passes.
        o.relabel = true;
        ASSERT_TRUE(compressToFile(in, out, o, &r).isOk());
        EXPECT_EQ(r.passes, 2);
        EXPECT_FALSE(r.restarted);
    }
    for (const auto& e : std::filesystem::directory_iterator(dir))
        EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

TEST(StreamingRelabel, LabelsThatFitTakeOnePassAndProgressHasStages) {
    const std::string dir = freshDir("onepass");
    TestVolume t{"fit", {19, 17, 23}, LabelType::I32, {}};
    for (uint64_t i = 0; i < 19 * 17 * 23; ++i) t.values.push_back((i / 6) % 50);
    writeTypedNrrd(dir + "/fit.nrrd", t);
    CompressOptions o;
    o.encode.brickSize = 8;
    std::vector<std::pair<double, std::string>> seen;
    o.progress = [&seen](double f, const char* stage) {
        seen.push_back({f, stage});
        return true;
    };
    CompressReport r;
    ASSERT_TRUE(compressToFile(dir + "/fit.nrrd", dir + "/fit.csgv", o, &r).isOk());
    EXPECT_FALSE(r.relabelled);
    EXPECT_EQ(r.passes, 1);
    EXPECT_GT(r.workingBytes, uint64_t(19 * 17 * 8 * 4));
    ASSERT_FALSE(seen.empty());
    EXPECT_EQ(seen.back().first, 1.0);
    for (const auto& p : seen) EXPECT_EQ(p.second, "encoding");
    Result<CsgvFile> f = openCsgv(dir + "/fit.csgv");
    ASSERT_TRUE(f.isOk());
    Result<LabelVolume> d = decodeVolume(f->volume, 0);
    ASSERT_TRUE(d.isOk());
    for (size_t i = 0; i < t.values.size(); ++i) ASSERT_EQ(d->labels[i], uint32_t(t.values[i])) << i;
    // With relabelling: "relabelling" up to 0.5, then "encoding" to 1, never going back.
    seen.clear();
    o.relabel = true;
    ASSERT_TRUE(compressToFile(dir + "/fit.nrrd", dir + "/fit.csgv", o, &r).isOk());
    ASSERT_FALSE(seen.empty());
    EXPECT_EQ(seen.front().second, "relabelling");
    EXPECT_EQ(seen.back().second, "encoding");
    EXPECT_EQ(seen.back().first, 1.0);
    for (size_t i = 1; i < seen.size(); ++i) {
        EXPECT_GE(seen[i].first, seen[i - 1].first);
        if (seen[i].second == "relabelling") {
            EXPECT_LE(seen[i].first, kRelabellingShare);
        }
    }
}

TEST(StreamingRelabel, ProgressAfterARestartNeverGoesBack) {
    // Only the last slice does not fit: the optimistic pass gets far, then the two passes that
    // follow share what is left, so the whole stays monotone and still reaches 1.
    TestVolume t = wideVolumes()[1];
    std::vector<uint64_t> v(t.values.size());
    for (size_t i = 0; i < v.size(); ++i) v[i] = t.values[i] & 0xFFFF;
    v.back() = uint64_t(-1);
    VectorSource src(t.dim, t.type, v);
    CompressOptions o;
    o.encode.brickSize = 8;
    std::vector<std::pair<double, std::string>> seen;
    o.progress = [&seen](double f, const char* stage) {
        seen.push_back({f, stage});
        return true;
    };
    CompressReport r;
    const std::string dir = freshDir("restart-progress");
    ASSERT_TRUE(compressSourceToFile(src, "memory", dir + "/r.csgv", o, &r).isOk());
    ASSERT_TRUE(r.restarted);
    ASSERT_FALSE(seen.empty());
    EXPECT_EQ(seen.back().first, 1.0);
    EXPECT_EQ(seen.back().second, "encoding");
    size_t firstRelabelling = seen.size();
    for (size_t i = 0; i < seen.size(); ++i) {
        if (i > 0) {
            EXPECT_GE(seen[i].first, seen[i - 1].first) << i << " " << seen[i].second;
        }
        if (seen[i].second == "relabelling" && firstRelabelling == seen.size()) firstRelabelling = i;
    }
    ASSERT_LT(firstRelabelling, seen.size());
    ASSERT_GT(firstRelabelling, 0u);
    // The restart begins where the optimistic pass stopped, and relabelling takes its share of the rest.
    const double restartAt = seen[firstRelabelling - 1].first;
    EXPECT_GT(restartAt, 0.0);
    EXPECT_EQ(seen[firstRelabelling].first, restartAt);
    for (const auto& p : seen) {
        if (p.second == "relabelling") {
            EXPECT_LE(p.first, restartAt + (1 - restartAt) * kRelabellingShare + 1e-12);
        }
    }
}

TEST(StreamingRelabel, AValueNewInPassTwoIsAnError) {
    // The input changed between the passes: a value pass 1 never saw is named with its voxel,
    // never silently mapped to 0.
    const TestVolume t = wideVolumes()[1];
    VectorSource first(t.dim, t.type, t.values);
    StreamingRelabeller r = streamRelabel(first, 8, 8, false);
    std::vector<uint32_t> ids(t.values.size());
    size_t miss = 99;
    EXPECT_TRUE(r.toIds(t.values.data(), t.values.size(), ids.data(), &miss));
    std::vector<uint64_t> changed = t.values;
    const uint32_t x = 5, y = 7, z = 12;
    const size_t at = size_t(x + uint64_t(t.dim[0]) * (y + uint64_t(t.dim[1]) * z));
    changed[at] = 123456789;
    EXPECT_FALSE(r.toIds(changed.data(), changed.size(), ids.data(), &miss));
    EXPECT_EQ(miss, at);
    VectorSource second(t.dim, t.type, changed);
    LabelSlabAdapter adapter(second, &r);
    const uint64_t slice = uint64_t(t.dim[0]) * t.dim[1];
    std::vector<uint32_t> slab(size_t(slice * 8));
    ASSERT_TRUE(adapter.readSlab(0, 8, slab.data()).isOk());
    Status s = adapter.readSlab(8, 8, slab.data());
    ASSERT_FALSE(s.isOk());
    EXPECT_EQ(s.message(), "the input changed during compression (label 123456789 at voxel (5, 7, 12) was not there "
                           "in the first pass)");
}

namespace {

/// @brief VectorSource reading bands of rows too.
class RowVectorSource : public VectorSource {
public:
    using VectorSource::VectorSource;
    bool readsRows() const override { return true; }
    Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) override {
        const uint32_t W = info().dim[0], H = info().dim[1];
        std::vector<uint64_t> slab(size_t(uint64_t(W) * H * depth));
        if (Status s = readSlab(z0, depth, slab.data()); !s) return s;
        for (uint32_t z = 0; z < depth; ++z)
            std::copy_n(slab.data() + (size_t(z) * H + y0) * W, size_t(W) * rows, out + size_t(z) * rows * W);
        return Status::ok();
    }
};

} // namespace

TEST(LabelSlabAdapter, BandsOfRowsAreTheRowsOfTheSlab) {
    // Through a relabeller and without one, readRows gives exactly the rows readSlab gives, and a
    // voxel it cannot map is named at its place in the volume.
    const TestVolume t = wideVolumes()[1];
    RowVectorSource first(t.dim, t.type, t.values);
    StreamingRelabeller r = streamRelabel(first, 8, 8, false);
    std::vector<uint64_t> small(t.values.size());
    for (size_t i = 0; i < small.size(); ++i) small[i] = t.values[i] % 1000;
    RowVectorSource plainSource(t.dim, LabelType::U32, small);
    RowVectorSource mappedSource(t.dim, t.type, t.values);
    LabelSlabAdapter plain(plainSource, nullptr), mapped(mappedSource, &r);
    const uint32_t W = t.dim[0], H = t.dim[1], D = t.dim[2];
    for (LabelSlabAdapter* a : {&plain, &mapped}) {
        ASSERT_TRUE(a->readsRows());
        std::vector<uint32_t> slab(size_t(uint64_t(W) * H * 8)), band;
        for (uint32_t z0 = 0; z0 < D; z0 += 8) {
            const uint32_t d = std::min(8u, D - z0);
            ASSERT_TRUE(a->readSlab(z0, d, slab.data()).isOk());
            for (uint32_t y0 = 0; y0 < H; y0 += 3) {
                const uint32_t rows = std::min(3u, H - y0);
                band.assign(size_t(uint64_t(W) * rows * d), 0);
                ASSERT_TRUE(a->readRows(z0, d, y0, rows, band.data()).isOk());
                for (uint32_t z = 0; z < d; ++z)
                    for (uint32_t y = 0; y < rows; ++y)
                        for (uint32_t x = 0; x < W; ++x)
                            ASSERT_EQ(band[x + W * (y + size_t(rows) * z)], slab[x + W * (y0 + y + size_t(H) * z)])
                                << "voxel (" << x << ", " << y0 + y << ", " << z0 + z << ")";
            }
        }
    }
    std::vector<uint64_t> changed = t.values;
    changed[size_t(5 + uint64_t(W) * (7 + uint64_t(H) * 12))] = 123456789;
    RowVectorSource second(t.dim, t.type, changed);
    LabelSlabAdapter adapter(second, &r);
    std::vector<uint32_t> band(size_t(uint64_t(W) * 6 * 8));
    const Status s = adapter.readRows(8, 8, 4, 6, band.data());
    ASSERT_FALSE(s.isOk());
    EXPECT_EQ(s.message(), "the input changed during compression (label 123456789 at voxel (5, 7, 12) was not there "
                           "in the first pass)");
}

namespace {

/// @brief A source that throws from readSlab (as an allocation inside a reader could).
class ThrowingSource : public InputSource {
public:
    explicit ThrowingSource(bool badAlloc) : m_badAlloc(badAlloc) {
        m_info.dim = {16, 16, 16};
        m_info.type = LabelType::U32;
        m_info.format = "memory";
    }
    Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) override {
        if (z0 >= 8) {
            if (m_badAlloc) throw std::bad_alloc();
            throw std::runtime_error("a reader's own exception");
        }
        std::fill_n(out, size_t(16 * 16 * depth), uint64_t(3));
        return Status::ok();
    }

private:
    bool m_badAlloc;
};

} // namespace

TEST(Compress, ExceptionsBecomeErrorsAndLeaveNoFiles) {
    const std::string dir = freshDir("throwing");
    for (bool badAlloc : {true, false})
        for (bool relabel : {false, true}) {
            ThrowingSource src(badAlloc);
            CompressOptions o;
            o.encode.brickSize = 8;
            o.relabel = relabel;
            Status s = compressSourceToFile(src, "thrower", dir + "/t.csgv", o);
            ASSERT_FALSE(s.isOk());
            // Thrown in pass 1 (compressToFile's guard) or inside encodeToFile (its own guard).
            EXPECT_NE(s.message().find("thrower"), std::string::npos) << s.message();
            EXPECT_EQ(s.message().find(".tmp-"), std::string::npos) << "names a temporary: " << s.message();
            if (badAlloc) {
                EXPECT_NE(s.message().find("out of memory while"), std::string::npos) << s.message();
            } else {
                EXPECT_NE(s.message().find("a reader's own exception"), std::string::npos) << s.message();
            }
            EXPECT_TRUE(std::filesystem::is_empty(dir)) << "files left after an exception";
        }
}

TEST(Compress, AFailedPublishLeavesTheOldSetAsItWas) {
    // An old relabelled volume is replaced; the metadata cannot be put in place (its name is taken
    // by a folder): the old volume and its database stay byte-identical, nothing new is left.
    const std::string dir = freshDir("publish");
    const std::string out = dir + "/v.csgv";
    CompressOptions o;
    o.encode.brickSize = 8;
    o.relabel = true;
    ASSERT_TRUE(compressToFile("synth:20x20x20:1", out, o).isOk());
    ASSERT_TRUE(fileExists(attributeDbPathFor(out)));
    const auto bytes = [](const std::string& p) {
        std::ifstream in(p, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    const std::string oldVolume = bytes(out), oldDb = bytes(attributeDbPathFor(out));
    std::filesystem::remove(metadataPathFor(out));
    std::filesystem::create_directories(metadataPathFor(out) + "/blocker");
    Status s = compressToFile("synth:20x20x20:2", out, o);
    ASSERT_FALSE(s.isOk());
    EXPECT_NE(s.message().find(metadataPathFor(out)), std::string::npos) << s.message();
    EXPECT_EQ(bytes(out), oldVolume) << "the old volume changed";
    EXPECT_EQ(bytes(attributeDbPathFor(out)), oldDb) << "the old database changed";
    for (const auto& e : std::filesystem::directory_iterator(dir))
        EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
    // With the way clear, the next compression publishes a whole, matching set.
    std::filesystem::remove_all(metadataPathFor(out));
    ASSERT_TRUE(compressToFile("synth:20x20x20:2", out, o).isOk());
    Result<CsgvFile> f = openCsgv(out);
    ASSERT_TRUE(f.isOk()) << f.message();
    EXPECT_TRUE(f->metadata.relabelled);
    EXPECT_TRUE(f->hasAttributes);
    EXPECT_NE(bytes(out), oldVolume);
}

TEST(Compress, MetadataNamesTheInputItself) {
    EXPECT_EQ(inputSourceName("/data/a.h5:/labels/seg"), "a.h5:/labels/seg");
    EXPECT_EQ(inputSourceName("/data/B.HDF5:/x"), "B.HDF5:/x");
    EXPECT_EQ(inputSourceName("/data/slices/"), "slices");
    EXPECT_EQ(inputSourceName("slices"), "slices");
    EXPECT_EQ(inputSourceName("/data/vol.nrrd"), "vol.nrrd");
    EXPECT_EQ(inputSourceName("/data/b.zarr/0"), "b.zarr/0");
    EXPECT_EQ(inputSourceName("/data/b.zarr/"), "b.zarr");
    EXPECT_EQ(inputSourceName("/data/cells/info#8_8_8"), "cells#8_8_8");
    EXPECT_EQ(inputSourceName("/data/cells/info"), "cells");
    EXPECT_EQ(inputSourceName("/data/stack/*.tif"), "stack/*.tif");
    EXPECT_EQ(inputSourceName("synth:8x8x8:3"), "synth:8x8x8:3");
    // Through compress: the metadata's source field.
    const std::string dir = freshDir("source-name");
    TestVolume t{"fit", {9, 8, 7}, LabelType::U16, {}};
    for (uint64_t i = 0; i < 9 * 8 * 7; ++i) t.values.push_back(i % 5);
    VectorSource src(t.dim, t.type, t.values);
    ASSERT_TRUE(compressSourceToFile(src, "/somewhere/x.h5:/labels/seg", dir + "/s.csgv", CompressOptions{}).isOk());
    Result<CsgvFile> f = openCsgv(dir + "/s.csgv");
    ASSERT_TRUE(f.isOk()) << f.message();
    EXPECT_EQ(f->metadata.source, "x.h5:/labels/seg");
}

TEST(StreamingRelabel, CancellingLeavesNoFiles) {
    const std::string dir = freshDir("cancel");
    TestVolume t = wideVolumes()[0];
    writeTypedNrrd(dir + "/in.nrrd", t);
    for (const char* when : {"relabelling", "encoding"}) {
        CompressOptions o;
        o.encode.brickSize = 8;
        o.relabel = true;
        // Cancel at the stage's second report: inside pass 1, or inside encodeToFile.
        int calls = 0;
        o.progress = [when, &calls](double, const char* stage) { return std::string(stage) != when || ++calls < 2; };
        Status s = compressToFile(dir + "/in.nrrd", dir + "/out.csgv", o);
        ASSERT_FALSE(s.isOk()) << when;
        EXPECT_NE(s.message().find("cancelled"), std::string::npos) << s.message();
        size_t files = 0;
        for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.path().filename() != "in.nrrd";
        EXPECT_EQ(files, 0u) << when;
    }
    // A synth: volume cancelled while encoding leaves nothing either.
    CompressOptions o;
    int calls = 0;
    o.progress = [&calls](double, const char*) { return ++calls < 2; };
    EXPECT_NE(compressToFile("synth:40x40x40", dir + "/s.csgv", o).message().find("cancelled"), std::string::npos);
    EXPECT_FALSE(fileExists(dir + "/s.csgv"));
    EXPECT_FALSE(fileExists(dir + "/s.csgv.json"));
}

TEST(StreamingRelabel, CompressReadsTheSourceInSlabsOncePerPass) {
    const std::string dir = freshDir("passes");
    TestVolume t = wideVolumes()[1]; // int32 with negatives
    const uint32_t D = t.dim[2];
    std::vector<uint32_t> refIds;
    const std::vector<uint64_t> ref = referenceRelabel(t.dim, t.values, 8, refIds);
    CompressOptions o;
    o.encode.brickSize = 8;
    auto decoded = [&](const std::string& path) {
        Result<CsgvFile> f = openCsgv(path);
        EXPECT_TRUE(f.isOk()) << f.message();
        return f.isOk() ? decodeVolume(f->volume, 0)->labels : std::vector<uint32_t>{};
    };
    // Forced: two passes, each reading every slice once, never more than a brick of slices at a time.
    {
        VectorSource src(t.dim, t.type, t.values);
        o.relabel = true;
        CompressReport r;
        ASSERT_TRUE(compressSourceToFile(src, "memory", dir + "/a.csgv", o, &r).isOk());
        EXPECT_EQ(src.slicesRead, 2u * D);
        EXPECT_LE(src.maxDepth, 8u);
        EXPECT_EQ(r.passes, 2);
        EXPECT_EQ(decoded(dir + "/a.csgv"), refIds);
        EXPECT_EQ(*readAttributeDb(dir + "/a_csgv.db3")->labels.rbegin(), int64_t(ref.back()));
    }
    // Only the last slice does not fit: one whole optimistic pass, then two more.
    {
        std::vector<uint64_t> v(t.values.size());
        for (size_t i = 0; i < v.size(); ++i) v[i] = t.values[i] & 0xFFFF;
        v.back() = uint64_t(-1);
        VectorSource src(t.dim, t.type, v);
        o.relabel = false;
        CompressReport r;
        ASSERT_TRUE(compressSourceToFile(src, "memory", dir + "/b.csgv", o, &r).isOk());
        EXPECT_TRUE(r.restarted);
        EXPECT_EQ(r.passes, 3);
        EXPECT_EQ(src.slicesRead, 3u * D);
        std::vector<uint32_t> ids;
        referenceRelabel(t.dim, v, 8, ids);
        EXPECT_EQ(decoded(dir + "/b.csgv"), ids);
    }
    // Labels that fit: one pass, the labels as they are, no database.
    {
        std::vector<uint64_t> v(t.values.size());
        for (size_t i = 0; i < v.size(); ++i) v[i] = t.values[i] & 0xFFFF;
        VectorSource src(t.dim, t.type, v);
        CompressReport r;
        ASSERT_TRUE(compressSourceToFile(src, "memory", dir + "/c.csgv", o, &r).isOk());
        EXPECT_EQ(src.slicesRead, uint64_t(D));
        EXPECT_FALSE(fileExists(dir + "/c_csgv.db3"));
        const std::vector<uint32_t> got = decoded(dir + "/c.csgv");
        ASSERT_EQ(got.size(), v.size());
        for (size_t i = 0; i < v.size(); ++i) ASSERT_EQ(got[i], uint32_t(v[i])) << i;
    }
}
