// SPDX-License-Identifier: MIT
/// @file Hdf5.cpp
/// @brief FILE.h5[:/group/dataset] (also .hdf5), through libhdf5. Not yet implemented.
#include "InputCommon.h"

namespace csgv {
namespace inputs {

bool claimsHdf5(const std::string&) { return false; }

Result<std::unique_ptr<InputSource>> openHdf5(const std::string& path, const InputOptions&) {
    return fail(path, "HDF5 input is not implemented yet");
}

} // namespace inputs
} // namespace csgv
