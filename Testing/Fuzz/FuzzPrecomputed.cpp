// SPDX-License-Identifier: MIT
/// @file FuzzPrecomputed.cpp
/// @brief Fuzz entry point over the Neuroglancer precomputed parsers (PrecomputedFormat.h): the
/// `info` JSON document, and compressed_segmentation and raw chunks.
///
/// Input layout: byte 0 picks the parser (0 mod 3: info, 1: compressed_segmentation, 2: raw).
/// For info the rest of the bytes are the document. For chunks bytes 1..7 are the label type
/// (compressed_segmentation: uint32 or uint64; raw: uint8..uint64), the chunk extent (1..16 per
/// axis) and the block size (1..8 per axis); the rest is the chunk. Aborts when a failure has no
/// message or a parsed info breaks what the reader relies on (positive sizes, one chunk size,
/// a block size for compressed_segmentation); sanitizers catch the rest. Seeds in
/// corpus/precomputed are written by Testing/Core/inputs/make_precomputed_seeds.py.

#include "csgv/inputs/PrecomputedFormat.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

namespace {

using namespace csgv;
using namespace csgv::inputs;

void requireMessage(const Status& s) {
    if (!s && s.message().empty()) std::abort(); // every failure must say why
}

void fuzzInfo(const uint8_t* data, size_t size) {
    Result<PrecomputedInfo> info = parsePrecomputedInfo(data, size);
    requireMessage(info.status());
    if (!info) return;
    if (info->scales.empty()) std::abort();
    for (const PrecomputedScale& s : info->scales) {
        for (size_t i = 0; i < 3; ++i) {
            if (s.size[i] == 0 || s.chunkSize[i] == 0) std::abort();
            if (s.encoding == PrecomputedScale::Encoding::CompressedSegmentation && s.blockSize[i] == 0) std::abort();
        }
        if (s.key.empty()) std::abort();
        requireMessage(checkPrecomputedScale(*info, s));
    }
}

void fuzzChunk(bool segmentation, const uint8_t* data, size_t size) {
    if (size < 8) return;
    static const LabelType rawTypes[] = {LabelType::U8, LabelType::U16, LabelType::U32, LabelType::U64};
    const LabelType type = segmentation ? (data[1] & 1 ? LabelType::U64 : LabelType::U32) : rawTypes[data[1] & 3];
    std::array<uint32_t, 3> extent{}, block{};
    for (size_t i = 0; i < 3; ++i) {
        extent[i] = 1 + data[2 + i] % 16;
        block[i] = 1 + data[5 + i] % 8;
    }
    std::vector<uint64_t> out(size_t(extent[0]) * extent[1] * extent[2]);
    const Status s = segmentation ? decodeCompressedSegmentation(data + 8, size - 8, type, extent, block, out.data())
                                  : decodeRawChunk(data + 8, size - 8, type, extent, out.data());
    requireMessage(s);
    if (segmentation && s && compressedSegmentationBound(type, extent, block) < 16) std::abort();
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    switch (data[0] % 3) {
    case 0: fuzzInfo(data + 1, size - 1); break;
    case 1: fuzzChunk(true, data, size); break;
    default: fuzzChunk(false, data, size); break;
    }
    return 0;
}
