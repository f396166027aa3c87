// SPDX-License-Identifier: MIT
/// @file Inputs.cpp
/// @brief The label types, and the dispatcher that picks a format reader by the file name's
/// suffix. Each format lives in its own file (Nrrd.cpp, Nifti.cpp, Vraw.cpp); a new format is
/// one new file and one row in kFormats.
#include "InputCommon.h"

namespace csgv {

const char* labelTypeName(LabelType type) {
    switch (type) {
    case LabelType::U8: return "uint8";
    case LabelType::I8: return "int8";
    case LabelType::U16: return "uint16";
    case LabelType::I16: return "int16";
    case LabelType::U32: return "uint32";
    case LabelType::I32: return "int32";
    case LabelType::U64: return "uint64";
    case LabelType::I64: return "int64";
    case LabelType::F32: return "float32";
    case LabelType::F64: return "float64";
    }
    return "unknown";
}

bool isSignedType(LabelType type) {
    // Floats count as signed: their integers are stored as int64 and may be negative.
    switch (type) {
    case LabelType::I8:
    case LabelType::I16:
    case LabelType::I32:
    case LabelType::I64:
    case LabelType::F32:
    case LabelType::F64: return true;
    default: return false;
    }
}

namespace {

/// @brief A file name suffix (lower case) and the reader of files that end with it.
struct Format {
    const char* suffix;
    Result<InputVolume> (*read)(const std::string& path, uint64_t maxBytes);
};

// In the order the unsupported-format message lists them.
const Format kFormats[] = {
    {".vraw", inputs::readVrawInput}, {".vraw.gz", inputs::readVrawInput},
    {".nrrd", readNrrd},              {".nhdr", readNrrd},
    {".nii", readNifti},              {".nii.gz", readNifti},
};

std::string supportedSuffixes() {
    std::string list;
    const size_t n = sizeof kFormats / sizeof kFormats[0];
    for (size_t i = 0; i < n; ++i) list += std::string(i == 0 ? "" : i + 1 == n ? " and " : ", ") + kFormats[i].suffix;
    return list;
}

} // namespace

Result<InputVolume> readInput(const std::string& path, uint64_t maxBytes) {
    const std::string name = inputs::lower(path);
    for (const Format& f : kFormats)
        if (inputs::endsWith(name, f.suffix)) return f.read(path, maxBytes);
    return inputs::fail(path, "unsupported input format; supported suffixes are " + supportedSuffixes());
}

} // namespace csgv
