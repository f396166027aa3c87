// SPDX-License-Identifier: MIT
#include "csgv/codec/Mesh.h"
#include "csgv/base/FileUtil.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>

namespace csgv {

namespace {

double determinant(const Geometry& g) {
    const auto& d = g.direction;
    const double det = d[0] * (d[4] * d[8] - d[5] * d[7]) - d[1] * (d[3] * d[8] - d[5] * d[6]) + d[2] * (d[3] * d[7] - d[4] * d[6]);
    return det * g.spacing[0] * g.spacing[1] * g.spacing[2];
}

template <typename T> void put(std::string& b, T v) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &v, sizeof(T)); // little-endian hosts (the formats' byte order)
    b.append(bytes, sizeof(T));
}

} // namespace

Result<LabelMesh> meshFromMask(const uint8_t* mask, const std::array<uint32_t, 3>& dim, const Geometry& g, int64_t label) {
    LabelMesh m;
    m.label = label;
    const uint64_t cx = uint64_t(dim[0]) + 1, cy = uint64_t(dim[1]) + 1, cz = uint64_t(dim[2]) + 1;
    const uint64_t corners = cx * cy * cz;
    if (dim[0] == 0 || dim[1] == 0 || dim[2] == 0) return m;
    if (corners >= std::numeric_limits<uint32_t>::max() || corners > (uint64_t(1) << 40))
        return Status::error("label " + std::to_string(label) + ": its box of " + std::to_string(dim[0]) + " x " +
                             std::to_string(dim[1]) + " x " + std::to_string(dim[2]) + " nodes is too large to mesh");
    std::vector<uint32_t> id(size_t(corners), ~0u);
    const bool mirror = determinant(g) < 0;
    auto corner = [&](uint32_t x, uint32_t y, uint32_t z) -> uint32_t {
        uint32_t& v = id[size_t(x + cx * (y + cy * uint64_t(z)))];
        if (v == ~0u) {
            v = uint32_t(m.vertices.size());
            const double c[3] = {double(x) * g.spacing[0], double(y) * g.spacing[1], double(z) * g.spacing[2]};
            std::array<double, 3> w;
            for (int r = 0; r < 3; ++r)
                w[r] = g.origin[r] + g.direction[3 * r] * c[0] + g.direction[3 * r + 1] * c[1] + g.direction[3 * r + 2] * c[2];
            m.vertices.push_back(w);
        }
        return v;
    };
    const uint64_t sx = 1, sy = dim[0], sz = uint64_t(dim[0]) * dim[1];
    const uint64_t stride[3] = {sx, sy, sz};
    for (uint32_t z = 0; z < dim[2]; ++z)
        for (uint32_t y = 0; y < dim[1]; ++y)
            for (uint32_t x = 0; x < dim[0]; ++x) {
                const uint64_t i = x + sy * y + sz * z;
                if (!mask[i]) continue;
                const uint32_t p[3] = {x, y, z};
                for (int a = 0; a < 3; ++a)
                    for (int s = 0; s < 2; ++s) { // s 0: the face towards -a, 1: towards +a
                        const bool outside = s ? p[a] + 1 >= dim[a] : p[a] == 0;
                        if (!outside && mask[s ? i + stride[a] : i - stride[a]]) continue;
                        const int u = (a + 1) % 3, v = (a + 2) % 3;
                        uint32_t c0[3] = {p[0], p[1], p[2]};
                        c0[a] += uint32_t(s);
                        uint32_t cu[3] = {c0[0], c0[1], c0[2]}, cv[3] = {c0[0], c0[1], c0[2]}, cuv[3] = {c0[0], c0[1], c0[2]};
                        ++cu[u];
                        ++cv[v];
                        ++cuv[u];
                        ++cuv[v];
                        const uint32_t q0 = corner(c0[0], c0[1], c0[2]), qu = corner(cu[0], cu[1], cu[2]),
                                       quv = corner(cuv[0], cuv[1], cuv[2]), qv = corner(cv[0], cv[1], cv[2]);
                        // e_u x e_v = e_a: (0, u, uv, v) faces +a in index space; mirrored
                        // geometry or the -a face reverses it.
                        if (bool(s) != mirror) m.quads.push_back({{q0, qu, quv, qv}});
                        else m.quads.push_back({{q0, qv, quv, qu}});
                    }
            }
    return m;
}

