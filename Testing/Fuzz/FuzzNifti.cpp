// SPDX-License-Identifier: MIT
/// @file FuzzNifti.cpp
/// @brief Fuzz entry point over the NIfTI-1 header parser that openInput() runs on every `.nii`
/// and `.nii.gz` (parseNiftiHeader, HeaderFormats.h): the input is the (inflated) file's first
/// bytes. A failure must name the file and say why; a header that parses must describe a volume
/// the readers can use.

#include "csgv/inputs/HeaderFormats.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string name = "fuzz.nii";
    csgv::Result<csgv::inputs::NiftiHeader> h = csgv::inputs::parseNiftiHeader(data, size, name);
    if (!h) {
        // Every failure names the file and says what is wrong.
        if (h.message().size() <= name.size() + 2 || h.message().compare(0, name.size(), name) != 0) std::abort();
        return 0;
    }
    if (size < csgv::inputs::kNiftiHeaderBytes) std::abort();
    for (uint32_t d : h->dim)
        if (d == 0 || d > 32767) std::abort(); // dim[] are int16
    for (int a = 0; a < 3; ++a)
        if (!(std::isfinite(h->geometry.spacing[a]) && h->geometry.spacing[a] > 0) ||
            !std::isfinite(h->geometry.origin[a]))
            std::abort();
    for (double v : h->geometry.direction)
        if (!std::isfinite(v)) std::abort();
    if (h->voxOffset < csgv::inputs::kNiftiHeaderBytes) std::abort();
    return 0;
}
