// SPDX-License-Identifier: MIT
#include "csgv/reference/RayCast.h"
#include "csgv/codec/BrickGroups.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/Layout.h"
#include "csgv/codec/UniformLevels.h"
#include "csgv/base/Morton.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace csgv {

namespace {

Face entryFace(int axis, double direction) {
    // Moving along +axis, a ray enters a voxel through its face with outward normal -axis.
    return Face(1 + 2 * axis + (direction > 0 ? 0 : 1));
}

} // namespace

GBuffer castRays(const LabelVolume& volume, const Geometry& g, const RayCastView& view,
                 const std::function<bool(uint32_t)>& visible) {
    GBuffer out;
    out.width = view.width;
    out.height = view.height;
    const size_t n = size_t(view.width) * view.height;
    out.label.assign(n, kInvalidLabel);
    out.depth.assign(n, 1.0f);
    out.face.assign(n, Face::None);
    Mat4 clipToWorld{};
    if (!invert(view.worldToClip, clipToWorld)) return out;
    const Mat4 indexToWorld = indexToWorldMatrix(g);
    Mat4 worldToIndex{};
    if (!invert(indexToWorld, worldToIndex)) return out;
    const double dim[3] = {double(volume.dim[0]), double(volume.dim[1]), double(volume.dim[2])};
    const double inf = std::numeric_limits<double>::infinity();

    for (uint32_t py = 0; py < view.height; ++py)
        for (uint32_t px = 0; px < view.width; ++px) {
            const double nx = (px + 0.5) / view.width * 2 - 1, ny = (py + 0.5) / view.height * 2 - 1;
            std::array<double, 4> nearW = transform(clipToWorld, {nx, ny, -1, 1});
            std::array<double, 4> farW = transform(clipToWorld, {nx, ny, 1, 1});
            if (nearW[3] == 0 || farW[3] == 0) continue;
            for (int k = 0; k < 3; ++k) {
                nearW[k] /= nearW[3];
                farW[k] /= farW[3];
            }
            nearW[3] = farW[3] = 1;
            const std::array<double, 4> a4 = transform(worldToIndex, nearW), b4 = transform(worldToIndex, farW);
            const double a[3] = {a4[0], a4[1], a4[2]};
            const double d[3] = {b4[0] - a4[0], b4[1] - a4[1], b4[2] - a4[2]};
            // Clip the segment t in [0, 1] to the volume's box [0, dim].
            double t0 = 0, t1 = 1;
            int entryAxis = -1;
            bool miss = false;
            for (int k = 0; k < 3 && !miss; ++k) {
                if (d[k] == 0) {
                    miss = a[k] < 0 || a[k] > dim[k];
                    continue;
                }
                const double ta = (0 - a[k]) / d[k], tb = (dim[k] - a[k]) / d[k];
                const double lo = std::min(ta, tb), hi = std::max(ta, tb);
                if (lo > t0) {
                    t0 = lo;
                    entryAxis = k;
                }
                t1 = std::min(t1, hi);
            }
            if (miss || t0 > t1) continue;
            int v[3], step[3];
            double tMax[3], tDelta[3];
            for (int k = 0; k < 3; ++k) {
                const double p = a[k] + t0 * d[k];
                v[k] = int(std::clamp(std::floor(p), 0.0, dim[k] - 1));
                if (k == entryAxis) v[k] = d[k] > 0 ? 0 : int(dim[k]) - 1; // exact on the entry face
                step[k] = d[k] > 0 ? 1 : (d[k] < 0 ? -1 : 0);
                tDelta[k] = d[k] != 0 ? std::fabs(1.0 / d[k]) : inf;
                tMax[k] = d[k] > 0 ? (v[k] + 1 - a[k]) / d[k] : (d[k] < 0 ? (v[k] - a[k]) / d[k] : inf);
            }
            double tEnter = t0;
            Face face = entryAxis >= 0 ? entryFace(entryAxis, d[entryAxis]) : Face::None;
            for (;;) {
                const uint32_t label = volume.at(uint32_t(v[0]), uint32_t(v[1]), uint32_t(v[2]));
                if (visible(label)) {
                    const size_t i = size_t(py) * view.width + px;
                    out.label[i] = label;
                    out.face[i] = face;
                    const std::array<double, 4> hit = {nearW[0] + tEnter * (farW[0] - nearW[0]),
                                                       nearW[1] + tEnter * (farW[1] - nearW[1]),
                                                       nearW[2] + tEnter * (farW[2] - nearW[2]), 1};
                    const std::array<double, 4> clip = transform(view.worldToClip, hit);
                    out.depth[i] = float(std::clamp(clip[2] / clip[3] * 0.5 + 0.5, 0.0, 1.0));
                    break;
                }
                int k = 0; // the axis whose boundary comes first (lowest axis on ties)
                if (tMax[1] < tMax[k]) k = 1;
                if (tMax[2] < tMax[k]) k = 2;
                if (tMax[k] > t1) break;
                tEnter = tMax[k];
                v[k] += step[k];
                if (v[k] < 0 || v[k] >= int(dim[k])) break;
                face = entryFace(k, d[k]);
                tMax[k] += tDelta[k];
            }
        }
    return out;
}

