// SPDX-License-Identifier: MIT
/// @file Nifti.cpp
/// @brief NIfTI-1 single files (`.nii`, `.nii.gz`) as a streaming source: the header is checked
/// whole at open (parseNiftiHeader, also the fuzz target's entry), then the voxels are read slab
/// by slab by VoxelFileSource: positioned reads of each slab's bytes in a plain file (one too
/// short for its voxels is refused at open), one gzip stream kept open between slabs otherwise.
/// Working memory: VoxelFileSource's (a decode buffer and a gzip stream, and for gzip read in
/// bands of rows one inflated slab, in memory up to 64 MiB, else in a scratch file).
#include "InputCommon.h"

#include "csgv/inputs/HeaderFormats.h"

#include <cmath>
#include <cstring>

namespace csgv {

using namespace inputs;

namespace {

/// @brief Reads fields of a NIfTI-1 header in the file's byte order.
struct NiftiFields {
    const uint8_t* p;
    bool big;
    uint64_t raw(size_t off, unsigned w) const {
        uint64_t v = 0;
        if (big)
            for (unsigned b = 0; b < w; ++b) v = (v << 8) | p[off + b];
        else
            for (unsigned b = w; b-- > 0;) v = (v << 8) | p[off + b];
        return v;
    }
    int16_t i16(size_t off) const { return int16_t(uint16_t(raw(off, 2))); }
    int32_t i32(size_t off) const { return int32_t(uint32_t(raw(off, 4))); }
    double f32(size_t off) const {
        const uint32_t bits = uint32_t(raw(off, 4));
        float f;
        std::memcpy(&f, &bits, 4);
        return f;
    }
};

bool niftiType(int code, LabelType& type) {
    switch (code) {
    case 2: type = LabelType::U8; return true;
    case 4: type = LabelType::I16; return true;
    case 8: type = LabelType::I32; return true;
    case 16: type = LabelType::F32; return true;
    case 64: type = LabelType::F64; return true;
    case 256: type = LabelType::I8; return true;
    case 512: type = LabelType::U16; return true;
    case 768: type = LabelType::U32; return true;
    case 1024: type = LabelType::I64; return true;
    case 1280: type = LabelType::U64; return true;
    default: return false;
    }
}

const char* niftiTypeName(int code) {
    switch (code) {
    case 1: return "binary";
    case 32: return "complex64";
    case 128: return "RGB24";
    case 1536: return "float128";
    case 1792: return "complex128";
    case 2048: return "complex256";
    case 2304: return "RGBA32";
    default: return "unknown";
    }
}

/// Words a stream failure as gzread's users always have ("cannot inflate" also for plain files,
/// whose reads go through the same stream).
Status streamError(const std::string& path, const InputStream& stream, const Status& s) {
    if (stream.failure() == InputStream::Failure::Open) return Status::error("cannot open '" + path + "': " + s.message());
    return Status::error("cannot inflate '" + path + "': " + path + ": " + s.message());
}

/// nifti1_io's rule: a pixdim that is not positive counts as 1.
double niftiSpacing(double v) { return std::isfinite(v) && v > 0 ? v : 1.0; }

/// Spacing, direction and origin: the sform when its code is set, else the qform, else pixdim.
Status niftiGeometry(const NiftiFields& hf, const std::string& path, Geometry& g) {
    const int qformCode = hf.i16(252), sformCode = hf.i16(254);
    double pixdim[8];
    for (int i = 0; i < 8; ++i) pixdim[i] = hf.f32(76 + 4 * size_t(i));
    if (sformCode > 0) {
        double m[3][4];
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) m[r][c] = hf.f32(280 + 16 * size_t(r) + 4 * size_t(c));
        for (int c = 0; c < 3; ++c) {
            const double norm = std::sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
            if (!std::isfinite(norm) || norm == 0)
                return fail(path, "sform (sform_code " + std::to_string(sformCode) + ") column " + std::to_string(c) +
                                      " has no usable length");
            g.spacing[size_t(c)] = norm;
            for (int r = 0; r < 3; ++r) g.direction[size_t(3 * r + c)] = m[r][c] / norm;
        }
        for (int r = 0; r < 3; ++r) {
            if (!std::isfinite(m[r][3])) return fail(path, "sform offset is not finite");
            g.origin[size_t(r)] = m[r][3];
        }
    } else if (qformCode > 0) {
        // The quaternion rule of the NIfTI-1 standard (nifti1.h, method 2), as nifti1_io applies it.
        double b = hf.f32(256), c = hf.f32(260), d = hf.f32(264);
        double a = 1.0 - (b * b + c * c + d * d);
        if (a < 1e-7) {
            const double len = std::sqrt(b * b + c * c + d * d);
            if (!std::isfinite(len) || len == 0) return fail(path, "qform quaternion is not usable");
            b /= len;
            c /= len;
            d /= len;
            a = 0;
        } else {
            a = std::sqrt(a);
        }
        const double qfac = pixdim[0] < 0 ? -1.0 : 1.0;
        const double rot[9] = {a * a + b * b - c * c - d * d, 2 * (b * c - a * d),         2 * (b * d + a * c),
                               2 * (b * c + a * d),         a * a + c * c - b * b - d * d, 2 * (c * d - a * b),
                               2 * (b * d - a * c),         2 * (c * d + a * b),         a * a + d * d - c * c - b * b};
        for (int i = 0; i < 9; ++i) g.direction[size_t(i)] = rot[i] * ((i % 3 == 2) ? qfac : 1.0);
        for (int k = 0; k < 3; ++k) g.spacing[size_t(k)] = niftiSpacing(pixdim[k + 1]);
        for (int r = 0; r < 3; ++r) {
            const double o = hf.f32(268 + 4 * size_t(r));
            if (!std::isfinite(o)) return fail(path, "qform offset is not finite");
            g.origin[size_t(r)] = o;
        }
        for (double v : g.direction)
            if (!std::isfinite(v)) return fail(path, "qform quaternion is not finite");
    } else {
        for (int k = 0; k < 3; ++k) g.spacing[size_t(k)] = niftiSpacing(pixdim[k + 1]);
    }
    return Status::ok();
}

/// The header's checks in order, on its first 348 bytes.
Result<NiftiHeader> parseFields(const uint8_t* head, const std::string& name) {
    NiftiHeader out;
    NiftiFields hf{head, false};
    const int32_t sizeofHdr = hf.i32(0);
    if (sizeofHdr != 348) {
        hf.big = true;
        if (hf.i32(0) != 348) {
            hf.big = false;
            if (sizeofHdr == 540 || NiftiFields{head, true}.i32(0) == 540)
                return fail(name, "NIfTI-2 (sizeof_hdr 540) is not supported, only NIfTI-1");
            return fail(name, "not a NIfTI-1 file: sizeof_hdr is " + std::to_string(sizeofHdr) + ", expected 348");
        }
    }
    out.bigEndian = hf.big;
    const std::string magic(reinterpret_cast<const char*>(head) + 344, 4);
    if (magic == std::string("ni1\0", 4))
        return fail(name, "a NIfTI-1 .hdr/.img pair (magic 'ni1') is not supported; use a single .nii file");
    if (magic != std::string("n+1\0", 4)) return fail(name, "NIfTI-1 magic " + quotedText(magic) + " is not 'n+1'");

    int dim[8];
    for (int i = 0; i < 8; ++i) dim[i] = hf.i16(40 + 2 * size_t(i));
    if (dim[0] < 2 || dim[0] > 7)
        return fail(name,
                    "dim[0] is " + std::to_string(dim[0]) + "; a label volume needs 3 (or 2, or 4 with dim[4] = 1)");
    std::array<uint32_t, 3> d3 = {{1, 1, 1}};
    for (int i = 1; i <= dim[0]; ++i) {
        if (dim[i] < 1)
            return fail(name, "dim[" + std::to_string(i) + "] is " + std::to_string(dim[i]) + ", not a positive size");
        if (i <= 3) d3[size_t(i - 1)] = uint32_t(dim[i]);
        else if (dim[i] != 1)
            return fail(name, "dim[" + std::to_string(i) + "] is " + std::to_string(dim[i]) +
                                  ": only one 3D volume is supported (dim[4..7] must be 1)");
    }
    out.dim = d3;

    const int datatype = hf.i16(70);
    if (!niftiType(datatype, out.type))
        return fail(name, "datatype " + std::to_string(datatype) + " (" + niftiTypeName(datatype) +
                              ") is not supported; a label volume needs an integer or float type");
    // A reader that trusts bitpix would read another voxel size than one that trusts datatype.
    const int bitpix = hf.i16(72);
    if (bitpix != int(typeBytes(out.type) * 8))
        return fail(name, "bitpix " + std::to_string(bitpix) + " disagrees with datatype " + std::to_string(datatype) +
                              " (" + niftiTypeName(datatype) + ", " + std::to_string(typeBytes(out.type) * 8) +
                              " bits a voxel): the header is damaged");

    double slope = hf.f32(112), inter = hf.f32(116);
    // nifti1_io treats non-finite scale fields as absent.
    if (!std::isfinite(slope)) slope = 0;
    if (!std::isfinite(inter)) inter = 0;
    if (!(slope == 0 || (slope == 1 && inter == 0)))
        return fail(name, "scaled data (scl_slope " + formatDouble(slope) + ", scl_inter " + formatDouble(inter) +
                              "): labels must be stored unscaled");

    const double voxOffset = hf.f32(108);
    if (!std::isfinite(voxOffset) || voxOffset < double(kNiftiHeaderBytes) || voxOffset != std::floor(voxOffset) ||
        voxOffset > 1e12)
        return fail(name, "vox_offset " + formatDouble(voxOffset) + " is not a whole byte offset of at least 348");
    out.voxOffset = uint64_t(voxOffset);

    if (Status s = niftiGeometry(hf, name, out.geometry); !s) return s;
    return out;
}

/// @brief A NIfTI-1 file's voxels, read slab by slab (VoxelFileSource): positioned reads when the
/// file is not compressed, one gzip stream kept open between slabs otherwise (an earlier slab
/// restarts it; the member's checksum is verified after the last voxel).
class NiftiSource : public VoxelFileSource {
protected:
    Status truncated(uint64_t available) const override {
        return fail(path(), "truncated: " + std::to_string(available) + " bytes of voxel data after vox_offset " +
                                std::to_string(m_voxOffset) + ", " + dimText(dims()) + " " +
                                labelTypeName(info().type) + " voxels need " + std::to_string(dataBytes()));
    }
    Status streamFailure(const InputStream& in, const Status& s) const override { return streamError(path(), in, s); }

public:
    explicit NiftiSource(uint64_t voxOffset) : m_voxOffset(voxOffset) {}

private:
    std::array<uint64_t, 3> dims() const { return {{info().dim[0], info().dim[1], info().dim[2]}}; }
    uint64_t m_voxOffset;
};

} // namespace

