// SPDX-License-Identifier: MIT
/// @file Seeds.cpp
/// @brief Writes the fuzz seed corpus: tiny procedural volumes in every encoding, a few brick
/// sizes and the interesting operation masks.

#include "csgv/codec/Encoder.h"
#include "csgv/inputs/Procedural.h"

#include <cstdio>
#include <string>

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: csgv_fuzz_seeds FOLDER\n");
        return 1;
    }
    csgv::SynthSpec spec;
    spec.dim = {19, 13, 11};
    spec.cellSize = 4;
    const csgv::LabelVolume v = *csgv::generateVolume(spec);
    int written = 0;
    for (int32_t enc : {0, 1, 2})
        for (uint32_t b : {8u, 16u})
            for (const char* ops : {"default", "all", "pnl", "s"}) {
                csgv::EncodeOptions o;
                o.encoding = enc;
                o.brickSize = b;
                o.opMask = *csgv::parseOperationMask(ops);
                csgv::Result<csgv::CompressedVolume> c = csgv::encodeVolume(v, o);
                if (!c) return 1;
                const std::string path = std::string(argv[1]) + "/seed_" + csgv::encodingName(enc) + "_b" +
                                         std::to_string(b) + "_" + ops + ".csgv";
                if (!csgv::writeCsgv(path, *c)) return 1;
                ++written;
            }
    std::printf("wrote %d seeds\n", written);
    return 0;
}