Result<MeshSummary> extractMeshes(const CsgvFile& file, const ExtractOptions& options, MeshSink& sink) {
    std::vector<int64_t> labels = options.labels;
    std::sort(labels.begin(), labels.end());
    labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    if (labels.empty()) return Status::error("the selection is empty: name at least one label");
    if (labels.size() > options.maxLabels)
        return Status::error("the selection names " + std::to_string(labels.size()) + " labels, more than the limit of " +
                             std::to_string(options.maxLabels) + " (raise the limit, or select fewer)");
    MeshSummary s;
    s.labelsSelected = labels.size();
    s.bricksTotal = file.volume.brickCount();
    const double n = double(labels.size());
    for (size_t i = 0; i < labels.size(); ++i) {
        ExtractOptions o = options;
        o.labels = {labels[i]};
        o.mask = true;
        if (options.progress)
            o.progress = [&options, i, n](double f) { return options.progress((double(i) + f) / n); };
        // The label where it lies, box by box: its mask never spans the volume between two far
        // places.
        bool any = false;
        Status st = extractByBoxes(file, o, [&](ExtractResult& r) -> Status {
            any = true;
            s.voxels += r.voxels;
            const Geometry g = extractGeometry(file.metadata.geometry, options.lod, r.offset);
            Result<LabelMesh> m = meshFromMask(r.mask.data(), r.dim, g, labels[i]);
            if (!m) return m.status();
            r = ExtractResult();
            s.vertices += m->vertices.size();
            s.quads += m->quads.size();
            return sink.add(*m);
        }, &s.bricksDecoded);
        if (!st) return st;
        s.labelsWithVoxels += any ? 1 : 0;
    }
    return s;
}

bool meshFormatFor(const std::string& path, MeshFormat& format) {
    if (endsWithNoCase(path, ".obj")) format = MeshFormat::Obj;
    else if (endsWithNoCase(path, ".ply")) format = MeshFormat::Ply;
    else if (endsWithNoCase(path, ".stl")) format = MeshFormat::Stl;
    else if (endsWithNoCase(path, ".vtp")) format = MeshFormat::Vtp;
    else return false;
    return true;
}

struct MeshFileWriter::Impl {
    AtomicFile out;
    std::string path;
    MeshFormat format = MeshFormat::Obj;
    bool wideLabel = false; ///< PLY: int64 labels
    std::FILE* scratchA = nullptr; ///< PLY and VTP vertices, STL triangles
    std::FILE* scratchB = nullptr; ///< PLY faces, VTP triangle labels
    std::FILE* scratchC = nullptr; ///< VTP connectivity
    std::string buffer;
    ~Impl() {
        if (scratchA) std::fclose(scratchA);
        if (scratchB) std::fclose(scratchB);
        if (scratchC) std::fclose(scratchC);
    }
    Status flushTo(std::FILE* f) {
        if (buffer.empty()) return Status::ok();
        Status st = Status::ok();
        if (f) {
            if (std::fwrite(buffer.data(), 1, buffer.size(), f) != buffer.size())
                st = Status::error(path + ": cannot write a scratch file: " + errnoText());
        } else {
            st = out.write(buffer.data(), buffer.size());
        }
        buffer.clear();
        return st;
    }
    /// Flushes the buffer to `f` (the output when null) once it holds 1 MiB.
    Status spill(std::FILE* f) { return buffer.size() > (1u << 20) ? flushTo(f) : Status::ok(); }
    /// A mesh's vertices as three doubles each (PLY, VTP), into `f`.
    Status putVertices(const LabelMesh& mesh, std::FILE* f) {
        for (const auto& v : mesh.vertices) {
            put(buffer, v[0]);
            put(buffer, v[1]);
            put(buffer, v[2]);
            if (Status st = spill(f); !st) return st;
        }
        return flushTo(f);
    }
    Status copy(std::FILE* f) {
        if (std::fflush(f) != 0 || std::fseek(f, 0, SEEK_SET) != 0)
            return Status::error(path + ": cannot read back a scratch file: " + errnoText());
        std::vector<char> chunk(size_t(1) << 20);
        for (;;) {
            const size_t got = std::fread(chunk.data(), 1, chunk.size(), f);
            if (got && !out.write(chunk.data(), got)) return Status::error(path + ": cannot write: " + errnoText());
            if (got < chunk.size()) break;
        }
        if (std::ferror(f)) return Status::error(path + ": cannot read back a scratch file");
        return Status::ok();
    }
};

