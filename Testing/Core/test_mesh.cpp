// SPDX-License-Identifier: MIT
// Voxel-face meshes of extracted labels (issue 41, item 4): for labels of the Volcanite fixtures
// the mesh's faces are exactly the label's boundary faces in the fully decoded volume (the
// oracle), every vertex is a voxel corner in world coordinates (also under a mirroring direction
// matrix), the surface is closed and outward (signed volume = voxels * voxel volume), and the
// OBJ/PLY/STL writers read back to the same mesh; bad input leaves no file.
#include "TestData.h"

#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Mesh.h"

#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

using namespace csgv;
using namespace csgvtest;

namespace {

struct Collect : MeshSink {
    std::vector<LabelMesh> meshes;
    Status add(const LabelMesh& m) override {
        meshes.push_back(m);
        return Status::ok();
    }
};

/// Labels (original) of a few stored ids spread over the decoded volume's distinct ids, with the
/// voxel count of each stored id.
std::vector<uint32_t> someIds(const LabelVolume& v, size_t count) {
    std::set<uint32_t> all(v.labels.begin(), v.labels.end());
    std::vector<uint32_t> sorted(all.begin(), all.end());
    std::vector<uint32_t> out;
    for (size_t i = 0; i < count && i < sorted.size(); ++i) out.push_back(sorted[i * sorted.size() / count]);
    return out;
}

/// 3x3 inverse of M = direction * diag(spacing).
std::array<double, 9> inverseOf(const Geometry& g, double& det) {
    std::array<double, 9> m;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) m[3 * r + c] = g.direction[3 * r + c] * g.spacing[c];
    det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
    std::array<double, 9> inv = {m[4] * m[8] - m[5] * m[7], m[2] * m[7] - m[1] * m[8], m[1] * m[5] - m[2] * m[4],
                                 m[5] * m[6] - m[3] * m[8], m[0] * m[8] - m[2] * m[6], m[2] * m[3] - m[0] * m[5],
                                 m[3] * m[7] - m[4] * m[6], m[1] * m[6] - m[0] * m[7], m[0] * m[4] - m[1] * m[3]};
    for (double& x : inv) x /= det;
    return inv;
}

using Face = std::array<int64_t, 4>; // voxel x, y, z; direction 0..5 (-x, +x, -y, +y, -z, +z)

