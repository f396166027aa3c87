// SPDX-License-Identifier: MIT
/// @file LabelLookup.h
/// @brief How the shaders find a stored label's material (render_common.glsl's materialOf): a
/// table indexed by the label when labels are small, else a two-slot hash table over the labels
/// the volume's palettes hold. Either replaces the scan of the material list, which CPU devices
/// (lavapipe) would run at every step of a ray: they execute every branch of a loop body.
#ifndef CSGV_GPU_LABEL_LOOKUP_H
#define CSGV_GPU_LABEL_LOOKUP_H

#include "csgv/codec/Container.h"
#include "csgv/gpu/FrameLayout.h"

#include <cstdint>
#include <vector>

namespace csgv::gpu {

/// Tables up to this many labels (4 bytes each dense, 8 a slot hashed, two slots a label or fewer).
constexpr uint32_t kMaterialTableLabels = 1u << 22;

struct LabelLookup {
    uint32_t kind = kLookupScan;    ///< kLookupScan, kLookupDense or kLookupHashed (FrameLayout.h)
    uint32_t largest = 0;           ///< the largest label any palette holds
    /// kLookupHashed: the label in each slot (kNone: empty), a power of two of them, and the two
    /// seeds of labelSlot.
    std::vector<uint32_t> slots;
    uint32_t seeds[2] = {0, 0};
    /// Entries of the table: a slot each hashed, a label each dense (also kLookupScan when the
    /// labels are small), else none.
    uint64_t entries() const {
        if (kind == kLookupHashed) return slots.size();
        return largest < kMaterialTableLabels ? uint64_t(largest) + 1 : 0;
    }
    /// Device bytes of the table (4 a label dense, 8 a slot hashed) and of the labels' colours
    /// (16 an entry, with the dense and hashed kinds only: label_colors.comp).
    uint64_t tableBytes() const { return entries() * (kind == kLookupHashed ? 8 : 4); }
    uint64_t colorBytes() const { return kind == kLookupScan ? 0 : entries() * 16; }
    /// The table's words: `materialOf` of every label (dense) or (label, material) per slot.
    template <class MaterialOf> std::vector<uint32_t> table(const MaterialOf& materialOf) const;
    /// A label's material in a table made by table() (as the shaders find it; kNone for a label
    /// the table does not hold, which the shaders never meet: their hashed lookup reads the
    /// second slot without checking it).
    uint32_t hostMaterial(const std::vector<uint32_t>& t, uint32_t label) const;
};

/// The lookup for a volume's stored labels: dense when the largest label is below
/// kMaterialTableLabels, hashed when the palettes hold at most kMaterialTableLabels distinct
/// labels (and 2^25 palette entries in all: counting them must stay quick), else the scan.
/// `piece`: an MPI rank's piece, whose rays also meet other ranks' labels (stand-ins, ghost
/// faces): the dense table when it covers this piece's labels, the scan for the rest. The
/// tables (with the labels' colours, 16 bytes an entry) may take a 64th of `budgetBytes`, the
/// renderer's device memory: under a tighter budget the brick cache comes first (the scan, with
/// the dense table where labels are small, as for pieces).
LabelLookup planLabelLookup(const CompressedVolume& volume, bool piece, uint64_t budgetBytes);

template <class MaterialOf> std::vector<uint32_t> LabelLookup::table(const MaterialOf& materialOf) const {
    std::vector<uint32_t> t;
    if (kind == kLookupHashed) {
        t.assign(slots.size() * 2, kNone);
#pragma omp parallel for schedule(static, 4096)
        for (int64_t i = 0; i < int64_t(slots.size()); ++i) {
            if (slots[size_t(i)] == kNone) continue;
            t[2 * size_t(i)] = slots[size_t(i)];
            t[2 * size_t(i) + 1] = materialOf(slots[size_t(i)]);
        }
    } else if (entries() > 0) {
        t.resize(size_t(entries()));
#pragma omp parallel for schedule(static, 4096)
        for (int64_t l = 0; l < int64_t(t.size()); ++l) t[size_t(l)] = materialOf(uint32_t(l));
    }
    return t;
}

} // namespace csgv::gpu

#endif