MeshFileWriter::MeshFileWriter() : m(new Impl) {}
MeshFileWriter::~MeshFileWriter() = default;

Status MeshFileWriter::open(const std::string& path, MeshFormat format, const std::vector<int64_t>& labels) {
    m->path = path;
    m->format = format;
    for (int64_t l : labels) m->wideLabel = m->wideLabel || l < std::numeric_limits<int32_t>::min() || l > std::numeric_limits<int32_t>::max();
    if (Status st = m->out.open(path); !st) return st;
    if (format != MeshFormat::Obj) {
        m->scratchA = std::tmpfile();
        if (format == MeshFormat::Ply || format == MeshFormat::Vtp) m->scratchB = std::tmpfile();
        if (format == MeshFormat::Vtp) m->scratchC = std::tmpfile();
        if (!m->scratchA || ((format == MeshFormat::Ply || format == MeshFormat::Vtp) && !m->scratchB) ||
            (format == MeshFormat::Vtp && !m->scratchC))
            return Status::error(path + ": cannot create a scratch file: " + errnoText());
    }
    return Status::ok();
}

Status MeshFileWriter::add(const LabelMesh& mesh) {
    std::string& b = m->buffer;
    const uint64_t base = m_vertices;
    if (m->format == MeshFormat::Obj) {
        b += "g label_" + std::to_string(mesh.label) + "\n";
        char line[128];
        for (const auto& v : mesh.vertices) {
            b.append(line, size_t(std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", v[0], v[1], v[2])));
            if (Status st = m->spill(nullptr); !st) return st;
        }
        for (const auto& q : mesh.quads) {
            const unsigned long long a = base + q[0] + 1, c1 = base + q[1] + 1, c2 = base + q[2] + 1, c3 = base + q[3] + 1;
            b.append(line, size_t(std::snprintf(line, sizeof line, "f %llu %llu %llu\nf %llu %llu %llu\n", a, c1, c2, a, c2, c3)));
            if (Status st = m->spill(nullptr); !st) return st;
        }
        if (Status st = m->flushTo(nullptr); !st) return st;
    } else if (m->format == MeshFormat::Ply) {
        if (base + mesh.vertices.size() > std::numeric_limits<uint32_t>::max())
            return Status::error(m->path + ": more than 2^32 - 1 vertices, more than PLY's uint indices hold");
        if (Status st = m->putVertices(mesh, m->scratchA); !st) return st;
        for (const auto& q : mesh.quads) {
            const uint32_t i[4] = {uint32_t(base + q[0]), uint32_t(base + q[1]), uint32_t(base + q[2]), uint32_t(base + q[3])};
            const uint32_t tri[2][3] = {{i[0], i[1], i[2]}, {i[0], i[2], i[3]}};
            for (const auto& t : tri) {
                put(b, uint8_t(3));
                put(b, t[0]);
                put(b, t[1]);
                put(b, t[2]);
                if (m->wideLabel) put(b, int64_t(mesh.label));
                else put(b, int32_t(mesh.label));
            }
            if (Status st = m->spill(m->scratchB); !st) return st;
        }
        if (Status st = m->flushTo(m->scratchB); !st) return st;
    } else if (m->format == MeshFormat::Vtp) {
        if (Status st = m->putVertices(mesh, m->scratchA); !st) return st;
        for (size_t k = 0; k < 2 * mesh.quads.size(); ++k) {
            put(b, int64_t(mesh.label));
            if (Status st = m->spill(m->scratchB); !st) return st;
        }
        if (Status st = m->flushTo(m->scratchB); !st) return st;
        for (const auto& q : mesh.quads) {
            const int64_t i[4] = {int64_t(base + q[0]), int64_t(base + q[1]), int64_t(base + q[2]), int64_t(base + q[3])};
            for (int64_t x : {i[0], i[1], i[2], i[0], i[2], i[3]}) put(b, x);
            if (Status st = m->spill(m->scratchC); !st) return st;
        }
        if (Status st = m->flushTo(m->scratchC); !st) return st;
    } else {
        if (m_triangles + 2 * mesh.quads.size() > std::numeric_limits<uint32_t>::max())
            return Status::error(m->path + ": more than 2^32 - 1 triangles, more than binary STL counts");
        for (const auto& q : mesh.quads) {
            const uint32_t tri[2][3] = {{q[0], q[1], q[2]}, {q[0], q[2], q[3]}};
            for (const auto& t : tri) {
                const auto& p0 = mesh.vertices[t[0]];
                const auto& p1 = mesh.vertices[t[1]];
                const auto& p2 = mesh.vertices[t[2]];
                const double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
                const double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
                double nrm[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
                const double len = std::sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
                for (double& c : nrm) c = len > 0 ? c / len : 0;
                for (double c : nrm) put(b, float(c));
                for (const auto* p : {&p0, &p1, &p2})
                    for (double c : *p) put(b, float(c));
                put(b, uint16_t(0));
            }
            if (Status st = m->spill(m->scratchA); !st) return st;
        }
        if (Status st = m->flushTo(m->scratchA); !st) return st;
    }
    m_vertices += mesh.vertices.size();
    m_triangles += 2 * mesh.quads.size();
    return Status::ok();
}

Status MeshFileWriter::commit() {
    if (m->format == MeshFormat::Ply) {
        const std::string header = "ply\nformat binary_little_endian 1.0\ncomment csgv extract: voxel-face surfaces\n"
                                   "element vertex " + std::to_string(m_vertices) +
                                   "\nproperty double x\nproperty double y\nproperty double z\n"
                                   "element face " + std::to_string(m_triangles) +
                                   "\nproperty list uchar uint vertex_indices\nproperty " +
                                   (m->wideLabel ? "int64" : "int") + " label\nend_header\n";
        if (Status st = m->out.write(header.data(), header.size()); !st) return st;
        if (Status st = m->copy(m->scratchA); !st) return st;
        if (Status st = m->copy(m->scratchB); !st) return st;
    } else if (m->format == MeshFormat::Vtp) {
        // VTK XML PolyData, every array appended raw (each block: its byte count as UInt64, then
        // the bytes): points, the triangles' labels, connectivity, offsets.
        const uint64_t n = m_vertices, t = m_triangles;
        const uint64_t oLabels = 8 + 24 * n, oConn = oLabels + 8 + 8 * t, oOffsets = oConn + 8 + 24 * t;
        const std::string header =
            "<?xml version=\"1.0\"?>\n"
            "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
            "  <PolyData>\n"
            "    <Piece NumberOfPoints=\"" + std::to_string(n) + "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" "
            "NumberOfStrips=\"0\" NumberOfPolys=\"" + std::to_string(t) + "\">\n"
            "      <Points>\n"
            "        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"appended\" offset=\"0\"/>\n"
            "      </Points>\n"
            "      <CellData Scalars=\"Label\">\n"
            "        <DataArray type=\"Int64\" Name=\"Label\" format=\"appended\" offset=\"" + std::to_string(oLabels) + "\"/>\n"
            "      </CellData>\n"
            "      <Polys>\n"
            "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"" + std::to_string(oConn) + "\"/>\n"
            "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"" + std::to_string(oOffsets) + "\"/>\n"
            "      </Polys>\n"
            "    </Piece>\n"
            "  </PolyData>\n"
            "  <AppendedData encoding=\"raw\">\n   _";
        if (Status st = m->out.write(header.data(), header.size()); !st) return st;
        std::string count;
        auto block = [&](uint64_t bytes, std::FILE* f) {
            count.clear();
            put(count, bytes);
            if (Status st = m->out.write(count.data(), count.size()); !st) return st;
            return m->copy(f);
        };
        if (Status st = block(24 * n, m->scratchA); !st) return st;
        if (Status st = block(8 * t, m->scratchB); !st) return st;
        if (Status st = block(24 * t, m->scratchC); !st) return st;
        std::string& b = m->buffer;
        b.clear();
        put(b, uint64_t(8 * t));
        for (uint64_t k = 1; k <= t; ++k) {
            put(b, int64_t(3 * k));
            if (Status st = m->spill(nullptr); !st) return st;
        }
        b += "\n  </AppendedData>\n</VTKFile>\n";
        if (Status st = m->flushTo(nullptr); !st) return st;
    } else if (m->format == MeshFormat::Stl) {
        char header[80] = {};
        std::snprintf(header, sizeof header, "csgv extract: voxel-face surfaces (binary STL: labels not stored)");
        if (Status st = m->out.write(header, sizeof header); !st) return st;
        std::string count;
        put(count, uint32_t(m_triangles));
        if (Status st = m->out.write(count.data(), count.size()); !st) return st;
        if (Status st = m->copy(m->scratchA); !st) return st;
    }
    return m->out.commit();
}

} // namespace csgv
