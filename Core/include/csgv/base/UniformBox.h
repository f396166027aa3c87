// SPDX-License-Identifier: MIT
#pragma once
/// @file UniformBox.h
/// @brief A box of voxels that a source knows, before reading any of them, to hold one value: an
/// HDF5 chunk never written is its fill value. The one currency of the constant-region path:
/// InputSource::uniformBoxes lists them with full-width values, LabelSlabAdapter turns the values
/// into format labels (SlabSource::uniformBoxes), and the encoder writes every brick they cover
/// as a constant brick without reading or scanning its voxels (Encoder.h).

#include <array>
#include <cstdint>

namespace csgv {

/// @brief Voxels [lo, hi) (x, y, z) all holding `value`. Boxes a source lists together are
/// disjoint and lie inside the region asked about.
struct UniformBox {
    std::array<uint32_t, 3> lo{{0, 0, 0}}, hi{{0, 0, 0}};
    /// InputSource: the full-width value readRows gives there; SlabSource: the format label.
    uint64_t value = 0;

    uint64_t voxels() const {
        uint64_t n = 1;
        for (int a = 0; a < 3; ++a) n *= hi[a] > lo[a] ? uint64_t(hi[a] - lo[a]) : 0;
        return n;
    }
};

} // namespace csgv
