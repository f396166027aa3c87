// SPDX-License-Identifier: MIT
#include "csgv/inputs/Relabel.h"
#include "csgv/base/Morton.h"

#include <algorithm>
#include <unordered_map>

namespace csgv {

namespace {

uint64_t spread21(uint64_t v) {
    v &= 0x1FFFFF;
    v = (v | v << 32) & 0x1F00000000FFFFull;
    v = (v | v << 16) & 0x1F0000FF0000FFull;
    v = (v | v << 8) & 0x100F00F00F00F00Full;
    v = (v | v << 4) & 0x10C30C30C30C30C3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
}

/// Visits every voxel in relabelling order: bricks in Morton order of (bx, by, bz), voxels in
/// Morton order inside a brick; fn(linearIndex).
template <typename Fn>
void forEachInMortonBrickOrder(const std::array<uint32_t, 3>& dim, uint32_t B, Fn fn) {
    std::array<uint32_t, 3> grid{};
    for (int a = 0; a < 3; ++a) grid[a] = (dim[a] - 1) / B + 1;
    std::vector<std::pair<uint64_t, std::array<uint32_t, 3>>> bricks;
    bricks.reserve(size_t(uint64_t(grid[0]) * grid[1] * grid[2]));
    for (uint32_t z = 0; z < grid[2]; ++z)
        for (uint32_t y = 0; y < grid[1]; ++y)
            for (uint32_t x = 0; x < grid[0]; ++x) bricks.push_back({morton3x21(x, y, z), {x, y, z}});
    std::sort(bricks.begin(), bricks.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    const uint32_t n = B * B * B;
    for (const auto& br : bricks) {
        const uint32_t ox = br.second[0] * B, oy = br.second[1] * B, oz = br.second[2] * B;
        const bool inside = ox + B <= dim[0] && oy + B <= dim[1] && oz + B <= dim[2];
        for (uint32_t m = 0; m < n; ++m) {
            const uint32_t x = ox + mortonX(m), y = oy + mortonY(m), z = oz + mortonZ(m);
            if (!inside && (x >= dim[0] || y >= dim[1] || z >= dim[2])) continue;
            fn(x + uint64_t(dim[0]) * (y + uint64_t(dim[1]) * z));
        }
    }
}

} // namespace

uint64_t morton3x21(uint32_t x, uint32_t y, uint32_t z) { return spread21(x) | spread21(y) << 1 | spread21(z) << 2; }

bool labelsFitFormat(const InputVolume& in) {
    const bool isSigned = isSignedType(in.type);
    for (uint64_t v : in.values)
        if ((isSigned && int64_t(v) < 0) || v >= 0xFFFFFFFFull) return false;
    return true;
}

Result<LabelVolume> prepareLabels(const InputVolume& in, uint32_t brickSize, bool forceRelabel, LabelMapping& mapping) {
    if (in.values.size() != in.voxelCount())
        return Status::error("input volume holds " + std::to_string(in.values.size()) + " values, expected " +
                             std::to_string(in.voxelCount()));
    if (brickSize < 8 || brickSize > 128 || (brickSize & (brickSize - 1)))
        return Status::error("brick size " + std::to_string(brickSize) + " is not a power of two from 8 to 128");
    mapping = LabelMapping{};
    mapping.type = in.type;
    LabelVolume out;
    out.dim = in.dim;
    out.labels.resize(in.values.size());
    if (!forceRelabel && labelsFitFormat(in)) {
        for (size_t i = 0; i < in.values.size(); ++i) out.labels[i] = uint32_t(in.values[i]);
        return out;
    }
    mapping.relabelled = true;
    mapping.originalBits.push_back(0); // 0 stays 0
    std::unordered_map<uint64_t, uint32_t> ids;
    ids.emplace(0, 0);
    uint64_t lastValue = 0;
    uint32_t lastId = 0;
    bool overflow = false;
    forEachInMortonBrickOrder(in.dim, brickSize, [&](uint64_t i) {
        const uint64_t v = in.values[size_t(i)];
        if (v != lastValue) {
            auto it = ids.find(v);
            if (it == ids.end()) {
                if (mapping.originalBits.size() >= 0xFFFFFFFFull) overflow = true;
                it = ids.emplace(v, uint32_t(mapping.originalBits.size())).first;
                mapping.originalBits.push_back(v);
            }
            lastValue = v;
            lastId = it->second;
        }
        out.labels[size_t(i)] = lastId;
    });
    if (overflow) return Status::error("the volume has more than 2^32 - 1 distinct labels");
    return out;
}

std::vector<uint64_t> relabelDense(LabelVolume& volume, uint32_t brickSize) {
    InputVolume in;
    in.dim = volume.dim;
    in.values.assign(volume.labels.begin(), volume.labels.end());
    LabelMapping m;
    Result<LabelVolume> r = prepareLabels(in, brickSize, true, m);
    volume = std::move(*r);
    return m.originalBits;
}

} // namespace csgv
