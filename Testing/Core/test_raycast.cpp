// SPDX-License-Identifier: MIT
// The CPU reference ray caster: exact analytic cases, and agreement with brute-force sampling
// along each ray for perspective and parallel views, anisotropic spacing and a rotated grid.
#include "csgv/codec/BrickGroups.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/UniformLevels.h"
#include "csgv/reference/RayCast.h"

#include <algorithm>
#include <cmath>
#include <gtest/gtest.h>
#include <random>

using namespace csgv; // Mat4, multiply, invert, ...: csgv/base/Math.h

namespace {

LabelVolume oneVoxel(uint32_t x, uint32_t y, uint32_t z, uint32_t label) {
    LabelVolume v;
    v.dim = {4, 4, 4};
    v.labels.assign(64, 0);
    v.labels[size_t(v.index(x, y, z))] = label;
    return v;
}

bool nonZero(uint32_t l) { return l != 0; }

} // namespace

TEST(RayCast, OrthographicViewHitsTheExpectedPixelsFaceAndDepth) {
    const LabelVolume vol = oneVoxel(1, 2, 3, 7);
    RayCastView view;
    view.width = view.height = 8;
    // Looking down -z from z = 10 at world [0,4] x [0,4]: each pixel is half a voxel.
    view.worldToClip = multiply(orthographicMatrix(-2, 2, -2, 2, 1, 20), lookAtMatrix({2, 2, 10}, {2, 2, 0}, {0, 1, 0}));
    const GBuffer g = castRays(vol, Geometry{}, view, nonZero);
    for (uint32_t y = 0; y < 8; ++y)
        for (uint32_t x = 0; x < 8; ++x) {
            const size_t i = size_t(y) * 8 + x;
            const double wx = (x + 0.5) * 0.5, wy = (y + 0.5) * 0.5; // row 0 is the bottom row
            const bool inside = wx > 1 && wx < 2 && wy > 2 && wy < 3;
            EXPECT_EQ(g.label[i], inside ? 7u : kInvalidLabel) << x << "," << y;
            if (inside) {
                EXPECT_EQ(g.face[i], Face::PlusZ); // travelling -z, the ray enters through the +z face
                // The hit is the voxel's top, z = 4: 6 units from the eye; ortho depth is linear.
                EXPECT_NEAR(g.depth[i], (6.0 - 1) / (20 - 1), 1e-6);
            } else {
                EXPECT_EQ(g.depth[i], 1.0f);
                EXPECT_EQ(g.face[i], Face::None);
            }
        }
}

TEST(RayCast, CameraInsideAVisibleVoxelHitsItAtTheNearPlane) {
    LabelVolume vol;
    vol.dim = {3, 3, 3};
    vol.labels.assign(27, 4);
    RayCastView view;
    view.width = view.height = 4;
    view.worldToClip = multiply(perspectiveMatrix(60, 1, 0.1, 50), lookAtMatrix({1.5, 1.5, 1.5}, {1.5, 1.5, 0}, {0, 1, 0}));
    const GBuffer g = castRays(vol, Geometry{}, view, nonZero);
    for (size_t i = 0; i < g.label.size(); ++i) {
        EXPECT_EQ(g.label[i], 4u);
        EXPECT_EQ(g.face[i], Face::None);
        EXPECT_NEAR(g.depth[i], 0.0f, 1e-6);
    }
    // Looking away from a volume behind the camera hits nothing.
    view.worldToClip = multiply(perspectiveMatrix(60, 1, 0.1, 50), lookAtMatrix({1.5, 1.5, 10}, {1.5, 1.5, 20}, {0, 1, 0}));
    const GBuffer away = castRays(vol, Geometry{}, view, nonZero);
    for (uint32_t l : away.label) EXPECT_EQ(l, kInvalidLabel);
}

