// SPDX-License-Identifier: MIT
// TieredVolume (issue 40): a mapped rANS two-table encoding split into a resident coarse tier and
// a finest level read from the file on demand. The coarse tier is a valid container that decodes
// every level but the finest exactly as the whole encoding does; the finest streams copied out
// are the file's; budgets, cancellation and what cannot be tiered fail clearly.
#include "TestData.h"

#include "csgv/base/MappedFile.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/codec/TieredVolume.h"

#include <gtest/gtest.h>

using namespace csgv;
using namespace csgvtest;

namespace {

std::shared_ptr<const CompressedVolume> mappedCopy(const std::string& fixtureName, const std::string& as) {
    const std::string path = tempDir() + "/" + as;
    writeBytes(path, fixtureBytes(fixtureName));
    Result<CompressedVolume> v = readCsgvMapped(path);
    EXPECT_TRUE(v.isOk()) << v.message();
    return v ? std::make_shared<const CompressedVolume>(std::move(*v)) : nullptr;
}

std::vector<std::string> rans2Fixtures() {
    std::vector<std::string> names;
    for (const std::string& n : allFixtureNames())
        if (loadFixture(n).encoding == kEncodingRans2 && loadFixture(n).levels() >= 2) names.push_back(n);
    return names;
}

} // namespace

TEST(Tiered, CoarseTierDecodesEveryLevelButTheFinestAsTheWholeDoes) {
    const std::vector<std::string> names = rans2Fixtures();
    ASSERT_GE(names.size(), 2u);
    for (const std::string& name : names) {
        std::shared_ptr<const CompressedVolume> full = mappedCopy(name, "tiered-" + name);
        ASSERT_TRUE(full);
        ASSERT_TRUE(TieredVolume::tierable(*full)) << name;
        Result<std::shared_ptr<const TieredVolume>> t = TieredVolume::create(full, {});
        ASSERT_TRUE(t.isOk()) << name << ": " << t.message();
        const TieredVolume& tiers = **t;
        EXPECT_TRUE(tiers.hasCoarseTier());
        const CompressedVolume& coarse = tiers.coarse();
        EXPECT_TRUE(checkContainer(coarse).isOk()) << name << ": " << checkContainer(coarse).message();
        EXPECT_LT(coarse.serializedSize(), full->serializedSize()) << name;
        EXPECT_EQ(coarse.maxPalette, full->maxPalette);
        for (uint32_t lod = 1; lod < full->levels(); ++lod) {
            Result<LabelVolume> a = decodeVolume(*full, lod), b = decodeVolume(coarse, lod);
            ASSERT_TRUE(a.isOk() && b.isOk()) << name << " lod " << lod << ": " << b.message();
            EXPECT_EQ(a->labels, b->labels) << name << " lod " << lod;
        }
        // The finest streams copied out are stream B of each brick, word for word.
        const uint32_t L = full->levels();
        uint64_t total = 0;
        for (uint64_t b = 0; b < full->brickCount(); ++b) {
            const BrickWords bw = full->brick(b);
            const uint32_t begin = bw.words[L - 1] / 8, end = bw.size - bw.words[L];
            ASSERT_EQ(tiers.finestWords(b), end - begin) << name << " brick " << b;
            std::vector<uint32_t> got(tiers.finestWords(b) + 1, 0xABCDEF01u);
            tiers.copyFinest(b, got.data());
            EXPECT_EQ(got.back(), 0xABCDEF01u) << "no word past the stream";
            got.pop_back();
            EXPECT_EQ(got, std::vector<uint32_t>(bw.words + begin, bw.words + end)) << name << " brick " << b;
            total += end - begin;
        }
        EXPECT_EQ(tiers.finestBytesTotal(), total * 4);
        const TierCounts c = tiers.counts();
        EXPECT_EQ(c.fileBricks, full->brickCount());
        EXPECT_EQ(c.fileBytes, total * 4);
        // Released pages decode the same, and read-ahead changes nothing.
        Result<LabelVolume> before = decodeVolume(*full, 0);
        ASSERT_TRUE(before.isOk()) << before.message();
        std::vector<uint32_t> all(size_t(full->brickCount()));
        for (size_t i = 0; i < all.size(); ++i) all[i] = uint32_t(i);
        tiers.release(all.size());
        tiers.readAhead(all.data(), all.size());
        EXPECT_EQ(tiers.counts().releasedBricks, all.size());
        Result<LabelVolume> finest = decodeVolume(*full, 0);
        ASSERT_TRUE(finest.isOk()) << finest.message();
        EXPECT_EQ(finest->labels, before->labels) << name;
        // The coarse tier is no substitute at full resolution: it fails, never reads past a brick.
        EXPECT_FALSE(decodeVolume(coarse, 0).isOk()) << name;
    }
}

