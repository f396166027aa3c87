// SPDX-License-Identifier: MIT
/// @file BrickGroups.h
/// @brief Groups of empty bricks that rays step over whole: the renderer (FrameLayout.h's
/// kSlotEmptyGroups) and Core's stable ray caster use the same levels, so they step alike.
#ifndef CSGV_CODEC_BRICK_GROUPS_H
#define CSGV_CODEC_BRICK_GROUPS_H

#include <array>
#include <cstdint>
#include <vector>

namespace csgv {

/// The largest group level kept: aligned groups of up to 2^4 = 16 bricks a side.
constexpr uint32_t kEmptyGroupLevels = 4;

/// For each brick of `grid` (x fastest), the largest g <= kEmptyGroupLevels such that its aligned
/// group of 2^g bricks a side holds only bricks `empty(b)` says are empty (the group's part beyond
/// the grid counts as empty: no ray meets a voxel there); 0 for a brick that is not empty.
template <class Empty> std::vector<uint32_t> emptyGroupLevels(const std::array<uint32_t, 3>& grid, const Empty& empty) {
    // Per level g, its groups (2^g bricks a side; x fastest) and whether all their bricks are empty.
    struct Level {
        std::array<uint32_t, 3> dims;
        std::vector<uint8_t> empty;
        bool at(uint32_t x, uint32_t y, uint32_t z) const { return empty[x + uint64_t(dims[0]) * (y + uint64_t(dims[1]) * z)]; }
    };
    std::vector<Level> levels(1, Level{grid, std::vector<uint8_t>(uint64_t(grid[0]) * grid[1] * grid[2])});
    for (uint64_t b = 0; b < levels[0].empty.size(); ++b) levels[0].empty[b] = empty(b) ? 1 : 0;
    for (uint32_t g = 1; g <= kEmptyGroupLevels; ++g) {
        const Level& below = levels.back();
        const std::array<uint32_t, 3> d = below.dims, up = {(d[0] + 1) / 2, (d[1] + 1) / 2, (d[2] + 1) / 2};
        Level next{up, std::vector<uint8_t>(uint64_t(up[0]) * up[1] * up[2], 1)};
        for (uint32_t z = 0; z < d[2]; ++z)
            for (uint32_t y = 0; y < d[1]; ++y)
                for (uint32_t x = 0; x < d[0]; ++x)
                    if (!below.at(x, y, z)) next.empty[x / 2 + uint64_t(up[0]) * (y / 2 + uint64_t(up[1]) * (z / 2))] = 0;
        levels.push_back(std::move(next));
    }
    std::vector<uint32_t> out(levels[0].empty.size(), 0);
    for (uint32_t z = 0; z < grid[2]; ++z)
        for (uint32_t y = 0; y < grid[1]; ++y)
            for (uint32_t x = 0; x < grid[0]; ++x) {
                uint32_t g = 0; // a group empty at g + 1 holds groups empty at g
                while (levels[0].at(x, y, z) && g < kEmptyGroupLevels && levels[g + 1].at(x >> (g + 1), y >> (g + 1), z >> (g + 1))) ++g;
                out[x + uint64_t(grid[0]) * (y + uint64_t(grid[1]) * z)] = g;
            }
    return out;
}

} // namespace csgv

#endif