TEST(RayCast, AgreesWithBruteForceSampling) {
    std::mt19937 rng(7);
    LabelVolume vol;
    vol.dim = {7, 5, 6};
    for (uint64_t i = 0; i < vol.voxelCount(); ++i) vol.labels.push_back(rng() % 5 == 0 ? 1 + rng() % 9 : 0);
    Geometry geo;
    geo.spacing = {0.5, 1.25, 0.8};
    geo.origin = {-1, 2, 0.5};
    // A rotation about z by 30 degrees, with the y axis mirrored (a reflection, as in LPS/RAS).
    const double c = std::cos(0.5235987755982988), s = std::sin(0.5235987755982988);
    geo.direction = {c, s, 0, s, -c, 0, 0, 0, 1};
    Mat4 worldToIndex{}, indexToWorld{};
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) indexToWorld[k * 4 + r] = geo.direction[3 * r + k] * geo.spacing[k];
        indexToWorld[12 + r] = geo.origin[r];
    }
    indexToWorld[15] = 1;
    ASSERT_TRUE(invert(indexToWorld, worldToIndex));
    for (int projection = 0; projection < 2; ++projection) {
        RayCastView view;
        view.width = 24;
        view.height = 20;
        const Mat4 proj = projection == 0 ? perspectiveMatrix(50, 1.2, 0.5, 30) : orthographicMatrix(-4, 4, -3.5, 3.5, 0.5, 30);
        view.worldToClip = multiply(proj, lookAtMatrix({-6, 9, 8}, {0.5, 1, 2.5}, {0, 0, 1}));
        const GBuffer g = castRays(vol, geo, view, nonZero);
        Mat4 clipToWorld{};
        ASSERT_TRUE(invert(view.worldToClip, clipToWorld));
        size_t checked = 0, ambiguous = 0, hits = 0;
        for (uint32_t py = 0; py < view.height; ++py)
            for (uint32_t px = 0; px < view.width; ++px) {
                const double nx = (px + 0.5) / view.width * 2 - 1, ny = (py + 0.5) / view.height * 2 - 1;
                auto unproject = [&](double z) {
                    std::array<double, 4> p{};
                    const double in[4] = {nx, ny, z, 1};
                    for (int r = 0; r < 4; ++r)
                        for (int k = 0; k < 4; ++k) p[r] += clipToWorld[k * 4 + r] * in[k];
                    return std::array<double, 3>{p[0] / p[3], p[1] / p[3], p[2] / p[3]};
                };
                const auto a = unproject(-1), b = unproject(1);
                const int samples = 40000;
                uint32_t label = kInvalidLabel;
                bool nearFace = false;
                for (int k = 0; k <= samples && label == kInvalidLabel; ++k) {
                    const double t = double(k) / samples;
                    double w[3], idx[3];
                    for (int q = 0; q < 3; ++q) w[q] = a[q] + t * (b[q] - a[q]);
                    for (int r = 0; r < 3; ++r)
                        idx[r] = worldToIndex[r] * w[0] + worldToIndex[4 + r] * w[1] + worldToIndex[8 + r] * w[2] + worldToIndex[12 + r];
                    if (idx[0] < 0 || idx[1] < 0 || idx[2] < 0 || idx[0] >= vol.dim[0] || idx[1] >= vol.dim[1] || idx[2] >= vol.dim[2])
                        continue;
                    const uint32_t l = vol.at(uint32_t(idx[0]), uint32_t(idx[1]), uint32_t(idx[2]));
                    if (nonZero(l)) {
                        label = l;
                        // The entry face is always close (the sample just crossed it); the hit is
                        // ambiguous only near an edge, where another coordinate is close too.
                        double dist[3];
                        for (int q = 0; q < 3; ++q) dist[q] = std::fabs(idx[q] - std::round(idx[q]));
                        std::sort(dist, dist + 3);
                        nearFace = dist[1] < 0.02;
                    }
                }
                const size_t i = size_t(py) * view.width + px;
                if (nearFace) {
                    ++ambiguous; // the sampled hit lies on a voxel edge: either neighbour is right
                    continue;
                }
                ++checked;
                hits += label != kInvalidLabel;
                EXPECT_EQ(g.label[i], label) << "projection " << projection << " pixel " << px << "," << py;
            }
        EXPECT_GT(hits, 40u) << "the view must see the volume";
        EXPECT_LT(ambiguous, checked / 5);
    }
}

TEST(RayCast, MatrixHelpers) {
    const Mat4 m = multiply(perspectiveMatrix(45, 1.5, 0.1, 100), lookAtMatrix({1, 2, 3}, {0, 0, 0}, {0, 1, 0}));
    Mat4 inv{}, id{};
    ASSERT_TRUE(invert(m, inv));
    id = multiply(m, inv);
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) EXPECT_NEAR(id[c * 4 + r], r == c ? 1.0 : 0.0, 1e-12);
    Mat4 singular{};
    EXPECT_FALSE(invert(singular, inv));
}

