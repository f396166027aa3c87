// SPDX-License-Identifier: MIT
#pragma once
/// @file Math.h
/// @brief The small matrix and vector helpers of Core and the backend: 4x4 matrices in
/// column-major order (OpenGL's layout, VTK's `wcdc` as it comes), clip = M * (x, y, z, 1), in
/// double precision. Header-only; the CPU reference ray caster and the renderer share these
/// exact operations, so their float results stay comparable bit for bit.

#include "csgv/base/Geometry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace csgv {

using Mat4 = std::array<double, 16>; ///< column-major: element (row r, column c) is m[c * 4 + r]
using Vec3 = std::array<double, 3>;
using Vec4 = std::array<double, 4>;


/// a * b.
inline Mat4 multiply(const Mat4& a, const Mat4& b) {
    Mat4 out{};
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            for (int k = 0; k < 4; ++k) out[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
    return out;
}

/// Inverse of a 4x4 matrix (Gauss-Jordan with partial pivoting); false when singular.
inline bool invert(const Mat4& m, Mat4& out) {
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

/// m * v for a homogeneous vector.
inline Vec4 transform(const Mat4& m, const Vec4& v) {
    Vec4 out{};
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out[r] += m[c * 4 + r] * v[c];
    return out;
}

/// m * (p, 1), divided by w.
inline Vec3 transformPoint(const Mat4& m, const Vec3& p) {
    double r[4];
    for (int i = 0; i < 4; ++i) r[i] = m[i] * p[0] + m[4 + i] * p[1] + m[8 + i] * p[2] + m[12 + i];
    return {r[0] / r[3], r[1] / r[3], r[2] / r[3]};
}

/// The upper 3x3 of m times v (a direction: no translation).
inline Vec3 transformDir(const Mat4& m, const Vec3& v) {
    Vec3 r{};
    for (int i = 0; i < 3; ++i) r[i] = m[i] * v[0] + m[4 + i] * v[1] + m[8 + i] * v[2];
    return r;
}

inline Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
/// v / |v|; v itself when it is zero. A vector whose squares would underflow or overflow (an up
/// vector of 1e-170, a direction of 1e200) is scaled by its largest component first.
inline Vec3 normalize(const Vec3& v) {
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (n > 1e-150 && n < 1e150) return Vec3{v[0] / n, v[1] / n, v[2] / n};
    const double m = std::max({std::fabs(v[0]), std::fabs(v[1]), std::fabs(v[2])});
    if (!(m > 0) || !std::isfinite(m)) return v;
    const Vec3 w{v[0] / m, v[1] / m, v[2] / m};
    const double k = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    return Vec3{w[0] / k, w[1] / k, w[2] / k};
}

/// world = origin + direction * (index * spacing) (corner geometry, Metadata.h).
inline Mat4 indexToWorldMatrix(const Geometry& g) {
    Mat4 m{};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) m[c * 4 + r] = g.direction[3 * r + c] * g.spacing[c];
        m[12 + r] = g.origin[r];
    }
    m[15] = 1;
    return m;
}

/// OpenGL's gluLookAt.
inline Mat4 lookAtMatrix(const Vec3& eye, const Vec3& target, const Vec3& up) {
    const Vec3 f = normalize({target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]});
    const Vec3 s = normalize(cross(f, up));
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

/// OpenGL's gluPerspective.
inline Mat4 perspectiveMatrix(double fovyDegrees, double aspect, double zNear, double zFar) {
    const double f = 1.0 / std::tan(fovyDegrees * 3.14159265358979323846 / 360.0);
    Mat4 m{};
    m[0] = f / aspect;
    m[5] = f;
    m[10] = (zFar + zNear) / (zNear - zFar);
    m[11] = -1;
    m[14] = 2 * zFar * zNear / (zNear - zFar);
    return m;
}

/// OpenGL's glOrtho.
inline Mat4 orthographicMatrix(double l, double r, double b, double t, double n, double f) {
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

} // namespace csgv
