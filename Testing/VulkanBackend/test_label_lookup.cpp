// SPDX-License-Identifier: MIT
// The label -> material lookup the shaders use instead of scanning the material list
// (csgv/gpu/LabelLookup.h): which kind a volume gets, and that the hashed table finds every label
// the palettes hold (in one of its two slots, as render_common.glsl's materialOf reads them) and
// no other.
#include "TestData.h"

#include "csgv/codec/CsgvFile.h"
#include "csgv/gpu/FrameLayout.h"
#include "csgv/gpu/LabelLookup.h"

#include <gtest/gtest.h>

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

uint32_t someMaterial(uint32_t label) { return label % 3 == 0 ? kNone : label % 7; }

constexpr uint64_t kBudget = uint64_t(1) << 30;

} // namespace

TEST(LabelLookup, LargeLabelsAreHashedAndEveryPaletteLabelIsFoundInOneOfItsTwoSlots) {
    Result<CsgvFile> file = openCsgv(fixture("synthA_b32_rans2.csgv")); // 222 labels up to 4282514378
    ASSERT_TRUE(file.isOk()) << file.message();
    const LabelLookup lookup = planLabelLookup(file->volume, false, kBudget);
    ASSERT_EQ(lookup.kind, kLookupHashed);
    const std::set<uint32_t> labels = paletteLabels(file->volume);
    EXPECT_EQ(lookup.largest, *labels.rbegin());
    ASSERT_GE(lookup.slots.size(), 2 * labels.size());
    EXPECT_EQ(lookup.slots.size() & (lookup.slots.size() - 1), 0u) << "a power of two";
    const std::vector<uint32_t> table = lookup.table(someMaterial);
    ASSERT_EQ(table.size(), 2 * lookup.slots.size());
    const uint32_t mask = uint32_t(lookup.slots.size()) - 1;
    size_t stored = 0;
    for (uint32_t l : lookup.slots) stored += l != kNone;
    EXPECT_EQ(stored, labels.size()) << "each label once";
    for (uint32_t l : labels) {
        const uint32_t a = labelSlot(l, lookup.seeds[0], mask), b = labelSlot(l, lookup.seeds[1], mask);
        EXPECT_TRUE(table[2 * a] == l || table[2 * b] == l) << "label " << l;
        EXPECT_EQ(lookup.hostMaterial(table, l), someMaterial(l)) << "label " << l;
    }
    // Labels no palette holds have no material, nor has kNone.
    size_t absent = 0;
    for (uint32_t l = 1; absent < 1000; l += 4099)
        if (!labels.count(l)) {
            ++absent;
            EXPECT_EQ(lookup.hostMaterial(table, l), kNone) << "label " << l;
        }
    EXPECT_EQ(lookup.hostMaterial(table, kNone), kNone);
    // Under a budget the tables would take more than a 64th of, the scan (the cache comes first).
    const uint64_t bytes = lookup.tableBytes() + lookup.colorBytes();
    EXPECT_EQ(lookup.entries(), lookup.slots.size());
    EXPECT_EQ(bytes, lookup.slots.size() * 24);
    EXPECT_EQ(planLabelLookup(file->volume, false, 64 * bytes).kind, kLookupHashed);
    const LabelLookup tight = planLabelLookup(file->volume, false, 64 * bytes - 64);
    EXPECT_EQ(tight.kind, kLookupScan);
    EXPECT_TRUE(tight.slots.empty());
}

TEST(LabelLookup, SmallLabelsGetADenseTableAndPiecesKeepTheScanForOtherRanksLabels) {
    Result<CsgvFile> file = openCsgv(fixture("synthA_b32_rans2_attr.csgv")); // relabelled: dense ids
    ASSERT_TRUE(file.isOk()) << file.message();
    const LabelLookup dense = planLabelLookup(file->volume, false, kBudget);
    EXPECT_EQ(dense.kind, kLookupDense);
    EXPECT_TRUE(dense.slots.empty());
    const std::vector<uint32_t> table = dense.table(someMaterial);
    ASSERT_EQ(table.size(), size_t(dense.largest) + 1);
    EXPECT_EQ(dense.entries(), table.size());
    EXPECT_EQ(dense.tableBytes() + dense.colorBytes(), table.size() * 20);
    for (uint32_t l = 0; l <= dense.largest; ++l) EXPECT_EQ(dense.hostMaterial(table, l), someMaterial(l));
    EXPECT_EQ(dense.hostMaterial(table, dense.largest + 1), kNone);
    // An MPI rank's piece: a dense table for its own labels, the scan for larger ones.
    EXPECT_EQ(planLabelLookup(file->volume, true, kBudget).kind, kLookupScan);
    Result<CsgvFile> large = openCsgv(fixture("synthA_b32_rans2.csgv"));
    ASSERT_TRUE(large.isOk()) << large.message();
    const LabelLookup piece = planLabelLookup(large->volume, true, kBudget);
    EXPECT_EQ(piece.kind, kLookupScan);
    EXPECT_TRUE(piece.table(someMaterial).empty()) << "labels beyond 2^22: no dense table, the scan";
}