namespace {

constexpr float kOneMinusEpsilon = 0.99999994f;
constexpr float kNever = 3.0e38f;

/// The walker of render_common.glsl.
struct Walker {
    int voxel[3];
    float vpos[3];
    float t;
    int face;
    float d[3], invD[3];
    float tEnd;
};

float clamp01(float v) { return std::min(std::max(v, 0.0f), kOneMinusEpsilon); }

/// stableStep() of render_common.glsl.
void stableStep(Walker& w, int k) {
    const float s = float(1 << k);
    const float invS = 1.0f / s;
    int cv[3];
    float cp[3], dist[3];
    for (int i = 0; i < 3; ++i) {
        cv[i] = w.voxel[i] >> k;
        cp[i] = (float(w.voxel[i] - cv[i] * (1 << k)) + w.vpos[i]) * invS;
        cp[i] = std::min(cp[i], kOneMinusEpsilon);
        const float target = w.d[i] > 0.0f ? 1.0f : 0.0f;
        // Parallel to the axis: its planes are never crossed (render_common.glsl's NEVER).
        dist[i] = w.d[i] == 0.0f ? kNever : (target - cp[i]) * (w.invD[i] * s);
    }
    int axis = 0;
    if (dist[1] < dist[axis]) axis = 1;
    if (dist[2] < dist[axis]) axis = 2;
    const float dt = dist[axis];
    float np[3];
    for (int i = 0; i < 3; ++i) np[i] = clamp01(cp[i] + (w.d[i] * invS) * dt);
    if (w.d[axis] > 0.0f) {
        cv[axis] += 1;
        np[axis] = 0.0f;
    } else {
        cv[axis] -= 1;
        np[axis] = kOneMinusEpsilon;
    }
    for (int i = 0; i < 3; ++i) {
        const float fine = np[i] * s;
        const float fl = std::floor(fine);
        w.voxel[i] = cv[i] * (1 << k) + int(fl); // cv may be -1 (the walk leaving the volume): no shift of a negative
        w.vpos[i] = fine - fl;
    }
    w.t = w.t + dt;
    w.face = 1 + 2 * axis + (w.d[axis] > 0.0f ? 0 : 1);
}

} // namespace

