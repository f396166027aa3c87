// SPDX-License-Identifier: MIT
/// @file FuzzZarr.cpp
/// @brief Fuzz entry point over the Zarr parsers we wrote (Core/include/csgv/inputs/ZarrFormat.h):
/// the `.zarray` and `.zattrs` parsers and the chunk decoder. Built with libFuzzer (README.md)
/// and, in every ordinary build, as csgv_fuzz_replay_zarr over corpus/zarr and crashers/zarr.
///
/// Input framing, by the first byte (mod 4):
///   0: the rest is `.zarray` text;
///   1: the rest is `.zattrs` text;
///   2: a chunk under fixed metadata: bytes 1..6 are compressor (mod 5: none, blosc, zlib, gzip,
///      zstd), dtype (mod 10), order (odd: F), chunk extents z, y, x (1 + byte mod 16); the
///      rest is the stored chunk;
///   3: `.zarray` text, a NUL byte, then a stored chunk decoded under that metadata.
/// Every failure must carry a message; a decoded chunk has exactly the metadata's size and each
/// of its elements is read.

#include "csgv/inputs/ZarrFormat.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

using namespace csgv;
using namespace csgv::inputs;

namespace {

void require(bool condition) {
    if (!condition) std::abort();
}

void decodeAndRead(const ZarrArray& array, const uint8_t* data, size_t size) {
    if (array.chunkBytes() > (uint64_t(1) << 20)) return; // keep each input fast
    std::vector<uint8_t> chunk;
    Status s = decodeZarrChunk(array, data, size, chunk);
    require(s.isOk() || !s.message().empty());
    if (!s) return;
    require(chunk.size() == array.chunkBytes());
    uint64_t value = 0, sum = 0;
    for (uint64_t i = 0; i < array.chunkElements(); ++i)
        if (zarrElement(array, chunk.data(), i, value)) sum += value;
    (void)sum;
}

ZarrArray fixedArray(const uint8_t* h) {
    static const struct {
        LabelType type;
        unsigned bytes;
    } kTypes[] = {{LabelType::U8, 1},  {LabelType::I8, 1},  {LabelType::U16, 2}, {LabelType::I16, 2}, {LabelType::U32, 4},
                  {LabelType::I32, 4}, {LabelType::U64, 8}, {LabelType::I64, 8}, {LabelType::F32, 4}, {LabelType::F64, 8}};
    ZarrArray a;
    a.compressor = ZarrCompressor(h[0] % 5);
    a.type = kTypes[h[1] % 10].type;
    a.itemBytes = kTypes[h[1] % 10].bytes;
    a.bigEndian = h[1] >= 128;
    a.fortranOrder = h[2] % 2 == 1;
    for (int i = 0; i < 3; ++i) {
        a.chunks.push_back(1 + h[3 + i] % 16);
        a.shape.push_back(a.chunks.back());
    }
    return a;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const uint8_t* rest = data + 1;
    const size_t restSize = size - 1;
    switch (data[0] % 4) {
    case 0: {
        Result<ZarrArray> a = parseZarray(std::string(reinterpret_cast<const char*>(rest), restSize));
        require(a.isOk() || !a.message().empty());
        if (a) require(a->chunkElements() > 0 && a->shape.size() == a->chunks.size());
        break;
    }
    case 1: {
        Result<ZarrAttrs> a = parseZattrs(std::string(reinterpret_cast<const char*>(rest), restSize));
        require(a.isOk() || !a.message().empty());
        if (a && a->hasMultiscales) require(!a->datasets.empty());
        break;
    }
    case 2:
        if (restSize < 6) return 0;
        decodeAndRead(fixedArray(rest), rest + 6, restSize - 6);
        break;
    default: {
        const void* nul = std::memchr(rest, 0, restSize);
        if (!nul) return 0;
        const size_t textSize = size_t(static_cast<const uint8_t*>(nul) - rest);
        Result<ZarrArray> a = parseZarray(std::string(reinterpret_cast<const char*>(rest), textSize));
        require(a.isOk() || !a.message().empty());
        if (a) decodeAndRead(*a, rest + textSize + 1, restSize - textSize - 1);
        break;
    }
    }
    return 0;
}
