// SPDX-License-Identifier: MIT
#include "csgv/inputs/Procedural.h"

#include <algorithm>
#include <cmath>
#include <omp.h>
#include <vector>

namespace csgv {

namespace {

uint64_t mix64(uint64_t x) { // splitmix64 finaliser
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ull;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebull;
    x ^= x >> 31;
    return x;
}

uint64_t cellHash(int64_t cx, int64_t cy, int64_t cz, uint64_t seed, uint64_t salt) {
    return mix64(seed ^ mix64(uint64_t(cx) * 0x9E3779B97F4A7C15ull ^ uint64_t(cy) * 0xC2B2AE3D27D4EB4Full ^
                              uint64_t(cz) * 0x165667B19E3779F9ull ^ salt));
}

double unit(uint64_t h) { return double(h >> 11) * (1.0 / 9007199254740992.0); }

/// Smooth 1D wave w_ab(t): displacement along axis a contributed by coordinate t on axis b.
struct Wave {
    double amp[2], freq[2], phase[2];
    double operator()(double t) const {
        return amp[0] * std::sin(freq[0] * t + phase[0]) + amp[1] * std::sin(freq[1] * t + phase[1]);
    }
};

struct Field {
    Wave wave[3][3]; // [a][b], a != b
    double cell;
    explicit Field(const SynthSpec& s) : cell(double(s.cellSize)) {
        const double pi2 = 6.283185307179586;
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) {
                Wave& w = wave[a][b];
                const uint64_t h = mix64(s.seed * 31 + uint64_t(a * 3 + b) + 0x51ED);
                w.amp[0] = 0.12 * cell;
                w.amp[1] = 0.05 * cell;
                w.freq[0] = pi2 / (cell * (2.5 + unit(h)));
                w.freq[1] = pi2 / (cell * (0.8 + 0.4 * unit(mix64(h + 1))));
                w.phase[0] = pi2 * unit(mix64(h + 2));
                w.phase[1] = pi2 * unit(mix64(h + 3));
            }
    }
};

} // namespace

bool isSynthName(const std::string& text) { return text.rfind("synth:", 0) == 0; }

Result<SynthSpec> parseSynthSpec(const std::string& text) {
    const std::string bad = "'" + text + "' is not a procedural volume name synth:WxHxD[:seed]";
    if (!isSynthName(text)) return Status::error(bad);
    SynthSpec s;
    std::string rest = text.substr(6);
    const size_t colon = rest.find(':');
    if (colon != std::string::npos) {
        const std::string seed = rest.substr(colon + 1);
        if (seed.empty() || seed.size() > 19 || seed.find_first_not_of("0123456789") != std::string::npos)
            return Status::error(bad + " (bad seed)");
        s.seed = std::stoull(seed);
        rest = rest.substr(0, colon);
    }
    size_t pos = 0;
    for (int a = 0; a < 3; ++a) {
        const size_t end = a < 2 ? rest.find('x', pos) : rest.size();
        if (end == std::string::npos) return Status::error(bad);
        const std::string num = rest.substr(pos, end - pos);
        if (num.empty() || num.size() > 10 || num.find_first_not_of("0123456789") != std::string::npos)
            return Status::error(bad);
        const uint64_t v = std::stoull(num);
        if (v == 0 || v > 0xFFFFFFFFull) return Status::error(bad + " (dimension out of range)");
        s.dim[a] = uint32_t(v);
        pos = end + 1;
    }
    return s;
}

