// SPDX-License-Identifier: MIT
/// @file Inputs.cpp
/// @brief The label types, the format table that recognises an input by its form and opens it,
/// and whole-volume reading on top of any source. Each format lives in its own file (Vraw.cpp,
/// Nrrd.cpp, Nifti.cpp, Hdf5.cpp, Tiff.cpp, Zarr.cpp, Precomputed.cpp); a new format is one new
/// file and one row in kFormats.
#include "InputCommon.h"

#include "csgv/base/Checked.h"

#include <algorithm>

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

/// @brief One input format: how a path is recognised and how it is opened.
struct Format {
    const char* forms;      ///< for messages, in the order they are listed
    const char* extensions; ///< file name extensions ParaView's reader factory offers it for
    const char* patterns;   ///< ... and file names it matches (the files inside a folder format)
    bool (*claims)(const std::string& path);
    Result<std::unique_ptr<InputSource>> (*open)(const std::string& path, const InputOptions& options);
};

// First match wins: folders that are Zarr or precomputed are claimed before a TIFF folder.
// One row a line, in this form: cmake/CSGVTables.cmake reads the extensions and patterns of each
// (by its opener's name) into the readers' server-manager XML (Plugin/CSGV/CSGVReaders.xml.in).
// clang-format off
const Format kFormats[] = {
    {"`.vraw`, `.vraw.gz`", "vraw vraw.gz", "", inputs::claimsVraw, inputs::openVraw},
    {"`.nrrd`, `.nhdr`", "nrrd nhdr", "", inputs::claimsNrrd, inputs::openNrrd},
    {"`.nii`, `.nii.gz`", "nii nii.gz", "", inputs::claimsNifti, inputs::openNifti},
    {"`FILE.h5[:/dataset]`, `FILE.hdf5[:/dataset]`", "h5 hdf5", "", inputs::claimsHdf5, inputs::openHdf5},
    {"`DIR.zarr[/path]`", "", ".zarray .zgroup .zattrs", inputs::claimsZarr, inputs::openZarr},
    {"a Neuroglancer precomputed folder `DIR[/info][#scale]`", "", "info", inputs::claimsPrecomputed, inputs::openPrecomputed},
    {"`.tif`, `.tiff`, a folder or a glob of TIFF slices", "tif tiff", "", inputs::claimsTiff, inputs::openTiff},
};
// clang-format on

const Format* formatOf(const std::string& path) {
    for (const Format& f : kFormats)
        if (f.claims(path)) return &f;
    return nullptr;
}

} // namespace

bool isInputPath(const std::string& path) { return formatOf(path) != nullptr; }

std::string supportedInputForms() {
    std::string list;
    const size_t n = sizeof kFormats / sizeof kFormats[0];
    for (size_t i = 0; i < n; ++i) list += std::string(i == 0 ? "" : i + 1 == n ? " and " : ", ") + kFormats[i].forms;
    return list;
}

Status InputSource::readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) {
    if (y0 == 0 && rows == m_info.dim[1]) return readSlab(z0, depth, out);
    return Status::error(m_info.format + " input reads whole slices only");
}

Result<std::unique_ptr<InputSource>> openInput(const std::string& path, const InputOptions& options) {
    const Format* f = formatOf(path);
    if (!f) return inputs::fail(path, "unsupported input format; supported are " + supportedInputForms());
    Result<std::unique_ptr<InputSource>> source = f->open(path, options);
    if (!source) return source;
    if (Status s = inputs::checkDimensions((*source)->info(), path); !s) return s;
    return source;
}

Result<InputVolume> readAll(InputSource& source, const std::string& path, uint64_t maxBytes) {
    const InputInfo& info = source.info();
    const std::array<uint64_t, 3> d = {info.dim[0], info.dim[1], info.dim[2]};
    if (Status s = inputs::checkBudget(path, d, maxBytes); !s) return s;
    InputVolume vol;
    vol.dim = info.dim;
    vol.type = info.type;
    vol.geometry = info.geometry;
    try {
        vol.values.resize(size_t(info.voxelCount()));
    } catch (const std::bad_alloc&) {
        return inputs::fail(path, "out of memory for " + std::to_string(info.voxelCount()) + " voxels");
    }
    const uint64_t slice = uint64_t(info.dim[0]) * info.dim[1];
    const uint32_t step = uint32_t(std::max<uint64_t>(1, std::min<uint64_t>(info.dim[2], (uint64_t(64) << 20) / std::max<uint64_t>(slice, 1))));
    for (uint32_t z = 0; z < info.dim[2]; z += step) {
        const uint32_t depth = std::min(step, info.dim[2] - z);
        if (Status s = source.readSlab(z, depth, vol.values.data() + slice * z); !s) return s;
    }
    return vol;
}

Result<InputVolume> readInput(const std::string& path, uint64_t maxBytes) {
    Result<std::unique_ptr<InputSource>> src = openInput(path);
    if (!src) return src.status();
    return readAll(**src, path, maxBytes);
}

} // namespace csgv
