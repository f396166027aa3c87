// SPDX-License-Identifier: MIT
/// @file Tiff.cpp
/// @brief TIFF: a multi-page file (pages = z), or a folder or glob of 2D slices sorted by name, through libtiff. Not yet implemented.
#include "InputCommon.h"

namespace csgv {
namespace inputs {

bool claimsTiff(const std::string&) { return false; }

Result<std::unique_ptr<InputSource>> openTiff(const std::string& path, const InputOptions&) {
    return fail(path, "TIFF input is not implemented yet");
}

} // namespace inputs
} // namespace csgv
