// SPDX-License-Identifier: MIT
#pragma once
/// @file Metadata.h
/// @brief `<file>.csgv.json`: what the container lacks (DESIGN.md, "Metadata beside a .csgv").
///
/// ```json
/// {"format": "csgv-metadata", "version": 1, "dimensions": [W, H, D],
///  "spacing": [sx, sy, sz], "origin": [ox, oy, oz], "direction": [9 numbers, row-major],
///  "original_type": "int16", "relabelled": false, "source": "aal.nii.gz"}
/// ```
/// `origin` is the world position of the minimum corner of voxel (0,0,0), so voxel (i,j,k) spans
/// origin + direction * ([i, i+1] * spacing) (ParaView cell data). Inputs whose voxels are centred
/// on grid points (NRRD, NIfTI) are converted by moving the origin half a voxel back. A `.csgv`
/// without this file has spacing 1, origin 0 and identity direction. Unknown keys are ignored
/// (newer writers may add some); known keys with wrong types are errors.

#include "csgv/inputs/Inputs.h"

#include <array>
#include <string>

namespace csgv {

struct VolumeMetadata {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    Geometry geometry;                 ///< origin: corner of voxel (0,0,0)
    std::string originalType = "uint32";
    bool relabelled = false;
    std::string source;
};

/// `vol.csgv` -> `vol.csgv.json`.
std::string metadataPathFor(const std::string& csgvPath);
/// Corner-origin geometry for a volume whose voxel centres sit at `centred` grid points.
Geometry cellGeometryFromPointGeometry(const Geometry& centred);
/// The inverse: centre-origin geometry (as NRRD and NIfTI store it) from corner-origin geometry.
Geometry pointGeometryFromCellGeometry(const Geometry& corner);
Status writeMetadata(const std::string& path, const VolumeMetadata& md);
Result<VolumeMetadata> readMetadata(const std::string& path);

} // namespace csgv
