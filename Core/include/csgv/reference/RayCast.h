// SPDX-License-Identifier: MIT
#pragma once
/// @file RayCast.h
/// @brief A simple, exact CPU ray caster over a label volume: the reference that the GPU ray
/// marcher's G-buffer (label, depth, entry face) is compared with.
///
/// Conventions (the same as the renderer's and VTK's):
/// - `worldToClip` is a 4x4 matrix in column-major order (OpenGL's layout, VTK's `wcdc` from
///   vtkOpenGLCamera::GetKeyMatrices as it comes): clip = M * (x, y, z, 1).
/// - Pixel (x, y) looks through NDC ((x + 0.5) / W * 2 - 1, (y + 0.5) / H * 2 - 1); row 0 is the
///   bottom row. Its ray runs from NDC z = -1 (near) to +1 (far), so perspective and parallel
///   projections need no special case.
/// - Voxels are cells: voxel (i, j, k) covers index space [i, i+1] x [j, j+1] x [k, k+1], and
///   world = origin + direction * (index * spacing) with `origin` the corner of voxel (0,0,0).
/// - Depth is window depth ndc_z * 0.5 + 0.5 of the point where the ray enters the hit voxel
///   (1 where nothing is hit, the near plane when the camera is inside the hit voxel).

#include "csgv/base/Geometry.h"
#include "csgv/base/Math.h"
#include "csgv/codec/LabelVolume.h"

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace csgv {

/// Faces through which a ray enters its hit voxel, named by their outward normal in index space.
enum class Face : uint8_t { None = 0, MinusX, PlusX, MinusY, PlusY, MinusZ, PlusZ };

struct GBuffer {
    uint32_t width = 0, height = 0;
    std::vector<uint32_t> label; ///< kInvalidLabel where no visible voxel is hit
    std::vector<float> depth;    ///< window depth in [0, 1]
    std::vector<Face> face;      ///< None where nothing is hit or the camera starts inside the voxel
    std::vector<float> distance; ///< world distance from the ray's near-plane point (castRaysStable only)
};

struct RayCastView {
    std::array<double, 16> worldToClip{}; ///< column-major
    uint32_t width = 0, height = 0;
};

/// Casts one ray per pixel and records the first voxel whose label is `visible`.
GBuffer castRays(const LabelVolume& volume, const Geometry& cornerGeometry, const RayCastView& view,
                 const std::function<bool(uint32_t)>& visible);

/// The float mirror of the GPU ray marcher (shaders/render_common.glsl and render.comp): the
/// paper's stable DDA on an integer voxel plus a sub-voxel offset in [0, 1)^3, with bricks of
/// `brickSize` that hold no visible voxel skipped whole (and, inside them, the sub-blocks of
/// csgv/codec/Layout.h that hold one label or no visible one, and uniform cubes as `steps` says),
/// operation for operation in single
/// precision, so the GPU's G-buffer at the finest level must equal it exactly (labels, faces).
/// How the marcher steps over a voxel whose label it read and found no surface: to the end of
/// its sub-block when that is uniform (the renderer's 64-bit masks), or of the largest uniform cube
/// around it (uniform levels, csgv/codec/UniformLevels.h: the renderer's cache of small labels).
enum class UniformSteps { SubBlocks, Levels };

GBuffer castRaysStable(const LabelVolume& volume, const Geometry& cornerGeometry, const RayCastView& view,
                       const std::function<bool(uint32_t)>& visible, uint32_t brickSize,
                       UniformSteps steps = UniformSteps::SubBlocks);

// Matrix helpers (indexToWorldMatrix, lookAtMatrix, multiply, invert, ...): csgv/base/Math.h.

} // namespace csgv
