// SPDX-License-Identifier: MIT
#include "csgv/codec/LabelVolume.h"
#include "csgv/base/FileUtil.h"

#include <cstring>
#include <sstream>

namespace csgv {

namespace {

/// Reads one '\n'-terminated text line of at most 64 characters starting at pos.
bool textLine(const uint8_t* b, size_t size, size_t& pos, std::string& line) {
    line.clear();
    while (pos < size && line.size() <= 64) {
        const char c = char(b[pos++]);
        if (c == '\n') return true;
        line += c;
    }
    return false;
}

std::string vrawHeader(const LabelVolume& vol) {
    return std::to_string(vol.dim[0]) + " " + std::to_string(vol.dim[1]) + " " + std::to_string(vol.dim[2]) +
           "\nuint32\n";
}

} // namespace

Result<VrawHeader> parseVrawHeader(const uint8_t* data, size_t size) {
    size_t pos = 0;
    std::string dims, type;
    if (!textLine(data, size, pos, dims) || !textLine(data, size, pos, type))
        return Status::error("not a .vraw volume: the header lines \"W H D\" and the label type are missing");
    std::istringstream in(dims);
    int64_t d[3] = {0, 0, 0};
    std::string rest;
    if (!(in >> d[0] >> d[1] >> d[2]) || (in >> rest))
        return Status::error("not a .vraw volume: first line '" + dims + "' is not \"W H D\"");
    VrawHeader h;
    for (int a = 0; a < 3; ++a) {
        if (d[a] < 1 || d[a] > 0xFFFFFFFFll)
            return Status::error(".vraw dimension " + std::to_string(d[a]) + " is out of range");
        h.dim[a] = uint32_t(d[a]);
    }
    if (!type.empty() && type.back() == '\r') type.pop_back();
    if (type == "uint8") h.bytesPerLabel = 1;
    else if (type == "uint16") h.bytesPerLabel = 2;
    else if (type == "uint32") h.bytesPerLabel = 4;
    else return Status::error(".vraw label type '" + type + "' is not supported (uint8, uint16 or uint32)");
    h.headerBytes = pos;
    return h;
}

Status VrawHeader::checkLabelBytes(uint64_t available) const {
    const uint64_t want = mulSaturate(product3(dim[0], dim[1], dim[2]), bytesPerLabel);
    if (want == available) return Status::ok();
    return Status::error(".vraw holds " + std::to_string(available) + " bytes of labels, expected " +
                         (want == kSaturated ? std::string("more than 2^64") : std::to_string(want)) + " for " +
                         std::to_string(dim[0]) + " " + std::to_string(dim[1]) + " " + std::to_string(dim[2]) +
                         " labels of " + std::to_string(bytesPerLabel) + " bytes");
}

void widenLabels(const uint8_t* p, uint32_t bytesPerLabel, size_t n, uint32_t* out) {
    if (bytesPerLabel == 4) std::memcpy(out, p, n * 4);
    else if (bytesPerLabel == 2)
        for (size_t i = 0; i < n; ++i) out[i] = uint32_t(p[2 * i] | (p[2 * i + 1] << 8));
    else
        for (size_t i = 0; i < n; ++i) out[i] = p[i];
}

Result<LabelVolume> parseVraw(const std::vector<uint8_t>& bytes) {
    Result<VrawHeader> h = parseVrawHeader(bytes.data(), bytes.size());
    if (!h) return h.status();
    Status s = h->checkLabelBytes(bytes.size() - h->headerBytes);
    if (!s) return s;
    LabelVolume v;
    v.dim = h->dim;
    v.labels.resize(size_t(v.voxelCount()));
    widenLabels(bytes.data() + h->headerBytes, h->bytesPerLabel, v.labels.size(), v.labels.data());
    return v;
}

Result<LabelVolume> readVraw(const std::string& path, uint64_t maxBytes) {
    Result<std::vector<uint8_t>> bytes = readFileMaybeGz(path, maxBytes + 64);
    if (!bytes) return bytes.status();
    Result<LabelVolume> v = parseVraw(*bytes);
    if (!v) return Status(v.status()).prefix(path);
    return v;
}

std::vector<uint8_t> serializeVraw(const LabelVolume& vol) {
    const std::string header = vrawHeader(vol);
    std::vector<uint8_t> out(header.begin(), header.end());
    const auto* p = reinterpret_cast<const uint8_t*>(vol.labels.data());
    out.insert(out.end(), p, p + vol.labels.size() * 4);
    return out;
}

Status writeVraw(const std::string& path, const LabelVolume& vol) {
    const std::string header = vrawHeader(vol);
    AtomicFile f;
    Status s = f.open(path);
    if (s) s = f.write(header.data(), header.size());
    if (s) s = f.write(vol.labels.data(), vol.labels.size() * 4);
    if (s) s = f.commit();
    return s;
}

Status writeVrawUint8(const std::string& path, const std::array<uint32_t, 3>& dim, const uint8_t* values) {
    const std::string header =
        std::to_string(dim[0]) + " " + std::to_string(dim[1]) + " " + std::to_string(dim[2]) + "\nuint8\n";
    AtomicFile f;
    Status s = f.open(path);
    if (s) s = f.write(header.data(), header.size());
    if (s) s = f.write(values, size_t(uint64_t(dim[0]) * dim[1] * dim[2]));
    if (s) s = f.commit();
    return s;
}

Status writeNrrd(const std::string& path, const std::array<uint32_t, 3>& dim, const char* nrrdType,
                 const void* data, size_t bytesPerVoxel, const Geometry& g) {
    std::ostringstream h;
    h.precision(17);
    h << "NRRD0004\n# written by csgv\ntype: " << nrrdType << "\ndimension: 3\nsizes: " << dim[0] << ' ' << dim[1]
      << ' ' << dim[2] << "\nencoding: raw\nendian: little\nspace dimension: 3\nspace directions:";
    for (int c = 0; c < 3; ++c)
        h << " (" << g.direction[c] * g.spacing[c] << ',' << g.direction[3 + c] * g.spacing[c] << ','
          << g.direction[6 + c] * g.spacing[c] << ')';
    h << "\nspace origin: (" << g.origin[0] << ',' << g.origin[1] << ',' << g.origin[2] << ")\n\n";
    const std::string header = h.str();
    const uint64_t bytes = uint64_t(dim[0]) * dim[1] * dim[2] * bytesPerVoxel;
    AtomicFile f;
    Status s = f.open(path);
    if (s) s = f.write(header.data(), header.size());
    if (s) s = f.write(data, size_t(bytes));
    if (s) s = f.commit();
    return s;
}

Status writeVti(const std::string& path, const std::array<uint32_t, 3>& offset, const std::array<uint32_t, 3>& dim,
                const char* vtkType, const char* name, const void* data, size_t bytesPerVoxel, const Geometry& g) {
    std::ostringstream extent;
    for (int a = 0; a < 3; ++a) extent << (a ? " " : "") << offset[a] << ' ' << uint64_t(offset[a]) + dim[a];
    std::ostringstream h;
    h.precision(17);
    h << "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n  <ImageData WholeExtent=\""
      << extent.str() << "\" Origin=\"" << g.origin[0] << ' ' << g.origin[1] << ' ' << g.origin[2] << "\" Spacing=\""
      << g.spacing[0] << ' ' << g.spacing[1] << ' ' << g.spacing[2] << "\" Direction=\"";
    for (int i = 0; i < 9; ++i) h << (i ? " " : "") << g.direction[size_t(i)];
    h << "\">\n    <Piece Extent=\"" << extent.str() << "\">\n      <PointData/>\n      <CellData Scalars=\"" << name
      << "\">\n        <DataArray type=\"" << vtkType << "\" Name=\"" << name
      << "\" format=\"appended\" offset=\"0\"/>\n      </CellData>\n    </Piece>\n  </ImageData>\n"
         "  <AppendedData encoding=\"raw\">\n   _";
    const std::string header = h.str();
    const uint64_t bytes = uint64_t(dim[0]) * dim[1] * dim[2] * bytesPerVoxel;
    const std::string footer = "\n  </AppendedData>\n</VTKFile>\n";
    AtomicFile f;
    Status s = f.open(path);
    if (s) s = f.write(header.data(), header.size());
    if (s) s = f.write(&bytes, 8); // the block's byte count (header_type UInt64, little-endian hosts)
    if (s) s = f.write(data, size_t(bytes));
    if (s) s = f.write(footer.data(), footer.size());
    if (s) s = f.commit();
    return s;
}

Status writeNrrd(const std::string& path, const LabelVolume& vol, const Geometry& centred) {
    return writeNrrd(path, vol.dim, "uint32", vol.labels.data(), 4, centred);
}

LabelVolume coarsenLabels(const LabelVolume& fine) {
    LabelVolume c;
    for (int a = 0; a < 3; ++a) c.dim[a] = (fine.dim[a] + 1) / 2;
    c.labels.resize(size_t(c.voxelCount()));
    for (uint32_t z = 0; z < c.dim[2]; ++z)
        for (uint32_t y = 0; y < c.dim[1]; ++y)
            for (uint32_t x = 0; x < c.dim[0]; ++x) {
                uint32_t child[8] = {};
                int n = 0;
                for (uint32_t i = 0; i < 8; ++i) { // child index order: x bit 0, y bit 1, z bit 2
                    const uint32_t fx = 2 * x + (i & 1), fy = 2 * y + ((i >> 1) & 1), fz = 2 * z + ((i >> 2) & 1);
                    if (fx < fine.dim[0] && fy < fine.dim[1] && fz < fine.dim[2]) child[n++] = fine.at(fx, fy, fz);
                }
                c.labels[size_t(c.index(x, y, z))] = modeOfChildren(child, n);
            }
    return c;
}

} // namespace csgv
