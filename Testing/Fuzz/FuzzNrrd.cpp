// SPDX-License-Identifier: MIT
/// @file FuzzNrrd.cpp
/// @brief Fuzz entry point over the Nrrd parser (not yet written: accepts anything).

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    (void)data;
    (void)size;
    return 0;
}
