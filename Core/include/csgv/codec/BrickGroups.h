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
    const uint64_t n = uint64_t(grid[0]) * grid[1] * grid[2];
    std::vector<uint32_t> level(n, 0);
    // flags[g]: per group of level g (2^g bricks a side), whether all its bricks are empty.
    std::vector<uint8_t> flags(n);
    for (uint64_t b = 0; b < n; ++b) flags[b] = empty(b) ? 1 : 0;
    std::array<uint32_t, 3> dims = grid;
    std::vector<std::vector<uint8_t>> byLevel{flags};
    for (uint32_t g = 1; g <= kEmptyGroupLevels; ++g) {
        const std::array<uint32_t, 3> up = {(dims[0] + 1) / 2, (dims[1] + 1) / 2, (dims[2] + 1) / 2};
        std::vector<uint8_t> next(uint64_t(up[0]) * up[1] * up[2], 1);
        const std::vector<uint8_t>& below = byLevel.back();
        for (uint32_t z = 0; z < dims[2]; ++z)
            for (uint32_t y = 0; y < dims[1]; ++y)
                for (uint32_t x = 0; x < dims[0]; ++x)
                    if (!below[x + uint64_t(dims[0]) * (y + uint64_t(dims[1]) * z)])
                        next[x / 2 + uint64_t(up[0]) * (y / 2 + uint64_t(up[1]) * (z / 2))] = 0;
        byLevel.push_back(std::move(next));
        dims = up;
    }
    for (uint32_t z = 0; z < grid[2]; ++z)
        for (uint32_t y = 0; y < grid[1]; ++y)
            for (uint32_t x = 0; x < grid[0]; ++x) {
                const uint64_t b = x + uint64_t(grid[0]) * (y + uint64_t(grid[1]) * z);
                if (!flags[b]) continue;
                std::array<uint32_t, 3> d = grid;
                uint32_t g = 0;
                while (g < kEmptyGroupLevels) {
                    const std::array<uint32_t, 3> up = {(d[0] + 1) / 2, (d[1] + 1) / 2, (d[2] + 1) / 2};
                    const uint32_t s = g + 1;
                    if (!byLevel[s][(x >> s) + uint64_t(up[0]) * ((y >> s) + uint64_t(up[1]) * (z >> s))]) break;
                    d = up;
                    g = s;
                }
                level[b] = g;
            }
    return level;
}

} // namespace csgv

#endif