namespace inputs {

Result<NiftiHeader> parseNiftiHeader(const uint8_t* bytes, size_t size, const std::string& name) {
    if (size < kNiftiHeaderBytes)
        return fail(name, "only " + std::to_string(size) + " bytes, too short for a NIfTI-1 header (348)");
    return parseFields(bytes, name);
}

Result<std::unique_ptr<InputSource>> openNiftiSource(const std::string& path, const InputOptions& options,
                                                     const uint64_t* wholeVolumeBudget) {
    if (Status s = regularFile(path); !s) return s;
    // The header through the stream that also tells whether the file is gzip (whatever its name,
    // as gzopen decides).
    InputStream stream;
    if (Status s = stream.open(path); !s) return streamError(path, stream, s);
    uint8_t head[kNiftiHeaderBytes];
    Result<size_t> headBytes = stream.read(head, sizeof head);
    if (!headBytes) return streamError(path, stream, headBytes.status());
    Result<NiftiHeader> h = parseNiftiHeader(head, *headBytes, path);
    if (!h) return h.status();
    const std::array<uint64_t, 3> d3 = {{h->dim[0], h->dim[1], h->dim[2]}};
    if (wholeVolumeBudget)
        if (Status s = checkBudget(path, d3, *wholeVolumeBudget); !s) return s;

    InputInfo info;
    info.dim = h->dim;
    info.type = h->type;
    info.geometry = h->geometry;
    info.format = "NIfTI";
    info.detail = voxelDetail(h->type, h->bigEndian, stream.compressed());
    VoxelData data;
    data.file = path;
    data.compressed = stream.compressed();
    data.mode = InputStream::Mode::Auto;
    data.stored = h->type;
    data.bigEndian = h->bigEndian;
    auto src = std::make_unique<NiftiSource>(h->voxOffset);
    if (data.compressed) {
        data.skip = h->voxOffset;
    } else {
        // Raw voxels: a file too short for them is refused now, before any is read.
        data.fileOffset = h->voxOffset;
        const uint64_t need = h->voxelCount() * typeBytes(h->type); // dims are at most 32767: no overflow
        Result<uint64_t> size = fileSize(path);
        if (!size) return size.status();
        const uint64_t available = *size > h->voxOffset ? *size - h->voxOffset : 0;
        if (available < need)
            return fail(path, "truncated: " + std::to_string(available) + " bytes of voxel data after vox_offset " +
                                  std::to_string(h->voxOffset) + ", " + dimText(d3) + " " + labelTypeName(h->type) +
                                  " voxels need " + std::to_string(need));
    }
    if (Status s = src->init(path, info, data, options); !s) return s;
    return std::unique_ptr<InputSource>(std::move(src));
}

bool claimsNifti(const std::string& path) { return endsWithNoCase(path, ".nii") || endsWithNoCase(path, ".nii.gz"); }

Result<std::unique_ptr<InputSource>> openNifti(const std::string& path, const InputOptions& options) {
    return openNiftiSource(path, options, nullptr);
}

} // namespace inputs

Result<InputVolume> readNifti(const std::string& path, uint64_t maxBytes) {
    Result<std::unique_ptr<InputSource>> src = inputs::openNiftiSource(path, InputOptions{}, &maxBytes);
    if (!src) return src.status();
    return readAll(**src, path, maxBytes);
}

} // namespace csgv
