// SPDX-License-Identifier: MIT
#include "csgv/gpu/LabelLookup.h"

#include <algorithm>

namespace csgv::gpu {
namespace {

/// Cuckoo hashing of `labels` (distinct, none kNone) into `capacity` slots with two seeds; false
/// when an insertion keeps evicting (the caller tries other seeds or more slots).
bool placeLabels(const std::vector<uint32_t>& labels, uint32_t capacity, const uint32_t seeds[2],
                 std::vector<uint32_t>& slots) {
    slots.assign(capacity, kNone);
    const uint32_t mask = capacity - 1;
    for (uint32_t label : labels) {
        uint32_t cur = label;
        uint32_t pos = labelSlot(cur, seeds[0], mask);
        for (int kick = 0; kick < 512 && cur != kNone; ++kick) {
            std::swap(cur, slots[pos]); // cur is kNone now, or the label it evicted
            if (cur == kNone) break;
            const uint32_t a = labelSlot(cur, seeds[0], mask), b = labelSlot(cur, seeds[1], mask);
            pos = pos == a ? b : a; // the evicted label goes to its other slot
        }
        if (cur != kNone) return false;
    }
    return true;
}

/// planLabelLookup without the budget.
LabelLookup planTables(const CompressedVolume& vol, bool piece) {
    LabelLookup out;
    const uint32_t L = vol.levels();
    uint32_t largest = 0;
    uint64_t entries = 0;
#pragma omp parallel for reduction(max : largest) reduction(+ : entries) schedule(dynamic, 64)
    for (int64_t b = 0; b < int64_t(vol.brickCount()); ++b) {
        const BrickWords bw = vol.brick(uint64_t(b));
        entries += bw.words[L];
        for (uint32_t k = 0; k < bw.words[L]; ++k) largest = std::max(largest, bw.words[bw.size - 1 - k]);
    }
    out.largest = largest;
    out.kind = kLookupScan;
    if (piece) return out; // other ranks' labels may lie beyond this piece's: a table for its own, the scan for those
    if (largest < kMaterialTableLabels) {
        out.kind = kLookupDense;
        return out;
    }
    if (entries > (uint64_t(1) << 25)) return out;
    std::vector<uint32_t> labels;
    labels.reserve(size_t(entries));
    for (uint64_t b = 0; b < vol.brickCount(); ++b) {
        const BrickWords bw = vol.brick(b);
        for (uint32_t k = 0; k < bw.words[L]; ++k) labels.push_back(bw.words[bw.size - 1 - k]);
    }
    std::sort(labels.begin(), labels.end());
    labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    if (!labels.empty() && labels.back() == kNone) labels.pop_back(); // not a label
    if (labels.size() > kMaterialTableLabels) return out;
    uint32_t capacity = 16;
    while (capacity < 2 * labels.size()) capacity *= 2;
    for (uint32_t attempt = 0; attempt < 32; ++attempt) {
        if (attempt > 0 && attempt % 8 == 0) capacity *= 2;
        out.seeds[0] = 0x9E3779B9u * (2 * attempt + 1);
        out.seeds[1] = 0x85EBCA6Bu * (2 * attempt + 2);
        if (placeLabels(labels, capacity, out.seeds, out.slots)) {
            out.kind = kLookupHashed;
            return out;
        }
    }
    out.slots.clear();
    return out;
}

} // namespace

LabelLookup planLabelLookup(const CompressedVolume& vol, bool piece, uint64_t budgetBytes) {
    LabelLookup out = planTables(vol, piece);
    if (out.kind != kLookupScan && out.tableBytes() + out.colorBytes() > budgetBytes / 64) {
        out.kind = kLookupScan;
        out.slots.clear();
        out.seeds[0] = out.seeds[1] = 0;
    }
    return out;
}

uint32_t LabelLookup::hostMaterial(const std::vector<uint32_t>& t, uint32_t label) const {
    if (label == kNone) return kNone;
    if (kind == kLookupHashed) {
        const uint32_t mask = uint32_t(slots.size()) - 1;
        for (uint32_t seed : seeds) {
            const size_t slot = labelSlot(label, seed, mask);
            if (t[2 * slot] == label) return t[2 * slot + 1];
        }
        return kNone;
    }
    return label < t.size() ? t[label] : kNone;
}

} // namespace csgv::gpu
