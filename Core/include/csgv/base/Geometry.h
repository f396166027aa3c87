// SPDX-License-Identifier: MIT
#pragma once
/// @file Geometry.h
/// @brief Placement of a voxel grid in world space.

#include <array>

namespace csgv {

/// @brief world = origin + direction * (index * spacing), direction row-major (direction[3*r + c];
/// column c is the world direction of index axis c). Whether `origin` is a voxel centre or a
/// voxel corner is said where a Geometry is stored (inputs: centres; `.csgv.json`: corners).
struct Geometry {
    std::array<double, 3> spacing{{1, 1, 1}};
    std::array<double, 3> origin{{0, 0, 0}};
    std::array<double, 9> direction{{1, 0, 0, 0, 1, 0, 0, 0, 1}};
};

/// The same placement, exactly (a changed one restarts a renderer's accumulation).
inline bool operator==(const Geometry& a, const Geometry& b) {
    return a.origin == b.origin && a.spacing == b.spacing && a.direction == b.direction;
}
inline bool operator!=(const Geometry& a, const Geometry& b) { return !(a == b); }

} // namespace csgv
