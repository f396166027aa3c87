// SPDX-License-Identifier: MIT
#pragma once
/// @file ZarrFormat.h
/// @brief The parts of Zarr v2 / OME-Zarr input that work on bytes alone: the `.zarray` and
/// `.zattrs` parsers and the chunk decoder (none, Blosc, zlib, gzip, zstd). Public so that the
/// fuzz target (Testing/Fuzz/FuzzZarr.cpp) can reach them; the reader on files is
/// Core/src/inputs/Zarr.cpp. Nothing here throws: every failure is a Status with a message.
/// Memory: decodeZarrChunk never produces more than ZarrArray::chunkBytes() bytes, whatever the
/// compressed stream claims.

#include "csgv/base/Checked.h"
#include "csgv/base/Status.h"
#include "csgv/inputs/Inputs.h"

#include <cstdint>
#include <string>
#include <vector>

namespace csgv {
namespace inputs {

enum class ZarrCompressor { None, Blosc, Zlib, Gzip, Zstd };

/// @brief A parsed `.zarray` (zarr_format 2), limited to what label volumes need.
struct ZarrArray {
    std::vector<uint64_t> shape;  ///< array axes, slowest first (as in the file)
    std::vector<uint64_t> chunks; ///< chunk shape, same axes
    LabelType type = LabelType::U8;
    unsigned itemBytes = 1;
    bool bigEndian = false;
    bool fortranOrder = false;    ///< order "F": the first axis varies fastest inside a chunk
    uint64_t fill = 0;            ///< fill_value at full width (null = 0)
    bool fillIsLabel = true;      ///< false for a float array's NaN (or fractional) fill_value:
                                  ///< only a missing chunk, which would need it, is then an error
    ZarrCompressor compressor = ZarrCompressor::None;
    std::string compressorText;   ///< for details: "none", "blosc(lz4)", "zlib", "gzip", "zstd"
    char separator = '.';         ///< dimension_separator

    /// Elements in one (full-size) chunk; edge chunks are stored full-size too.
    uint64_t chunkElements() const;
    uint64_t chunkBytes() const { return mulSaturate(chunkElements(), itemBytes); }
};

/// Parses `.zarray` text. Refuses (with a message naming the key) what the reader cannot
/// decode: other zarr_format, dtypes other than |u1 |i1 <u2..<i8 >u2..>i8 <f4 <f8 >f4 >f8,
/// compressors other than blosc/zlib/gzip/zstd, any filter, more than 5 or fewer than 2 axes,
/// zero or oversized chunks (a chunk larger than 2 GiB decoded), JSON nested more than 64 levels.
Result<ZarrArray> parseZarray(const std::string& text);

/// Decodes one stored chunk into exactly `array.chunkBytes()` bytes (`out` is resized to that).
/// A stream that decodes to fewer or more bytes is an error giving both sizes; the caller
/// prefixes the chunk file's name.
Status decodeZarrChunk(const ZarrArray& array, const uint8_t* data, size_t size, std::vector<uint8_t>& out);

/// Reads element `index` of a decoded chunk as a full-width label (Inputs.h: signed values
/// sign-extended, floats holding integers as int64 bits). False when a float element is not an
/// integer (fraction, NaN, infinity or out of int64 range); its value then goes to `notInteger`
/// when given.
bool zarrElement(const ZarrArray& array, const uint8_t* chunk, uint64_t index, uint64_t& value,
                 double* notInteger = nullptr);

/// @brief One OME-Zarr multiscale level: its path and its own scale/translation (array axes).
struct OmeDataset {
    std::string path;
    std::vector<double> scale;       ///< empty when absent
    std::vector<double> translation; ///< empty when absent
};

/// @brief What a group's `.zattrs` says that the reader uses.
struct ZarrAttrs {
    bool hasMultiscales = false;
    std::vector<OmeDataset> datasets;  ///< of multiscales[0], full resolution first
    std::vector<std::string> axes;     ///< axis names of multiscales[0] ("t", "c", "z", "y", "x"); empty when absent
    std::vector<double> globalScale;   ///< multiscales[0].coordinateTransformations; empty when absent
    std::vector<double> globalTranslation;
    bool hasLabels = false;
    std::vector<std::string> labels;   ///< the "labels" list of a `labels` group
};

/// Parses `.zattrs` text (any JSON object; unknown keys are ignored, known keys of the wrong
/// shape are errors naming them).
Result<ZarrAttrs> parseZattrs(const std::string& text);

} // namespace inputs
} // namespace csgv
