// SPDX-License-Identifier: MIT
#pragma once
/// @file Inputs.h
/// @brief Label volumes from files other than `.csgv`: Volcanite's `.vraw`, NRRD (`.nrrd`,
/// `.nhdr` with a detached data file; raw or gzip; 8 to 64-bit integers, signed or not, and floats
/// holding integers; spacing, space origin and directions) and NIfTI-1 (`.nii`, `.nii.gz`;
/// integer types and float types holding integers; spacing and the sform/qform origin and
/// direction). Values are kept at full width so that nothing is truncated before relabelling.

#include "csgv/base/Geometry.h"
#include "csgv/base/Status.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace csgv {

/// Voxel type of the input file.
enum class LabelType { U8, I8, U16, I16, U32, I32, U64, I64, F32, F64 };
/// "uint8", "int8", "uint16", "int16", "uint32", "int32", "uint64", "int64", "float32", "float64".
const char* labelTypeName(LabelType type);
bool isSignedType(LabelType type);

// Geometry of inputs (Geometry.h): `origin` is the centre of voxel (0,0,0), as in NRRD and NIfTI.

/// @brief A label volume at full width. Signed values are stored sign-extended (as int64 bits),
/// float values that hold integers are converted to those integers (int64 bits).
struct InputVolume {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    LabelType type = LabelType::U32;
    Geometry geometry; ///< origin: centre of voxel (0,0,0)
    std::vector<uint64_t> values; ///< x fastest

    uint64_t voxelCount() const { return uint64_t(dim[0]) * dim[1] * dim[2]; }
    /// True when the value of voxel i, read as the file's type, is negative.
    bool isNegative(size_t i) const { return isSignedType(type) && int64_t(values[i]) < 0; }
};

/// `maxBytes` bounds the values in memory (8 bytes a voxel) and is checked before allocating.
/// NRRD (`.nrrd` attached, `.nhdr` detached; encodings raw and gzip; endian little or big).
Result<InputVolume> readNrrd(const std::string& path, uint64_t maxBytes = uint64_t(16) << 30);
/// NIfTI-1 single file (`.nii`, `.nii.gz`), 3D (or 4D with one volume); scl_slope/inter must be
/// identity (a scaled label volume is an error).
Result<InputVolume> readNifti(const std::string& path, uint64_t maxBytes = uint64_t(16) << 30);
/// Dispatches on the name: `.vraw[.gz]`, `.nrrd`, `.nhdr`, `.nii`, `.nii.gz`. (`synth:` names
/// and `.csgv` are handled by callers.) Each format is one file in Core/src/inputs/ reading
/// through InputStream (FileUtil.h); the suffix table is in Inputs.cpp.
Result<InputVolume> readInput(const std::string& path, uint64_t maxBytes = uint64_t(16) << 30);

} // namespace csgv
