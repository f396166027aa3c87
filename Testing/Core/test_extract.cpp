// SPDX-License-Identifier: MIT
// extractLabels (issue 41): label images and masks equal the fully decoded volume's voxels of the
// selected labels inside the tight bounding box (the whole-volume decoder is the oracle), at full
// resolution and a coarser level, with and without a box; exactly the bricks whose palettes hold
// a selected label are decoded; bad selections are clear errors.
#include "TestData.h"

#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/codec/Extract.h"

#include <gtest/gtest.h>
#include <algorithm>
#include <set>
#include <unordered_map>

using namespace csgv;
using namespace csgvtest;

namespace {

CsgvFile openFixture(const std::string& name) {
    Result<CsgvFile> f = openCsgv(fixture(name));
    EXPECT_TRUE(f.isOk()) << f.message();
    return f.isOk() ? std::move(*f) : CsgvFile();
}

/// Up to `count` distinct labels of a decoded volume, spread over its sorted distinct labels,
/// label 0 left out (it is the background of the output).
std::vector<int64_t> someLabels(const LabelVolume& v, size_t count) {
    std::set<uint32_t> all(v.labels.begin(), v.labels.end());
    all.erase(0);
    std::vector<uint32_t> sorted(all.begin(), all.end());
    std::vector<int64_t> out;
    for (size_t i = 0; i < count && i < sorted.size(); ++i) out.push_back(sorted[i * sorted.size() / count]);
    return out;
}

/// The stored value (id or label) of each selected original label.
std::set<uint32_t> storedOf(const CsgvFile& f, const std::vector<int64_t>& labels) {
    std::set<uint32_t> s;
    for (int64_t l : labels) {
        if (!f.hasAttributes) {
            s.insert(uint32_t(l));
            continue;
        }
        auto it = std::find(f.attributes.labels.begin(), f.attributes.labels.end(), l);
        EXPECT_NE(it, f.attributes.labels.end());
        s.insert(uint32_t(it - f.attributes.labels.begin()));
    }
    return s;
}

/// Bricks whose palette (the last header[L] words, read here from the words directly) holds a
/// selected stored value and that meet the node box [lo, hi) at `lod`.
uint64_t bricksHolding(const CompressedVolume& v, const std::set<uint32_t>& stored, uint32_t lod,
                       std::array<uint32_t, 3> lo, std::array<uint32_t, 3> hi) {
    const uint32_t L = v.levels(), edge = v.brickSize >> lod;
    const auto g = v.brickGrid();
    uint64_t n = 0;
    for (uint64_t b = 0; b < v.brickCount(); ++b) {
        const uint64_t c[3] = {b % g[0], (b / g[0]) % g[1], b / (uint64_t(g[0]) * g[1])};
        bool meets = true;
        for (int a = 0; a < 3; ++a) meets = meets && c[a] * edge < hi[a] && (c[a] + 1) * edge > lo[a];
        if (!meets) continue;
        const BrickWords bw = v.brick(b);
        bool hit = false;
        for (uint32_t k = 0; k < bw.words[L]; ++k) hit = hit || stored.count(bw.words[bw.size - 1 - k]);
        n += hit;
    }
    return n;
}

/// Checks a result against the decoded level image `full` restricted to the node box [lo, hi).
void expectMatchesOracle(const CsgvFile& f, const ExtractOptions& o, const ExtractResult& r, const LabelVolume& full,
                         std::array<uint32_t, 3> lo, std::array<uint32_t, 3> hi) {
    const std::set<int64_t> want(o.labels.begin(), o.labels.end());
    std::array<uint32_t, 3> bmin{{~0u, ~0u, ~0u}}, bmax{{0, 0, 0}};
    uint64_t count = 0;
    std::set<uint64_t> bricksWithVoxels;
    const uint32_t edge = f.volume.brickSize >> o.lod;
    const auto g = f.volume.brickGrid();
    for (uint32_t z = lo[2]; z < hi[2]; ++z)
        for (uint32_t y = lo[1]; y < hi[1]; ++y)
            for (uint32_t x = lo[0]; x < hi[0]; ++x)
                if (want.count(full.at(x, y, z))) {
                    ++count;
                    const uint32_t c[3] = {x, y, z};
                    for (int a = 0; a < 3; ++a) {
                        bmin[a] = std::min(bmin[a], c[a]);
                        bmax[a] = std::max(bmax[a], c[a] + 1);
                    }
                    bricksWithVoxels.insert(x / edge + uint64_t(g[0]) * (y / edge + uint64_t(g[1]) * (z / edge)));
                }
    ASSERT_EQ(r.voxels, count);
    EXPECT_EQ(r.bricksWithVoxels, bricksWithVoxels.size());
    EXPECT_EQ(r.bricksDecoded, bricksHolding(f.volume, storedOf(f, o.labels), o.lod, lo, hi));
    EXPECT_LE(r.bricksDecoded, r.bricksInBox);
    EXPECT_EQ(r.bricksTotal, f.volume.brickCount());
    if (!count) {
        EXPECT_TRUE(r.empty());
        return;
    }
    // The tight box: every face of it touches a selected voxel.
    ASSERT_EQ(r.offset, bmin);
    for (int a = 0; a < 3; ++a) ASSERT_EQ(r.dim[a], bmax[a] - bmin[a]);
    ASSERT_EQ(o.mask ? r.mask.size() : r.labels.size(), size_t(r.dim[0]) * r.dim[1] * r.dim[2]);
    size_t i = 0;
    for (uint32_t z = bmin[2]; z < bmax[2]; ++z)
        for (uint32_t y = bmin[1]; y < bmax[1]; ++y)
            for (uint32_t x = bmin[0]; x < bmax[0]; ++x, ++i) {
                const uint32_t v = full.at(x, y, z);
                const bool sel = want.count(v) != 0;
                if (o.mask) ASSERT_EQ(r.mask[i], sel ? 1 : 0) << "node " << x << " " << y << " " << z;
                else ASSERT_EQ(r.labels[i], sel ? v : 0u) << "node " << x << " " << y << " " << z;
            }
}

class ExtractFixture : public ::testing::TestWithParam<std::string> {};

TEST_P(ExtractFixture, EqualsTheDecodedVolumeAtTwoLevelsWithAndWithoutABox) {
    const CsgvFile f = openFixture(GetParam());
    for (uint32_t lod : {0u, 2u}) {
        Result<LabelVolume> full = decodeVolume(f.volume, lod, f.decodeOptions());
        ASSERT_TRUE(full.isOk()) << full.message();
        for (size_t count : {1u, 10u}) {
            for (bool mask : {false, true}) {
                ExtractOptions o;
                o.labels = someLabels(*full, count);
                o.lod = lod;
                o.mask = mask;
                o.threads = 2;
                Result<ExtractResult> r = extractLabels(f, o);
                ASSERT_TRUE(r.isOk()) << r.message();
                SCOPED_TRACE(GetParam() + " lod " + std::to_string(lod) + " labels " + std::to_string(count) +
                             (mask ? " mask" : " labels"));
                EXPECT_EQ(r->labelsSelected, o.labels.size());
                EXPECT_EQ(r->labelsFound, o.labels.size());
                expectMatchesOracle(f, o, *r, *full, {0, 0, 0}, full->dim);
                // A box: full-resolution voxels, the output keeps the level's nodes that meet it.
                o.hasBox = true;
                o.box.min = {f.volume.dim[0] / 5, f.volume.dim[1] / 4, f.volume.dim[2] / 3};
                o.box.max = {f.volume.dim[0] * 4 / 5, f.volume.dim[1] - 1, f.volume.dim[2] * 2 / 3 + 1};
                std::array<uint32_t, 3> lo{}, hi{};
                for (int a = 0; a < 3; ++a) {
                    lo[a] = o.box.min[a] >> lod;
                    hi[a] = std::min(full->dim[a], (o.box.max[a] + (1u << lod) - 1) >> lod);
                }
                Result<ExtractResult> boxed = extractLabels(f, o);
                ASSERT_TRUE(boxed.isOk()) << boxed.message();
                expectMatchesOracle(f, o, *boxed, *full, lo, hi);
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Fixtures, ExtractFixture,
                         ::testing::Values("synthA_b32_rans2.csgv", "synthA_b16_nibble.csgv", "synthA_b8_nibble_delta.csgv",
                                           "synthA_b32_rans2_attr.csgv", "denseB_b32_rans1.csgv",
                                           "denseB_b16_rans2_delta.csgv"),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                             return info.param.substr(0, info.param.size() - 5);
                         });

TEST(Extract, OnlyBricksHoldingALabelAreDecoded) {
    const CsgvFile f = openFixture("synthA_b32_rans2.csgv");
    Result<LabelVolume> full = decodeVolume(f.volume, 0);
    ASSERT_TRUE(full.isOk());
    ExtractOptions o;
    o.labels = someLabels(*full, 3);
    Result<ExtractResult> r = extractLabels(f, o);
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_LT(r->bricksDecoded, r->bricksTotal / 2) << "a few labels should touch few bricks";
    EXPECT_EQ(r->bricksInBox, r->bricksTotal);
    EXPECT_GT(r->bricksDecoded, 0u);
}

TEST(Extract, GeometryMovesTheOriginToTheFirstNode) {
    Geometry corner;
    corner.spacing = {0.5, 2, 1.5};
    corner.origin = {-90, -125, -71};
    corner.direction = {0, 1, 0, -1, 0, 0, 0, 0, 1}; // column c is index axis c: x along world -y, y along +x
    const Geometry g = extractGeometry(corner, 1, {3, 4, 5});
    EXPECT_EQ(g.spacing, (std::array<double, 3>{1, 4, 3}));
    EXPECT_EQ(g.direction, corner.direction);
    // world = origin + D * (offset * spacing): offset * spacing = (3, 16, 15)
    EXPECT_DOUBLE_EQ(g.origin[0], -90 + 16);
    EXPECT_DOUBLE_EQ(g.origin[1], -125 - 3);
    EXPECT_DOUBLE_EQ(g.origin[2], -71 + 15);
}

TEST(Extract, BadSelectionsAreClearErrors) {
    const CsgvFile f = openFixture("synthA_b32_rans2.csgv");
    const CsgvFile attr = openFixture("synthA_b32_rans2_attr.csgv");
    Result<LabelVolume> full = decodeVolume(f.volume, 0);
    ASSERT_TRUE(full.isOk());
    const std::vector<int64_t> real = someLabels(*full, 2);
    auto message = [](const CsgvFile& file, const ExtractOptions& o) {
        Result<ExtractResult> r = extractLabels(file, o);
        return r.isOk() ? std::string("ok") : r.message();
    };
    ExtractOptions o;
    EXPECT_NE(message(f, o).find("selection is empty"), std::string::npos) << message(f, o);

    o.labels = {real[0], 3, 99999, -4, int64_t(1) << 40};
    std::string m = message(f, o);
    EXPECT_NE(m.find("4 of the 5 selected labels occur nowhere"), std::string::npos) << m;
    EXPECT_NE(m.find("-4, 3, 99999, 1099511627776"), std::string::npos) << m;
    m = message(attr, o);
    EXPECT_NE(m.find("4 of the 5 selected labels are not in"), std::string::npos) << m;
    EXPECT_NE(m.find("_csgv.db3"), std::string::npos) << m;
    // checkOnly: the same checks, nothing decoded.
    o.checkOnly = true;
    EXPECT_NE(message(f, o).find("4 of the 5 selected labels occur nowhere"), std::string::npos) << message(f, o);
    o.labels = real;
    Result<ExtractResult> checked = extractLabels(f, o);
    ASSERT_TRUE(checked.isOk()) << checked.message();
    EXPECT_EQ(checked->bricksDecoded, 0u);
    EXPECT_EQ(checked->labelsFound, real.size());
    EXPECT_TRUE(checked->empty());
    o.checkOnly = false;

    o.labels = real;
    o.hasBox = true;
    o.box.min = {0, 0, 0};
    o.box.max = {200, 10, 10};
    m = message(f, o);
    EXPECT_NE(m.find("box's x range [0, 200) is empty or outside the volume's [0, 133)"), std::string::npos) << m;
    o.box.max = {10, 10, 0};
    m = message(f, o);
    EXPECT_NE(m.find("box's z range"), std::string::npos) << m;
    o.hasBox = false;

    o.maxLabels = 1;
    m = message(f, o);
    EXPECT_NE(m.find("names 2 labels, more than the limit of 1"), std::string::npos) << m;
    o.maxLabels = kDefaultMaxExtractLabels;
    o.labels = {real[0], real[0], real[0]}; // repeats count once
    o.maxLabels = 1;
    EXPECT_EQ(message(f, o), "ok");
    o.maxLabels = kDefaultMaxExtractLabels;

    o.labels = {0};
    o.maxOutputBytes = 1 << 20;
    m = message(f, o);
    EXPECT_NE(m.find("bounding box at level 0 is 133 x 70 x 194"), std::string::npos) << m;
    EXPECT_NE(m.find("more than the output limit of 1.0 MiB"), std::string::npos) << m;
    o.mask = true; // a mask is a quarter of the bytes
    o.maxOutputBytes = 133 * 70 * 194;
    EXPECT_EQ(message(f, o), "ok");

    o.lod = 6;
    m = message(f, o);
    EXPECT_NE(m.find("level 6 is out of range 0..5"), std::string::npos) << m;
    o.lod = 0;

    o.progress = [](double) { return false; };
    m = message(f, o);
    EXPECT_NE(m.find("cancelled"), std::string::npos) << m;
}

TEST(Extract, LabelsOutsideTheBoxGiveAnEmptyResult) {
    const CsgvFile f = openFixture("synthA_b32_rans2.csgv");
    Result<LabelVolume> full = decodeVolume(f.volume, 0);
    ASSERT_TRUE(full.isOk());
    // A label and a one-voxel box where it is not.
    const uint32_t label = full->at(60, 30, 90) ? full->at(60, 30, 90) : someLabels(*full, 1)[0];
    uint32_t x = 0;
    while (full->at(x, 0, 0) == label) ++x;
    ExtractOptions o;
    o.labels = {label};
    o.hasBox = true;
    o.box.min = {x, 0, 0};
    o.box.max = {x + 1, 1, 1};
    Result<ExtractResult> r = extractLabels(f, o);
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_TRUE(r->empty());
    EXPECT_EQ(r->dim, (std::array<uint32_t, 3>{0, 0, 0}));
    EXPECT_TRUE(r->labels.empty());
}

TEST(Extract, QuerySelectsLabelsOfTheAttributeDatabase) {
    const CsgvFile attr = openFixture("synthA_b32_rans2_attr.csgv");
    Result<std::vector<int64_t>> q = labelsMatchingQuery(attr, "voxels > 5000 and kind = 3");
    ASSERT_TRUE(q.isOk()) << q.message();
    const AttributeColumn* voxels = attr.attributes.column("voxels");
    const AttributeColumn* kind = attr.attributes.column("kind");
    ASSERT_TRUE(voxels && kind);
    std::vector<int64_t> expected;
    for (size_t id = 0; id < attr.attributes.labels.size(); ++id)
        if (voxels->values[id] > 5000 && kind->values[id] == 3) expected.push_back(attr.attributes.labels[id]);
    std::sort(expected.begin(), expected.end());
    EXPECT_FALSE(expected.empty());
    EXPECT_EQ(*q, expected);
    ExtractOptions o;
    o.labels = *q;
    o.mask = true;
    Result<ExtractResult> r = extractLabels(attr, o);
    ASSERT_TRUE(r.isOk()) << r.message();
    EXPECT_GT(r->voxels, 0u);

    Result<std::vector<int64_t>> bad = labelsMatchingQuery(attr, "voxels >");
    ASSERT_FALSE(bad.isOk());
    EXPECT_NE(bad.message().find("syntax error"), std::string::npos) << bad.message();
    const CsgvFile plain = openFixture("synthA_b32_rans2.csgv");
    bad = labelsMatchingQuery(plain, "voxels > 1");
    ASSERT_FALSE(bad.isOk());
    EXPECT_NE(bad.message().find("no attribute database"), std::string::npos) << bad.message();
}

} // namespace

TEST_P(ExtractFixture, SelectionBoxesAreDisjointAndExtractTheSameVoxels) {
    const CsgvFile f = openFixture(GetParam());
    for (uint32_t lod : {0u, 2u}) {
        Result<LabelVolume> full = decodeVolume(f.volume, lod, f.decodeOptions());
        ASSERT_TRUE(full.isOk()) << full.message();
        ExtractOptions o;
        o.labels = someLabels(*full, 10);
        o.lod = lod;
        o.threads = 2;
        Result<ExtractResult> whole = extractLabels(f, o);
        ASSERT_TRUE(whole.isOk()) << whole.message();
        for (size_t most : {size_t(256), size_t(3)}) { // 3: neighbouring groups joined
        Result<std::vector<Box>> boxes = selectionBoxes(f, o, most);
        ASSERT_TRUE(boxes.isOk()) << boxes.message();
        ASSERT_FALSE(boxes->empty());
        EXPECT_LE(boxes->size(), most);
        for (size_t i = 0; i < boxes->size(); ++i)
            for (size_t j = i + 1; j < boxes->size(); ++j) {
                bool apart = false;
                for (int a = 0; a < 3; ++a)
                    apart = apart || (*boxes)[i].max[a] <= (*boxes)[j].min[a] || (*boxes)[j].max[a] <= (*boxes)[i].min[a];
                EXPECT_TRUE(apart) << GetParam() << ": boxes " << i << " and " << j << " overlap";
            }
        uint64_t voxels = 0;
        for (const Box& b : *boxes) {
            ExtractOptions ob = o;
            ob.hasBox = true;
            ob.box = b;
            Result<ExtractResult> r = extractLabels(f, ob);
            ASSERT_TRUE(r.isOk()) << r.message();
            voxels += r->voxels;
            std::array<uint32_t, 3> lo{}, hi{};
            for (int a = 0; a < 3; ++a) {
                lo[a] = b.min[a] >> lod;
                hi[a] = std::min(full->dim[a], (b.max[a] + (1u << lod) - 1) >> lod);
            }
            SCOPED_TRACE(GetParam() + " lod " + std::to_string(lod));
            expectMatchesOracle(f, ob, *r, *full, lo, hi);
        }
        EXPECT_EQ(voxels, whole->voxels) << GetParam() << ": the boxes hold every selected voxel once";
        }
    }
}

TEST(Extract, AScatteredLabelGetsABoxPerPlace) {
    LabelVolume v;
    v.dim = {64, 64, 64};
    v.labels.assign(size_t(v.voxelCount()), 1);
    for (uint32_t z = 0; z < 4; ++z)
        for (uint32_t y = 0; y < 4; ++y)
            for (uint32_t x = 0; x < 4; ++x) {
                v.labels[size_t(v.index(x, y, z))] = 7;
                v.labels[size_t(v.index(60 + x, 60 + y, 60 + z))] = 7;
                v.labels[size_t(v.index(30 + x, 2 + y, 40 + z))] = 9;
            }
    EncodeOptions eo;
    eo.brickSize = 16;
    Result<CompressedVolume> c = encodeVolume(v, eo);
    ASSERT_TRUE(c.isOk()) << c.message();
    CsgvFile f;
    f.volume = std::move(*c);
    ExtractOptions o;
    o.labels = {7};
    Result<std::vector<Box>> boxes = selectionBoxes(f, o);
    ASSERT_TRUE(boxes.isOk()) << boxes.message();
    ASSERT_EQ(boxes->size(), 2u) << "two corners, two boxes";
    EXPECT_EQ((*boxes)[0].min, (std::array<uint32_t, 3>{0, 0, 0}));
    EXPECT_EQ((*boxes)[0].max, (std::array<uint32_t, 3>{16, 16, 16}));
    EXPECT_EQ((*boxes)[1].min, (std::array<uint32_t, 3>{48, 48, 48}));
    EXPECT_EQ((*boxes)[1].max, (std::array<uint32_t, 3>{64, 64, 64}));
    o.labels = {7, 9};
    EXPECT_EQ(selectionBoxes(f, o)->size(), 3u);
    // More groups than boxes allowed: neighbours joined, at most that many boxes, disjoint, and
    // every selected voxel still in one of them.
    for (size_t most : {1u, 2u}) {
        Result<std::vector<Box>> few = selectionBoxes(f, o, most);
        ASSERT_TRUE(few.isOk());
        EXPECT_GE(few->size(), 1u);
        EXPECT_LE(few->size(), most);
        uint64_t voxels = 0;
        for (const Box& b : *few) {
            ExtractOptions ob = o;
            ob.hasBox = true;
            ob.box = b;
            voxels += extractLabels(f, ob)->voxels;
        }
        EXPECT_EQ(voxels, 3u * 64u) << "at most " << most << " boxes";
    }
    o.labels = {5};
    EXPECT_FALSE(selectionBoxes(f, o).isOk() && !selectionBoxes(f, o)->empty()) << "a label no brick holds: no box";
}
