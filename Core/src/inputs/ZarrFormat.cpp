// SPDX-License-Identifier: MIT
/// @file ZarrFormat.cpp
/// @brief Zarr v2 metadata parsing (`.zarray`, OME `.zattrs`) and chunk decoding from bytes.
/// JSON is parsed without exceptions (nlohmann's allow_exceptions=false) and read only through
/// type-checked accessors; a catch-all keeps any library exception inside Core. A chunk decodes
/// into a buffer of exactly the size the metadata gives (plus one byte that detects a long
/// stream), so no stream can make us allocate or write more than that.
#include "csgv/inputs/ZarrFormat.h"

#include "InputCommon.h"
#include "csgv/base/Checked.h"

#include <blosc.h>
#include <nlohmann/json.hpp>
#include <zlib.h>
#include <zstd.h>
#include <zstd_errors.h>

#include <climits>
#include <cmath>
#include <cstring>
#include <exception>

namespace csgv {
namespace inputs {

using nlohmann::json;

namespace {

/// Largest decoded chunk we accept: zlib and Blosc 1 sizes are 32-bit, and a chunk is held
/// whole in memory while it is copied out.
constexpr uint64_t kMaxChunkBytes = uint64_t(1) << 31;

Status bad(const std::string& what) { return Status::error(what); }

/// Parses text into a JSON object, or says why not. Deep nesting is refused first (InputCommon's
/// kMaxJsonDepth): nothing below then recurses more than that deep.
Result<json> parseObject(const std::string& text, const char* what) {
    if (const std::string deep = jsonTooDeep(text.data(), text.size()); !deep.empty())
        return bad(std::string(what) + " " + deep);
    json j = json::parse(text, nullptr, false);
    if (j.is_discarded()) return bad(std::string(what) + " is not valid JSON");
    if (!j.is_object()) return bad(std::string(what) + " is not a JSON object");
    return j;
}

/// A non-negative integer array (shape, chunks).
Status readSizes(const json& j, const char* key, std::vector<uint64_t>& out) {
    auto it = j.find(key);
    if (it == j.end()) return bad(std::string("missing \"") + key + "\"");
    if (!it->is_array()) return bad(std::string("\"") + key + "\" is not an array: " + jsonText(*it));
    for (const json& v : *it) {
        if (!v.is_number_unsigned()) return bad(std::string("\"") + key + "\" holds " + jsonText(v) + ", not a size");
        out.push_back(v.get<uint64_t>());
    }
    return Status::ok();
}

Status readDtype(const json& j, ZarrArray& a) {
    auto it = j.find("dtype");
    if (it == j.end()) return bad("missing \"dtype\"");
    if (!it->is_string()) return bad("\"dtype\" is not a string: " + jsonText(*it));
    const std::string d = it->get<std::string>();
    const bool shapeOk = d.size() == 3 && (d[0] == '<' || d[0] == '>' || d[0] == '|') && d[2] >= '1' && d[2] <= '8';
    const std::string unsupported = "unsupported dtype " + jsonText(*it) + " (label volumes need |u1 |i1 <u2 <i2 <u4 <i4 <u8 <i8, "
                                    "big-endian > too, or <f4 <f8 holding integers)";
    if (!shapeOk) return bad(unsupported);
    const char kind = d[1];
    const unsigned bytes = unsigned(d[2] - '0');
    struct Row { char kind; unsigned bytes; LabelType type; };
    static const Row kRows[] = {{'u', 1, LabelType::U8},  {'i', 1, LabelType::I8},  {'u', 2, LabelType::U16},
                                {'i', 2, LabelType::I16}, {'u', 4, LabelType::U32}, {'i', 4, LabelType::I32},
                                {'u', 8, LabelType::U64}, {'i', 8, LabelType::I64}, {'f', 4, LabelType::F32},
                                {'f', 8, LabelType::F64}};
    for (const Row& r : kRows)
        if (r.kind == kind && r.bytes == bytes) {
            if (d[0] == '|' && bytes != 1) return bad(unsupported);
            a.type = r.type;
            a.itemBytes = bytes;
            a.bigEndian = d[0] == '>';
            return Status::ok();
        }
    return bad(unsupported);
}

bool isFloat(LabelType t) { return t == LabelType::F32 || t == LabelType::F64; }

Status readFill(const json& j, ZarrArray& a) {
    auto it = j.find("fill_value");
    if (it == j.end() || it->is_null()) return Status::ok(); // absent or null: 0
    const std::string text = "fill_value " + jsonText(*it);
    const bool isSigned = isSignedType(a.type);
    if (it->is_number_unsigned()) {
        const uint64_t v = it->get<uint64_t>();
        const uint64_t maxU = a.itemBytes == 8 ? ~uint64_t(0) : (uint64_t(1) << (8 * a.itemBytes)) - 1;
        const uint64_t maxV = isFloat(a.type) ? (uint64_t(1) << 53) : isSigned ? maxU >> 1 : maxU;
        if (v > maxV) return bad(text + " does not fit dtype " + labelTypeName(a.type));
        a.fill = v;
        return Status::ok();
    }
    if (it->is_number_integer()) { // negative
        const int64_t v = it->get<int64_t>();
        if (!isSigned || (a.itemBytes < 8 && !isFloat(a.type) && v < -(int64_t(1) << (8 * a.itemBytes - 1))))
            return bad(text + " does not fit dtype " + labelTypeName(a.type));
        a.fill = uint64_t(v);
        return Status::ok();
    }
    int64_t v = 0;
    if (it->is_number_float() && floatToInt64(it->get<double>(), v)) {
        if (!isSigned && v < 0) return bad(text + " does not fit dtype " + labelTypeName(a.type));
        a.fill = uint64_t(v);
        return Status::ok();
    }
    // Float arrays often say NaN ("NaN" in the JSON); that matters only where a chunk is missing.
    if (isFloat(a.type) && (it->is_number_float() || it->is_string())) {
        a.fillIsLabel = false;
        return Status::ok();
    }
    return bad(text + " is not an integer label");
}

Status readCompressor(const json& j, ZarrArray& a) {
    auto it = j.find("compressor");
    if (it == j.end() || it->is_null()) {
        a.compressor = ZarrCompressor::None;
        a.compressorText = "none";
        return Status::ok();
    }
    if (!it->is_object() || !it->contains("id") || !(*it)["id"].is_string())
        return bad("\"compressor\" is not an object with an \"id\": " + jsonText(*it));
    const std::string id = (*it)["id"].get<std::string>();
    if (id == "blosc") {
        a.compressor = ZarrCompressor::Blosc;
        const json& c = *it;
        std::string text = "blosc(";
        text += c.contains("cname") && c["cname"].is_string() ? c["cname"].get<std::string>() : std::string("?");
        if (c.contains("shuffle") && c["shuffle"].is_number_integer()) {
            const int64_t s = c["shuffle"].get<int64_t>();
            text += s == 0 ? ", noshuffle" : s == 1 ? ", shuffle" : s == 2 ? ", bitshuffle" : ", autoshuffle";
        }
        a.compressorText = text + ")";
    } else if (id == "zlib") {
        a.compressor = ZarrCompressor::Zlib;
        a.compressorText = "zlib";
    } else if (id == "gzip") {
        a.compressor = ZarrCompressor::Gzip;
        a.compressorText = "gzip";
    } else if (id == "zstd") {
        a.compressor = ZarrCompressor::Zstd;
        a.compressorText = "zstd";
    } else {
        return bad("unsupported compressor " + jsonText((*it)["id"]) + " (supported: blosc, zlib, gzip, zstd, none)");
    }
    return Status::ok();
}

Status readFilters(const json& j) {
    auto it = j.find("filters");
    if (it == j.end() || it->is_null()) return Status::ok();
    if (!it->is_array()) return bad("\"filters\" is not a list: " + jsonText(*it));
    if (it->empty()) return Status::ok();
    const json& f = (*it)[0];
    const std::string id = f.is_object() && f.contains("id") ? jsonText(f["id"]) : jsonText(f);
    return bad("unsupported filter " + id + " (only arrays without filters can be read)");
}

Status readLayout(const json& j, ZarrArray& a) {
    auto order = j.find("order");
    if (order != j.end()) {
        if (*order == "F") a.fortranOrder = true;
        else if (*order != "C") return bad("unsupported order " + jsonText(*order) + " (\"C\" or \"F\")");
    }
    auto sep = j.find("dimension_separator");
    if (sep != j.end() && !sep->is_null()) {
        if (*sep == "/") a.separator = '/';
        else if (*sep != ".") return bad("unsupported dimension_separator " + jsonText(*sep) + " (\".\" or \"/\")");
    }
    return Status::ok();
}

Status checkShape(ZarrArray& a) {
    if (a.shape.size() != a.chunks.size())
        return bad("\"shape\" has " + std::to_string(a.shape.size()) + " axes but \"chunks\" " + std::to_string(a.chunks.size()));
    if (a.shape.size() < 2 || a.shape.size() > 5)
        return bad("arrays of " + std::to_string(a.shape.size()) + " axes are not label volumes (2 to 5 axes: [t, c,] [z,] y, x)");
    uint64_t bytes = a.itemBytes; // stays <= kMaxChunkBytes: checked before each product
    for (uint64_t c : a.chunks) {
        if (c == 0) return bad("a chunk size is 0");
        if (c > kMaxChunkBytes || bytes * c > kMaxChunkBytes)
            return bad("chunks larger than " + std::to_string(kMaxChunkBytes >> 20) + " MiB decoded are not supported");
        bytes *= c;
    }
    return Status::ok();
}

Result<ZarrArray> parseZarrayJson(const json& j) {
    auto format = j.find("zarr_format");
    if (format == j.end()) return bad("missing \"zarr_format\"");
    if (!format->is_number_unsigned() || format->get<uint64_t>() != 2)
        return bad("zarr_format " + jsonText(*format) + " is not supported (only Zarr v2)");
    ZarrArray a;
    for (Status s : {readSizes(j, "shape", a.shape), readSizes(j, "chunks", a.chunks), readDtype(j, a)})
        if (!s) return s;
    for (Status s : {readFill(j, a), readCompressor(j, a), readFilters(j), readLayout(j, a), checkShape(a)})
        if (!s) return s;
    return a;
}

// ---- chunk decoders: each fills `out` (capacity chunkBytes + 1) and reports what it produced.

std::string sizeText(uint64_t got, uint64_t want) {
    return "chunk decodes to " + std::to_string(got) + " bytes, expected " + std::to_string(want);
}

Status decodeRaw(const uint8_t* data, size_t size, uint64_t want, std::vector<uint8_t>& out) {
    if (size != want) return bad("chunk holds " + std::to_string(size) + " bytes, expected " + std::to_string(want) + " (uncompressed)");
    std::memcpy(out.data(), data, size);
    return Status::ok();
}

Status decodeBlosc(const uint8_t* data, size_t size, uint64_t want, std::vector<uint8_t>& out) {
    if (size < BLOSC_MIN_HEADER_LENGTH)
        return bad("blosc chunk of " + std::to_string(size) + " bytes is shorter than its header");
    size_t nbytes = 0, cbytes = 0, blocksize = 0;
    blosc_cbuffer_sizes(data, &nbytes, &cbytes, &blocksize);
    if (cbytes > size)
        return bad("blosc chunk is truncated: its header says " + std::to_string(cbytes) + " bytes, the file holds " + std::to_string(size));
    if (blosc_cbuffer_validate(data, size, &nbytes) < 0) return bad("corrupt blosc chunk (header fails validation)");
    if (nbytes != want) return bad(sizeText(nbytes, want) + " (blosc header)");
    const int n = blosc_decompress_ctx(data, out.data(), size_t(want), 1);
    if (n < 0) return bad("corrupt blosc chunk (blosc_decompress error " + std::to_string(n) + ")");
    if (uint64_t(n) != want) return bad(sizeText(uint64_t(n), want));
    return Status::ok();
}

Status decodeZlib(const uint8_t* data, size_t size, uint64_t want, std::vector<uint8_t>& out, bool gzip) {
    if (size > UINT_MAX) return bad("compressed chunk too large");
    z_stream zs{};
    // 15 + 16: gzip wrapper only; 15: zlib wrapper only.
    if (inflateInit2(&zs, gzip ? 15 + 16 : 15) != Z_OK) return bad("zlib initialisation failed");
    zs.next_in = const_cast<Bytef*>(data);
    zs.avail_in = uInt(size);
    zs.next_out = out.data();
    zs.avail_out = uInt(want + 1);
    const int rc = inflate(&zs, Z_FINISH);
    const uint64_t produced = zs.total_out;
    const std::string msg = zs.msg ? zs.msg : "";
    inflateEnd(&zs);
    const char* name = gzip ? "gzip" : "zlib";
    if (produced > want) return bad("chunk decodes to more than " + std::to_string(want) + " bytes");
    if (rc == Z_STREAM_END) return produced == want ? Status::ok() : bad(sizeText(produced, want));
    if (rc == Z_BUF_ERROR)
        return bad(std::string(name) + " stream is truncated: it ends after " + std::to_string(produced) + " of " + std::to_string(want) + " bytes");
    return bad(std::string("corrupt ") + name + " stream" + (msg.empty() ? "" : " (" + msg + ")"));
}

/// One-shot decoding straight into `out` (want + 1 bytes): the output buffer is the window, so a
/// frame header claiming a large window (up to 2^31 bytes) makes us allocate nothing (streaming
/// decoding would allocate that window whatever the chunk's size).
Status decodeZstd(const uint8_t* data, size_t size, uint64_t want, std::vector<uint8_t>& out) {
    ZSTD_DCtx* ctx = ZSTD_createDCtx();
    if (!ctx) return bad("zstd initialisation failed");
    const size_t r = ZSTD_decompressDCtx(ctx, out.data(), size_t(want + 1), data, size);
    ZSTD_freeDCtx(ctx);
    if (ZSTD_isError(r)) {
        if (ZSTD_getErrorCode(r) == ZSTD_error_dstSize_tooSmall)
            return bad("chunk decodes to more than " + std::to_string(want) + " bytes");
        if (ZSTD_getErrorCode(r) == ZSTD_error_srcSize_wrong)
            return bad("zstd stream is truncated: it ends before its " + std::to_string(want) + " bytes");
        return bad(std::string("corrupt zstd stream (") + ZSTD_getErrorName(r) + ")");
    }
    if (r > want) return bad("chunk decodes to more than " + std::to_string(want) + " bytes");
    if (r != want) return bad(sizeText(r, want));
    return Status::ok();
}

/// Reads one `.zattrs` transformation list ([{type: scale, scale: [...]}, {type: translation, ...}]).
Status readTransforms(const json& list, const std::string& where, std::vector<double>& scale, std::vector<double>& translation) {
    if (!list.is_array()) return bad(where + " coordinateTransformations is not a list");
    for (const json& t : list) {
        if (!t.is_object() || !t.contains("type") || !t["type"].is_string()) return bad(where + " has a transformation without a type");
        const std::string type = t["type"].get<std::string>();
        if (type != "scale" && type != "translation") continue; // identity, path-based: nothing to apply
        auto v = t.find(type);
        if (v == t.end() || !v->is_array()) return bad(where + " " + type + " has no list of numbers");
        std::vector<double>& dst = type == "scale" ? scale : translation;
        dst.clear();
        for (const json& x : *v) {
            if (!x.is_number()) return bad(where + " " + type + " holds " + jsonText(x) + ", not a number");
            dst.push_back(x.get<double>());
        }
    }
    return Status::ok();
}

Status readMultiscale(const json& ms, ZarrAttrs& attrs) {
    if (!ms.is_object()) return bad("multiscales[0] is not an object");
    auto axes = ms.find("axes");
    if (axes != ms.end()) {
        if (!axes->is_array()) return bad("multiscales[0].axes is not a list");
        for (const json& a : *axes) {
            if (a.is_string()) attrs.axes.push_back(a.get<std::string>()); // OME-Zarr 0.3
            else if (a.is_object() && a.contains("name") && a["name"].is_string()) attrs.axes.push_back(a["name"].get<std::string>());
            else return bad("multiscales[0].axes holds " + jsonText(a) + ", not an axis");
        }
    }
    auto ds = ms.find("datasets");
    if (ds == ms.end() || !ds->is_array() || ds->empty()) return bad("multiscales[0] has no datasets");
    for (const json& d : *ds) {
        if (!d.is_object() || !d.contains("path") || !d["path"].is_string()) return bad("multiscales[0].datasets holds an entry without a path");
        OmeDataset level;
        level.path = d["path"].get<std::string>();
        if (d.contains("coordinateTransformations"))
            if (Status s = readTransforms(d["coordinateTransformations"], "dataset " + level.path, level.scale, level.translation); !s)
                return s;
        attrs.datasets.push_back(std::move(level));
    }
    if (ms.contains("coordinateTransformations"))
        if (Status s = readTransforms(ms["coordinateTransformations"], "multiscales[0]", attrs.globalScale, attrs.globalTranslation); !s)
            return s;
    return Status::ok();
}

Result<ZarrAttrs> parseZattrsJson(const json& j) {
    ZarrAttrs attrs;
    auto ms = j.find("multiscales");
    if (ms != j.end()) {
        if (!ms->is_array() || ms->empty()) return bad("\"multiscales\" is not a non-empty list");
        attrs.hasMultiscales = true;
        if (Status s = readMultiscale((*ms)[0], attrs); !s) return s;
    }
    auto labels = j.find("labels");
    if (labels != j.end()) {
        if (!labels->is_array()) return bad("\"labels\" is not a list");
        for (const json& l : *labels) {
            if (!l.is_string()) return bad("\"labels\" holds " + jsonText(l) + ", not a name");
            attrs.labels.push_back(l.get<std::string>());
        }
        attrs.hasLabels = true;
    }
    return attrs;
}

} // namespace

uint64_t ZarrArray::chunkElements() const {
    uint64_t n = 1;
    for (uint64_t c : chunks) n = mulSaturate(n, c); // parseZarray bounds it; a hand-made array saturates
    return n;
}

Result<ZarrArray> parseZarray(const std::string& text) {
    try {
        Result<json> j = parseObject(text, ".zarray");
        if (!j) return j.status();
        return parseZarrayJson(*j);
    } catch (const std::exception& e) { // a library surprise stays inside Core
        return bad(std::string(".zarray could not be read: ") + e.what());
    }
}

Result<ZarrAttrs> parseZattrs(const std::string& text) {
    try {
        Result<json> j = parseObject(text, ".zattrs");
        if (!j) return j.status();
        Result<ZarrAttrs> a = parseZattrsJson(*j);
        if (!a) return bad(".zattrs: " + a.message());
        return a;
    } catch (const std::exception& e) {
        return bad(std::string(".zattrs could not be read: ") + e.what());
    }
}

Status decodeZarrChunk(const ZarrArray& array, const uint8_t* data, size_t size, std::vector<uint8_t>& out) {
    const uint64_t want = array.chunkBytes();
    if (want == 0 || want > kMaxChunkBytes) return bad("chunk size out of range");
    // One spare byte shows a stream that decodes too long.
    if (Status s = resizeOrFail(out, size_t(want + 1), "chunk"); !s)
        return bad("out of memory for a chunk of " + std::to_string(want) + " bytes");
    Status s;
    switch (array.compressor) {
    case ZarrCompressor::None: s = decodeRaw(data, size, want, out); break;
    case ZarrCompressor::Blosc: s = decodeBlosc(data, size, want, out); break;
    case ZarrCompressor::Zlib: s = decodeZlib(data, size, want, out, false); break;
    case ZarrCompressor::Gzip: s = decodeZlib(data, size, want, out, true); break;
    case ZarrCompressor::Zstd: s = decodeZstd(data, size, want, out); break;
    }
    out.resize(size_t(want));
    return s;
}

bool zarrElement(const ZarrArray& array, const uint8_t* chunk, uint64_t index, uint64_t& value, double* notInteger) {
    double bad = 0;
    if (widenSamples(chunk + index * array.itemBytes, array.type, array.bigEndian, &value, 1, bad) == 1) return true;
    if (notInteger) *notInteger = bad;
    return false;
}

} // namespace inputs
} // namespace csgv
