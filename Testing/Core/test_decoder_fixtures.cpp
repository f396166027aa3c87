// SPDX-License-Identifier: MIT
// Every Volcanite fixture decodes exactly to its source volume, at every level of detail, through
// every entry point (whole volume, sub-box, voxel, single brick), with any thread count.
#include "TestData.h"

#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/base/Morton.h"

#include <gtest/gtest.h>
#include <map>
#include <random>

using namespace csgv;
using namespace csgvtest;

namespace {

// From shared/data/volcanite-0.6/README.md: SHA-256 of the uncompressed `.vraw` files.
const std::map<std::string, std::string> kSourceSha256 = {
    {"synthA", "9c00e33edcd55ae78519ddbd02e71a65e84f531f26f81fef4f9ae3d587c08617"},
    {"denseB", "3c5de9fd3b522b3879327cdc2c140c3297cda70848d9d16ca3291f0d86bed065"},
};

std::string stemOf(const std::string& name) { return name.substr(0, name.find('_')); }

class Fixture : public ::testing::TestWithParam<std::string> {};

std::string paramName(const ::testing::TestParamInfo<std::string>& info) {
    std::string n = info.param.substr(0, info.param.size() - 5);
    for (char& c : n)
        if (!isalnum(static_cast<unsigned char>(c))) c = '_';
    return n;
}

} // namespace

TEST(FixtureSources, MatchPublishedHashes) {
    for (const auto& kv : kSourceSha256) {
        const LabelVolume& v = sourceVolume(kv.first + "_x");
        const std::vector<uint8_t> bytes = serializeVraw(v);
        EXPECT_EQ(sha256Hex(bytes.data(), bytes.size()), kv.second) << kv.first;
    }
}

TEST(FixtureSources, AllTwelveFixturesPresent) { EXPECT_EQ(allFixtureNames().size(), 12u); }

TEST_P(Fixture, DecodesToPublishedHash) {
    Result<CsgvFile> f = openCsgv(fixture(GetParam()));
    ASSERT_TRUE(f.isOk()) << f.message();
    EXPECT_EQ(f->hasAttributes, GetParam().find("_attr") != std::string::npos);
    Result<LabelVolume> v = decodeVolume(f->volume, 0, f->decodeOptions());
    ASSERT_TRUE(v.isOk()) << v.message();
    const std::vector<uint8_t> bytes = serializeVraw(*v);
    EXPECT_EQ(sha256Hex(bytes.data(), bytes.size()), kSourceSha256.at(stemOf(GetParam())));
}

TEST_P(Fixture, EveryLevelMatchesIndependentCoarseRule) {
    Result<CsgvFile> f = openCsgv(fixture(GetParam()));
    ASSERT_TRUE(f.isOk()) << f.message();
    LabelVolume expected = sourceVolume(GetParam());
    for (uint32_t lod = 0; lod < f->volume.levels(); ++lod) {
        if (lod > 0) expected = referenceCoarsen(expected);
        Result<LabelVolume> got = decodeVolume(f->volume, lod, f->decodeOptions());
        ASSERT_TRUE(got.isOk()) << got.message();
        ASSERT_EQ(got->dim, expected.dim) << "lod " << lod;
        ASSERT_EQ(got->dim, lodDimensions(f->volume.dim, lod));
        size_t mismatches = 0;
        for (size_t i = 0; i < expected.labels.size(); ++i) mismatches += got->labels[i] != expected.labels[i];
        EXPECT_EQ(mismatches, 0u) << "lod " << lod;
        // Core's own coarsening (used by `csgv verify`) agrees with the independent reference.
        if (lod > 0 && lod < 3) {
            const LabelVolume& src = sourceVolume(GetParam());
            LabelVolume core = src;
            for (uint32_t k = 0; k < lod; ++k) core = coarsenLabels(core);
            EXPECT_EQ(core.labels, expected.labels) << "lod " << lod;
        }
    }
}