void generateBox(const SynthSpec& spec, const std::array<uint32_t, 3>& origin, const std::array<uint32_t, 3>& size,
                 uint32_t* out) {
    const Field field(spec);
    const double S = field.cell;
    // Per-axis displacement tables over the box: disp[a][b][t] for coordinate t along axis b.
    std::vector<double> table[3][3];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            if (a == b) continue;
            table[a][b].resize(size[b]);
            for (uint32_t t = 0; t < size[b]; ++t) table[a][b][t] = field.wave[a][b](double(origin[b]) + t + 0.5);
        }
    // Feature points and labels of every cell a displaced voxel of this box can reach, as
    // structure-of-arrays so the 8-candidate search below runs without branches.
    const double maxDisp = 2 * (0.12 + 0.05) * S;
    int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = int64_t(std::floor((double(origin[a]) - maxDisp) / S)) - 1;
        hi[a] = int64_t(std::floor((double(origin[a]) + size[a] + maxDisp) / S)) + 1;
    }
    const int64_t nx = hi[0] - lo[0] + 1, ny = hi[1] - lo[1] + 1, nz = hi[2] - lo[2] + 1;
    const size_t nCells = size_t(nx * ny * nz);
    std::vector<double> px(nCells), py(nCells), pz(nCells);
    std::vector<uint32_t> cellLabel(nCells);
    for (int64_t cz = lo[2]; cz <= hi[2]; ++cz)
        for (int64_t cy = lo[1]; cy <= hi[1]; ++cy)
            for (int64_t cx = lo[0]; cx <= hi[0]; ++cx) {
                const size_t i = size_t((cx - lo[0]) + nx * ((cy - lo[1]) + ny * (cz - lo[2])));
                px[i] = (double(cx) + 0.25 + 0.5 * unit(cellHash(cx, cy, cz, spec.seed, 1))) * S;
                py[i] = (double(cy) + 0.25 + 0.5 * unit(cellHash(cx, cy, cz, spec.seed, 2))) * S;
                pz[i] = (double(cz) + 0.25 + 0.5 * unit(cellHash(cx, cy, cz, spec.seed, 3))) * S;
                const uint64_t h = cellHash(cx, cy, cz, spec.seed, 7);
                uint32_t label = uint32_t(h);
                if ((h >> 40) % 5 == 0) label = 0;
                else if (label == 0) label = 1;
                else if (label == 0xFFFFFFFFu) label = 0xFFFFFFFEu;
                cellLabel[i] = label;
            }
    int64_t offset[8];
    for (int k = 0; k < 8; ++k) offset[k] = (k & 1) + nx * ((k >> 1 & 1) + ny * (k >> 2));
    const double invS = 1.0 / S;
    // Shift cell coordinates positive so truncation equals floor (displacements are bounded).
    const int64_t shift[3] = {1 - lo[0], 1 - lo[1], 1 - lo[2]};
    for (uint32_t z = 0; z < size[2]; ++z)
        for (uint32_t y = 0; y < size[1]; ++y) {
            uint32_t* row = out + (uint64_t(z) * size[1] + y) * size[0];
            const double qx0 = double(origin[0]) + 0.5 + table[0][1][y] + table[0][2][z];
            const double qy0 = double(origin[1]) + y + 0.5 + table[1][2][z];
            const double qz0 = double(origin[2]) + z + 0.5 + table[2][1][y];
            for (uint32_t x = 0; x < size[0]; ++x) {
                const double q[3] = {qx0 + x, qy0 + table[1][0][x], qz0 + table[2][0][x]};
                int64_t c0[3];
                for (int a = 0; a < 3; ++a) {
                    const double f = q[a] * invS + double(shift[a]);
                    const int64_t c = int64_t(f);
                    c0[a] = (f - double(c) < 0.5 ? c - 1 : c) - 1; // lower of the two nearest cells
                }
                const int64_t base = c0[0] + nx * (c0[1] + ny * c0[2]);
                double best = 1e300;
                uint32_t label = 0;
                for (int k = 0; k < 8; ++k) {
                    const size_t i = size_t(base + offset[k]);
                    const double d0 = q[0] - px[i], d1 = q[1] - py[i], d2 = q[2] - pz[i];
                    const double d = d0 * d0 + d1 * d1 + d2 * d2;
                    const bool closer = d < best;
                    best = closer ? d : best;
                    label = closer ? cellLabel[i] : label;
                }
                row[x] = label;
            }
        }
}

Result<LabelVolume> generateVolume(const SynthSpec& spec, uint64_t maxBytes) {
    LabelVolume v;
    v.dim = spec.dim;
    if (v.voxelCount() > maxBytes / 4)
        return Status::error("procedural volume of " + std::to_string(spec.dim[0]) + "x" + std::to_string(spec.dim[1]) +
                             "x" + std::to_string(spec.dim[2]) + " exceeds the memory limit of " +
                             std::to_string(maxBytes) + " bytes");
    v.labels.resize(size_t(v.voxelCount()));
    ProceduralSlabSource src(spec);
    Status s = src.readSlab(0, spec.dim[2], v.labels.data());
    if (!s) return s;
    return v;
}

Status ProceduralSlabSource::readSlab(uint32_t z0, uint32_t depth, uint32_t* out) {
    return readRows(z0, depth, 0, m_spec.dim[1], out);
}

Status ProceduralSlabSource::readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint32_t* out) {
    // Parallel over pieces of a few rows of one slice: each piece is an independent box.
    const uint32_t W = m_spec.dim[0];
    const uint32_t step = 32;
    const int64_t piecesPerSlice = (rows + step - 1) / step;
    const int64_t pieces = piecesPerSlice * depth;
#pragma omp parallel for schedule(dynamic, 1) num_threads(int(std::min<int64_t>(omp_get_max_threads(), pieces)))
    for (int64_t c = 0; c < pieces; ++c) {
        const uint32_t z = uint32_t(c / piecesPerSlice), y = uint32_t(c % piecesPerSlice) * step;
        const uint32_t h = std::min(step, rows - y);
        generateBox(m_spec, {0, y0 + y, z0 + z}, {W, h, 1}, out + (uint64_t(z) * rows + y) * W);
    }
    return Status::ok();
}

} // namespace csgv
