// SPDX-License-Identifier: MIT
#pragma once
/// @file Png.h
/// @brief PNG output and input through libpng (8-bit RGB or RGBA), written atomically.

#include "csgv/base/Status.h"

#include <cstdint>
#include <string>
#include <vector>

namespace csgv {

/// `pixels` holds `channels` (3 or 4) bytes per pixel, top row first.
Status writePng(const std::string& path, uint32_t width, uint32_t height, uint32_t channels,
                const std::vector<uint8_t>& pixels);

/// Reads 8-bit RGB or RGBA PNGs (what writePng() writes, any filters); `channels`
/// is set to 3 or 4. Other PNGs are refused with a message.
Status readPng(const std::string& path, uint32_t& width, uint32_t& height, uint32_t& channels,
               std::vector<uint8_t>& pixels);

} // namespace csgv
