// SPDX-License-Identifier: MIT
#pragma once
/// @file Relabel.h
/// @brief Turning any integer labels into the format's unsigned 32-bit labels: kept as they are
/// when they fit, or relabelled to dense ids (DESIGN.md "Relabelling"): 0 stays 0, every other
/// label gets 1, 2, ... in order of first appearance, visiting bricks in Morton order of their
/// coordinates and voxels in Morton order inside each brick (Volcanite's order).

#include "csgv/inputs/Inputs.h"
#include "csgv/codec/LabelVolume.h"

#include <cstdint>
#include <vector>

namespace csgv {

/// @brief How ids map back to the input's labels.
struct LabelMapping {
    bool relabelled = false;
    LabelType type = LabelType::U32;   ///< how to read originalBits
    std::vector<uint64_t> originalBits; ///< id -> original value (signed types: int64 bits)
};

/// True when every value is a valid format label (unsigned, below 0xFFFFFFFF).
bool labelsFitFormat(const InputVolume& in);
/// Morton code of brick coordinates (21 bits per axis), for ordering bricks.
uint64_t morton3x21(uint32_t x, uint32_t y, uint32_t z);

/// Converts to format labels, relabelling when the values do not fit or when forced.
Result<LabelVolume> prepareLabels(const InputVolume& in, uint32_t brickSize, bool forceRelabel, LabelMapping& mapping);
/// Dense relabelling of a label volume in place (Volcanite's order); returns id -> label.
std::vector<uint64_t> relabelDense(LabelVolume& volume, uint32_t brickSize);

} // namespace csgv
