// SPDX-License-Identifier: MIT
/// @file Zarr.cpp
/// @brief Zarr v2 arrays and OME-Zarr label groups (DIR.zarr[/path]). Not yet implemented.
#include "InputCommon.h"

namespace csgv {
namespace inputs {

bool claimsZarr(const std::string&) { return false; }

Result<std::unique_ptr<InputSource>> openZarr(const std::string& path, const InputOptions&) {
    return fail(path, "Zarr input is not implemented yet");
}

} // namespace inputs
} // namespace csgv
