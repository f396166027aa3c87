// SPDX-License-Identifier: MIT
/// @file Precomputed.cpp
/// @brief Neuroglancer precomputed segmentation (a local folder with an info file). Not yet implemented.
#include "InputCommon.h"

namespace csgv {
namespace inputs {

bool claimsPrecomputed(const std::string&) { return false; }

Result<std::unique_ptr<InputSource>> openPrecomputed(const std::string& path, const InputOptions&) {
    return fail(path, "precomputed input is not implemented yet");
}

} // namespace inputs
} // namespace csgv
