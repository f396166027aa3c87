// SPDX-License-Identifier: MIT
// The label -> material lookup the shaders use instead of scanning the material list
// (csgv/gpu/LabelLookup.h): which kind a volume gets, and that large labels are stored as ids
// (their index among the palettes' labels) with a dense table over them.
#include "TestData.h"

#include "csgv/codec/CsgvFile.h"
#include "csgv/gpu/FrameLayout.h"
#include "csgv/gpu/LabelLookup.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

using namespace csgv;
using namespace csgv::gpu;
using namespace csgvtest;

namespace {

std::set<uint32_t> paletteLabels(const CompressedVolume& vol) {
    std::set<uint32_t> labels;
    for (uint64_t b = 0; b < vol.brickCount(); ++b) {
        const BrickWords bw = vol.brick(b);
        for (uint32_t k = 0; k < bw.words[vol.levels()]; ++k) labels.insert(bw.words[bw.size - 1 - k]);
    }
    return labels;
}

/// A label's index in ascending `ids` by a binary search of them all: the reference.
uint32_t idOfLabel(const std::vector<uint32_t>& ids, uint32_t label) {
    const auto it = std::lower_bound(ids.begin(), ids.end(), label);
    return it != ids.end() && *it == label ? uint32_t(it - ids.begin()) : kNone;
}

uint32_t someMaterial(uint32_t label) { return label % 3 == 0 ? kNone : label % 7; }

constexpr uint64_t kBudget = uint64_t(1) << 30;

} // namespace

// The grouped index finds exactly what a binary search of all ids finds: dense labels, labels
// clustered at both ends of the 32-bit range, one id, the largest label there is, and labels
// between, below and above them.
TEST(LabelLookup, TheIdIndexFindsWhatABinarySearchFinds) {
    std::vector<std::vector<uint32_t>> cases;
    std::vector<uint32_t> dense(70000);
    for (uint32_t i = 0; i < dense.size(); ++i) dense[i] = i;
    cases.push_back(dense);
    std::vector<uint32_t> ends;
    for (uint32_t i = 0; i < 3000; ++i) ends.push_back(i * 3);
    for (uint32_t i = 0; i < 3000; ++i) ends.push_back(0xFFFFFFFEu - 3000 * 7 + i * 7);
    cases.push_back(ends);
    cases.push_back({5});
    cases.push_back({0xFFFFFFFEu});
    std::vector<uint32_t> spread;
    uint64_t x = 88172645463325252ull;
    for (int i = 0; i < 50000; ++i) {
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        spread.push_back(uint32_t(x % 0xFFFFFFFFull));
    }
    std::sort(spread.begin(), spread.end());
    spread.erase(std::unique(spread.begin(), spread.end()), spread.end());
    cases.push_back(spread);
    for (const std::vector<uint32_t>& ids : cases) {
        const LabelIdIndex index = LabelIdIndex::build(ids);
        EXPECT_LE(index.start.size(), (size_t(1) << 22) + 2);
        for (uint32_t i = 0; i < ids.size(); ++i) ASSERT_EQ(index.find(ids, ids[i]), i);
        std::vector<uint32_t> probes = {0, 1, 2, 4, 6, kNone, 0xFFFFFFFEu, 0x7FFFFFFFu, 0x80000000u};
        for (uint32_t id : ids) {
            if (probes.size() > 200000) break;
            probes.push_back(id + 1);
            probes.push_back(id - 1);
        }
        for (uint32_t l : probes) ASSERT_EQ(index.find(ids, l), idOfLabel(ids, l)) << "label " << l;
    }
}