TEST(RayCast, RaysInAPlaneOfTheGridHitLikeTheirNeighbours) {
    // A solid block seen from the side with an odd number of rows: the middle row's rays lie
    // in the plane z = 8.5 exactly (their direction's z is +0.0). Every row that crosses the block
    // must hit it, that one too (it used to step along z by an infinite distance and hit nothing).
    LabelVolume vol; // a solid 10^3 block in empty space: rays step through empty voxels and bricks first
    vol.dim = {16, 16, 16};
    vol.labels.assign(16 * 16 * 16, 0);
    for (uint32_t z = 3; z < 13; ++z)
        for (uint32_t y = 3; y < 13; ++y)
            for (uint32_t x = 5; x < 13; ++x) vol.labels[size_t(vol.index(x, y, z))] = 3;
    RayCastView view;
    view.width = 31;
    view.height = 31;
    for (const double y : {8.5, 8.0}) { // eye in a voxel's middle and on a voxel boundary
      for (const bool parallel : {false, true}) {
       for (const UniformSteps steps : {UniformSteps::SubBlocks, UniformSteps::Levels}) {
        view.worldToClip = multiply(parallel ? orthographicMatrix(-12, 12, -12, 12, 1, 100) : perspectiveMatrix(30, 1.0, 1.0, 100.0),
                                    lookAtMatrix({-40, y, 8.5}, {8, y, 8.5}, {0, 0, 1}));
        const GBuffer g = castRaysStable(vol, Geometry{}, view, nonZero, 8, steps);
        auto hits = [&](uint32_t row) {
            uint32_t n = 0;
            for (uint32_t x = 0; x < view.width; ++x) n += g.label[size_t(row) * view.width + x] == 3u;
            return n;
        };
        EXPECT_GT(hits(15), 0u) << y << " parallel " << parallel;
        EXPECT_EQ(hits(15), hits(14)) << y << " parallel " << parallel;
        EXPECT_EQ(hits(15), hits(16)) << y << " parallel " << parallel;
       }
      }
    }
}

// Each empty brick's group level is the largest g whose aligned group of 2^g bricks a side holds
// empty bricks alone (beyond the grid counts as empty), on a grid of odd sizes.
TEST(RayCast, EmptyBrickGroupsAreTheLargestAlignedOnes) {
    const std::array<uint32_t, 3> grid = {13, 6, 9};
    std::mt19937 rng(7);
    std::vector<uint8_t> empty(size_t(grid[0]) * grid[1] * grid[2]);
    for (size_t b = 0; b < empty.size(); ++b) {
        const uint32_t x = uint32_t(b % grid[0]), z = uint32_t(b / (grid[0] * grid[1]));
        empty[b] = x < 8 && z < 8 ? (rng() % 50 != 0) : (rng() % 3 != 0); // a mostly empty corner
    }
    const std::vector<uint32_t> levels = emptyGroupLevels(grid, [&](uint64_t b) { return empty[size_t(b)] != 0; });
    ASSERT_EQ(levels.size(), empty.size());
    uint32_t largest = 0;
    for (uint32_t z = 0; z < grid[2]; ++z)
        for (uint32_t y = 0; y < grid[1]; ++y)
            for (uint32_t x = 0; x < grid[0]; ++x) {
                const size_t b = x + size_t(grid[0]) * (y + size_t(grid[1]) * z);
                uint32_t want = 0;
                for (uint32_t g = 1; empty[b] && g <= kEmptyGroupLevels; ++g) {
                    bool all = true;
                    for (uint32_t k = (z >> g) << g; k < std::min(grid[2], ((z >> g) + 1) << g); ++k)
                        for (uint32_t j = (y >> g) << g; j < std::min(grid[1], ((y >> g) + 1) << g); ++j)
                            for (uint32_t i = (x >> g) << g; i < std::min(grid[0], ((x >> g) + 1) << g); ++i)
                                all = all && empty[i + size_t(grid[0]) * (j + size_t(grid[1]) * k)];
                    if (!all) break;
                    want = g;
                }
                EXPECT_EQ(levels[b], want) << x << " " << y << " " << z;
                largest = std::max(largest, levels[b]);
            }
    EXPECT_GE(largest, 2u) << "the grid must have groups of several levels";
}

