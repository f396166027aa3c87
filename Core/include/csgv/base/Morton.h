// SPDX-License-Identifier: MIT
#pragma once
/// @file Morton.h
/// @brief 3D Morton (Z-order) codes with x in bit 0, y in bit 1, z in bit 2 of each 3-bit group.

#include <cstdint>

namespace csgv {

/// Spreads the low 10 bits of v so that bit i moves to bit 3i.
constexpr uint32_t mortonSpread(uint32_t v) {
    v &= 0x3FFu;
    v = (v | (v << 16)) & 0x030000FFu;
    v = (v | (v << 8)) & 0x0300F00Fu;
    v = (v | (v << 4)) & 0x030C30C3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
}

/// Inverse of mortonSpread: gathers bits 0, 3, 6, ... into the low bits.
constexpr uint32_t mortonCompact(uint32_t v) {
    v &= 0x09249249u;
    v = (v | (v >> 2)) & 0x030C30C3u;
    v = (v | (v >> 4)) & 0x0300F00Fu;
    v = (v | (v >> 8)) & 0x030000FFu;
    v = (v | (v >> 16)) & 0x000003FFu;
    return v;
}

/// Morton code of (x, y, z), each coordinate below 1024.
constexpr uint32_t morton3(uint32_t x, uint32_t y, uint32_t z) {
    return mortonSpread(x) | (mortonSpread(y) << 1) | (mortonSpread(z) << 2);
}

constexpr uint32_t mortonX(uint32_t m) { return mortonCompact(m); }
constexpr uint32_t mortonY(uint32_t m) { return mortonCompact(m >> 1); }
constexpr uint32_t mortonZ(uint32_t m) { return mortonCompact(m >> 2); }

/// Bits of one axis in a Morton code (axis 0 = x, 1 = y, 2 = z).
constexpr uint32_t mortonAxisMask(int axis) { return 0x09249249u << axis; }

/// Morton code with the coordinate along `axis` decreased by one (the coordinate must be > 0).
constexpr uint32_t mortonDecrement(uint32_t m, int axis) {
    const uint32_t mask = mortonAxisMask(axis);
    return (((m & mask) - 1u) & mask) | (m & ~mask);
}

/// Morton code with the coordinate along `axis` increased by one.
constexpr uint32_t mortonIncrement(uint32_t m, int axis) {
    const uint32_t mask = mortonAxisMask(axis);
    return (((m | ~mask) + 1u) & mask) | (m & ~mask);
}

} // namespace csgv
