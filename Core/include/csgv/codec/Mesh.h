// SPDX-License-Identifier: MIT
#pragma once
/// @file Mesh.h
/// @brief Voxel-face surface meshes of selected labels (issue 41, item 4: `csgv extract IN.csgv
/// OUT.obj|OUT.ply|OUT.stl`), VTK-free.
///
/// Each selected label is extracted on its own (extractLabels with one label, as a mask, so that
/// its bounding box is its own: scattered labels never make one huge box; ParaView's CSGV Extract
/// Labels filter does the same) and meshed exactly: one quad for every face between a voxel of the
/// label and a voxel not of it (or the outside of the extracted box), each quad's four corners are
/// voxel corners shared within the label's mesh, in world coordinates (origin + direction *
/// (spacing * corner index), the corner convention of Geometry / extractGeometry), wound
/// counter-clockwise seen from outside (also when the direction matrix mirrors). The mesh of a
/// label is closed and two-manifold except where voxels touch only along an edge or a corner
/// (there a vertex or edge is shared by more faces; every edge still has an even count).
///
/// Memory: one label at a time: its mask (1 byte per node of its box), the corner index (4 bytes
/// per corner of its box) and its mesh (24 bytes per vertex, 16 bytes per quad), plus what
/// extractLabels holds for it. Writers stream label after label (PLY and STL through unnamed
/// scratch files, since their headers need the totals).

#include "csgv/base/Geometry.h"
#include "csgv/base/Status.h"
#include "csgv/codec/Extract.h"

#include <array>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace csgv {

/// @brief The surface of one label: vertices (world coordinates) and quads (indices into
/// vertices, counter-clockwise seen from outside).
struct LabelMesh {
    int64_t label = 0;
    std::vector<std::array<double, 3>> vertices;
    std::vector<std::array<uint32_t, 4>> quads;
};

/// The surface of the nodes where `mask` is nonzero in a box of `dim` nodes (x fastest), placed
/// by `g` (corner geometry of the box's node 0). Errors when the box is too large to index.
Result<LabelMesh> meshFromMask(const uint8_t* mask, const std::array<uint32_t, 3>& dim, const Geometry& g, int64_t label);

/// @brief Receives the label meshes one by one.
class MeshSink {
public:
    virtual ~MeshSink() = default;
    virtual Status add(const LabelMesh& mesh) = 0;
};

/// @brief Totals of extractMeshes.
struct MeshSummary {
    uint64_t labelsSelected = 0;  ///< distinct labels asked for
    uint64_t labelsWithVoxels = 0;///< of those, with a voxel in the box at the level
    uint64_t voxels = 0;
    uint64_t vertices = 0;
    uint64_t quads = 0;           ///< faces; triangles are twice as many
    uint64_t bricksTotal = 0;
    uint64_t bricksDecoded = 0;   ///< summed over labels (a brick holding two labels counts twice)
};

/// Extracts `options.labels` one by one (options.mask is ignored; each label is extracted as a
/// mask with the other options), meshes each one and hands it to `sink` (labels in ascending
/// order, labels without voxels skipped). `volumeCorner` is the file's corner geometry
/// (CsgvFile::metadata.geometry). The first error (an unknown label, a limit, the sink) stops it.
Result<MeshSummary> extractMeshes(const CsgvFile& file, const ExtractOptions& options, MeshSink& sink);

enum class MeshFormat { Obj, Ply, Stl, Vtp };

/// The format named by a path's extension (.obj, .ply, .stl, .vtp; any case), or false. VTP is
/// VTK's XML PolyData (appended raw binary, little-endian, 64-bit), with the label as cell data.
bool meshFormatFor(const std::string& path, MeshFormat& format);

/// @brief Writes meshes to a file atomically: nothing appears under the name until commit().
/// OBJ: `g label_<L>` per label, `v x y z` (17 significant digits), `f a b c` (two triangles per
/// quad, 1-based). PLY: binary little endian, double x y z; faces as `list uchar uint
/// vertex_indices` (triangles) with `int label` (or `int64 label` when a label does not fit
/// int32). STL: binary, float32 coordinates, no labels (STL has no place for them).
class MeshFileWriter : public MeshSink {
public:
    MeshFileWriter();
    ~MeshFileWriter() override;
    /// Opens the output (its temporary beside the target, so an unwritable path fails here).
    /// `labels`: every label that may come, to choose PLY's label type.
    Status open(const std::string& path, MeshFormat format, const std::vector<int64_t>& labels);
    Status add(const LabelMesh& mesh) override;
    Status commit();
    uint64_t vertices() const { return m_vertices; }
    uint64_t triangles() const { return m_triangles; }

private:
    struct Impl;
    std::unique_ptr<Impl> m;
    uint64_t m_vertices = 0;
    uint64_t m_triangles = 0;
};

} // namespace csgv