// Each voxel's uniform level is the largest k whose aligned cube of 2^k voxels around it lies inside
// the volume and holds one label (brute force over every cube), on a brick of 16^3 made of uniform
// cubes of every size, a few voxels changed, partly beyond a volume of odd sizes.
/// A grid's uniform levels (an MPI piece's coarse stand-ins): the largest aligned cube of one
/// label around each node, inside the grid, up to the level asked for; brute force agrees.
TEST(RayCast, GridUniformLevelsAreTheLargestUniformCubesInside) {
    std::mt19937 rng(5);
    for (const std::array<uint32_t, 3> dim : {std::array<uint32_t, 3>{16, 16, 16}, std::array<uint32_t, 3>{13, 16, 11}}) {
        for (const uint32_t maxLevel : {0u, 2u, 3u}) {
            std::vector<uint32_t> labels(size_t(dim[0]) * dim[1] * dim[2]);
            for (uint32_t z = 0; z < dim[2]; ++z)
                for (uint32_t y = 0; y < dim[1]; ++y)
                    for (uint32_t x = 0; x < dim[0]; ++x) // cubes of 8, 4, 2 by region, and kInvalidLabel ones
                        labels[x + dim[0] * (y + dim[1] * z)] = z < 8 ? (x / 8 + y / 8) % 2 : y < 8 ? (x / 2) % 3 + 5 : kInvalidLabel;
            for (int k = 0; k < 12; ++k) // single nodes break cubes (beyond the cubes of 8)
                labels[size_t(dim[0]) * dim[1] * 8 + rng() % (labels.size() - size_t(dim[0]) * dim[1] * 8)] = 7;
            const std::vector<uint8_t> got = gridUniformLevels(labels, dim, maxLevel);
            ASSERT_EQ(got.size(), labels.size());
            uint32_t seen[4] = {};
            for (uint32_t z = 0; z < dim[2]; ++z)
                for (uint32_t y = 0; y < dim[1]; ++y)
                    for (uint32_t x = 0; x < dim[0]; ++x) {
                        uint32_t want = 0;
                        for (uint32_t k = maxLevel; k >= 1 && want == 0; --k) {
                            const uint32_t m = ~((1u << k) - 1), x0 = x & m, y0 = y & m, z0 = z & m, e = 1u << k;
                            bool ok = x0 + e <= dim[0] && y0 + e <= dim[1] && z0 + e <= dim[2];
                            for (uint32_t c = 0; ok && c < e * e * e; ++c)
                                ok = labels[(x0 + c % e) + dim[0] * ((y0 + c / e % e) + dim[1] * (z0 + c / (e * e)))] ==
                                     labels[x0 + dim[0] * (y0 + dim[1] * z0)];
                            if (ok) want = k;
                        }
                        ASSERT_EQ(got[x + dim[0] * (y + dim[1] * z)], want)
                            << "node " << x << "," << y << "," << z << " of " << dim[0] << "x" << dim[1] << "x" << dim[2] << " up to " << maxLevel;
                        ++seen[want];
                    }
            for (uint32_t k = 0; k <= maxLevel; ++k) EXPECT_GT(seen[k], 0u) << "level " << k << " up to " << maxLevel;
        }
    }
}

TEST(RayCast, UniformLevelsAreTheLargestUniformCubesInside) {
    const uint32_t shift = 4, edge = 1u << shift, n = edge * edge * edge;
    std::mt19937 rng(11);
    for (const std::array<uint32_t, 3> dim : {std::array<uint32_t, 3>{32, 32, 32}, std::array<uint32_t, 3>{29, 30, 27}}) {
        const std::array<uint32_t, 3> origin = {16, 16, 16};
        std::vector<uint32_t> labels(n);
        for (uint32_t e = 0; e < n; ++e) {
            // A label per cube of a size that varies over the brick (eighths of it: 2^0 .. 2^3).
            const uint32_t size = (e >> 9) % 4;
            labels[e] = 1 + (e >> (3 * size)) % 3;
        }
        for (int k = 0; k < 20; ++k) labels[(k % 2 == 0 ? 512 : 2560) + rng() % 512] = 9; // single voxels break cubes (eighths 1 and 5)
        for (uint32_t e = 0; e < n; ++e) { // beyond the volume: outside (kInvalidLabel), as decoders give it
            const uint32_t x = origin[0] + mortonX(e), y = origin[1] + mortonY(e), z = origin[2] + mortonZ(e);
            if (x >= dim[0] || y >= dim[1] || z >= dim[2]) labels[e] = kInvalidLabel;
        }
        std::vector<uint8_t> levels(n / 8); // one a run of eight entries
        uniformLevels(labels.data(), shift, origin, dim, levels.data());
        uint32_t seen[5] = {};
        for (uint32_t e = 0; e < n; ++e) {
            uint32_t want = 0;
            for (uint32_t k = shift; k >= 1 && want == 0; --k) {
                const uint32_t first = e & ~((1u << (3 * k)) - 1);
                bool inside = true, same = true;
                for (uint32_t i = first; i < first + (1u << (3 * k)); ++i) {
                    inside = inside && origin[0] + mortonX(i) < dim[0] && origin[1] + mortonY(i) < dim[1] &&
                             origin[2] + mortonZ(i) < dim[2];
                    same = same && labels[i] == labels[first];
                }
                if (inside && same) want = k;
            }
            ASSERT_EQ(levels[e / 8], want) << "entry " << e << " of a volume " << dim[0] << "x" << dim[1] << "x" << dim[2];
            ++seen[want];
        }
        if (dim[0] == 32) // every level below the brick's occurs where the brick lies inside
            for (uint32_t k = 0; k < 4; ++k) EXPECT_GT(seen[k], 0u) << "level " << k;
        else
            EXPECT_GT(seen[0] * seen[1] * seen[2], 0u);
    }
}
