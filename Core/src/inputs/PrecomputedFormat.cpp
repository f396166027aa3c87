// SPDX-License-Identifier: MIT
/// @file PrecomputedFormat.cpp
/// @brief Neuroglancer precomputed `info` parsing and chunk decoding (raw, compressed_segmentation)
/// from bytes. Written from the public specifications (volume.md and the compressed_segmentation
/// README); JSON through nlohmann_json with exceptions off, so nothing throws out of here.
#include "csgv/inputs/PrecomputedFormat.h"

#include "InputCommon.h"
#include "csgv/base/Checked.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>

namespace csgv {
namespace inputs {

namespace {

using Json = nlohmann::json;

// Bounds that keep every product below 2^63 and every coordinate inside int64 without rejecting
// any real volume: the largest published ones are about 2^18 voxels along an axis.
constexpr int64_t kMaxExtent = int64_t(1) << 31;
constexpr int64_t kMaxOffset = int64_t(1) << 40;
constexpr int64_t kMaxBlock = 4096;

std::string num(uint64_t v) { return std::to_string(v); }

std::string triple(const std::array<uint32_t, 3>& v) { return num(v[0]) + "x" + num(v[1]) + "x" + num(v[2]); }

/// The JSON value's short form for a message (bounded, never dumping a container).
std::string shown(const Json& v) { return jsonText(v); }

/// The value as an integer in [lo, hi]: a JSON integer, or a number with no fraction (some
/// writers emit 64.0).
bool intIn(const Json& v, int64_t lo, int64_t hi, int64_t& out) {
    int64_t x = 0;
    if (v.is_number_unsigned()) {
        if (v.get<uint64_t>() > uint64_t(hi)) return false;
        x = int64_t(v.get<uint64_t>());
    } else if (v.is_number_integer()) {
        x = v.get<int64_t>();
    } else if (v.is_number_float()) {
        const double d = v.get<double>();
        if (!std::isfinite(d) || std::floor(d) != d || std::fabs(d) > 9e18) return false;
        x = int64_t(d);
    } else {
        return false;
    }
    if (x < lo || x > hi) return false;
    out = x;
    return true;
}

std::string rangeText(int64_t lo, int64_t hi) { return "an integer in " + std::to_string(lo) + ".." + std::to_string(hi); }

/// Reads member `name` of `obj`, an integer in [lo, hi].
Status readInt(const Json& obj, const char* name, int64_t lo, int64_t hi, const std::string& where, int64_t& out) {
    const auto it = obj.find(name);
    if (it == obj.end()) return Status::error(where + "missing \"" + name + "\"");
    if (!intIn(*it, lo, hi, out))
        return Status::error(where + "\"" + name + "\" is " + shown(*it) + ", not " + rangeText(lo, hi));
    return Status::ok();
}

/// Reads `v`, a 3-element array [x, y, z] of integers in [lo, hi] (`name` is for messages).
Status readInt3(const Json& v, const std::string& name, int64_t lo, int64_t hi, const std::string& where,
                std::array<int64_t, 3>& out) {
    if (!v.is_array() || v.size() != 3)
        return Status::error(where + "\"" + name + "\" is " + shown(v) + ", not an [x, y, z] array");
    for (size_t i = 0; i < 3; ++i)
        if (!intIn(v[i], lo, hi, out[i]))
            return Status::error(where + "\"" + name + "\" element " + num(i) + " is " + shown(v[i]) + ", not " +
                                 rangeText(lo, hi));
    return Status::ok();
}

Status readExtent3(const Json& obj, const char* name, int64_t hi, const std::string& where,
                   std::array<uint32_t, 3>& out) {
    const auto it = obj.find(name);
    if (it == obj.end()) return Status::error(where + "missing \"" + name + "\"");
    std::array<int64_t, 3> v{};
    if (Status s = readInt3(*it, name, 1, hi, where, v); !s) return s;
    for (size_t i = 0; i < 3; ++i) out[i] = uint32_t(v[i]);
    return Status::ok();
}

Status readString(const Json& obj, const char* name, const std::string& where, std::string& out) {
    const auto it = obj.find(name);
    if (it == obj.end()) return Status::error(where + "missing \"" + name + "\"");
    if (!it->is_string()) return Status::error(where + "\"" + name + "\" is " + shown(*it) + ", not a string");
    out = it->get<std::string>();
    return Status::ok();
}

Status parseDataType(const std::string& name, LabelType& out) {
    const std::string l = lower(name);
    if (l == "uint8") out = LabelType::U8;
    else if (l == "uint16") out = LabelType::U16;
    else if (l == "uint32") out = LabelType::U32;
    else if (l == "uint64") out = LabelType::U64;
    else
        return Status::error("unsupported \"data_type\" " + shown(Json(name)) +
                             " (labels must be uint8, uint16, uint32 or uint64)");
    return Status::ok();
}

Status parseResolution(const Json& obj, const std::string& where, std::array<double, 3>& out) {
    const auto it = obj.find("resolution");
    if (it == obj.end()) return Status::error(where + "missing \"resolution\"");
    const Json& v = *it;
    if (!v.is_array() || v.size() != 3)
        return Status::error(where + "\"resolution\" is " + shown(v) + ", not an [x, y, z] array");
    for (size_t i = 0; i < 3; ++i) {
        if (!v[i].is_number() || !std::isfinite(v[i].get<double>()) || v[i].get<double>() <= 0)
            return Status::error(where + "\"resolution\" element " + num(i) + " is " + shown(v[i]) +
                                 ", not a positive number");
        out[i] = v[i].get<double>();
    }
    return Status::ok();
}

Status parseEncoding(const Json& obj, const std::string& where, PrecomputedScale& scale) {
    if (Status s = readString(obj, "encoding", where, scale.encodingName); !s) return s;
    const std::string l = lower(scale.encodingName);
    if (l == "raw") {
        scale.encoding = PrecomputedScale::Encoding::Raw;
    } else if (l == "compressed_segmentation") {
        scale.encoding = PrecomputedScale::Encoding::CompressedSegmentation;
        return readExtent3(obj, "compressed_segmentation_block_size", kMaxBlock, where, scale.blockSize);
    } else {
        scale.encoding = PrecomputedScale::Encoding::Other;
    }
    return Status::ok();
}

Status parseScale(const Json& obj, size_t index, PrecomputedScale& scale) {
    const std::string where = "scale " + num(index) + ": ";
    if (!obj.is_object()) return Status::error(where + "is " + shown(obj) + ", not an object");
    if (Status s = readString(obj, "key", where, scale.key); !s) return s;
    if (scale.key.empty()) return Status::error(where + "\"key\" is empty");
    if (Status s = readExtent3(obj, "size", kMaxExtent - 1, where, scale.size); !s) return s;
    if (Status s = parseResolution(obj, where, scale.resolution); !s) return s;
    if (const auto it = obj.find("voxel_offset"); it != obj.end())
        if (Status s = readInt3(*it, "voxel_offset", -kMaxOffset, kMaxOffset, where, scale.voxelOffset); !s) return s;
    const auto chunks = obj.find("chunk_sizes");
    if (chunks == obj.end()) return Status::error(where + "missing \"chunk_sizes\"");
    if (!chunks->is_array() || chunks->empty())
        return Status::error(where + "\"chunk_sizes\" is " + shown(*chunks) + ", not a non-empty array of [x, y, z]");
    std::array<int64_t, 3> c{};
    if (Status s = readInt3((*chunks)[0], "chunk_sizes[0]", 1, kMaxExtent - 1, where, c); !s) return s;
    for (size_t i = 0; i < 3; ++i) scale.chunkSize[i] = uint32_t(c[i]);
    if (Status s = parseEncoding(obj, where, scale); !s) return s;
    // A block larger than the chunk would make the encoding's size bound (and its headers) grow
    // with the block, not with the chunk's voxels; no writer produces one.
    if (scale.encoding == PrecomputedScale::Encoding::CompressedSegmentation)
        for (size_t i = 0; i < 3; ++i)
            if (scale.blockSize[i] > scale.chunkSize[i])
                return Status::error(where + "\"compressed_segmentation_block_size\" " + triple(scale.blockSize) +
                                     " is larger than the chunk size " + triple(scale.chunkSize));
    const auto sharding = obj.find("sharding");
    scale.sharded = sharding != obj.end() && !sharding->is_null();
    return Status::ok();
}

uint32_t word(const uint8_t* p, uint64_t index) {
    p += index * 4;
    return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

/// @brief One channel of compressed_segmentation data: its words, and the block grid over the chunk.
struct SegmentationChannel {
    const uint8_t* bytes = nullptr; ///< the whole chunk
    uint64_t begin = 0;             ///< first word of the channel (offsets are relative to it)
    uint64_t words = 0;             ///< words from begin to the end of the data
    unsigned valueWords = 1;        ///< 1 for uint32, 2 for uint64
    std::array<uint32_t, 3> extent{}, block{}, grid{};

    uint32_t at(uint64_t relative) const { return word(bytes, begin + relative); }
};

std::string blockName(const std::array<uint32_t, 3>& b) {
    return "block (" + num(b[0]) + ", " + num(b[1]) + ", " + num(b[2]) + ")";
}

/// Decodes one block of the grid into the chunk's voxels, checking its header against the data.
Status decodeBlock(const SegmentationChannel& ch, const std::array<uint32_t, 3>& b, uint64_t* out) {
    const uint64_t headerIndex = b[0] + uint64_t(ch.grid[0]) * (b[1] + uint64_t(ch.grid[1]) * b[2]);
    const uint32_t h0 = ch.at(2 * headerIndex), h1 = ch.at(2 * headerIndex + 1);
    const uint64_t table = h0 & 0xFFFFFFu;
    const unsigned bits = h0 >> 24;
    const uint64_t values = h1;
    if (bits != 0 && bits != 1 && bits != 2 && bits != 4 && bits != 8 && bits != 16 && bits != 32)
        return Status::error("compressed_segmentation " + blockName(b) + " has " + num(bits) +
                             " encoded bits (must be 0, 1, 2, 4, 8, 16 or 32)");
    // The voxels of this block inside the chunk (the last block of a row may be clipped).
    std::array<uint32_t, 3> lo{}, n{};
    for (size_t i = 0; i < 3; ++i) {
        lo[i] = b[i] * ch.block[i];
        n[i] = std::min(ch.block[i], ch.extent[i] - lo[i]);
    }
    const uint64_t lastPosition = (n[0] - 1) + uint64_t(ch.block[0]) * ((n[1] - 1) + uint64_t(ch.block[1]) * (n[2] - 1));
    const uint64_t valueWordsNeeded = bits == 0 ? 0 : (lastPosition * bits) / 32 + 1;
    if (bits != 0 && (values > ch.words || valueWordsNeeded > ch.words - values))
        return Status::error("compressed_segmentation " + blockName(b) + ": encoded values at word " + num(values) +
                             " (" + num(valueWordsNeeded) + " words) run past the " + num(ch.words) +
                             " words of data");
    const uint64_t entries = table > ch.words ? 0 : (ch.words - table) / ch.valueWords;
    if (entries == 0)
        return Status::error("compressed_segmentation " + blockName(b) + ": lookup table offset " + num(table) +
                             " is outside the " + num(ch.words) + " words of data");
    const uint32_t mask = bits == 32 ? 0xFFFFFFFFu : (uint32_t(1) << bits) - 1;
    for (uint32_t z = 0; z < n[2]; ++z)
        for (uint32_t y = 0; y < n[1]; ++y) {
            uint64_t* row = out + lo[0] + uint64_t(ch.extent[0]) * ((lo[1] + y) + uint64_t(ch.extent[1]) * (lo[2] + z));
            for (uint32_t x = 0; x < n[0]; ++x) {
                uint64_t index = 0;
                if (bits != 0) {
                    const uint64_t bit = (x + uint64_t(ch.block[0]) * (y + uint64_t(ch.block[1]) * z)) * bits;
                    index = (ch.at(values + bit / 32) >> (bit % 32)) & mask;
                }
                if (index >= entries)
                    return Status::error("compressed_segmentation " + blockName(b) + ": lookup table index " +
                                         num(index) + " at word " + num(table) + " runs past the " + num(ch.words) +
                                         " words of data");
                const uint64_t e = table + index * ch.valueWords;
                row[x] = ch.valueWords == 1 ? ch.at(e) : (uint64_t(ch.at(e)) | uint64_t(ch.at(e + 1)) << 32);
            }
        }
    return Status::ok();
}

} // namespace

Result<PrecomputedInfo> parsePrecomputedInfo(const uint8_t* data, size_t size) {
    // Deep nesting is refused before parsing: nothing below then recurses more than that deep.
    if (const std::string deep = jsonTooDeep(reinterpret_cast<const char*>(data), size); !deep.empty())
        return Status::error(deep);
    const Json doc = Json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
    if (doc.is_discarded()) return Status::error("is not valid JSON");
    if (!doc.is_object()) return Status::error("is " + shown(doc) + ", not a JSON object");
    PrecomputedInfo info;
    if (Status s = readString(doc, "type", "", info.volumeType); !s) return s;
    if (info.volumeType != "segmentation" && info.volumeType != "image")
        return Status::error("\"type\" is " + shown(Json(info.volumeType)) + " (must be \"segmentation\" or \"image\")");
    std::string dataType;
    if (Status s = readString(doc, "data_type", "", dataType); !s) return s;
    if (Status s = parseDataType(dataType, info.type); !s) return s;
    int64_t channels = 0;
    if (Status s = readInt(doc, "num_channels", 0, std::numeric_limits<int64_t>::max(), "", channels); !s) return s;
    if (channels != 1)
        return Status::error("\"num_channels\" is " + std::to_string(channels) + " (a label volume has 1 channel)");
    const auto scales = doc.find("scales");
    if (scales == doc.end()) return Status::error("missing \"scales\"");
    if (!scales->is_array() || scales->empty())
        return Status::error("\"scales\" is " + shown(*scales) + ", not a non-empty array");
    // One at a time: a list of many empty entries fails at its first, before anything is held.
    for (size_t i = 0; i < scales->size(); ++i) {
        PrecomputedScale scale;
        if (Status s = parseScale((*scales)[i], i, scale); !s) return s;
        info.scales.push_back(std::move(scale));
    }
    return info;
}

Status checkPrecomputedScale(const PrecomputedInfo& info, const PrecomputedScale& scale) {
    const std::string where = "scale " + shown(Json(scale.key)) + ": ";
    if (scale.sharded) return Status::error(where + "sharded precomputed volumes are not supported");
    if (scale.encoding == PrecomputedScale::Encoding::Other)
        return Status::error(where + "encoding " + shown(Json(scale.encodingName)) +
                             " is not supported (labels need \"raw\" or \"compressed_segmentation\")");
    if (scale.encoding == PrecomputedScale::Encoding::CompressedSegmentation && info.type != LabelType::U32 &&
        info.type != LabelType::U64)
        return Status::error(where + "compressed_segmentation needs uint32 or uint64 labels, not " +
                             labelTypeName(info.type));
    return Status::ok();
}

Status decodeRawChunk(const uint8_t* data, size_t size, LabelType type, const std::array<uint32_t, 3>& extent,
                      uint64_t* out) {
    const unsigned width = typeBytes(type);
    const uint64_t voxels = product3(extent[0], extent[1], extent[2]);
    const uint64_t bytes = mulSaturate(voxels, width);
    if (bytes == kSaturated || size != bytes)
        return Status::error("raw chunk has " + num(size) + " bytes, expected " + num(bytes) + " (" +
                             triple(extent) + " voxels of " + labelTypeName(type) + ")");
    // Unsigned little-endian integers (checkPrecomputedScale's types): no value can fail.
    return decodeVoxels(data, type, false, extent, std::string(), 0, out, size_t(voxels));
}

Status decodeCompressedSegmentation(const uint8_t* data, size_t size, LabelType type,
                                    const std::array<uint32_t, 3>& extent, const std::array<uint32_t, 3>& blockSize,
                                    uint64_t* out) {
    if (type != LabelType::U32 && type != LabelType::U64)
        return Status::error(std::string("compressed_segmentation needs uint32 or uint64 labels, not ") +
                             labelTypeName(type));
    for (size_t i = 0; i < 3; ++i)
        if (extent[i] == 0 || blockSize[i] == 0)
            return Status::error("compressed_segmentation chunk " + triple(extent) + " in blocks of " +
                                 triple(blockSize) + ": sizes must be positive");
    if (size % 4 != 0)
        return Status::error("compressed_segmentation data of " + num(size) +
                             " bytes is not a whole number of 32-bit words");
    const uint64_t words = size / 4;
    if (words < 1) return Status::error("compressed_segmentation data is empty");
    // One channel: word 0 is where its data starts, in words from the start of the chunk.
    SegmentationChannel ch;
    ch.bytes = data;
    ch.begin = word(data, 0);
    if (ch.begin < 1 || ch.begin >= words)
        return Status::error("compressed_segmentation channel offset " + num(ch.begin) + " is outside the " +
                             num(words) + " words of data");
    ch.words = words - ch.begin;
    ch.valueWords = type == LabelType::U64 ? 2 : 1;
    ch.extent = extent;
    ch.block = blockSize;
    for (size_t i = 0; i < 3; ++i) ch.grid[i] = (extent[i] + blockSize[i] - 1) / blockSize[i];
    const uint64_t blocks = product3(ch.grid[0], ch.grid[1], ch.grid[2]);
    if (mulSaturate(2, blocks) > ch.words)
        return Status::error("compressed_segmentation data of " + num(ch.words) + " words is too short for the " +
                             num(blocks) + " block headers of a " + triple(extent) + " chunk in blocks of " +
                             triple(blockSize));
    std::array<uint32_t, 3> b{};
    for (b[2] = 0; b[2] < ch.grid[2]; ++b[2])
        for (b[1] = 0; b[1] < ch.grid[1]; ++b[1])
            for (b[0] = 0; b[0] < ch.grid[0]; ++b[0])
                if (Status s = decodeBlock(ch, b, out); !s) return s;
    return Status::ok();
}

uint64_t compressedSegmentationBound(LabelType type, const std::array<uint32_t, 3>& extent,
                                     const std::array<uint32_t, 3>& blockSize) {
    uint64_t blocks = 1, padded = 1;
    for (size_t i = 0; i < 3; ++i) {
        const uint64_t g = blockSize[i] == 0 ? extent[i] : (uint64_t(extent[i]) + blockSize[i] - 1) / blockSize[i];
        blocks = mulSaturate(blocks, g);
        padded = mulSaturate(padded, mulSaturate(g, std::max<uint32_t>(blockSize[i], 1)));
    }
    const uint64_t valueWords = type == LabelType::U64 ? 2 : 1;
    // Channel offset, headers, 32-bit values and a full table for every voxel of the padded grid.
    const uint64_t words = mulSaturate(2, blocks);
    const uint64_t table = mulSaturate(padded, 1 + valueWords);
    if (words == kSaturated || table == kSaturated || words + table >= kSaturated / 8) return kSaturated;
    return 4 * (1 + words + table) + 4096;
}

} // namespace inputs
} // namespace csgv
