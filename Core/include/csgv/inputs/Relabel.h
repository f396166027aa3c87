// SPDX-License-Identifier: MIT
#pragma once
/// @file Relabel.h
/// @brief Turning any integer labels into the format's unsigned 32-bit labels: kept as they are
/// when they fit, or relabelled to dense ids (DESIGN.md "Relabelling"): 0 stays 0, every other
/// label gets 1, 2, ... in order of first appearance, visiting bricks in Morton order of their
/// coordinates and voxels in Morton order inside each brick (Volcanite's order).
///
/// The order is streamable: a voxel's visiting position is the pair (Morton code of its brick,
/// Morton index inside the brick), computable for any voxel in any read order. StreamingRelabeller
/// keeps, per distinct label, the smallest position it was seen at (pass 1, slabs in any order);
/// sorting labels by that position gives the ids; pass 2 maps values to ids. Memory: one hash
/// entry per distinct label (about 50 bytes each), nothing per voxel. prepareLabels and
/// relabelDense run the same code over a volume in memory, so there is one definition of the order.

#include "csgv/inputs/Inputs.h"
#include "csgv/codec/LabelVolume.h"

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace csgv {

/// @brief How ids map back to the input's labels.
struct LabelMapping {
    bool relabelled = false;
    LabelType type = LabelType::U32;   ///< how to read originalBits
    std::vector<uint64_t> originalBits; ///< id -> original value (signed types: int64 bits)
};

/// True when a full-width value (signed ones as int64 bits) is a valid format label: unsigned and
/// below 0xFFFFFFFF. A negative int64 read as uint64 is >= 2^63, so one comparison covers both.
inline bool labelFitsFormat(uint64_t value) { return value < 0xFFFFFFFFull; }
/// True when every value a type can hold fits the format (uint8, uint16): no check is needed.
bool typeAlwaysFitsFormat(LabelType type);
/// True when every value is a valid format label (unsigned, below 0xFFFFFFFF).
bool labelsFitFormat(const InputVolume& in);
/// Morton code of brick coordinates (21 bits per axis), for ordering bricks.
uint64_t morton3x21(uint32_t x, uint32_t y, uint32_t z);

/// @brief Where relabelling visits a voxel: bricks by the Morton code of their coordinates, then
/// voxels by their Morton index inside the brick.
struct VisitPosition {
    uint64_t brick = 0;
    uint32_t voxel = 0;
    bool operator<(const VisitPosition& o) const { return brick != o.brick ? brick < o.brick : voxel < o.voxel; }
};
/// The visiting position of voxel (x, y, z) for bricks of 2^brickShift voxels a side.
VisitPosition visitPosition(uint32_t x, uint32_t y, uint32_t z, uint32_t brickShift);

/// @brief Dense relabelling in two streaming passes (see the file comment).
///
/// Pass 1: observe() every slab once, in any order. finish() assigns the ids. Pass 2: toIds()
/// maps values (any order, any number of times). Values are full width (InputSource's).
class StreamingRelabeller {
public:
    StreamingRelabeller(const std::array<uint32_t, 3>& dim, uint32_t brickSize);
    /// Pass 1: values of slices [z0, z0 + depth), x fastest.
    void observe(uint32_t z0, uint32_t depth, const uint64_t* values);
    /// Pass 1 over a box of the volume: `size` voxels from `lo`, x fastest (a piece of a volume
    /// relabelled in pieces, one relabeller each; see firstVisits).
    void observeBox(const std::array<uint32_t, 3>& lo, const std::array<uint32_t, 3>& size, const uint64_t* values);
    /// Pass 1 over a box known to hold one value (InputSource::uniformBoxes), without its voxels:
    /// visiting positions grow with each coordinate, so the box is first visited at its lowest
    /// corner.
    void observeUniform(const UniformBox& box);
    /// @brief Relabelling in pieces: each piece's relabeller observes its box, one relabeller
    /// takes every piece's first visits (takeFirstVisit) and finishes; the others take its
    /// originalBits (useIds) for their own labels. The ids are those of one relabeller seeing all.
    std::vector<std::pair<uint64_t, VisitPosition>> firstVisits() const;
    void takeFirstVisit(uint64_t value, const VisitPosition& position);
    /// Ends pass 1 with ids chosen elsewhere (id -> original bits, [0] = 0); fails naming a label
    /// this relabeller saw that they lack.
    Status useIds(const std::vector<uint64_t>& originalBits);
    /// Ends pass 1; fails when there are more labels than ids (2^32 - 1 with 0).
    Status finish();
    /// Pass 2: ids of `count` values. Returns false at the first value pass 1 never saw (the
    /// input changed between the passes), its index in `*missAt` when given; ids before it are set.
    bool toIds(const uint64_t* values, size_t count, uint32_t* ids, size_t* missAt = nullptr) const;
    /// Distinct non-zero labels seen (the hash map's entries).
    size_t mapSize() const { return m_entries.size(); }
    /// id -> original value bits; [0] is 0. Valid after finish().
    const std::vector<uint64_t>& originalBits() const { return m_originalBits; }
    /// Bytes held: hash entries and the id table (estimated from the node size).
    uint64_t memoryBytes() const;

private:
    struct Entry {
        VisitPosition first; ///< pass 1: smallest position seen
        uint32_t id = 0;     ///< after finish()
    };
    std::array<uint32_t, 3> m_dim;
    uint32_t m_shift = 0;
    std::unordered_map<uint64_t, Entry> m_entries; ///< non-zero label -> entry
    std::vector<uint64_t> m_originalBits;
    bool m_finished = false;
};

/// Converts to format labels, relabelling when the values do not fit or when forced.
Result<LabelVolume> prepareLabels(const InputVolume& in, uint32_t brickSize, bool forceRelabel, LabelMapping& mapping);
/// Dense relabelling of a label volume in place (Volcanite's order); returns id -> label.
std::vector<uint64_t> relabelDense(LabelVolume& volume, uint32_t brickSize);

} // namespace csgv
