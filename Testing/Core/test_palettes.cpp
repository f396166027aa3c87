// SPDX-License-Identifier: MIT
// summarizePalettes (issue 40: one sweep over the palettes at open, shared by the reader, the
// label table and the renderer): its entries, range and sorted distinct labels equal a plain
// reading of every palette of every fixture, with 1 to 3 threads; a cap below the distinct labels
// lists none; bricks whose header words are wrong are listed and their palettes not read. And
// writeTiledCsgv (csgv tile): a tiled volume decodes as its source repeated.
#include "TestData.h"

#include "csgv/base/FileUtil.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/codec/Palettes.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <set>
#include <unistd.h>

using namespace csgv;
using namespace csgvtest;

namespace {

struct Plain {
    uint64_t entries = 0;
    std::set<uint32_t> labels;
};

Plain readEveryPalette(const CompressedVolume& v, const std::vector<uint64_t>& skip = {}) {
    Plain p;
    const uint32_t L = v.levels();
    for (uint64_t b = 0; b < v.brickCount(); ++b) {
        if (std::binary_search(skip.begin(), skip.end(), b)) continue;
        const BrickWords bw = v.brick(b);
        for (uint32_t k = 0; k < bw.words[L]; ++k) p.labels.insert(bw.words[bw.size - 1 - k]);
        p.entries += bw.words[L];
    }
    return p;
}

} // namespace

TEST(Palettes, EveryFixtureAsAPlainReadingOfItsPalettes) {
    for (const std::string& name : allFixtureNames()) {
        const CompressedVolume v = loadFixture(name);
        const Plain want = readEveryPalette(v);
        for (int threads : {1, 3}) {
            omp_set_num_threads(threads);
            const PaletteSummary s = summarizePalettes(v, kSummaryLabels);
            EXPECT_EQ(s.entries, want.entries) << name;
            EXPECT_EQ(s.smallest, *want.labels.begin()) << name;
            EXPECT_EQ(s.largest, *want.labels.rbegin()) << name;
            EXPECT_TRUE(s.labelsComplete) << name;
            EXPECT_EQ(s.labels, std::vector<uint32_t>(want.labels.begin(), want.labels.end())) << name << ", " << threads;
            EXPECT_TRUE(s.unsound.empty()) << name;
            ASSERT_EQ(s.first.size(), v.brickCount()) << name;
            for (uint64_t b = 0; b < v.brickCount(); ++b) {
                const BrickWords bw = v.brick(b);
                ASSERT_EQ(s.first[size_t(b)], bw.words[bw.size - 1]) << name << ": brick " << b << "'s root label";
            }
            // A cap of exactly the distinct labels lists them; one less lists none.
            const size_t n = want.labels.size();
            EXPECT_TRUE(summarizePalettes(v, n).labelsComplete) << name;
            const PaletteSummary capped = summarizePalettes(v, n - 1);
            EXPECT_FALSE(capped.labelsComplete) << name;
            EXPECT_TRUE(capped.labels.empty()) << name;
            EXPECT_EQ(capped.largest, s.largest) << "the range does not depend on the cap";
            EXPECT_EQ(summarizePalettes(v, std::numeric_limits<size_t>::max()).labels, s.labels) << name;
        }
        omp_set_num_threads(omp_get_num_procs());
    }
}

TEST(Palettes, UnsoundBricksAreListedAndTheirPalettesNotRead) {
    CompressedVolume v = loadFixture("synthA_b32_rans2.csgv");
    std::vector<uint32_t>& words = v.arrays[0].owned();
    const uint32_t L = v.levels();
    const std::vector<uint64_t> bad = {3, 40, v.brickCount() - 1};
    for (uint64_t b : bad) words[v.brickStarts[size_t(b)] + L] = v.maxPalette + 1; // one array: starts are offsets
    const Plain want = readEveryPalette(v, bad);
    const PaletteSummary s = summarizePalettes(v, kSummaryLabels);
    EXPECT_EQ(s.unsound, bad);
    for (uint64_t b = 0; b < v.brickCount(); ++b) // as checkBrick says, brick by brick
        EXPECT_EQ(std::binary_search(s.unsound.begin(), s.unsound.end(), b), !checkBrick(v, b).isOk()) << b;
    EXPECT_EQ(s.entries, want.entries);
    EXPECT_EQ(s.labels, std::vector<uint32_t>(want.labels.begin(), want.labels.end()));
}

