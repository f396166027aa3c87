// SPDX-License-Identifier: MIT
#pragma once
/// @file HeaderFormats.h
/// @brief The NRRD and NIfTI-1 header parsers, from bytes in memory: exactly what openInput()
/// and readNrrd()/readNifti() run on a file's first bytes, public so that the fuzz targets
/// (Testing/Fuzz/FuzzNrrd.cpp, FuzzNifti.cpp) exercise the production code. Every header check
/// happens here, before any voxel is read; a failure names `name` and what is wrong.

#include "csgv/base/Geometry.h"
#include "csgv/base/Status.h"
#include "csgv/inputs/Inputs.h"

#include <array>
#include <cstdint>
#include <map>
#include <string>

namespace csgv {
namespace inputs {

/// @brief What a NRRD header says about its one 3D volume and where its data lie.
struct NrrdHeader {
    std::map<std::string, std::string> fields; ///< lower-case field name -> trimmed value
    std::array<uint32_t, 3> dim{{0, 0, 0}};    ///< the three spatial axes (a size-1 4th axis dropped)
    LabelType type = LabelType::U8;
    Geometry geometry; ///< origin: centre of voxel (0,0,0)
    bool gzip = false; ///< encoding gzip (gzip or zlib stream), else raw
    bool bigEndian = false;
    /// Attached data: a blank line ends the header and data follow at dataOffset.
    bool attached = false;
    uint64_t dataOffset = 0;
    /// `data file` as written (a path relative to the header's folder, or absolute); empty for
    /// attached data.
    std::string dataFile;
    int64_t lineSkip = 0; ///< text lines before the data (in the file, before any inflating)
    int64_t byteSkip = 0; ///< bytes before the data (inflated bytes for gzip); -1: data end the file

    uint64_t voxelCount() const { return uint64_t(dim[0]) * dim[1] * dim[2]; }
};

/// Longest NRRD header searched for its blank line.
constexpr uint64_t kMaxNrrdHeaderBytes = uint64_t(4) << 20;

/// Parses a NRRD header from the first bytes of a `.nrrd` or `.nhdr` file: `text` holds the
/// whole header (attached data may follow the blank line that ends it; a detached header may end
/// without one). Checks magic, required fields, type, dimension and sizes (their byte count must
/// fit in 64 bits), encoding, endian, geometry, data file and skips. `name` prefixes messages.
Result<NrrdHeader> parseNrrdHeader(const std::string& text, const std::string& name);

/// @brief What a NIfTI-1 header says about its one 3D volume.
struct NiftiHeader {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    LabelType type = LabelType::U8;
    Geometry geometry; ///< sform, else qform, else pixdim; origin: centre of voxel (0,0,0)
    bool bigEndian = false;
    uint64_t voxOffset = 352; ///< byte offset of the voxels in the (inflated) file

    uint64_t voxelCount() const { return uint64_t(dim[0]) * dim[1] * dim[2]; }
};

constexpr size_t kNiftiHeaderBytes = 348;

/// Parses a NIfTI-1 header (`.nii`, its first 348 bytes, already inflated for `.nii.gz`):
/// sizeof_hdr (either byte order), magic `n+1`, dim (3D, or 2D, or 4D+ with one volume), a
/// supported datatype, unscaled data, vox_offset, and the geometry. Fewer than 348 bytes is an
/// error. `name` prefixes messages.
Result<NiftiHeader> parseNiftiHeader(const uint8_t* bytes, size_t size, const std::string& name);

} // namespace inputs
} // namespace csgv
