// SPDX-License-Identifier: MIT
/// @file FuzzTarget.cpp
/// @brief One fuzz entry point over the container reader and every decoder path. Built two ways:
/// with libFuzzer (clang, ASan, UBSan; Testing/Fuzz/README.md) and, in every ordinary build, as
/// csgv_fuzz_replay, which runs the committed corpus and every crasher ever found.

#include "csgv/codec/Container.h"
#include "csgv/codec/Decoder.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    csgv::Result<csgv::CompressedVolume> vol = csgv::parseCsgv(data, size);
    if (!vol) {
        if (vol.message().empty()) std::abort(); // every failure must say why
        return 0;
    }
    // Decoding cost follows the claimed volume; small claims only, so each input stays fast.
    if (vol->voxelCount() > (uint64_t(1) << 22)) return 0;
    csgv::DecodeOptions o;
    o.threads = 1;
    o.maxOutputBytes = uint64_t(1) << 26;
    const csgv::Status all = csgv::validateStreams(*vol, 1);
    for (uint32_t lod = 0; lod < vol->levels(); ++lod) {
        csgv::Result<csgv::LabelVolume> v = csgv::decodeVolume(*vol, lod, o);
        if (v.isOk() != all.isOk() && lod == 0) std::abort(); // a full check and a decode disagree
        if (v)
            for (uint32_t l : v->labels)
                if (l == csgv::kInvalidLabel) std::abort(); // undefined labels must never escape
    }
    csgv::BrickDecoder dec(*vol);
    for (uint64_t b = 0; b < vol->brickCount() && b < 64; ++b) (void)dec.decode(b, b % vol->levels());
    // Re-serialising what parsed must give the same bytes.
    if (csgv::serializeCsgv(*vol).size() != size) std::abort();
    return 0;
}