TEST_P(Fixture, ThreadCountDoesNotChangeTheResult) {
    Result<CsgvFile> f = openCsgv(fixture(GetParam()));
    ASSERT_TRUE(f.isOk()) << f.message();
    Result<LabelVolume> one = decodeVolume(f->volume, 0, f->decodeOptions(1));
    Result<LabelVolume> two = decodeVolume(f->volume, 0, f->decodeOptions(2));
    ASSERT_TRUE(one.isOk() && two.isOk());
    EXPECT_EQ(one->labels, two->labels);
}

TEST_P(Fixture, SubBoxesAndVoxelsMatchTheWholeVolume) {
    Result<CsgvFile> f = openCsgv(fixture(GetParam()));
    ASSERT_TRUE(f.isOk()) << f.message();
    std::mt19937 rng(1234);
    for (uint32_t lod = 0; lod < f->volume.levels(); ++lod) {
        Result<LabelVolume> whole = decodeVolume(f->volume, lod, f->decodeOptions());
        ASSERT_TRUE(whole.isOk()) << whole.message();
        for (int trial = 0; trial < 4; ++trial) {
            Box box;
            for (int a = 0; a < 3; ++a) {
                const uint32_t d = whole->dim[a];
                box.min[a] = rng() % d;
                box.max[a] = box.min[a] + 1 + rng() % (d - box.min[a]);
            }
            Result<LabelVolume> sub = decodeRegion(f->volume, lod, box, f->decodeOptions());
            ASSERT_TRUE(sub.isOk()) << sub.message();
            for (uint32_t z = 0; z < sub->dim[2]; ++z)
                for (uint32_t y = 0; y < sub->dim[1]; ++y)
                    for (uint32_t x = 0; x < sub->dim[0]; ++x)
                        ASSERT_EQ(sub->at(x, y, z), whole->at(x + box.min[0], y + box.min[1], z + box.min[2]))
                            << "lod " << lod << " at " << x << "," << y << "," << z;
            const std::array<uint32_t, 3> p = {box.min[0], box.max[1] - 1, box.min[2]};
            Result<uint32_t> voxel = decodeVoxel(f->volume, p, lod, f->decodeOptions());
            ASSERT_TRUE(voxel.isOk()) << voxel.message();
            EXPECT_EQ(*voxel, whole->at(p[0], p[1], p[2]));
        }
    }
}