GBuffer castRaysStable(const LabelVolume& volume, const Geometry& g, const RayCastView& view,
                       const std::function<bool(uint32_t)>& visible, uint32_t brickSize, UniformSteps steps) {
    GBuffer out;
    out.width = view.width;
    out.height = view.height;
    const size_t n = size_t(view.width) * view.height;
    out.label.assign(n, kInvalidLabel);
    out.depth.assign(n, 1.0f);
    out.face.assign(n, Face::None);
    out.distance.assign(n, 0.0f);
    Mat4 clipToWorld{};
    if (!invert(view.worldToClip, clipToWorld)) return out;
    const Mat4 indexToWorld = indexToWorldMatrix(g);
    Mat4 worldToIndex{};
    if (!invert(indexToWorld, worldToIndex)) return out;
    // The same double products as Renderer.cpp, rounded to float as uploaded.
    const Mat4 clipToIndexD = multiply(worldToIndex, clipToWorld);
    const Mat4 indexToClipD = multiply(view.worldToClip, indexToWorld);
    float M[16], toClip[16], toWorld[16];
    for (int i = 0; i < 16; ++i) {
        M[i] = float(clipToIndexD[i]);
        toClip[i] = float(indexToClipD[i]);
        toWorld[i] = float(indexToWorld[i]);
    }
    int shift = 0;
    while ((1u << (shift + 1)) <= brickSize) ++shift;
    const int lo[3] = {0, 0, 0};
    const int hi[3] = {int(volume.dim[0]), int(volume.dim[1]), int(volume.dim[2])};
    const uint32_t grid[3] = {(volume.dim[0] + brickSize - 1) / brickSize, (volume.dim[1] + brickSize - 1) / brickSize,
                              (volume.dim[2] + brickSize - 1) / brickSize};
    std::vector<uint8_t> brickVisible(size_t(grid[0]) * grid[1] * grid[2], 0);
    for (uint32_t z = 0; z < volume.dim[2]; ++z)
        for (uint32_t y = 0; y < volume.dim[1]; ++y)
            for (uint32_t x = 0; x < volume.dim[0]; ++x) {
                const size_t b = (x >> shift) + grid[0] * ((y >> shift) + size_t(grid[1]) * (z >> shift));
                if (!brickVisible[b] && visible(volume.at(x, y, z))) brickVisible[b] = 1;
            }
    const std::vector<uint32_t> emptyGroup =
        emptyGroupLevels({grid[0], grid[1], grid[2]}, [&](uint64_t b) { return !brickVisible[size_t(b)]; });
    // The sub-blocks the renderer steps over whole (Layout.h), inside the volume: uniform ones (one
    // label) and hidden ones (no visible label; cache_hidden.comp), the latter marked where the
    // volume holds two labels or more that are not visible (else they are uniform).
    bool hiddenLabels = false;
    {
        uint32_t first = kInvalidLabel;
        for (size_t i = 0; i < volume.labels.size() && !hiddenLabels; ++i)
            if (!visible(volume.labels[i])) {
                if (first == kInvalidLabel) first = volume.labels[i];
                hiddenLabels = volume.labels[i] != first;
            }
    }
    const int subShift = shift - int(kUniformShift);
    std::vector<uint64_t> uniform(brickVisible.size(), 0), hidden(brickVisible.size(), 0);
    if (subShift >= 0) {
        const uint32_t edge = 1u << subShift;
        for (size_t b = 0; b < uniform.size(); ++b) {
            const uint32_t bc[3] = {uint32_t(b % grid[0]) << shift, uint32_t(b / grid[0] % grid[1]) << shift,
                                    uint32_t(b / (size_t(grid[0]) * grid[1])) << shift};
            for (uint32_t j = 0; j < 64; ++j) {
                if (!uniformSubBlockInside(j, uint32_t(subShift), bc[0], bc[1], bc[2], volume.dim[0], volume.dim[1], volume.dim[2]))
                    continue;
                const uint32_t o[3] = {bc[0] + mortonX(j) * edge, bc[1] + mortonY(j) * edge, bc[2] + mortonZ(j) * edge};
                const uint32_t first = volume.at(o[0], o[1], o[2]);
                bool same = true, none = hiddenLabels;
                for (uint32_t z = 0; z < edge && (same || none); ++z)
                    for (uint32_t y = 0; y < edge && (same || none); ++y)
                        for (uint32_t x = 0; x < edge && (same || none); ++x) {
                            const uint32_t l = volume.at(o[0] + x, o[1] + y, o[2] + z);
                            same = same && l == first;
                            none = none && !visible(l);
                        }
                if (same) uniform[b] |= uint64_t(1) << j;
                if (none) hidden[b] |= uint64_t(1) << j;
            }
        }
    }
    // Uniform levels: every voxel's, brick by brick (UniformLevels.h, on the brick's Morton order).
    std::vector<uint8_t> voxelLevel;
    if (steps == UniformSteps::Levels) {
        voxelLevel.assign(volume.labels.size(), 0);
        const uint64_t n = uint64_t(1) << (3 * shift);
        std::vector<uint32_t> morton(n);
        std::vector<uint8_t> levels(n / 8);
        const std::array<uint32_t, 3> dim = {volume.dim[0], volume.dim[1], volume.dim[2]};
        std::vector<size_t> voxelOf(n); // the volume index of each Morton entry, SIZE_MAX beyond the volume
        for (size_t b = 0; b < brickVisible.size(); ++b) {
            const uint32_t bc[3] = {uint32_t(b % grid[0]) << shift, uint32_t(b / grid[0] % grid[1]) << shift,
                                    uint32_t(b / (size_t(grid[0]) * grid[1])) << shift};
            for (uint64_t e = 0; e < n; ++e) {
                const uint32_t x = bc[0] + mortonX(uint32_t(e)), y = bc[1] + mortonY(uint32_t(e)), z = bc[2] + mortonZ(uint32_t(e));
                voxelOf[e] = x < dim[0] && y < dim[1] && z < dim[2] ? x + size_t(dim[0]) * (y + size_t(dim[1]) * z) : SIZE_MAX;
                morton[e] = voxelOf[e] != SIZE_MAX ? volume.labels[voxelOf[e]] : kInvalidLabel;
            }
            uniformLevelsOfBrick(morton.data(), uint32_t(shift), b, dim, levels.data());
            for (uint64_t e = 0; e < n; ++e)
                if (voxelOf[e] != SIZE_MAX) voxelLevel[voxelOf[e]] = levels[e / 8];
        }
    }
    const float pixX = 2.0f / float(view.width), pixY = 2.0f / float(view.height);

    for (uint32_t py = 0; py < view.height; ++py)
        for (uint32_t px = 0; px < view.width; ++px) {
            const float ndcX = ((float(px) + 0.5f) + 0.0f) * pixX - 1.0f;
            const float ndcY = ((float(py) + 0.5f) + 0.0f) * pixY - 1.0f;
            float a[4], b[4];
            for (int r = 0; r < 4; ++r) {
                a[r] = ((M[r] * ndcX + M[4 + r] * ndcY) - M[8 + r]) + M[12 + r];
                b[r] = ((M[r] * ndcX + M[4 + r] * ndcY) + M[8 + r]) + M[12 + r];
            }
            const float ia = 1.0f / a[3], ib = 1.0f / b[3];
            float o[3], d[3];
            Walker w{};
            for (int k = 0; k < 3; ++k) {
                o[k] = a[k] * ia;
                d[k] = b[k] * ib - o[k];
                w.d[k] = d[k];
                w.invD[k] = 1.0f / d[k];
            }
            // startRay()
            float t0 = 0.0f, t1 = 1.0f;
            int entryAxis = -1;
            bool miss = false;
            for (int k = 0; k < 3 && !miss; ++k) {
                if (d[k] == 0.0f) {
                    miss = o[k] < float(lo[k]) || o[k] > float(hi[k]);
                    continue;
                }
                const float ta = (float(lo[k]) - o[k]) * w.invD[k];
                const float tb = (float(hi[k]) - o[k]) * w.invD[k];
                const float tlo = std::min(ta, tb), thi = std::max(ta, tb);
                if (tlo > t0) {
                    t0 = tlo;
                    entryAxis = k;
                }
                t1 = std::min(t1, thi);
            }
            if (miss || t0 > t1) continue;
            for (int k = 0; k < 3; ++k) {
                const float p = o[k] + d[k] * t0;
                w.voxel[k] = std::clamp(int(std::floor(p)), lo[k], hi[k] - 1);
                w.vpos[k] = clamp01(p - float(w.voxel[k]));
            }
            w.face = 0;
            if (entryAxis >= 0) {
                const bool up = d[entryAxis] > 0.0f;
                w.voxel[entryAxis] = up ? lo[entryAxis] : hi[entryAxis] - 1;
                w.vpos[entryAxis] = up ? 0.0f : kOneMinusEpsilon;
                w.face = 1 + 2 * entryAxis + (up ? 0 : 1);
            }
            w.t = t0;
            w.tEnd = t1;
            // march()
            uint32_t prev = kInvalidLabel;
            for (uint32_t it = 0; it < 60000u; ++it) {
                if (w.t > w.tEnd) break;
                const size_t bi = size_t(w.voxel[0] >> shift) +
                                  grid[0] * (size_t(w.voxel[1] >> shift) + size_t(grid[1]) * size_t(w.voxel[2] >> shift));
                if (!brickVisible[bi]) { // with its group of empty bricks (BrickGroups.h)
                    prev = kInvalidLabel;
                    stableStep(w, shift + int(emptyGroup[bi]));
                } else {
                    // A hidden sub-block (with its Morton-aligned 2x2x2 group when all are) is
                    // stepped over without its label, a uniform one after it: no surface inside.
                    const uint32_t local = (1u << shift) - 1;
                    const uint32_t j = subShift >= 0 ? uniformSubBlockOf(uint32_t(w.voxel[0]) & local, uint32_t(w.voxel[1]) & local,
                                                                         uint32_t(w.voxel[2]) & local, uint32_t(subShift))
                                                     : 0;
                    if (subShift >= 0 && ((hidden[bi] >> j) & 1u) != 0) {
                        prev = kInvalidLabel;
                        stableStep(w, ((hidden[bi] >> (j & 56u)) & 0xFFu) == 0xFFu ? subShift + 1 : subShift);
                    } else {
                        const uint32_t label = volume.at(uint32_t(w.voxel[0]), uint32_t(w.voxel[1]), uint32_t(w.voxel[2]));
                        if (label != prev) {
                            prev = label;
                            if (visible(label)) {
                                const size_t i = size_t(py) * view.width + px;
                                out.label[i] = label;
                                out.face[i] = Face(w.face);
                                const float q[3] = {float(w.voxel[0]) + w.vpos[0], float(w.voxel[1]) + w.vpos[1],
                                                    float(w.voxel[2]) + w.vpos[2]};
                                float clip[4];
                                for (int r = 0; r < 4; ++r)
                                    clip[r] = toClip[r] * q[0] + toClip[4 + r] * q[1] + toClip[8 + r] * q[2] + toClip[12 + r];
                                out.depth[i] = std::clamp(clip[2] / clip[3] * 0.5f + 0.5f, 0.0f, 1.0f);
                                float dist2 = 0;
                                for (int r = 0; r < 3; ++r) {
                                    const float v = toWorld[r] * (q[0] - o[0]) + toWorld[4 + r] * (q[1] - o[1]) +
                                                    toWorld[8 + r] * (q[2] - o[2]);
                                    dist2 += v * v;
                                }
                                out.distance[i] = std::sqrt(dist2);
                                break;
                            }
                        }
                        if (steps == UniformSteps::Levels)
                            stableStep(w, voxelLevel[size_t(volume.index(uint32_t(w.voxel[0]), uint32_t(w.voxel[1]), uint32_t(w.voxel[2])))]);
                        else
                            stableStep(w, subShift >= 0 && ((uniform[bi] >> j) & 1u) != 0 ? subShift : 0);
                    }
                }
                bool outside = false;
                for (int k = 0; k < 3; ++k) outside = outside || w.voxel[k] < lo[k] || w.voxel[k] >= hi[k];
                if (outside) break;
            }
        }
    return out;
}

} // namespace csgv