void checkLabel(const LabelVolume& full, uint32_t id, const LabelMesh& m, const Geometry& g) {
    // Oracle: the boundary faces of `id` in the decoded volume.
    std::set<Face> want;
    uint64_t voxels = 0;
    const auto& d = full.dim;
    for (uint32_t z = 0; z < d[2]; ++z)
        for (uint32_t y = 0; y < d[1]; ++y)
            for (uint32_t x = 0; x < d[0]; ++x) {
                if (full.labels[x + size_t(d[0]) * (y + size_t(d[1]) * z)] != id) continue;
                ++voxels;
                const int64_t p[3] = {x, y, z};
                for (int a = 0; a < 3; ++a)
                    for (int s = 0; s < 2; ++s) {
                        int64_t q[3] = {p[0], p[1], p[2]};
                        q[a] += s ? 1 : -1;
                        const bool out = q[a] < 0 || q[a] >= int64_t(d[a]);
                        if (out || full.labels[size_t(q[0] + int64_t(d[0]) * (q[1] + int64_t(d[1]) * q[2]))] != id)
                            want.insert({p[0], p[1], p[2], 2 * a + s});
                    }
            }
    double det = 0;
    const auto inv = inverseOf(g, det);
    // Vertices: voxel corners, each once.
    std::vector<std::array<int64_t, 3>> idx(m.vertices.size());
    std::set<std::array<int64_t, 3>> distinct;
    for (size_t i = 0; i < m.vertices.size(); ++i) {
        double rel[3];
        for (int r = 0; r < 3; ++r) rel[r] = m.vertices[i][r] - g.origin[r];
        for (int r = 0; r < 3; ++r) {
            const double c = inv[3 * r] * rel[0] + inv[3 * r + 1] * rel[1] + inv[3 * r + 2] * rel[2];
            idx[i][r] = std::llround(c);
            ASSERT_NEAR(c, double(idx[i][r]), 1e-6) << "vertex " << i << " is not a voxel corner";
            ASSERT_GE(idx[i][r], 0);
            ASSERT_LE(idx[i][r], int64_t(d[r]));
        }
        distinct.insert(idx[i]);
    }
    EXPECT_EQ(distinct.size(), m.vertices.size()) << "vertices are not shared";
    // Faces, their orientation, edges and the signed volume.
    std::set<Face> got;
    std::map<std::pair<uint32_t, uint32_t>, int64_t> directed;
    double volume = 0;
    const double sign = det < 0 ? -1 : 1;
    for (const auto& q : m.quads) {
        const auto& c0 = idx[q[0]];
        int64_t lo[3], hi[3];
        for (int r = 0; r < 3; ++r) {
            lo[r] = hi[r] = c0[r];
            for (int k = 1; k < 4; ++k) {
                lo[r] = std::min(lo[r], idx[q[k]][r]);
                hi[r] = std::max(hi[r], idx[q[k]][r]);
            }
        }
        int a = -1, span = 0;
        for (int r = 0; r < 3; ++r) {
            if (hi[r] == lo[r]) a = r;
            else span += hi[r] - lo[r] == 1;
        }
        ASSERT_TRUE(a >= 0 && span == 2) << "a quad that is not a voxel face";
        // Index-space normal (world winding corrected by the geometry's handedness).
        const auto &c1 = idx[q[1]], &c2 = idx[q[2]];
        const int64_t e1[3] = {c1[0] - c0[0], c1[1] - c0[1], c1[2] - c0[2]}, e2[3] = {c2[0] - c0[0], c2[1] - c0[1], c2[2] - c0[2]};
        const int64_t n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        const bool plus = double(n[a]) * sign > 0;
        Face f{lo[0], lo[1], lo[2], 2 * a + (plus ? 1 : 0)};
        if (plus) f[size_t(a)] -= 1;
        EXPECT_TRUE(got.insert(f).second) << "a face twice";
        for (int k = 0; k < 4; ++k) ++directed[{q[size_t(k)], q[size_t((k + 1) % 4)]}];
        for (const auto& t : {std::array<uint32_t, 3>{q[0], q[1], q[2]}, std::array<uint32_t, 3>{q[0], q[2], q[3]}}) {
            const auto &p0 = m.vertices[t[0]], &p1 = m.vertices[t[1]], &p2 = m.vertices[t[2]];
            volume += (p0[0] * (p1[1] * p2[2] - p1[2] * p2[1]) - p0[1] * (p1[0] * p2[2] - p1[2] * p2[0]) +
                       p0[2] * (p1[0] * p2[1] - p1[1] * p2[0])) / 6;
        }
    }
    EXPECT_EQ(got, want) << "faces differ from the decoded volume's boundary";
    // Closed and consistently oriented: every edge is used as often in each direction; twice in
    // all except where voxels of the label touch only along that edge (four times).
    uint64_t manifold = 0, nonManifold = 0;
    for (const auto& e : directed) {
        auto back = directed.find({e.first.second, e.first.first});
        ASSERT_TRUE(back != directed.end()) << "an open edge";
        EXPECT_EQ(back->second, e.second);
        EXPECT_TRUE(e.second == 1 || e.second == 2);
        (e.second == 1 ? manifold : nonManifold) += 1;
    }
    EXPECT_GT(manifold, 0u);
    EXPECT_NEAR(volume, double(voxels) * std::fabs(det), 1e-7 * double(voxels) * std::fabs(det) + 1e-9);
    EXPECT_GT(volume, 0);
}

class MeshFixture : public ::testing::TestWithParam<std::string> {};

