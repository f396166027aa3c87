// SPDX-License-Identifier: MIT
#pragma once
/// @file Hash.h
/// @brief The one stable string hash (64-bit FNV-1a) for names of cache files: the same on every
/// machine and run (std::hash is not), not a security boundary (the files are our own).

#include <cstdint>
#include <cstdio>
#include <string>

namespace csgv {

/// 64-bit FNV-1a of `text`, continuing from `h` (chain calls to hash several strings).
inline uint64_t fnv1a64(const std::string& text, uint64_t h = 1469598103934665603ull) {
    for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
    return h;
}

/// fnv1a64 as 16 lowercase hexadecimal digits: a file name stem.
inline std::string fnv1a64Hex(const std::string& text) {
    char hex[17];
    std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(fnv1a64(text)));
    return hex;
}

} // namespace csgv