TEST(LabelLookup, LargeLabelsAreStoredAsIdsWithADenseTableOverThem) {
    Result<CsgvFile> file = openCsgv(fixture("synthA_b32_rans2.csgv")); // 222 labels up to 4282514378
    ASSERT_TRUE(file.isOk()) << file.message();
    const StoredLabels stored = storedLabels(file->volume, false);
    const std::vector<uint32_t>& ids = stored.ids;
    const std::set<uint32_t> labels = paletteLabels(file->volume);
    ASSERT_EQ(ids, std::vector<uint32_t>(labels.begin(), labels.end())) << "the palettes' labels, ascending";
    for (uint32_t i = 0; i < ids.size(); ++i) EXPECT_EQ(idOfLabel(ids, ids[i]), i);
    for (uint32_t i = 0; i < ids.size(); ++i) EXPECT_EQ(stored.storedOf(ids[i]), i);
    EXPECT_EQ(stored.storedOf(kNone), kNone);
    size_t absent = 0;
    for (uint32_t l = 1; absent < 1000; l += 4099)
        if (!labels.count(l)) {
            ++absent;
            EXPECT_EQ(idOfLabel(ids, l), kNone) << "label " << l;
        }
    EXPECT_EQ(idOfLabel(ids, kNone), kNone);
    EXPECT_EQ(stored.largest, ids.size() - 1) << "the largest id";
    const LabelLookup lookup = planLabelLookup(stored.largest, false, kBudget);
    ASSERT_EQ(lookup.kind, kLookupDense);
    const std::vector<uint32_t> table = lookup.table(someMaterial);
    ASSERT_EQ(table.size(), ids.size());
    for (uint32_t i = 0; i < ids.size(); ++i) EXPECT_EQ(lookup.hostMaterial(table, i), someMaterial(i));
    EXPECT_EQ(lookup.hostMaterial(table, uint32_t(ids.size())), kNone);
    EXPECT_EQ(lookup.hostMaterial(table, kNone), kNone);
    // Under a budget the tables would take more than a 64th of, the scan (the cache comes first),
    // which keeps the table over the ids (its colours are what it saves).
    const uint64_t bytes = lookup.tableBytes() + lookup.colorBytes();
    EXPECT_EQ(bytes, ids.size() * 20);
    EXPECT_EQ(planLabelLookup(stored.largest, false, 64 * bytes).kind, kLookupDense);
    const LabelLookup tight = planLabelLookup(stored.largest, false, 64 * bytes - 64);
    EXPECT_EQ(tight.kind, kLookupScan);
    EXPECT_EQ(tight.entries(), ids.size());
    EXPECT_EQ(tight.colorBytes(), 0u);
    // A piece stores such labels as they are: no table, the scan.
    const StoredLabels piece = storedLabels(file->volume, true);
    EXPECT_TRUE(piece.ids.empty());
    EXPECT_EQ(piece.largest, *labels.rbegin());
    const LabelLookup labelsAsThey = planLabelLookup(piece.largest, true, kBudget);
    EXPECT_EQ(labelsAsThey.kind, kLookupScan);
    EXPECT_EQ(labelsAsThey.entries(), 0u);
}

TEST(LabelLookup, SmallLabelsGetADenseTableAndPiecesKeepTheScanForOtherRanksUnknownLabels) {
    Result<CsgvFile> file = openCsgv(fixture("synthA_b32_rans2_attr.csgv")); // relabelled: dense ids
    ASSERT_TRUE(file.isOk()) << file.message();
    const StoredLabels stored = storedLabels(file->volume, false);
    EXPECT_TRUE(stored.ids.empty()) << "small labels are stored as they are";
    EXPECT_EQ(stored.largest, *paletteLabels(file->volume).rbegin());
    const LabelLookup dense = planLabelLookup(stored.largest, false, kBudget);
    EXPECT_EQ(dense.kind, kLookupDense);
    const std::vector<uint32_t> table = dense.table(someMaterial);
    ASSERT_EQ(table.size(), size_t(dense.largest) + 1);
    EXPECT_EQ(dense.entries(), table.size());
    EXPECT_EQ(dense.tableBytes() + dense.colorBytes(), table.size() * 20);
    for (uint32_t l = 0; l <= dense.largest; ++l) EXPECT_EQ(dense.hostMaterial(table, l), someMaterial(l));
    EXPECT_EQ(dense.hostMaterial(table, dense.largest + 1), kNone);
    // An MPI rank's piece: a dense table for its own labels, the scan for larger ones, unless the
    // largest label of the other ranks' stand-ins and ghost faces is known and small: then one
    // dense table covers both (and the labels' colours).
    EXPECT_EQ(planLabelLookup(stored.largest, true, kBudget).kind, kLookupScan);
    const LabelLookup known = planLabelLookup(stored.largest / 2, true, kBudget, stored.largest);
    EXPECT_EQ(known.kind, kLookupDense);
    EXPECT_EQ(known.largest, stored.largest) << "the table covers the other ranks' labels";
    EXPECT_EQ(known.entries(), size_t(stored.largest) + 1);
    EXPECT_EQ(planLabelLookup(stored.largest, true, kBudget, 3).largest, stored.largest) << "and its own";
    EXPECT_EQ(planLabelLookup(stored.largest, true, kBudget, kMaterialTableLabels).kind, kLookupScan)
        << "other ranks' labels beyond a table";
    EXPECT_EQ(planLabelLookup(stored.largest, true, (known.tableBytes() + known.colorBytes()) * 64 - 64, stored.largest).kind,
              kLookupScan)
        << "a budget the tables would take more than a 64th of";
    Result<CsgvFile> large = openCsgv(fixture("synthA_b32_rans2.csgv"));
    ASSERT_TRUE(large.isOk()) << large.message();
    const LabelLookup piece = planLabelLookup(storedLabels(large->volume, true).largest, true, kBudget);
    EXPECT_EQ(piece.kind, kLookupScan);
    EXPECT_TRUE(piece.table(someMaterial).empty()) << "labels beyond 2^22: no dense table, the scan";
}
