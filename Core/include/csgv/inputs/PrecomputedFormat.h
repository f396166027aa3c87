// SPDX-License-Identifier: MIT
#pragma once
/// @file PrecomputedFormat.h
/// @brief The parts of Neuroglancer's precomputed volume format that we parse ourselves, from
/// bytes (no files), so that the reader (Core/src/inputs/Precomputed.cpp) and the fuzz target
/// (Testing/Fuzz/FuzzPrecomputed.cpp) share them: the `info` JSON document and the two chunk
/// encodings we support, `raw` and `compressed_segmentation`. Specifications: neuroglancer's
/// src/datasource/precomputed/volume.md and sliceview/compressed_segmentation/README.md.
///
/// Every function returns errors as values whose message says what is wrong without a file
/// name (callers prefix it); none reads outside the bytes it is given or allocates what the
/// bytes merely claim.

#include "csgv/base/Status.h"
#include "csgv/inputs/Inputs.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace csgv {
namespace inputs {

/// @brief One entry of the info file's `scales` array (only its first chunk size is used).
struct PrecomputedScale {
    enum class Encoding { Raw, CompressedSegmentation, Other };

    std::string key;                              ///< sub-folder of the chunks, relative to the info's folder
    std::array<uint32_t, 3> size{{0, 0, 0}};      ///< voxels, x y z
    std::array<double, 3> resolution{{1, 1, 1}};  ///< nanometres a voxel
    std::array<int64_t, 3> voxelOffset{{0, 0, 0}};
    std::array<uint32_t, 3> chunkSize{{0, 0, 0}}; ///< chunk_sizes[0]
    Encoding encoding = Encoding::Raw;
    std::string encodingName;                     ///< as written (for messages about others)
    std::array<uint32_t, 3> blockSize{{0, 0, 0}}; ///< compressed_segmentation_block_size
    bool sharded = false;                         ///< a "sharding" member is present
};

/// @brief What the info file says about the volume.
struct PrecomputedInfo {
    std::string volumeType; ///< "segmentation" or "image"
    LabelType type = LabelType::U32;
    std::vector<PrecomputedScale> scales;
};

/// Parses an info document: `type` ("segmentation", or "image" with an unsigned integer
/// data_type), `data_type` (uint8, uint16, uint32, uint64), `num_channels` (must be 1) and every
/// scale's key, size, resolution, voxel_offset (optional), chunk_sizes, encoding and, for
/// compressed_segmentation, its block size (no larger than the chunk size along any axis). JSON
/// nested more than 64 levels deep is refused before parsing. Whether a scale's encoding and
/// storage are supported
/// is checkPrecomputedScale's business, so that an unsupported scale that is not used is no error.
Result<PrecomputedInfo> parsePrecomputedInfo(const uint8_t* data, size_t size);

/// An error unless the scale can be read: unsharded, raw or compressed_segmentation (the latter
/// for uint32 and uint64 only).
Status checkPrecomputedScale(const PrecomputedInfo& info, const PrecomputedScale& scale);

/// Decodes a raw chunk (little-endian, x fastest, then y, then z) of `extent` voxels into `out`
/// (extent voxels, full width). The byte count must be exactly extent * the type's size.
Status decodeRawChunk(const uint8_t* data, size_t size, LabelType type, const std::array<uint32_t, 3>& extent,
                      uint64_t* out);

/// Decodes a single-channel compressed_segmentation chunk of `extent` voxels encoded in blocks of
/// `blockSize` into `out` (extent voxels, x fastest). `type` is U32 or U64. Every offset, lookup
/// table entry and packed value is checked against the bytes.
Status decodeCompressedSegmentation(const uint8_t* data, size_t size, LabelType type,
                                    const std::array<uint32_t, 3>& extent, const std::array<uint32_t, 3>& blockSize,
                                    uint64_t* out);

/// The largest byte count a compressed_segmentation chunk of this extent and block size can
/// need when laid out without gaps (block headers, 32-bit values, a full lookup table a block),
/// so that a reader refuses a larger file before reading it whole. Saturates at 2^64 - 1.
uint64_t compressedSegmentationBound(LabelType type, const std::array<uint32_t, 3>& extent,
                                     const std::array<uint32_t, 3>& blockSize);

} // namespace inputs
} // namespace csgv
