// SPDX-License-Identifier: MIT
#include "csgv/gpu/LabelLookup.h"

#include <algorithm>

namespace csgv::gpu {

StoredLabels storedLabels(const PaletteSummary& palettes, bool piece) {
    StoredLabels out;
    out.largest = palettes.largest;
    // Ids only where a dense table of the labels themselves would be too large, and not for an
    // MPI rank's piece (whose rays meet other ranks' labels).
    if (piece || palettes.largest < kMaterialTableLabels || palettes.entries > (uint64_t(1) << 25) || !palettes.labelsComplete)
        return out;
    std::vector<uint32_t> labels = palettes.labels;
    if (!labels.empty() && labels.back() == kNone) labels.pop_back(); // not a label
    if (labels.empty() || labels.size() > kMaterialTableLabels) return out;
    out.largest = uint32_t(labels.size() - 1);
    out.ids = std::move(labels);
    out.index = LabelIdIndex::build(out.ids);
    return out;
}

StoredLabels storedLabels(const CompressedVolume& vol, bool piece) {
    return storedLabels(summarizePalettes(vol, kMaterialTableLabels), piece);
}

LabelIdIndex LabelIdIndex::build(const std::vector<uint32_t>& ids) {
    LabelIdIndex x;
    if (ids.empty()) return x;
    auto width = [](uint64_t v) { uint32_t w = 0; while (v >> w) ++w; return w; };
    // About one id a group: groups = the ids' count rounded up to a power of two, over the
    // labels' bits (at most 2^22 groups, 16 MiB, for the most ids a table takes).
    const uint32_t groupBits = std::min<uint32_t>(std::max<uint32_t>(width(ids.size()), 1), 22);
    const uint32_t labelBits = width(ids.back());
    x.shift = labelBits > groupBits ? labelBits - groupBits : 0;
    const size_t groups = size_t(ids.back() >> x.shift) + 2; // the last one ends the ids
    x.start.assign(groups, uint32_t(ids.size()));
    size_t i = 0;
    for (size_t k = 0; k < groups; ++k) {
        while (i < ids.size() && (ids[i] >> x.shift) < k) ++i;
        x.start[k] = uint32_t(i);
    }
    return x;
}

uint32_t LabelIdIndex::find(const std::vector<uint32_t>& ids, uint32_t label) const {
    const size_t k = label >> shift;
    if (k + 1 >= start.size()) return kNone;
    const auto first = ids.begin() + start[k], last = ids.begin() + start[k + 1];
    const auto it = std::lower_bound(first, last, label);
    return it != last && *it == label ? uint32_t(it - ids.begin()) : kNone;
}


LabelLookup planLabelLookup(uint32_t largestStored, bool piece, uint64_t budgetBytes, uint32_t largestOther) {
    LabelLookup out;
    out.largest = largestStored;
    // A piece's rays meet other ranks' labels too: its table covers them where they are known and
    // small, else the scan takes those beyond its table.
    const bool othersCovered = !piece || largestOther < kMaterialTableLabels;
    if (piece && othersCovered) out.largest = std::max(largestStored, largestOther);
    out.kind = othersCovered && out.largest < kMaterialTableLabels ? kLookupDense : kLookupScan;
    if (out.kind != kLookupScan && out.tableBytes() + out.colorBytes() > budgetBytes / 64) out.kind = kLookupScan;
    return out;
}

uint32_t LabelLookup::hostMaterial(const std::vector<uint32_t>& t, uint32_t stored) const {
    return stored < t.size() ? t[stored] : kNone;
}

} // namespace csgv::gpu
