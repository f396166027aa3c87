// SPDX-License-Identifier: MIT
#pragma once
/// @file Checked.h
/// @brief Saturating arithmetic for sizes read from untrusted input (three u32 dimensions can
/// claim 2^96 voxels, which must compare as "too large", never wrap to something small).

#include <cstdint>
#include <limits>

namespace csgv {

constexpr uint64_t kSaturated = std::numeric_limits<uint64_t>::max();

constexpr uint64_t mulSaturate(uint64_t a, uint64_t b) {
    return (a != 0 && b > kSaturated / a) ? kSaturated : a * b;
}

constexpr uint64_t product3(uint64_t a, uint64_t b, uint64_t c) { return mulSaturate(mulSaturate(a, b), c); }

/// floor(log2(v)) for v >= 1 (0 for v == 0).
constexpr uint32_t floorLog2(uint32_t v) {
    uint32_t l = 0;
    while (v > 1) {
        v >>= 1;
        ++l;
    }
    return l;
}

} // namespace csgv
