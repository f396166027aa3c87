// SPDX-License-Identifier: MIT
#pragma once
/// @file Decoder.h
/// @brief CPU decoding of CSGV bricks (encodings 0, 1, 2, every operation mask) to any level of
/// detail, of whole volumes, sub-boxes and single voxels, in parallel over bricks.
///
/// Level numbering in this API is the user-facing one: `lod` 0 is full resolution, `lod` k has
/// nodes of 2^k voxels per axis, up to `levels() - 1` (one node per brick). A level image has
/// `(dim - 1) / 2^k + 1` nodes per axis (a node exists when its minimum-corner voxel does).
///
/// Every stream violation of CSGV-FORMAT.md section 9 is returned as an error naming the brick,
/// the level (lod) and the node (Morton index within its level).

#include "csgv/codec/Container.h"
#include "csgv/codec/LabelVolume.h"

#include <array>
#include <cstdint>
#include <vector>

namespace csgv {

/// Box in the voxel grid of one level of detail, half-open: [min, max).
struct Box {
    std::array<uint32_t, 3> min{{0, 0, 0}};
    std::array<uint32_t, 3> max{{0, 0, 0}};
};

/// Dimensions of the level image at `lod`.
std::array<uint32_t, 3> lodDimensions(const std::array<uint32_t, 3>& dim, uint32_t lod);

/// @brief Decodes single bricks; holds per-level scratch, so keep one per thread and reuse it.
class BrickDecoder {
public:
    explicit BrickDecoder(const CompressedVolume& vol);

    /// Decodes brick `index` down to `lod`. Afterwards labels() holds that level's nodes in Morton
    /// order of the brick-local grid of (B >> lod)^3 nodes; nodes outside the volume hold
    /// kInvalidLabel unless an ancestor's stop bit filled them. A brick of a mapped file that
    /// was cut short under the decoder (MappedFile's guard read zeros for it) is an error naming
    /// the file's change, whatever it decoded to.
    Status decode(uint64_t index, uint32_t lod);
    const uint32_t* labels() const { return m_labels.data() + m_levelOffset[m_decodedLevel]; }
    /// Nodes per axis of the last decoded level.
    uint32_t gridSize() const { return 1u << m_decodedLevel; }

private:
    Status decodeBrick(uint64_t index, uint32_t lod);
    template <typename Reader>
    Status decodeLevels(uint64_t index, const BrickWords& bw, Reader& reader, uint32_t firstLevel,
                        uint32_t lastLevel);
    Status decodeLevel(uint64_t index, const BrickWords& bw, uint32_t level);

    const CompressedVolume& m_vol;
    uint32_t m_levels;
    std::array<uint32_t, 8> m_levelOffset{};
    std::vector<uint32_t> m_labels;  ///< all levels, level l at m_levelOffset[l], Morton order
    std::vector<uint8_t> m_open;     ///< visited without a stop bit: its children get visited
    std::array<uint32_t, 3> m_origin{};
    uint32_t m_decodedLevel = 0;
    // Brick state while decoding.
    uint32_t m_paletteCursor = 0; ///< next PALETTE_ADV word
    uint32_t m_appended = 0;      ///< palette entries appended so far
    struct RansTable {
        std::array<uint32_t, 17> cum{};
        std::array<uint32_t, 16> freq{};
        std::vector<uint8_t> symbol; ///< 16384 entries: slot -> symbol
    };
    RansTable m_tableA, m_tableB;
    friend struct RansReader;
};

/// Options for volume decoding.
struct DecodeOptions {
    int threads = 0;                       ///< 0: OpenMP's default
    uint64_t maxOutputBytes = uint64_t(16) << 30;
    /// When set, decoded palette values are ids into this table (a relabelled file with its
    /// attribute database); outputs hold the table's labels. An id past the table is an error.
    const std::vector<uint32_t>* idToLabel = nullptr;
};

/// Decodes a sub-box of the level image at `lod`, touching only the bricks it intersects.
Result<LabelVolume> decodeRegion(const CompressedVolume& vol, uint32_t lod, const Box& box,
                                 const DecodeOptions& options = {});
/// Decodes the whole level image at `lod`.
Result<LabelVolume> decodeVolume(const CompressedVolume& vol, uint32_t lod, const DecodeOptions& options = {});
/// Decodes one voxel (coordinates in the level image at `lod`), decoding only its brick.
Result<uint32_t> decodeVoxel(const CompressedVolume& vol, std::array<uint32_t, 3> pos, uint32_t lod = 0,
                             const DecodeOptions& options = {});
/// Decodes every brick to full resolution and discards the result: a complete stream check.
Status validateStreams(const CompressedVolume& vol, int threads = 0);

} // namespace csgv
