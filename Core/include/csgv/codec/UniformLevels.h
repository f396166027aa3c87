// SPDX-License-Identifier: MIT
/// @file UniformLevels.h
/// @brief The uniform level of every voxel of a brick (Layout.h kUniformLevelShift): the largest
/// aligned cube around it that lies inside the volume and holds one label. The renderer's host
/// decoding writes them into its cache, shaders/cache_uniform.comp computes the same after GPU
/// decoding, and Core's stable ray caster (castRaysStable) steps over the same cubes.
#ifndef CSGV_CODEC_UNIFORM_LEVELS_H
#define CSGV_CODEC_UNIFORM_LEVELS_H

#include "csgv/codec/Layout.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

namespace csgv {

/// For a brick's finest labels in Morton order (edge 2^shift, so 8^shift of them; its lowest voxel
/// `origin` in a volume of `dim` voxels), the uniform level of its entries: the largest k <= shift
/// such that the aligned cube of 2^k voxels holding an entry (a run of 8^k consecutive entries)
/// lies wholly inside the volume and holds one label; 0 when none does. The eight entries of a run
/// of eight (a cube of 2^1) share their level: `out` takes one a run, 8^shift / 8 bytes.
inline void uniformLevels(const uint32_t* labels, uint32_t shift, const std::array<uint32_t, 3>& origin,
                          const std::array<uint32_t, 3>& dim, uint8_t* out) {
    const uint64_t runs = (uint64_t(1) << (3 * shift)) / 8;
    // A brick wholly inside the volume (the rule) needs no cube tested for it.
    const uint32_t edge = 1u << shift;
    const bool whole = origin[0] + edge <= dim[0] && origin[1] + edge <= dim[1] && origin[2] + edge <= dim[2];
    auto inside = [&](uint64_t cube, uint32_t k) {
        return whole || uniformSubBlockInside(uint32_t(cube), k, origin[0], origin[1], origin[2], dim[0], dim[1], dim[2]);
    };
    // Level by level, out[r] holds the largest uniform cube that begins with run r: a cube is
    // uniform when it lies inside and its eight octants are, with one label.
    for (uint64_t r = 0; r < runs; ++r) { // level 1: the run's eight labels (no branch a label)
        const uint32_t* l = labels + 8 * r;
        uint32_t differ = 0;
        for (uint32_t c = 1; c < 8; ++c) differ |= l[c] ^ l[0];
        out[r] = differ == 0 && inside(r, 1) ? 1 : 0;
    }
    for (uint32_t k = 2; k <= shift; ++k) {
        const uint64_t cube = uint64_t(1) << (3 * (k - 1)); // runs a cube of level k holds
        const uint64_t part = cube / 8;                     // ... and each of its octants
        for (uint64_t r = 0; r < runs; r += cube) {
            bool same = inside(r >> (3 * (k - 1)), k);
            for (uint64_t c = 0; c < 8 && same; ++c) same = out[r + c * part] >= k - 1 && labels[8 * (r + c * part)] == labels[8 * r];
            if (same) out[r] = uint8_t(k);
        }
    }
    // Each run: the largest k whose cube, beginning at the run's index with its low 3(k - 1) bits
    // cleared, is uniform; the cubes around a run are uniform up to a level and no further (a cube
    // inside a uniform one is uniform). Overwriting a run's entry with its level keeps the test true
    // for the runs after it, for the same reason.
    for (uint64_t r = 0; r < runs; ++r) {
        uint32_t k = 1;
        while (k <= shift && out[r & ~((uint64_t(1) << (3 * (k - 1))) - 1)] >= k) ++k;
        out[r] = uint8_t(k - 1);
    }
}

/// The same for brick `brick` (x fastest) of a volume of `dim` voxels in bricks of 2^shift a side.
inline void uniformLevelsOfBrick(const uint32_t* labels, uint32_t shift, uint64_t brick, const std::array<uint32_t, 3>& dim,
                                 uint8_t* out) {
    const uint32_t edge = 1u << shift;
    const uint64_t gx = (dim[0] + edge - 1) / edge, gy = (dim[1] + edge - 1) / edge;
    const std::array<uint32_t, 3> origin = {uint32_t(brick % gx) << shift, uint32_t(brick / gx % gy) << shift,
                                            uint32_t(brick / (gx * gy)) << shift};
    uniformLevels(labels, shift, origin, dim, out);
}

/// For a grid of labels (x fastest, `dim` nodes a side), the uniform level of every node: the
/// largest k <= maxLevel such that the aligned cube of 2^k nodes holding it lies inside the grid
/// and holds one label; 0 when none does. An MPI piece's coarse stand-ins carry them, so rays step
/// over other ranks' uniform regions as over the rank's own (Renderer::setCoarseStandIns).
inline std::vector<uint8_t> gridUniformLevels(const std::vector<uint32_t>& labels, const std::array<uint32_t, 3>& dim,
                                              uint32_t maxLevel) {
    const uint64_t nx = dim[0], nxy = uint64_t(dim[0]) * dim[1];
    std::vector<uint8_t> begins(labels.size(), 0); // at a cube's lowest node: the largest uniform cube it begins
    for (uint32_t k = 1; k <= maxLevel; ++k) {
        const uint32_t step = 1u << k, half = step >> 1;
        for (uint64_t z = 0; z + step <= dim[2]; z += step)
            for (uint64_t y = 0; y + step <= dim[1]; y += step)
                for (uint64_t x = 0; x + step <= dim[0]; x += step) {
                    const uint64_t o = x + nx * y + nxy * z;
                    bool same = true;
                    for (uint32_t c = 0; c < 8 && same; ++c) {
                        const uint64_t i = o + ((c & 1) ? half : 0) + ((c & 2) ? nx * half : 0) + ((c & 4) ? nxy * half : 0);
                        same = begins[i] >= k - 1 && labels[i] == labels[o];
                    }
                    if (same) begins[o] = uint8_t(k);
                }
    }
    std::vector<uint8_t> out(labels.size(), 0);
    for (uint64_t z = 0; z < dim[2]; ++z)
        for (uint64_t y = 0; y < dim[1]; ++y)
            for (uint64_t x = 0; x < dim[0]; ++x) {
                uint32_t k = 0;
                while (k < maxLevel) {
                    const uint64_t m = ~((uint64_t(1) << (k + 1)) - 1);
                    if (begins[(x & m) + nx * (y & m) + nxy * (z & m)] < k + 1) break;
                    ++k;
                }
                out[x + nx * y + nxy * z] = uint8_t(k);
            }
    return out;
}

} // namespace csgv

#endif