// ------------------------------------------------------------------------------------------------
// writeTiledCsgv (csgv tile): a volume larger than memory from a smaller encoding.
// ------------------------------------------------------------------------------------------------

TEST(Tiled, TheTiledVolumeDecodesAsTheSourceRepeated) {
    LabelVolume src;
    src.dim = {32, 48, 16};
    src.labels.resize(size_t(src.voxelCount()));
    for (uint32_t z = 0; z < src.dim[2]; ++z)
        for (uint32_t y = 0; y < src.dim[1]; ++y)
            for (uint32_t x = 0; x < src.dim[0]; ++x)
                src.labels[size_t(src.index(x, y, z))] = (x / 5) * 7 + (y / 3) * 11 + z / 4 + (x * y > 300 ? 1000 : 0);
    for (int32_t encoding : {kEncodingNibble, kEncodingRans2}) {
        EncodeOptions o;
        o.brickSize = 16;
        o.encoding = encoding;
        Result<CompressedVolume> c = encodeVolume(src, o);
        ASSERT_TRUE(c.isOk()) << c.message();
        const std::string path = tempDir() + "/tiled.csgv";
        const std::array<uint32_t, 3> times = {3, 1, 2};
        ASSERT_TRUE(writeTiledCsgv(path, *c, times).isOk());
        Result<CompressedVolume> t = readCsgv(path);
        ASSERT_TRUE(t.isOk()) << t.message();
        EXPECT_TRUE(checkContainer(*t).isOk());
        EXPECT_EQ(t->dim, (std::array<uint32_t, 3>{96, 48, 32}));
        Result<LabelVolume> d = decodeVolume(*t, 0);
        ASSERT_TRUE(d.isOk()) << d.message();
        for (uint32_t z = 0; z < 32; ++z)
            for (uint32_t y = 0; y < 48; ++y)
                for (uint32_t x = 0; x < 96; ++x)
                    ASSERT_EQ(d->at(x, y, z), src.at(x % 32, y % 48, z % 16)) << x << " " << y << " " << z;
        // Refused: a volume of partial bricks, a zero count, a cancelled write (nothing left behind).
        CompressedVolume partial = *c;
        partial.dim[0] = 30;
        EXPECT_FALSE(writeTiledCsgv(tempDir() + "/no.csgv", partial, times).isOk());
        EXPECT_FALSE(writeTiledCsgv(tempDir() + "/no.csgv", *c, {1, 0, 1}).isOk());
        const Status cancelled = writeTiledCsgv(tempDir() + "/no.csgv", *c, times, {}, [](double) { return false; });
        EXPECT_NE(cancelled.message().find("cancelled"), std::string::npos) << cancelled.message();
        EXPECT_FALSE(fileSize(tempDir() + "/no.csgv").isOk()) << "nothing left behind";
        // A mapped source cut short while it is tiled (zeros past its new end): refused, no file.
        const std::string srcPath = tempDir() + "/tile_source.csgv";
        ASSERT_TRUE(writeCsgv(srcPath, *c).isOk());
        Result<CompressedVolume> mapped = readCsgvMapped(srcPath);
        ASSERT_TRUE(mapped.isOk()) << mapped.message();
        ASSERT_EQ(::truncate(srcPath.c_str(), off_t(*fileSize(srcPath) / 2)), 0);
        const Status cut = writeTiledCsgv(tempDir() + "/no.csgv", *mapped, times);
        EXPECT_NE(cut.message().find("changed on disk"), std::string::npos) << cut.message();
        EXPECT_FALSE(fileSize(tempDir() + "/no.csgv").isOk()) << "nothing left behind";
    }
}

TEST(Palettes, ProgressIsAskedAndCancels) {
    const CompressedVolume v = loadFixture("synthA_b32_rans2.csgv");
    std::vector<double> seen;
    Result<PaletteSummary> s = summarizePalettes(v, kSummaryLabels, [&](double f) {
        seen.push_back(f);
        return true;
    });
    ASSERT_TRUE(s.isOk());
    EXPECT_EQ(s->labels, summarizePalettes(v, kSummaryLabels).labels);
    ASSERT_GE(seen.size(), 2u);
    EXPECT_EQ(seen.front(), 0.0);
    EXPECT_EQ(seen.back(), 1.0);
    const Result<PaletteSummary> c = summarizePalettes(v, kSummaryLabels, [](double f) { return f < 0.5; });
    ASSERT_FALSE(c.isOk());
    EXPECT_EQ(c.message(), "cancelled");
}