TEST(Tiered, ABudgetTheCoarseLevelsExceedKeepsNoLevelResident) {
    std::shared_ptr<const CompressedVolume> full = mappedCopy(rans2Fixtures().front(), "tiered-budget.csgv");
    ASSERT_TRUE(full);
    TieredVolume::Options o;
    for (uint64_t budget : {uint64_t(64), full->serializedSize() / 4}) {
        o.budgetBytes = budget;
        Result<std::shared_ptr<const TieredVolume>> t = TieredVolume::create(full, o);
        ASSERT_TRUE(t.isOk()) << t.message();
        const TieredVolume& tiers = **t;
        EXPECT_FALSE(tiers.hasCoarseTier());
        EXPECT_EQ(&tiers.coarse(), full.get()) << "every level is the file's";
        EXPECT_EQ(tiers.residentBytes(), 0u);
        const uint32_t L = full->levels();
        for (uint64_t b = 0; b < full->brickCount(); ++b) {
            const BrickWords bw = full->brick(b);
            ASSERT_EQ(tiers.finestWords(b), bw.size - bw.words[L] - bw.words[L - 1] / 8);
        }
    }
    EXPECT_TRUE(TieredVolume::wanted(*full, 64));
    EXPECT_FALSE(TieredVolume::wanted(*full, full->serializedSize()));
    o.budgetBytes = 64 << 20;
    Result<std::shared_ptr<const TieredVolume>> fits = TieredVolume::create(full, o);
    ASSERT_TRUE(fits.isOk()) << fits.message();
    EXPECT_LE((*fits)->residentBytes(), o.budgetBytes);
    EXPECT_GT((*fits)->residentBytes(), 0u);
}

TEST(Tiered, OnlyMappedRansTwoTableEncodingsAreTiered) {
    const std::string rans2 = rans2Fixtures().front();
    CompressedVolume read = loadFixture(rans2); // owned words: nothing to release
    EXPECT_FALSE(TieredVolume::tierable(read));
    Result<std::shared_ptr<const TieredVolume>> t = TieredVolume::create(std::make_shared<const CompressedVolume>(read), {});
    ASSERT_FALSE(t.isOk());
    EXPECT_NE(t.message().find("rANS two-table encoding read from a mapped file"), std::string::npos) << t.message();
    for (const std::string& name : allFixtureNames()) {
        if (loadFixture(name).encoding == kEncodingRans2) continue;
        std::shared_ptr<const CompressedVolume> m = mappedCopy(name, "tiered-other-" + name);
        ASSERT_TRUE(m);
        EXPECT_FALSE(TieredVolume::tierable(*m)) << name;
        EXPECT_FALSE(TieredVolume::create(m, {}).isOk()) << name;
    }
    EXPECT_FALSE(TieredVolume::create(nullptr, {}).isOk());
}

TEST(Tiered, TheSweepCanBeCancelled) {
    std::shared_ptr<const CompressedVolume> full = mappedCopy(rans2Fixtures().front(), "tiered-cancel.csgv");
    ASSERT_TRUE(full);
    TieredVolume::Options o;
    int asked = 0;
    o.progress = [&](double f) {
        EXPECT_GE(f, 0.0);
        EXPECT_LE(f, 1.0);
        ++asked;
        return false;
    };
    Result<std::shared_ptr<const TieredVolume>> t = TieredVolume::create(full, o);
    ASSERT_FALSE(t.isOk());
    EXPECT_EQ(t.message(), "cancelled");
    EXPECT_EQ(asked, 1);
}

TEST(Tiered, SplitEncodingArraysKeepTheirLayoutInTheCoarseTier) {
    // Bricks spread over many encoding arrays (a small array limit stands in for 2^29 words): the
    // coarse tier's brick starts follow the container's rule for bricks that open an array.
    EncodeOptions eo;
    eo.brickSize = 16;
    eo.maxArrayWords = 4000;
    const LabelVolume& labels = sourceVolume("synthA_b32_rans2.csgv");
    Result<CompressedVolume> enc = encodeVolume(labels, eo);
    ASSERT_TRUE(enc.isOk()) << enc.message();
    ASSERT_GT(enc->arrays.size(), 3u);
    const std::string path = tempDir() + "/tiered-split.csgv";
    ASSERT_TRUE(writeCsgv(path, *enc).isOk());
    Result<CompressedVolume> m = readCsgvMapped(path);
    ASSERT_TRUE(m.isOk()) << m.message();
    auto full = std::make_shared<const CompressedVolume>(std::move(*m));
    for (uint64_t budget : {uint64_t(0), uint64_t(1) << 20, uint64_t(100)}) {
        TieredVolume::Options o;
        o.budgetBytes = budget;
        Result<std::shared_ptr<const TieredVolume>> t = TieredVolume::create(full, o);
        ASSERT_TRUE(t.isOk()) << t.message();
        const CompressedVolume& coarse = (*t)->coarse();
        EXPECT_EQ((*t)->hasCoarseTier(), budget != 100) << budget;
        EXPECT_TRUE(checkContainer(coarse).isOk()) << checkContainer(coarse).message();
        EXPECT_EQ(coarse.arrays.size(), full->arrays.size());
        for (uint32_t lod = 1; lod < full->levels(); ++lod) {
            Result<LabelVolume> a = decodeVolume(*full, lod), b = decodeVolume(coarse, lod);
            ASSERT_TRUE(a.isOk() && b.isOk()) << b.message();
            EXPECT_EQ(a->labels, b->labels) << "budget " << budget << " lod " << lod;
        }
        Result<LabelVolume> finest = decodeVolume(*full, 0);
        ASSERT_TRUE(finest.isOk());
        EXPECT_EQ(finest->labels, labels.labels);
    }
}
