// SPDX-License-Identifier: MIT
#include "csgv/RayCast.h"
#include "csgv/Container.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace csgv {

namespace {

using Vec3 = std::array<double, 3>;
using Mat4 = std::array<double, 16>;

std::array<double, 4> transform4(const Mat4& m, const std::array<double, 4>& v) {
    std::array<double, 4> out{};
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out[r] += m[c * 4 + r] * v[c];
    return out;
}

Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

Vec3 normalized(const Vec3& v) {
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return n > 0 ? Vec3{v[0] / n, v[1] / n, v[2] / n} : v;
}

Face entryFace(int axis, double direction) {
    // Moving along +axis, a ray enters a voxel through its face with outward normal -axis.
    return Face(1 + 2 * axis + (direction > 0 ? 0 : 1));
}

} // namespace

Mat4 multiply(const Mat4& a, const Mat4& b) {
    Mat4 out{};
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            for (int k = 0; k < 4; ++k) out[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
    return out;
}

bool invert(const Mat4& m, Mat4& out) {
    // Gauss-Jordan with partial pivoting on [M | I], rows of the mathematical matrix.
    double a[4][8];
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) {
            a[r][c] = m[c * 4 + r];
            a[r][c + 4] = r == c ? 1.0 : 0.0;
        }
    for (int col = 0; col < 4; ++col) {
        int pivot = col;
        for (int r = col + 1; r < 4; ++r)
            if (std::fabs(a[r][col]) > std::fabs(a[pivot][col])) pivot = r;
        if (std::fabs(a[pivot][col]) < 1e-300) return false;
        if (pivot != col)
            for (int c = 0; c < 8; ++c) std::swap(a[col][c], a[pivot][c]);
        const double d = a[col][col];
        for (int c = 0; c < 8; ++c) a[col][c] /= d;
        for (int r = 0; r < 4; ++r) {
            if (r == col) continue;
            const double f = a[r][col];
            for (int c = 0; c < 8; ++c) a[r][c] -= f * a[col][c];
        }
    }
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out[c * 4 + r] = a[r][c + 4];
    return true;
}

Mat4 lookAtMatrix(const Vec3& eye, const Vec3& target, const Vec3& up) {
    const Vec3 f = normalized({target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]});
    const Vec3 s = normalized(cross(f, up));
    const Vec3 u = cross(s, f);
    Mat4 m{};
    for (int c = 0; c < 3; ++c) {
        m[c * 4 + 0] = s[c];
        m[c * 4 + 1] = u[c];
        m[c * 4 + 2] = -f[c];
    }
    m[12] = -(s[0] * eye[0] + s[1] * eye[1] + s[2] * eye[2]);
    m[13] = -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]);
    m[14] = f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2];
    m[15] = 1;
    return m;
}

Mat4 perspectiveMatrix(double fovyDegrees, double aspect, double zNear, double zFar) {
    const double f = 1.0 / std::tan(fovyDegrees * 3.14159265358979323846 / 360.0);
    Mat4 m{};
    m[0] = f / aspect;
    m[5] = f;
    m[10] = (zFar + zNear) / (zNear - zFar);
    m[11] = -1;
    m[14] = 2 * zFar * zNear / (zNear - zFar);
    return m;
}

Mat4 orthographicMatrix(double l, double r, double b, double t, double n, double f) {
    Mat4 m{};
    m[0] = 2 / (r - l);
    m[5] = 2 / (t - b);
    m[10] = -2 / (f - n);
    m[12] = -(r + l) / (r - l);
    m[13] = -(t + b) / (t - b);
    m[14] = -(f + n) / (f - n);
    m[15] = 1;
    return m;
}

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
    // Index space from world space: the inverse of world = origin + direction * (index * spacing).
    Mat4 indexToWorld{};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) indexToWorld[c * 4 + r] = g.direction[3 * r + c] * g.spacing[c];
        indexToWorld[12 + r] = g.origin[r];
    }
    indexToWorld[15] = 1;
    Mat4 worldToIndex{};
    if (!invert(indexToWorld, worldToIndex)) return out;
    const double dim[3] = {double(volume.dim[0]), double(volume.dim[1]), double(volume.dim[2])};
    const double inf = std::numeric_limits<double>::infinity();

    for (uint32_t py = 0; py < view.height; ++py)
        for (uint32_t px = 0; px < view.width; ++px) {
            const double nx = (px + 0.5) / view.width * 2 - 1, ny = (py + 0.5) / view.height * 2 - 1;
            std::array<double, 4> nearW = transform4(clipToWorld, {nx, ny, -1, 1});
            std::array<double, 4> farW = transform4(clipToWorld, {nx, ny, 1, 1});
            if (nearW[3] == 0 || farW[3] == 0) continue;
            for (int k = 0; k < 3; ++k) {
                nearW[k] /= nearW[3];
                farW[k] /= farW[3];
            }
            nearW[3] = farW[3] = 1;
            const std::array<double, 4> a4 = transform4(worldToIndex, nearW), b4 = transform4(worldToIndex, farW);
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
                    const std::array<double, 4> clip = transform4(view.worldToClip, hit);
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

} // namespace csgv
