// SPDX-License-Identifier: MIT
#include "csgv/LabelVolume.h"
#include "csgv/FileUtil.h"

#include <cstring>
#include <sstream>

namespace csgv {

namespace {

/// Reads one '\n'-terminated text line of at most 64 characters starting at pos.
bool textLine(const std::vector<uint8_t>& b, size_t& pos, std::string& line) {
    line.clear();
    while (pos < b.size() && line.size() <= 64) {
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

Result<LabelVolume> parseVraw(const std::vector<uint8_t>& bytes) {
    size_t pos = 0;
    std::string dims, type;
    if (!textLine(bytes, pos, dims) || !textLine(bytes, pos, type))
        return Status::error("not a .vraw volume: the header lines \"W H D\" and the label type are missing");
    std::istringstream in(dims);
    int64_t d[3] = {0, 0, 0};
    std::string rest;
    if (!(in >> d[0] >> d[1] >> d[2]) || (in >> rest))
        return Status::error("not a .vraw volume: first line '" + dims + "' is not \"W H D\"");
    for (int a = 0; a < 3; ++a)
        if (d[a] < 1 || d[a] > 0xFFFFFFFFll)
            return Status::error(".vraw dimension " + std::to_string(d[a]) + " is out of range");
    if (!type.empty() && type.back() == '\r') type.pop_back();
    size_t bytesPerLabel = 0;
    if (type == "uint8") bytesPerLabel = 1;
    else if (type == "uint16") bytesPerLabel = 2;
    else if (type == "uint32") bytesPerLabel = 4;
    else return Status::error(".vraw label type '" + type + "' is not supported (uint8, uint16 or uint32)");
    LabelVolume v;
    v.dim = {uint32_t(d[0]), uint32_t(d[1]), uint32_t(d[2])};
    const uint64_t n = v.voxelCount();
    const uint64_t want = mulSaturate(n, bytesPerLabel);
    if (want != bytes.size() - pos)
        return Status::error(".vraw holds " + std::to_string(bytes.size() - pos) + " bytes of labels, expected " +
                             (want == kSaturated ? std::string("more than 2^64") : std::to_string(want)) + " for " +
                             dims + " " + type);
    v.labels.resize(size_t(n));
    const uint8_t* p = bytes.data() + pos;
    if (bytesPerLabel == 4)
        std::memcpy(v.labels.data(), p, size_t(n) * 4);
    else
        for (size_t i = 0; i < size_t(n); ++i)
            v.labels[i] = bytesPerLabel == 1 ? p[i] : uint32_t(p[2 * i] | (p[2 * i + 1] << 8));
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
