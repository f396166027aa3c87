// SPDX-License-Identifier: MIT
/// @file Morton.h
/// @brief 3D Morton (Z-order) codes with x in bit 0, y in bit 1, z in bit 2 of each 3-bit group.
/// Shared with the shaders (GlslShim.h): the GPU decoder includes this very file.
#ifndef CSGV_BASE_MORTON_H
#define CSGV_BASE_MORTON_H

#include "csgv/base/GlslShim.h"

CSGV_NAMESPACE_BEGIN(csgv)

/// Spreads the low 10 bits of v so that bit i moves to bit 3i.
CSGV_FN uint32_t mortonSpread(uint32_t v) {
    v &= 0x3FFu;
    v = (v | (v << 16u)) & 0x030000FFu;
    v = (v | (v << 8u)) & 0x0300F00Fu;
    v = (v | (v << 4u)) & 0x030C30C3u;
    v = (v | (v << 2u)) & 0x09249249u;
    return v;
}

/// Inverse of mortonSpread: gathers bits 0, 3, 6, ... into the low bits.
CSGV_FN uint32_t mortonCompact(uint32_t v) {
    v &= 0x09249249u;
    v = (v | (v >> 2u)) & 0x030C30C3u;
    v = (v | (v >> 4u)) & 0x0300F00Fu;
    v = (v | (v >> 8u)) & 0x030000FFu;
    v = (v | (v >> 16u)) & 0x000003FFu;
    return v;
}

/// Morton code of (x, y, z), each coordinate below 1024.
CSGV_FN uint32_t morton3(uint32_t x, uint32_t y, uint32_t z) {
    return mortonSpread(x) | (mortonSpread(y) << 1u) | (mortonSpread(z) << 2u);
}

CSGV_FN uint32_t mortonX(uint32_t m) { return mortonCompact(m); }
CSGV_FN uint32_t mortonY(uint32_t m) { return mortonCompact(m >> 1u); }
CSGV_FN uint32_t mortonZ(uint32_t m) { return mortonCompact(m >> 2u); }

/// Bits of one axis in a Morton code (axis 0 = x, 1 = y, 2 = z).
CSGV_FN uint32_t mortonAxisMask(uint32_t axis) { return 0x09249249u << axis; }

/// Morton code with the coordinate along `axis` decreased by one (the coordinate must be > 0).
CSGV_FN uint32_t mortonDecrement(uint32_t m, uint32_t axis) {
    return (((m & mortonAxisMask(axis)) - 1u) & mortonAxisMask(axis)) | (m & ~mortonAxisMask(axis));
}

/// Morton code with the coordinate along `axis` increased by one.
CSGV_FN uint32_t mortonIncrement(uint32_t m, uint32_t axis) {
    return (((m | ~mortonAxisMask(axis)) + 1u) & mortonAxisMask(axis)) | (m & ~mortonAxisMask(axis));
}

CSGV_NAMESPACE_END

#endif // CSGV_BASE_MORTON_H