TEST_P(Fixture, SingleBricksMatchTheWholeVolume) {
    Result<CsgvFile> f = openCsgv(fixture(GetParam()));
    ASSERT_TRUE(f.isOk()) << f.message();
    const CompressedVolume& vol = f->volume;
    auto label = [&](uint32_t v) { return f->hasAttributes ? f->idToLabel.at(v) : v; }; // palettes of _attr hold ids
    const LabelVolume& src = sourceVolume(GetParam());
    BrickDecoder dec(vol);
    const auto grid = vol.brickGrid();
    const uint64_t last = vol.brickCount() - 1;
    for (uint64_t b : {uint64_t(0), last / 2, last}) {
        ASSERT_TRUE(dec.decode(b, 0).isOk());
        const uint32_t o[3] = {uint32_t(b % grid[0]) * vol.brickSize, uint32_t(b / grid[0] % grid[1]) * vol.brickSize,
                               uint32_t(b / (uint64_t(grid[0]) * grid[1])) * vol.brickSize};
        ASSERT_EQ(dec.gridSize(), vol.brickSize);
        for (uint32_t m = 0; m < vol.brickSize * vol.brickSize * vol.brickSize; ++m) {
            const uint32_t x = o[0] + mortonX(m), y = o[1] + mortonY(m), z = o[2] + mortonZ(m);
            if (x < vol.dim[0] && y < vol.dim[1] && z < vol.dim[2]) {
                ASSERT_EQ(label(dec.labels()[m]), src.at(x, y, z));
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Volcanite, Fixture, ::testing::ValuesIn(allFixtureNames()), paramName);

TEST(AttributeDatabase, VolcaniteDb3IsReadWithItsColumns) {
    Result<CsgvFile> f = openCsgv(fixture("synthA_b32_rans2_attr.csgv"));
    ASSERT_TRUE(f.isOk()) << f.message();
    ASSERT_TRUE(f->hasAttributes);
    const AttributeDatabase& db = f->attributes;
    EXPECT_EQ(db.labelColumn, "label");
    EXPECT_EQ(db.labels.size(), 222u);
    EXPECT_EQ(db.labels[0], 0);
    EXPECT_EQ(db.labels[1], 337694179);
    ASSERT_EQ(db.columns.size(), 3u);
    EXPECT_EQ(db.columns[0].name, "voxels");
    EXPECT_EQ(db.columns[1].name, "kind");
    EXPECT_EQ(db.columns[2].name, "score");
    for (const auto& c : db.columns) {
        EXPECT_TRUE(c.numeric) << c.name;
        EXPECT_EQ(c.values.size(), 222u) << c.name;
    }
    // The database's voxel counts are counts of the decoded labels.
    Result<LabelVolume> v = decodeVolume(f->volume, 0, f->decodeOptions());
    ASSERT_TRUE(v.isOk());
    std::map<uint32_t, uint64_t> counts;
    for (uint32_t l : v->labels) ++counts[l];
    EXPECT_EQ(counts.size(), 222u);
    const AttributeColumn* voxels = db.column("voxels");
    ASSERT_NE(voxels, nullptr);
    for (size_t id = 0; id < db.labels.size(); ++id)
        EXPECT_EQ(uint64_t(voxels->values[id]), counts[uint32_t(db.labels[id])]) << "id " << id;
}

TEST(AttributeDatabase, PathFollowsVolcanitesNaming) {
    EXPECT_EQ(attributeDbPathFor("a/vol.csgv"), "a/vol_csgv.db3");
    EXPECT_EQ(attributeDbPathFor("vol.csgv"), "vol_csgv.db3");
    EXPECT_EQ(attributeDbPathFor("a.b/vol"), "a.b/vol_csgv.db3");
}

TEST(AttributeDatabase, IdsWithoutALabelAreAnError) {
    Result<CsgvFile> f = openCsgv(fixture("synthA_b32_rans2_attr.csgv"));
    ASSERT_TRUE(f.isOk());
    std::vector<uint32_t> shortMap(f->idToLabel.begin(), f->idToLabel.begin() + 10);
    DecodeOptions o;
    o.idToLabel = &shortMap;
    Result<LabelVolume> v = decodeVolume(f->volume, 0, o);
    ASSERT_FALSE(v.isOk());
    EXPECT_NE(v.message().find("attribute database"), std::string::npos) << v.message();
}

TEST(DecodeLimits, OutputLargerThanTheLimitIsRefusedBeforeAllocating) {
    const CompressedVolume vol = loadFixture("synthA_b32_rans2.csgv");
    DecodeOptions o;
    o.maxOutputBytes = 1000;
    Result<LabelVolume> v = decodeVolume(vol, 0, o);
    ASSERT_FALSE(v.isOk());
    EXPECT_NE(v.message().find("limit"), std::string::npos) << v.message();
    EXPECT_TRUE(decodeVolume(vol, vol.levels() - 1, o).isOk()); // 5x3x7 voxels fit
}

TEST(DecodeLimits, BadLevelsAndBoxesAreErrors) {
    const CompressedVolume vol = loadFixture("synthA_b32_rans2.csgv");
    EXPECT_FALSE(decodeVolume(vol, vol.levels()).isOk());
    Box empty;
    EXPECT_FALSE(decodeRegion(vol, 0, empty).isOk());
    Box outside;
    outside.max = {134, 70, 194};
    EXPECT_FALSE(decodeRegion(vol, 0, outside).isOk());
    EXPECT_FALSE(decodeVoxel(vol, {133, 0, 0}).isOk());
    BrickDecoder dec(vol);
    EXPECT_FALSE(dec.decode(vol.brickCount(), 0).isOk());
    EXPECT_FALSE(dec.decode(0, vol.levels()).isOk());
}
