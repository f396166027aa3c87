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
    return out;
}

StoredLabels storedLabels(const CompressedVolume& vol, bool piece) {
    return storedLabels(summarizePalettes(vol, kMaterialTableLabels), piece);
}

uint32_t idOfLabel(const std::vector<uint32_t>& ids, uint32_t label) {
    const auto it = std::lower_bound(ids.begin(), ids.end(), label);
    return it != ids.end() && *it == label ? uint32_t(it - ids.begin()) : kNone;
}

LabelLookup planLabelLookup(uint32_t largestStored, bool piece, uint64_t budgetBytes) {
    LabelLookup out;
    out.largest = largestStored;
    // A piece's rays meet other ranks' labels too (the scan takes those beyond its table).
    out.kind = !piece && out.largest < kMaterialTableLabels ? kLookupDense : kLookupScan;
    if (out.kind != kLookupScan && out.tableBytes() + out.colorBytes() > budgetBytes / 64) out.kind = kLookupScan;
    return out;
}

uint32_t LabelLookup::hostMaterial(const std::vector<uint32_t>& t, uint32_t stored) const {
    return stored < t.size() ? t[stored] : kNone;
}

} // namespace csgv::gpu
