// SPDX-License-Identifier: MIT
#pragma once
/// @file Procedural.h
/// @brief Deterministic, seeded synthetic segmentations that produce any box independently, so
/// volumes far larger than memory can be generated (and compressed) brick by brick.
///
/// The volume: noisy Voronoi cells. Feature points sit on a jittered grid (one per cell of edge
/// `cellSize`, jittered within the cell's central half); each voxel is displaced by a smooth,
/// separable wave field before it takes the label of the nearest feature point among the 2x2x2
/// cells around it, so boundaries are wavy rather than planar. One cell in five is background
/// (label 0); the others get large, sparse 32-bit labels from a hash of the cell and the seed,
/// as in real connectomics volumes. Named `synth:WxHxD[:seed]` wherever an input is expected.

#include "csgv/codec/Encoder.h"

#include <array>
#include <cstdint>
#include <string>

namespace csgv {

struct SynthSpec {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    uint64_t seed = 1;
    uint32_t cellSize = 24; ///< voxels between feature points
};

/// True when the text starts with "synth:".
bool isSynthName(const std::string& text);
/// Parses "synth:WxHxD[:seed]".
Result<SynthSpec> parseSynthSpec(const std::string& text);
/// Labels of the box [origin, origin + size) in x-fastest order; any box, any order, same labels.
void generateBox(const SynthSpec& spec, const std::array<uint32_t, 3>& origin, const std::array<uint32_t, 3>& size,
                 uint32_t* out);
/// The whole volume in memory (refuses more than maxBytes).
Result<LabelVolume> generateVolume(const SynthSpec& spec, uint64_t maxBytes = uint64_t(16) << 30);

/// @brief Slab source over a procedural volume; generates each slab in parallel.
class ProceduralSlabSource : public SlabSource {
public:
    explicit ProceduralSlabSource(const SynthSpec& spec) : m_spec(spec) {}
    std::array<uint32_t, 3> dimensions() const override { return m_spec.dim; }
    Status readSlab(uint32_t z0, uint32_t depth, uint32_t* out) override;
    bool readsRows() const override { return true; }
    Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint32_t* out) override;

private:
    SynthSpec m_spec;
};

} // namespace csgv
