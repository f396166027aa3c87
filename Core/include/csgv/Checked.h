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

} // namespace csgv
