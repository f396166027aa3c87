// SPDX-License-Identifier: MIT
#pragma once
/// @file Partition.h
/// @brief Whole-brick pieces of a volume for data-parallel work (MPI ranks): the one rule that
/// says which rank owns which brick, for the reader, the renderer and the writer alike.

#include <array>
#include <cstdint>

namespace csgv {

/// A box of bricks [lo, hi) per axis (x, y, z), in brick coordinates.
struct BrickBox {
    std::array<uint32_t, 3> lo{{0, 0, 0}}, hi{{0, 0, 0}};
    bool empty() const { return lo[0] >= hi[0] || lo[1] >= hi[1] || lo[2] >= hi[2]; }
    uint64_t bricks() const {
        return empty() ? 0 : uint64_t(hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
    }
    bool contains(uint32_t x, uint32_t y, uint32_t z) const {
        return x >= lo[0] && x < hi[0] && y >= lo[1] && y < hi[1] && z >= lo[2] && z < hi[2];
    }
    bool operator==(const BrickBox& o) const { return lo == o.lo && hi == o.hi; }
};

/// Piece `piece` of `pieces` of a brick grid: a k-d bisection (the longest axis in bricks, the
/// lowest axis on ties, split in proportion to the pieces on each side), so every brick belongs
/// to exactly one piece, pieces are boxes and their sizes differ by about one slab of bricks.
/// Empty when there are more pieces than bricks along the cuts; the whole grid for one piece.
BrickBox brickPartition(const std::array<uint32_t, 3>& grid, uint32_t pieces, uint32_t piece);

} // namespace csgv
