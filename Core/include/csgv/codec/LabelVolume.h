// SPDX-License-Identifier: MIT
#pragma once
/// @file LabelVolume.h
/// @brief Uncompressed label volumes: Volcanite's `.vraw`, NRRD output, and the coarse-label rule.

#include "csgv/base/Checked.h"
#include "csgv/base/Geometry.h"
#include "csgv/base/Status.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace csgv {

/// @brief W x H x D uint32 labels, x fastest.
struct LabelVolume {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    std::vector<uint32_t> labels;

    uint64_t voxelCount() const { return product3(dim[0], dim[1], dim[2]); } ///< saturating
    uint64_t index(uint32_t x, uint32_t y, uint32_t z) const {
        return x + uint64_t(dim[0]) * (y + uint64_t(dim[1]) * z);
    }
    uint32_t at(uint32_t x, uint32_t y, uint32_t z) const { return labels[size_t(index(x, y, z))]; }
};

/// @brief The two text lines that open a `.vraw` ("W H D\n", "uint8|uint16|uint32\n").
struct VrawHeader {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    uint32_t bytesPerLabel = 4;
    uint64_t headerBytes = 0; ///< where the labels start
    /// An error unless exactly `available` bytes of labels follow the header.
    Status checkLabelBytes(uint64_t available) const;
};
/// Parses the header from the start of a `.vraw` (the first 160 bytes suffice).
Result<VrawHeader> parseVrawHeader(const uint8_t* data, size_t size);
/// Little-endian labels of 1, 2 or 4 bytes to uint32.
void widenLabels(const uint8_t* src, uint32_t bytesPerLabel, size_t count, uint32_t* out);

/// Reads Volcanite's `.vraw` ("W H D\n", "uint8|uint16|uint32\n", little-endian labels), also
/// gzip-compressed (`.vraw.gz`). Refuses volumes whose labels need more than maxBytes.
Result<LabelVolume> readVraw(const std::string& path, uint64_t maxBytes = uint64_t(16) << 30);
/// Parses `.vraw` content from memory.
Result<LabelVolume> parseVraw(const std::vector<uint8_t>& bytes);
/// Serialises as `.vraw` with uint32 labels.
std::vector<uint8_t> serializeVraw(const LabelVolume& vol);
/// Writes `.vraw` (uint32) through a temporary file renamed into place.
Status writeVraw(const std::string& path, const LabelVolume& vol);
/// Writes `.vraw` with uint8 values (a mask), through a temporary file renamed into place.
Status writeVrawUint8(const std::string& path, const std::array<uint32_t, 3>& dim, const uint8_t* values);
/// Writes a raw little-endian NRRD of any voxel type ("uint32", "int64", ...) with its geometry
/// (`origin` the centre of voxel 0), through a temporary file renamed into place.
Status writeNrrd(const std::string& path, const std::array<uint32_t, 3>& dim, const char* nrrdType,
                 const void* data, size_t bytesPerVoxel, const Geometry& centred);
/// Writes VTK's XML image data (`.vti`, raw appended, little-endian, 64-bit block header) holding
/// one cell array `name` of `vtkType` ("UInt8", "UInt32", "Int64", "UInt64"): the cells
/// `offset` + [0, dim) of an image whose node (0,0,0) has its minimum corner at `corner`'s origin
/// (point extent offset .. offset + dim, spacing, direction), so it overlays the volume as
/// ParaView's CSGV Extract Labels image does. Through a temporary file renamed into place.
Status writeVti(const std::string& path, const std::array<uint32_t, 3>& offset, const std::array<uint32_t, 3>& dim,
                const char* vtkType, const char* name, const void* data, size_t bytesPerVoxel, const Geometry& corner);
/// Writes uint32 labels as NRRD.
Status writeNrrd(const std::string& path, const LabelVolume& vol, const Geometry& centred = {});

/// The coarse-label rule for one node (CSGV-FORMAT.md section 1): the label carried by most of
/// the `count` in-volume children given in child-index order, ties to the lowest child index.
inline uint32_t modeOfChildren(const uint32_t* labels, int count) {
    uint32_t best = labels[0];
    int bestCount = 0;
    for (int i = 0; i < count; ++i) {
        int c = 0;
        for (int j = 0; j < count; ++j) c += labels[j] == labels[i];
        if (c > bestCount) {
            bestCount = c;
            best = labels[i];
        }
    }
    return best;
}

/// One step of the coarse-label rule (CSGV-FORMAT.md section 1): each node of the next level
/// takes the label carried by most of its in-volume children, ties going to the lowest child
/// index (x parity bit 0, y bit 1, z bit 2).
LabelVolume coarsenLabels(const LabelVolume& fine);

} // namespace csgv
