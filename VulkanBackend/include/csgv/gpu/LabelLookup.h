// SPDX-License-Identifier: MIT
/// @file LabelLookup.h
/// @brief How the shaders find a stored label's material (render_common.glsl's materialOf): a
/// table indexed by the stored label, which covers every one when labels are small or the
/// volume's labels are stored as ids (their index among the palettes' labels: labelIds), else
/// the labels below the table's end. It replaces the scan of the material list, which CPU devices
/// (lavapipe) would run at every step of a ray: they execute every branch of a loop body.
#ifndef CSGV_GPU_LABEL_LOOKUP_H
#define CSGV_GPU_LABEL_LOOKUP_H

#include "csgv/codec/Container.h"
#include "csgv/codec/Palettes.h"
#include "csgv/gpu/FrameLayout.h"

#include <cstdint>
#include <vector>

namespace csgv::gpu {

/// Tables up to this many labels (4 bytes each, and 16 for its colour).
constexpr uint32_t kMaterialTableLabels = kSummaryLabels; // a palette summary lists as many (Palettes.h)

/// Finds a label's id in a few reads: the ids grouped by their label's high bits (`start[k]`: the
/// first id whose label >> shift is k or more), about one id a group, then a binary search in its
/// group. A binary search of all ids took 20-odd reads scattered over megabytes: relabelling the
/// palettes of a 2048^3 volume for the device (5 million entries, 523,847 labels) took 1.3 s.
struct LabelIdIndex {
    uint32_t shift = 0;
    std::vector<uint32_t> start;
    static LabelIdIndex build(const std::vector<uint32_t>& ids);
    /// The label's index in `ids` (the vector build() was given), kNone when it does not hold it.
    uint32_t find(const std::vector<uint32_t>& ids, uint32_t label) const;
};

/// The labels as the shaders see them (stored labels). `ids`: the labels of the volume's palettes,
/// ascending, when one of them is kMaterialTableLabels or larger, they are at most
/// kMaterialTableLabels distinct labels (and 2^25 palette entries in all: counting them must stay
/// quick) and the volume is no MPI rank's piece (whose rays meet other ranks' labels); else none
/// (empty). A label is then stored as its index in `ids` (its id): in the device's palettes and
/// the brick cache (GpuVolume), so a ray step finds its material in one read of a dense table
/// where a hash table would take two (and the cache's runs of one label are unchanged). The
/// renderer maps ids back for its outputs. `largest`: the largest stored label (an id with ids).
struct StoredLabels {
    uint32_t largest = 0;
    std::vector<uint32_t> ids;
    LabelIdIndex index; ///< over ids
    /// A label as stored: its id with ids (kNone for a label they do not hold), else itself.
    uint32_t storedOf(uint32_t label) const { return ids.empty() ? label : index.find(ids, label); }
};
StoredLabels storedLabels(const CompressedVolume& volume, bool piece);
/// The same from the volume's palette summary (summarizePalettes with a cap of at least
/// kMaterialTableLabels).
StoredLabels storedLabels(const PaletteSummary& palettes, bool piece);


struct LabelLookup {
    uint32_t kind = kLookupScan; ///< kLookupScan or kLookupDense (FrameLayout.h)
    uint32_t largest = 0;        ///< the largest stored label (StoredLabels::largest)
    /// Entries of the table: a stored label each up to the largest, when below
    /// kMaterialTableLabels (also with kLookupScan), else none.
    uint64_t entries() const { return largest < kMaterialTableLabels ? uint64_t(largest) + 1 : 0; }
    /// Device bytes of the table (4 an entry) and of the labels' colours (16 an entry, with the
    /// dense kind only: label_colors.comp).
    uint64_t tableBytes() const { return entries() * 4; }
    uint64_t colorBytes() const { return kind == kLookupScan ? 0 : entries() * 16; }
    /// The table's words: `materialOf` of every stored label up to the largest.
    template <class MaterialOf> std::vector<uint32_t> table(const MaterialOf& materialOf) const;
    /// A stored label's material in a table made by table() (kNone beyond it, and for kNone).
    uint32_t hostMaterial(const std::vector<uint32_t>& t, uint32_t stored) const;
};

/// The lookup for a volume's stored labels up to `largestStored` (StoredLabels::largest): dense
/// when it is below kMaterialTableLabels, else the scan. `piece`: an MPI rank's piece, whose rays
/// also meet other ranks' labels (stand-ins, ghost faces), the largest of which is
/// `largestOther` (kNone: not known): dense when both are below kMaterialTableLabels (its table
/// then covers both), else the table where it covers this piece's labels, the scan for the rest.
/// The tables (with the labels' colours, 16 bytes an entry) may
/// take a 64th of `budgetBytes`, the renderer's device memory: under a tighter budget the brick
/// cache comes first (the scan, with the table where labels are small).
LabelLookup planLabelLookup(uint32_t largestStored, bool piece, uint64_t budgetBytes, uint32_t largestOther = kNone);

template <class MaterialOf> std::vector<uint32_t> LabelLookup::table(const MaterialOf& materialOf) const {
    std::vector<uint32_t> t(static_cast<size_t>(entries()));
#pragma omp parallel for schedule(static, 4096)
    for (int64_t l = 0; l < int64_t(t.size()); ++l) t[size_t(l)] = materialOf(uint32_t(l));
    return t;
}

} // namespace csgv::gpu

#endif
