// SPDX-License-Identifier: MIT
/// @file Layout.h
/// @brief The codec facts that Core's decoder and the GPU decoder (shaders/csgv_decode.glsl)
/// both need, written once: valid C++ and GLSL (csgv/base/GlslShim.h). The shader compiler
/// embeds this file; changing a value here changes both sides.
#ifndef CSGV_CODEC_LAYOUT_H
#define CSGV_CODEC_LAYOUT_H

#include "csgv/base/GlslShim.h"
#include "csgv/base/Morton.h"

CSGV_NAMESPACE_BEGIN(csgv)

/// Reserved label: "undefined" inside decoders, "outside the volume" in the GPU cache.
CSGV_CONST(uint32_t, kInvalidLabel, 0xFFFFFFFFu)

/// A brick's finest labels in Morton order (decoder output, renderer cache) fall into
/// (1 << kUniformShift)^3 sub-blocks, each a contiguous run: renderers mark the sub-blocks that
/// lie inside the volume and hold one label (a 64-bit mask per brick) and step over them whole.
/// Sub-blocks have edge 1 << (brick shift - kUniformShift): the `subShift` below.
CSGV_CONST(uint32_t, kUniformShift, 2u)

/// Uniform levels (csgv/codec/UniformLevels.h): where a renderer's cache holds 32-bit labels all
/// below kUniformLabelMask, a word of a brick cached at the finest level holds its label in the low
/// kUniformLevelShift bits and, above them, its uniform level: the largest k such that the aligned
/// cube of 2^k voxels holding it lies inside the volume and holds one label. Rays step over that
/// cube whole once they read the label (no surface lies inside it). kInvalidLabel words stay all ones.
CSGV_CONST(uint32_t, kUniformLevelShift, 29u)
CSGV_CONST(uint32_t, kUniformLabelMask, 0x1FFFFFFFu)

/// The Morton number of the sub-block holding brick-local voxel (x, y, z).
CSGV_FN uint32_t uniformSubBlockOf(uint32_t x, uint32_t y, uint32_t z, uint32_t subShift) {
    return mortonSpread(x >> subShift) | (mortonSpread(y >> subShift) << 1u) | (mortonSpread(z >> subShift) << 2u);
}

/// Whether sub-block j of the brick whose lowest voxel is (bx, by, bz) lies wholly inside a
/// volume of (dx, dy, dz) voxels (only such sub-blocks are ever marked).
CSGV_FN bool uniformSubBlockInside(uint32_t j, uint32_t subShift, uint32_t bx, uint32_t by, uint32_t bz, uint32_t dx,
                                   uint32_t dy, uint32_t dz) {
    return bx + ((mortonX(j) + 1u) << subShift) <= dx && by + ((mortonY(j) + 1u) << subShift) <= dy &&
           bz + ((mortonZ(j) + 1u) << subShift) <= dz;
}

// rANS (CSGV-FORMAT.md section 5): 32-bit state, byte-wise renormalisation.
CSGV_CONST(uint32_t, kRansProbBits, 14u)
CSGV_CONST(uint32_t, kRansTotal, 1u << kRansProbBits) ///< frequencies sum to this
CSGV_CONST(uint32_t, kRansLowerBound, 1u << 23u)      ///< the state stays at or above this

// Operation codes (low 3 bits of an operation symbol) and the stop bit.
CSGV_CONST(uint32_t, kOpParent, 0u)
CSGV_CONST(uint32_t, kOpNeighborX, 1u)
CSGV_CONST(uint32_t, kOpNeighborY, 2u)
CSGV_CONST(uint32_t, kOpNeighborZ, 3u)
CSGV_CONST(uint32_t, kOpPaletteAdv, 4u)
CSGV_CONST(uint32_t, kOpPaletteLast, 5u)
CSGV_CONST(uint32_t, kOpPaletteD, 6u)
CSGV_CONST(uint32_t, kOpInvalid, 7u)
CSGV_CONST(uint32_t, kStopBit, 8u)
CSGV_CONST(uint32_t, kOpMask, kStopBit - 1u)       ///< the operation bits of a symbol
/// A PALETTE_D distance: groups of 3 bits, most significant first, bit 3 set on all but the last.
CSGV_CONST(uint32_t, kMaxDistanceGroups, 11u)

// Results of the GPU decoder per brick (GpuVolume.cpp's decodeResultText() names them).
CSGV_CONST(uint32_t, kDecodeOk, 0u)
CSGV_CONST(uint32_t, kDecodeStreamEnd, 1u)        ///< the stream runs past its end
CSGV_CONST(uint32_t, kDecodeBadRoot, 2u)          ///< root operation is not PALETTE_ADV
CSGV_CONST(uint32_t, kDecodeBadOperation, 3u)     ///< operation symbol 7
CSGV_CONST(uint32_t, kDecodeStopAtFinest, 4u)     ///< stop bit at the finest level
CSGV_CONST(uint32_t, kDecodeBadNeighbour, 5u)     ///< neighbour outside the brick or the volume
CSGV_CONST(uint32_t, kDecodePaletteOverflow, 6u)  ///< more PALETTE_ADV than the palette holds
CSGV_CONST(uint32_t, kDecodeBadDistance, 7u)      ///< PALETTE_D past the palette or too long
CSGV_CONST(uint32_t, kDecodeRansIntegrity, 8u)    ///< the rANS end-of-stream check fails
CSGV_CONST(uint32_t, kDecodeRunning, 0xFFFFFFFFu) ///< not finished yet (resumable decoding)

CSGV_NAMESPACE_END

#endif // CSGV_CODEC_LAYOUT_H
