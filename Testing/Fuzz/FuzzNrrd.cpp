// SPDX-License-Identifier: MIT
/// @file FuzzNrrd.cpp
/// @brief Fuzz entry point over the NRRD header parser that openInput() runs on every `.nrrd` and
/// `.nhdr` (parseNrrdHeader, HeaderFormats.h): the input is a file's first bytes. A failure must
/// name the file and say why; a header that parses must describe a volume the readers can use.

#include "csgv/inputs/HeaderFormats.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string name = "fuzz.nrrd";
    const std::string text(reinterpret_cast<const char*>(data), size);
    csgv::Result<csgv::inputs::NrrdHeader> h = csgv::inputs::parseNrrdHeader(text, name);
    if (!h) {
        // Every failure names the file and says what is wrong.
        if (h.message().size() <= name.size() + 2 || h.message().compare(0, name.size(), name) != 0) std::abort();
        return 0;
    }
    for (uint32_t d : h->dim)
        if (d == 0) std::abort();
    for (int a = 0; a < 3; ++a)
        if (!(std::isfinite(h->geometry.spacing[a]) && h->geometry.spacing[a] > 0) ||
            !std::isfinite(h->geometry.origin[a]))
            std::abort();
    for (double v : h->geometry.direction)
        if (!std::isfinite(v)) std::abort();
    // The readers compute byte counts from these without further checks.
    const uint64_t voxels = h->voxelCount();
    if (voxels / h->dim[0] / h->dim[1] != h->dim[2] || voxels > (~uint64_t(0)) / 8) std::abort();
    if (h->lineSkip < 0 || h->byteSkip < -1 || (h->gzip && h->byteSkip == -1)) std::abort();
    if (h->dataFile.empty() && !h->attached) std::abort(); // where would the data be?
    if (h->attached && (h->dataOffset == 0 || h->dataOffset > size)) std::abort();
    return 0;
}
