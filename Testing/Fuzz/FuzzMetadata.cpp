// SPDX-License-Identifier: MIT
/// @file FuzzMetadata.cpp
/// @brief Fuzz entry point over the `.csgv.json` sidecar reader (readMetadata, Metadata.h): the
/// input is the file. A failure must name the file; metadata that reads must hold usable values
/// (positive finite spacing, finite origin and direction) and survive writeMetadata and a second
/// readMetadata unchanged.

#include "FuzzFiles.h"

#include "csgv/codec/Metadata.h"

#include <algorithm>
#include <cmath>

using namespace csgv;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = fuzz::scratchDir() + "/fuzz.csgv.json";
    fuzz::writeFile(path, data, size);
    Result<VolumeMetadata> md = readMetadata(path);
    if (!md) {
        fuzz::require(fuzz::namesPath(md.message(), path));
        return 0;
    }
    for (int a = 0; a < 3; ++a) {
        fuzz::require(std::isfinite(md->geometry.spacing[a]) && md->geometry.spacing[a] > 0);
        fuzz::require(std::isfinite(md->geometry.origin[a]));
    }
    for (double v : md->geometry.direction) fuzz::require(std::isfinite(v));
    const bool noDims = md->dim[0] == 0 && md->dim[1] == 0 && md->dim[2] == 0;
    fuzz::require(noDims || (md->dim[0] > 0 && md->dim[1] > 0 && md->dim[2] > 0));

    // What reads must write and read back as it was (a writer always knows the dimensions).
    if (noDims) md->dim = {1, 2, 3};
    const std::string again = fuzz::scratchDir() + "/again.csgv.json";
    fuzz::require(writeMetadata(again, *md).isOk());
    Result<VolumeMetadata> back = readMetadata(again);
    fuzz::require(back.isOk());
    fuzz::require(back->dim == md->dim && back->geometry.spacing == md->geometry.spacing &&
                  back->geometry.origin == md->geometry.origin && back->geometry.direction == md->geometry.direction &&
                  back->originalType == md->originalType && back->relabelled == md->relabelled &&
                  back->source == md->source);

    // Names from outside (an input's file name, a ParaView array name) may be any bytes: writing
    // them must not fail, and what is written must read back.
    md->source.clear();
    for (size_t i = 0; i < size && i < 64; ++i) md->source += char(data[i] ^ 0x80); // never valid UTF-8 text
    md->originalType = md->source;
    fuzz::require(writeMetadata(again, *md).isOk());
    fuzz::require(readMetadata(again).isOk());
    return 0;
}