TEST_P(MeshFixture, FacesAreTheDecodedBoundaryClosedAndOutward) {
    for (bool mirror : {false, true}) {
        Result<CsgvFile> fr = openCsgv(fixture(GetParam()));
        ASSERT_TRUE(fr.isOk()) << fr.message();
        CsgvFile& f = *fr;
        if (mirror) { // y and x swapped, x flipped: det < 0, anisotropic, shifted
            f.metadata.geometry.spacing = {{0.5, 2.0, 1.25}};
            f.metadata.geometry.origin = {{10, -3, 7.5}};
            f.metadata.geometry.direction = {{0, -1, 0, 1, 0, 0, 0, 0, 1}};
        }
        Result<LabelVolume> full = decodeVolume(f.volume, 0);
        ASSERT_TRUE(full.isOk()) << full.message();
        const std::vector<uint32_t> ids = someIds(*full, 4);
        ExtractOptions o;
        for (uint32_t id : ids) o.labels.push_back(f.hasAttributes ? f.originalLabel(id) : int64_t(id));
        o.threads = 2;
        Collect c;
        Result<MeshSummary> s = extractMeshes(f, o, c);
        ASSERT_TRUE(s.isOk()) << s.message();
        ASSERT_EQ(c.meshes.size(), ids.size());
        for (const LabelMesh& m : c.meshes) {
            const auto it = std::find_if(ids.begin(), ids.end(), [&](uint32_t id) {
                return (f.hasAttributes ? f.originalLabel(id) : int64_t(id)) == m.label;
            });
            ASSERT_TRUE(it != ids.end());
            SCOPED_TRACE(GetParam() + " label " + std::to_string(m.label) + (mirror ? " mirrored" : ""));
            checkLabel(*full, *it, m, f.metadata.geometry);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Fixtures, MeshFixture,
                         ::testing::Values("synthA_b16_nibble.csgv", "denseB_b32_rans1.csgv"),
                         [](const ::testing::TestParamInfo<std::string>& i) {
                             std::string n = i.param.substr(0, i.param.find('.'));
                             for (char& ch : n)
                                 if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                             return n;
                         });

std::vector<uint8_t> readAll(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

template <typename T> T get(const std::vector<uint8_t>& b, size_t& at) {
    T v;
    std::memcpy(&v, b.data() + at, sizeof v);
    at += sizeof v;
    return v;
}

bool noFilesIn(const std::string& dir) { return std::filesystem::is_empty(dir); }

TEST(Mesh, WritersReadBack) {
    Result<CsgvFile> f = openCsgv(fixture("synthA_b16_nibble.csgv"));
    ASSERT_TRUE(f.isOk());
    Result<LabelVolume> full = decodeVolume(f->volume, 0);
    ASSERT_TRUE(full.isOk());
    ExtractOptions o;
    for (uint32_t id : someIds(*full, 3)) o.labels.push_back(f->hasAttributes ? f->originalLabel(id) : int64_t(id));
    Collect c;
    ASSERT_TRUE(extractMeshes(*f, o, c).isOk());
    std::vector<std::array<double, 3>> verts;
    std::vector<std::array<uint64_t, 3>> tris;
    std::vector<int64_t> triLabel;
    for (const auto& m : c.meshes) {
        const uint64_t base = verts.size();
        verts.insert(verts.end(), m.vertices.begin(), m.vertices.end());
        for (const auto& q : m.quads) {
            tris.push_back({base + q[0], base + q[1], base + q[2]});
            tris.push_back({base + q[0], base + q[2], base + q[3]});
            triLabel.push_back(m.label);
            triLabel.push_back(m.label);
        }
    }
    const std::string dir = tempDir() + "/mesh_rt";
    std::filesystem::create_directories(dir);
    for (MeshFormat fmt : {MeshFormat::Obj, MeshFormat::Ply, MeshFormat::Stl, MeshFormat::Vtp}) {
        const std::string path = dir + (fmt == MeshFormat::Obj ? "/m.obj"
                                        : fmt == MeshFormat::Ply ? "/m.ply"
                                        : fmt == MeshFormat::Vtp ? "/m.vtp"
                                                                 : "/m.stl");
        {
            MeshFileWriter w;
            ASSERT_TRUE(w.open(path, fmt, o.labels).isOk());
            ASSERT_TRUE(extractMeshes(*f, o, w).isOk());
            ASSERT_TRUE(w.commit().isOk());
            EXPECT_EQ(w.vertices(), verts.size());
            EXPECT_EQ(w.triangles(), tris.size());
        }
        if (fmt == MeshFormat::Obj) {
            std::ifstream in(path);
            std::string line, group;
            size_t v = 0, t = 0, groups = 0;
            while (std::getline(in, line)) {
                std::istringstream ls(line);
                std::string k;
                ls >> k;
                if (k == "g") {
                    ls >> group;
                    ++groups;
                } else if (k == "v") {
                    double x, y, z;
                    ls >> x >> y >> z;
                    ASSERT_LT(v, verts.size());
                    EXPECT_EQ(x, verts[v][0]);
                    EXPECT_EQ(y, verts[v][1]);
                    EXPECT_EQ(z, verts[v][2]);
                    ++v;
                } else if (k == "f") {
                    uint64_t a, b, cc;
                    ls >> a >> b >> cc;
                    ASSERT_LT(t, tris.size());
                    EXPECT_EQ((std::array<uint64_t, 3>{a - 1, b - 1, cc - 1}), tris[t]);
                    EXPECT_EQ(group, "label_" + std::to_string(triLabel[t]));
                    ++t;
                }
            }
            EXPECT_EQ(v, verts.size());
            EXPECT_EQ(t, tris.size());
            EXPECT_EQ(groups, c.meshes.size());
        } else if (fmt == MeshFormat::Ply) {
            const std::vector<uint8_t> b = readAll(path);
            const std::string text(b.begin(), b.end());
            const size_t end = text.find("end_header\n");
            ASSERT_NE(end, std::string::npos);
            const std::string header = text.substr(0, end);
            EXPECT_NE(header.find("element vertex " + std::to_string(verts.size()) + "\n"), std::string::npos);
            EXPECT_NE(header.find("element face " + std::to_string(tris.size()) + "\n"), std::string::npos);
            const bool wide = header.find("property int64 label") != std::string::npos;
            size_t at = end + 11;
            ASSERT_EQ(b.size(), at + verts.size() * 24 + tris.size() * (13 + (wide ? 8 : 4)));
            for (const auto& v : verts)
                for (int k = 0; k < 3; ++k) ASSERT_EQ(get<double>(b, at), v[size_t(k)]);
            for (size_t i = 0; i < tris.size(); ++i) {
                ASSERT_EQ(get<uint8_t>(b, at), 3);
                for (int k = 0; k < 3; ++k) ASSERT_EQ(get<uint32_t>(b, at), tris[i][size_t(k)]);
                ASSERT_EQ(wide ? get<int64_t>(b, at) : int64_t(get<int32_t>(b, at)), triLabel[i]);
            }
        } else if (fmt == MeshFormat::Vtp) {
            // The counts in the Piece, then the appended blocks (UInt64 byte count, then the
            // bytes): points, the triangles' labels, connectivity, offsets (VTK reading the file
            // is checked by the paraview test test_extract_labels.py).
            const std::vector<uint8_t> b = readAll(path);
            const std::string text(b.begin(), b.end());
            EXPECT_NE(text.find("NumberOfPoints=\"" + std::to_string(verts.size()) + "\""), std::string::npos);
            EXPECT_NE(text.find("NumberOfPolys=\"" + std::to_string(tris.size()) + "\""), std::string::npos);
            const size_t raw = text.find("<AppendedData encoding=\"raw\">");
            ASSERT_NE(raw, std::string::npos);
            size_t at = text.find('_', raw) + 1;
            ASSERT_EQ(get<uint64_t>(b, at), 24 * verts.size());
            for (const auto& v : verts)
                for (int k = 0; k < 3; ++k) ASSERT_EQ(get<double>(b, at), v[size_t(k)]);
            ASSERT_EQ(get<uint64_t>(b, at), 8 * tris.size());
            for (int64_t l : triLabel) ASSERT_EQ(get<int64_t>(b, at), l);
            ASSERT_EQ(get<uint64_t>(b, at), 24 * tris.size());
            for (const auto& t : tris)
                for (int k = 0; k < 3; ++k) ASSERT_EQ(uint64_t(get<int64_t>(b, at)), t[size_t(k)]);
            ASSERT_EQ(get<uint64_t>(b, at), 8 * tris.size());
            for (size_t i = 0; i < tris.size(); ++i) ASSERT_EQ(get<int64_t>(b, at), int64_t(3 * (i + 1)));
            EXPECT_EQ(text.substr(at), "\n  </AppendedData>\n</VTKFile>\n");
        } else {
            const std::vector<uint8_t> b = readAll(path);
            ASSERT_EQ(b.size(), 84 + 50 * tris.size());
            size_t at = 80;
            ASSERT_EQ(get<uint32_t>(b, at), tris.size());
            for (const auto& t : tris) {
                at += 12; // normal
                for (int k = 0; k < 3; ++k)
                    for (int r = 0; r < 3; ++r) ASSERT_EQ(get<float>(b, at), float(verts[t[size_t(k)]][size_t(r)]));
                at += 2;
            }
        }
    }
}

TEST(Mesh, BadInputLeavesNoFile) {
    Result<CsgvFile> f = openCsgv(fixture("synthA_b16_nibble.csgv"));
    ASSERT_TRUE(f.isOk());
    const std::string dir = tempDir() + "/mesh_bad";
    std::filesystem::create_directories(dir);
    for (MeshFormat fmt : {MeshFormat::Obj, MeshFormat::Ply, MeshFormat::Stl, MeshFormat::Vtp}) {
        {
            ExtractOptions o;
            o.labels = {123456789}; // in no palette
            MeshFileWriter w;
            ASSERT_TRUE(w.open(dir + "/m.out", fmt, o.labels).isOk());
            Result<MeshSummary> s = extractMeshes(*f, o, w);
            ASSERT_FALSE(s.isOk());
            EXPECT_NE(s.message().find("123456789"), std::string::npos) << s.message();
        }
        EXPECT_TRUE(noFilesIn(dir));
        MeshFileWriter w;
        EXPECT_FALSE(w.open(dir + "/no/such/dir/m.obj", fmt, {1}).isOk());
    }
    EXPECT_TRUE(noFilesIn(dir));
    MeshFormat fmt;
    EXPECT_TRUE(meshFormatFor("a.OBJ", fmt) && fmt == MeshFormat::Obj);
    EXPECT_TRUE(meshFormatFor("a.ply", fmt) && fmt == MeshFormat::Ply);
    EXPECT_TRUE(meshFormatFor("a.Stl", fmt) && fmt == MeshFormat::Stl);
    EXPECT_TRUE(meshFormatFor("a.vtp", fmt) && fmt == MeshFormat::Vtp);
    EXPECT_FALSE(meshFormatFor("a.nrrd", fmt));
}

} // namespace
