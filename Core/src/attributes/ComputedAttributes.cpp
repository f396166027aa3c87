// SPDX-License-Identifier: MIT
// Attributes computed from the compressed volume, one decoded brick at a time per thread.
#include "csgv/attributes/Attributes.h"
#include "csgv/codec/Decoder.h"
#include "csgv/base/Morton.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <limits>
#include <mutex>
#include <new>
#include <omp.h>

namespace csgv {

namespace {

/// Integer statistics of one label: exact, so merging in any order gives the same result.
struct LabelStats {
    uint64_t count = 0;
    uint64_t faces = 0;
    std::array<uint64_t, 3> sum{{0, 0, 0}}; ///< sums of voxel indices
    std::array<uint32_t, 3> min{{0xFFFFFFFFu, 0xFFFFFFFFu, 0xFFFFFFFFu}};
    std::array<uint32_t, 3> max{{0, 0, 0}};

    void add(const LabelStats& o) {
        count += o.count;
        faces += o.faces;
        for (int a = 0; a < 3; ++a) {
            sum[a] += o.sum[a];
            min[a] = std::min(min[a], o.min[a]);
            max[a] = std::max(max[a], o.max[a]);
        }
    }
};

/// @brief Open-addressing map from a stored label to its statistics. kInvalidLabel, which no
/// voxel holds, marks free slots; entries stay in insertion order and are addressed by index.
class StatsMap {
public:
    struct Entry {
        uint32_t key;
        size_t slot;
        LabelStats stats;
    };

    StatsMap() { rehash(64); }

    /// Index of the key's entry, inserted when absent. Indices stay valid; references do not.
    uint32_t find(uint32_t key) {
        size_t h = slotOf(key);
        for (;;) {
            const uint32_t k = m_keys[h];
            if (k == key) return m_index[h];
            if (k == kInvalidLabel) break;
            h = (h + 1) & m_mask;
        }
        if ((m_entries.size() + 1) * 2 > m_keys.size()) {
            rehash(m_keys.size() * 2);
            return find(key);
        }
        m_keys[h] = key;
        m_index[h] = uint32_t(m_entries.size());
        m_entries.push_back(Entry{key, h, LabelStats{}});
        return m_index[h];
    }
    LabelStats& operator[](uint32_t index) { return m_entries[index].stats; }
    const std::vector<Entry>& entries() const { return m_entries; }
    /// Empties the map in time proportional to its entries (slots stay allocated).
    void clear() {
        for (const Entry& e : m_entries) m_keys[e.slot] = kInvalidLabel;
        m_entries.clear();
    }
    void addAll(const StatsMap& other) {
        for (const Entry& e : other.m_entries) {
            const uint32_t i = find(e.key);
            m_entries[i].stats.add(e.stats);
        }
    }

private:
    size_t slotOf(uint32_t key) const { return size_t((uint64_t(key) * 0x9E3779B97F4A7C15ull) >> m_shift); }
    void rehash(size_t capacity) {
        m_keys.assign(capacity, kInvalidLabel);
        m_index.assign(capacity, 0);
        m_mask = capacity - 1;
        m_shift = 64;
        for (size_t c = capacity; c > 1; c >>= 1) --m_shift;
        for (size_t i = 0; i < m_entries.size(); ++i) {
            size_t h = slotOf(m_entries[i].key);
            while (m_keys[h] != kInvalidLabel) h = (h + 1) & m_mask;
            m_keys[h] = m_entries[i].key;
            m_index[h] = uint32_t(i);
            m_entries[i].slot = h;
        }
    }

    std::vector<uint32_t> m_keys;
    std::vector<uint32_t> m_index;
    std::vector<Entry> m_entries;
    size_t m_mask = 0;
    unsigned m_shift = 64;
};

/// Looks labels up through a one-entry cache: neighbouring voxels mostly share a label.
struct CachedLookup {
    StatsMap& map;
    uint32_t lastKey = kInvalidLabel;
    uint32_t lastIndex = 0;
    LabelStats& operator()(uint32_t key) {
        if (key != lastKey) {
            lastIndex = map.find(key);
            lastKey = key;
        }
        return map[lastIndex];
    }
    void reset() { lastKey = kInvalidLabel; }
};

/// Faces between two rows of n voxels (a[i] faces b[i]), counted a run of equal pairs at a time;
/// one lookup cache per side, as each side's labels change rarely along a row.
inline void facesBetween(const uint32_t* a, const uint32_t* b, uint32_t n, CachedLookup& atA, CachedLookup& atB) {
    for (uint32_t x = 0; x < n;) {
        const uint32_t va = a[x], vb = b[x];
        if (va == vb) {
            ++x;
            continue;
        }
        uint32_t x1 = x + 1;
        while (x1 < n && a[x1] == va && b[x1] == vb) ++x1;
        atA(va).faces += x1 - x;
        atB(vb).faces += x1 - x;
        x = x1;
    }
}

/// Faces of a row of n voxels on the volume's boundary.
inline void boundaryFaces(const uint32_t* a, uint32_t n, CachedLookup& at) {
    for (uint32_t x = 0; x < n;) {
        const uint32_t v = a[x];
        uint32_t x1 = x + 1;
        while (x1 < n && a[x1] == v) ++x1;
        at(v).faces += x1 - x;
        x = x1;
    }
}

enum Side { kMinusX, kPlusX, kMinusY, kPlusY, kMinusZ, kPlusZ };

} // namespace

const std::vector<std::string>& computedAttributeNames() {
    static const std::vector<std::string> names = {"voxel_count", "surface_area", "bbox_min_x", "bbox_min_y",
                                                   "bbox_min_z",  "bbox_max_x",   "bbox_max_y", "bbox_max_z",
                                                   "centroid_x",  "centroid_y",   "centroid_z"};
    return names;
}

namespace {

LabelStats statsAt(const AttributeSums& sums, size_t i) {
    const uint64_t* v = sums.values.data() + i * AttributeSums::kValues;
    LabelStats s;
    s.count = v[0];
    s.faces = v[1];
    for (int a = 0; a < 3; ++a) {
        s.sum[a] = v[2 + a];
        s.min[a] = uint32_t(v[5 + a]);
        s.max[a] = uint32_t(v[8 + a]);
    }
    return s;
}

void putStats(const LabelStats& s, uint64_t* v) {
    v[0] = s.count;
    v[1] = s.faces;
    for (int a = 0; a < 3; ++a) {
        v[2 + a] = s.sum[a];
        v[5 + a] = s.min[a];
        v[8 + a] = s.max[a];
    }
}

} // namespace

void AttributeSums::add(const AttributeSums& other) {
    AttributeSums out;
    out.keys.reserve(keys.size() + other.keys.size());
    out.values.reserve(values.size() + other.values.size());
    size_t i = 0, j = 0;
    while (i < keys.size() || j < other.keys.size()) {
        LabelStats s;
        uint32_t key;
        if (j >= other.keys.size() || (i < keys.size() && keys[i] < other.keys[j])) {
            key = keys[i];
            s = statsAt(*this, i++);
        } else if (i >= keys.size() || other.keys[j] < keys[i]) {
            key = other.keys[j];
            s = statsAt(other, j++);
        } else {
            key = keys[i];
            s = statsAt(*this, i++);
            s.add(statsAt(other, j++));
        }
        out.keys.push_back(key);
        out.values.resize(out.values.size() + kValues);
        putStats(s, out.values.data() + out.values.size() - kValues);
    }
    *this = std::move(out);
}

void AttributeSums::addFacesBetween(const uint32_t* a, const uint32_t* b, size_t n) {
    auto facesOf = [&](uint32_t key) -> uint64_t* {
        const auto it = std::lower_bound(keys.begin(), keys.end(), key);
        if (it == keys.end() || *it != key) {
            // A label only a neighbour's layer shows (its piece's sums were not added yet).
            const size_t at = size_t(it - keys.begin());
            keys.insert(it, key);
            LabelStats s;
            std::vector<uint64_t> v(kValues);
            putStats(s, v.data());
            values.insert(values.begin() + std::ptrdiff_t(at * kValues), v.begin(), v.end());
            return &values[at * kValues + 1];
        }
        return &values[size_t(it - keys.begin()) * kValues + 1];
    };
    for (size_t x = 0; x < n;) {
        const uint32_t va = a[x], vb = b[x];
        if (va == vb) {
            ++x;
            continue;
        }
        size_t x1 = x + 1;
        while (x1 < n && a[x1] == va && b[x1] == vb) ++x1;
        *facesOf(va) += x1 - x;
        *facesOf(vb) += x1 - x;
        x = x1;
    }
}

Result<AttributeTable> computeAttributes(const CompressedVolume& vol, const ComputeAttributesOptions& options) {
    Result<AttributeSums> sums = computeAttributeSums(vol, options);
    if (!sums) return sums.status();
    return attributeTable(*sums, options);
}

Result<AttributeSums> computeAttributeSums(const CompressedVolume& vol, const ComputeAttributesOptions& options,
                                           const std::array<uint32_t, 3>& offset,
                                           const std::array<uint32_t, 3>& volumeDims) {
    Status check = checkContainer(vol);
    if (!check) return check;
    const uint32_t B = vol.brickSize;
    const auto dim = vol.dim;
    const auto grid = vol.brickGrid();
    const uint64_t layerBricks = uint64_t(grid[0]) * grid[1];
    const size_t faceSize = size_t(B) * B;
    const bool countBoundary = options.countBoundaryFaces;
    // Which sides of this volume are the whole volume's (a piece's inner sides are not).
    std::array<bool, 6> outer{};
    for (int a = 0; a < 3; ++a) {
        const uint32_t whole = volumeDims[a] ? volumeDims[a] : offset[a] + dim[a];
        if (uint64_t(offset[a]) + dim[a] > whole)
            return Status::error("a piece of " + std::to_string(dim[a]) + " voxels at " + std::to_string(offset[a]) +
                                 " along axis " + std::to_string(a) + " does not fit a volume of " +
                                 std::to_string(whole));
        outer[size_t(2 * a)] = offset[a] == 0;
        outer[size_t(2 * a + 1)] = offset[a] + dim[a] == whole;
    }

    // Faces left behind by the bricks of the current layer (6 per brick), and the +z faces of the
    // previous layer. Faces are B x B, indexed (u + v * B) with (u, v) = (y, z), (x, z), (x, y).
    std::vector<uint32_t> faces, prevZ;
    try {
        faces.resize(size_t(layerBricks) * 6 * faceSize);
        prevZ.resize(size_t(layerBricks) * faceSize);
    } catch (const std::bad_alloc&) {
        return Status::error("not enough memory for the brick faces of one layer (" +
                             std::to_string(layerBricks * 7 * faceSize * 4) + " bytes)");
    }
    const int requested = options.threads > 0 ? options.threads : omp_get_max_threads();
    // Never more threads than bricks in a layer: idle OpenMP workers would spin.
    const int nThreads = int(std::max<int64_t>(1, std::min<int64_t>(requested, int64_t(layerBricks))));
    std::vector<StatsMap> perThread(static_cast<size_t>(nThreads));

    std::array<uint32_t, 128> spread{};
    for (uint32_t i = 0; i < 128; ++i) spread[i] = mortonSpread(i);

    std::atomic<bool> failed{false};
    double reported = 0; // the fraction last reported (thread 0 alone touches it)
    std::mutex mutex;
    uint64_t errorBrick = ~uint64_t(0);
    Status error;
    auto record = [&](uint64_t brick, Status s) {
        std::lock_guard<std::mutex> lock(mutex);
        if (brick < errorBrick) {
            errorBrick = brick;
            error = std::move(s);
        }
        failed = true;
    };

#pragma omp parallel num_threads(nThreads)
    {
        // Each thread's maps live on its own stack: map headers side by side in one vector would
        // share cache lines between threads that insert.
        StatsMap total;
        StatsMap local;
        CachedLookup at{local}, other{local};
        BrickDecoder decoder(vol);
        std::vector<uint32_t> lin(size_t(B) * B * B);

        for (uint32_t bz = 0; bz < grid[2]; ++bz) {
            // Pass 1: decode each brick of the layer; count voxels and the faces inside it; leave
            // its six boundary faces behind.
#pragma omp for schedule(dynamic, 1)
            for (int64_t i = 0; i < int64_t(layerBricks); ++i) {
                if (failed.load(std::memory_order_relaxed)) continue;
                const uint32_t bx = uint32_t(uint64_t(i) % grid[0]), by = uint32_t(uint64_t(i) / grid[0]);
                const uint64_t b = uint64_t(i) + layerBricks * bz;
                // Progress and cancellation, asked on the calling thread (OpenMP's thread 0)
                // between its bricks: a caller's callback runs where the caller does.
                if (options.progress && omp_get_thread_num() == 0 &&
                    !options.progress(reported = std::max(reported, double(b) / double(layerBricks * grid[2])))) {
                    record(~uint64_t(0) - 1, Status::error("cancelled"));
                    continue;
                }
                try {
                    Status st = decoder.decode(b, 0);
                    if (!st) {
                        record(b, st);
                        continue;
                    }
                    const uint32_t lo[3] = {bx * B, by * B, bz * B};
                    const uint32_t ex = std::min(B, dim[0] - lo[0]), ey = std::min(B, dim[1] - lo[1]),
                                   ez = std::min(B, dim[2] - lo[2]);
                    // Voxel indices of the volume this is a piece of.
                    const uint32_t o[3] = {offset[0] + lo[0], offset[1] + lo[1], offset[2] + lo[2]};
                    const uint32_t* labels = decoder.labels();
                    bool reserved = false;
                    for (uint32_t z = 0; z < ez; ++z)
                        for (uint32_t y = 0; y < ey; ++y) {
                            const uint32_t myz = (spread[y] << 1) | (spread[z] << 2);
                            uint32_t* row = lin.data() + (size_t(z) * ey + y) * ex;
                            for (uint32_t x = 0; x < ex; ++x) {
                                const uint32_t v = labels[myz | spread[x]];
                                reserved |= v == kInvalidLabel;
                                row[x] = v;
                            }
                        }
                    if (reserved) {
                        record(b, Status::error("brick " + std::to_string(b) +
                                                ": a voxel inside the volume holds the reserved label 0xFFFFFFFF"));
                        continue;
                    }
                    local.clear();
                    at.reset();
                    other.reset();
                    const size_t slice = size_t(ex) * ey;
                    for (uint32_t z = 0; z < ez; ++z)
                        for (uint32_t y = 0; y < ey; ++y) {
                            const uint32_t* row = lin.data() + z * slice + size_t(y) * ex;
                            const uint32_t gy = o[1] + y, gz = o[2] + z;
                            for (uint32_t x = 0; x < ex;) {
                                const uint32_t v = row[x];
                                uint32_t x1 = x + 1;
                                while (x1 < ex && row[x1] == v) ++x1;
                                const uint64_t n = x1 - x;
                                LabelStats& s = at(v);
                                s.count += n;
                                s.sum[0] += n * (o[0] + x) + n * (n - 1) / 2;
                                s.sum[1] += n * gy;
                                s.sum[2] += n * gz;
                                s.min[0] = std::min(s.min[0], o[0] + x);
                                s.max[0] = std::max(s.max[0], o[0] + x1 - 1);
                                s.min[1] = std::min(s.min[1], gy);
                                s.max[1] = std::max(s.max[1], gy);
                                s.min[2] = std::min(s.min[2], gz);
                                s.max[2] = std::max(s.max[2], gz);
                                if (x1 < ex) {
                                    ++s.faces;
                                    ++at(row[x1]).faces;
                                }
                                x = x1;
                            }
                            // Faces towards +y and +z inside the brick; equal rows have none.
                            for (int axis = 1; axis < 3; ++axis) {
                                if (axis == 1 ? y + 1 >= ey : z + 1 >= ez) continue;
                                const uint32_t* next = row + (axis == 1 ? size_t(ex) : slice);
                                if (std::memcmp(row, next, size_t(ex) * 4) != 0) facesBetween(row, next, ex, at, other);
                            }
                        }
                    total.addAll(local);

                    uint32_t* f = faces.data() + size_t(i) * 6 * faceSize;
                    for (uint32_t z = 0; z < ez; ++z)
                        for (uint32_t y = 0; y < ey; ++y) {
                            const uint32_t* row = lin.data() + z * slice + size_t(y) * ex;
                            f[kMinusX * faceSize + y + z * B] = row[0];
                            f[kPlusX * faceSize + y + z * B] = row[ex - 1];
                        }
                    for (uint32_t z = 0; z < ez; ++z) {
                        std::memcpy(f + kMinusY * faceSize + z * B, lin.data() + z * slice, size_t(ex) * 4);
                        std::memcpy(f + kPlusY * faceSize + z * B, lin.data() + z * slice + size_t(ey - 1) * ex,
                                    size_t(ex) * 4);
                    }
                    for (uint32_t y = 0; y < ey; ++y) {
                        std::memcpy(f + kMinusZ * faceSize + y * B, lin.data() + size_t(y) * ex, size_t(ex) * 4);
                        std::memcpy(f + kPlusZ * faceSize + y * B, lin.data() + (ez - 1) * slice + size_t(y) * ex,
                                    size_t(ex) * 4);
                    }
                } catch (const std::bad_alloc&) {
                    record(b, Status::error("brick " + std::to_string(b) + ": out of memory"));
                }
            }
            // Pass 2 (after every brick of the layer left its faces): faces across brick borders,
            // each pair of bricks handled once, by the brick on its lower side; and the volume's
            // boundary.
#pragma omp for schedule(dynamic, 4)
            for (int64_t i = 0; i < int64_t(layerBricks); ++i) {
                if (failed.load(std::memory_order_relaxed)) continue;
                const uint32_t bx = uint32_t(uint64_t(i) % grid[0]), by = uint32_t(uint64_t(i) / grid[0]);
                const uint64_t b = uint64_t(i) + layerBricks * bz;
                // Progress and cancellation, asked on the calling thread (OpenMP's thread 0)
                // between its bricks: a caller's callback runs where the caller does.
                if (options.progress && omp_get_thread_num() == 0 &&
                    !options.progress(reported = std::max(reported, double(b) / double(layerBricks * grid[2])))) {
                    record(~uint64_t(0) - 1, Status::error("cancelled"));
                    continue;
                }
                try {
                    const uint32_t ex = std::min(B, dim[0] - bx * B), ey = std::min(B, dim[1] - by * B),
                                   ez = std::min(B, dim[2] - bz * B);
                    const uint32_t* f = faces.data() + size_t(i) * 6 * faceSize;
                    uint32_t* pz = prevZ.data() + size_t(i) * faceSize;
                    local.clear();
                    at.reset();
                    other.reset();
                    auto boundary = [&](Side side, const uint32_t* face, uint32_t nu, uint32_t nv) {
                        if (!countBoundary || !outer[side]) return;
                        for (uint32_t v = 0; v < nv; ++v) boundaryFaces(face + v * B, nu, at);
                    };
                    auto across = [&](const uint32_t* mine, const uint32_t* theirs, uint32_t nu, uint32_t nv) {
                        for (uint32_t v = 0; v < nv; ++v) facesBetween(mine + v * B, theirs + v * B, nu, at, other);
                    };
                    if (bx == 0) boundary(kMinusX, f + kMinusX * faceSize, ey, ez);
                    if (bx + 1 == grid[0]) boundary(kPlusX, f + kPlusX * faceSize, ey, ez);
                    else across(f + kPlusX * faceSize, f + (6 + kMinusX) * faceSize, ey, ez);
                    if (by == 0) boundary(kMinusY, f + kMinusY * faceSize, ex, ez);
                    if (by + 1 == grid[1]) boundary(kPlusY, f + kPlusY * faceSize, ex, ez);
                    else across(f + kPlusY * faceSize, f + (6 * size_t(grid[0]) + kMinusY) * faceSize, ex, ez);
                    if (bz == 0) boundary(kMinusZ, f + kMinusZ * faceSize, ex, ey);
                    else across(f + kMinusZ * faceSize, pz, ex, ey);
                    if (bz + 1 == grid[2]) boundary(kPlusZ, f + kPlusZ * faceSize, ex, ey);
                    else std::memcpy(pz, f + kPlusZ * faceSize, faceSize * 4);
                    total.addAll(local);
                } catch (const std::bad_alloc&) {
                    record(b, Status::error("brick " + std::to_string(b) + ": out of memory"));
                }
            }
        }
        perThread[size_t(omp_get_thread_num())] = std::move(total);
    }
    if (failed) return error;

    try {
        StatsMap& all = perThread[0];
        for (size_t t = 1; t < perThread.size(); ++t) {
            all.addAll(perThread[t]);
            perThread[t] = StatsMap();
        }
        const auto& entries = all.entries();
        std::vector<std::pair<uint32_t, uint32_t>> keyed(entries.size()); // key, entry
        for (size_t e = 0; e < entries.size(); ++e) keyed[e] = {entries[e].key, uint32_t(e)};
        std::sort(keyed.begin(), keyed.end());
        AttributeSums sums;
        sums.keys.resize(keyed.size());
        sums.values.resize(keyed.size() * AttributeSums::kValues);
        for (size_t r = 0; r < keyed.size(); ++r) {
            sums.keys[r] = keyed[r].first;
            putStats(entries[keyed[r].second].stats, sums.values.data() + r * AttributeSums::kValues);
        }
        return sums;
    } catch (const std::bad_alloc&) {
        return Status::error("not enough memory for the attributes of every label");
    }
}

Result<PieceLayers> pieceLayers(const CompressedVolume& volume, const std::array<uint32_t, 3>& lo,
                                const std::array<uint32_t, 3>& hi) {
    PieceLayers out;
    out.lo = lo;
    out.hi = hi;
    for (int a = 0; a < 3; ++a)
        if (lo[a] >= hi[a] || hi[a] > volume.dim[a])
            return Status::error("the piece's voxels [" + std::to_string(lo[a]) + ", " + std::to_string(hi[a]) +
                                 ") along axis " + std::to_string(a) + " are empty or outside the volume's " +
                                 std::to_string(volume.dim[a]));
    for (int side = 0; side < 6; ++side) {
        const int a = side / 2;
        const bool plus = side % 2 == 1;
        if (plus ? hi[a] == volume.dim[a] : lo[a] == 0) continue;
        Box box;
        box.min = lo;
        box.max = hi;
        box.min[a] = plus ? hi[a] - 1 : lo[a];
        box.max[a] = box.min[a] + 1;
        Result<LabelVolume> layer = decodeRegion(volume, 0, box);
        if (!layer) return layer.status();
        // x fastest, then y, then z: with one axis flat that is the other two in order.
        out.layers[size_t(side)] = std::move(layer->labels);
    }
    return out;
}

void addFacesBetweenPieces(AttributeSums& sums, const std::vector<PieceLayers>& pieces) {
    std::vector<uint32_t> rowA, rowB;
    for (const PieceLayers& A : pieces)
        for (const PieceLayers& B : pieces)
            for (int a = 0; a < 3; ++a) {
                // A's + side against B's - side.
                const std::vector<uint32_t>& la = A.layers[size_t(2 * a + 1)];
                const std::vector<uint32_t>& lb = B.layers[size_t(2 * a)];
                if (&A == &B || A.hi[a] != B.lo[a] || la.empty() || lb.empty()) continue;
                const int u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
                const uint32_t u0 = std::max(A.lo[u], B.lo[u]), u1 = std::min(A.hi[u], B.hi[u]);
                const uint32_t v0 = std::max(A.lo[v], B.lo[v]), v1 = std::min(A.hi[v], B.hi[v]);
                if (u0 >= u1 || v0 >= v1) continue;
                const size_t wa = A.hi[u] - A.lo[u], wb = B.hi[u] - B.lo[u];
                for (uint32_t y = v0; y < v1; ++y) {
                    const uint32_t* ra = la.data() + size_t(y - A.lo[v]) * wa + (u0 - A.lo[u]);
                    const uint32_t* rb = lb.data() + size_t(y - B.lo[v]) * wb + (u0 - B.lo[u]);
                    sums.addFacesBetween(ra, rb, u1 - u0);
                }
            }
}

std::array<std::vector<uint32_t>, 6> ghostFaces(const std::array<uint32_t, 3>& lo, const std::array<uint32_t, 3>& hi,
                                                const std::array<uint32_t, 3>& volumeDims,
                                                const std::vector<PieceLayers>& pieces) {
    std::array<std::vector<uint32_t>, 6> out;
    for (int side = 0; side < 6; ++side) {
        const int a = side / 2;
        const bool plus = side % 2 == 1;
        if (plus ? hi[a] >= volumeDims[a] : lo[a] == 0) continue;
        const int u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
        const uint32_t outside = plus ? hi[a] : lo[a] - 1;
        const size_t w = hi[u] - lo[u];
        std::vector<uint32_t>& face = out[size_t(side)];
        face.assign(w * (hi[v] - lo[v]), kInvalidLabel);
        for (const PieceLayers& p : pieces) {
            // The neighbour's layer on the opposite side holds the plane `outside`.
            const std::vector<uint32_t>& layer = p.layers[size_t(2 * a + (plus ? 0 : 1))];
            if (layer.empty() || (plus ? p.lo[a] != outside : p.hi[a] != outside + 1)) continue;
            const uint32_t u0 = std::max(lo[u], p.lo[u]), u1 = std::min(hi[u], p.hi[u]);
            const uint32_t v0 = std::max(lo[v], p.lo[v]), v1 = std::min(hi[v], p.hi[v]);
            const size_t pw = p.hi[u] - p.lo[u];
            for (uint32_t y = v0; y < v1; ++y)
                for (uint32_t x = u0; x < u1; ++x)
                    face[(x - lo[u]) + w * (y - lo[v])] = layer[(x - p.lo[u]) + pw * (y - p.lo[v])];
        }
    }
    return out;
}

Result<AttributeTable> attributeTable(const AttributeSums& sums, const ComputeAttributesOptions& options) {
    try {
        if (sums.values.size() != sums.keys.size() * AttributeSums::kValues)
            return Status::error("attribute sums hold " + std::to_string(sums.values.size()) + " values for " +
                                 std::to_string(sums.keys.size()) + " labels");
        std::vector<std::pair<int64_t, uint32_t>> keyed(sums.keys.size()); // label, row of the sums
        for (size_t e = 0; e < sums.keys.size(); ++e) {
            const uint32_t key = sums.keys[e];
            int64_t label = key;
            if (options.idToLabel) {
                if (key >= options.idToLabel->size())
                    return Status::error("the volume holds id " + std::to_string(key) +
                                         ", past the end of the id -> label table (" +
                                         std::to_string(options.idToLabel->size()) + " labels)");
                label = (*options.idToLabel)[key];
            }
            keyed[e] = {label, uint32_t(e)};
        }
        std::sort(keyed.begin(), keyed.end());
        std::vector<int64_t> labels(keyed.size());
        for (size_t r = 0; r < keyed.size(); ++r) labels[r] = keyed[r].first;
        Result<AttributeTable> table = AttributeTable::fromLabels(std::move(labels));
        if (!table) return Status::error("the id -> label table maps two ids present in the volume to one label: " +
                                         table.message());
        const auto& names = computedAttributeNames();
        std::vector<AttributeColumn> cols(names.size());
        for (size_t c = 0; c < names.size(); ++c) {
            cols[c].name = names[c];
            cols[c].values.resize(keyed.size());
        }
        for (size_t r = 0; r < keyed.size(); ++r) {
            const LabelStats s = statsAt(sums, keyed[r].second);
            if (s.count == 0)
                return Status::error("label " + std::to_string(keyed[r].first) + " has faces but no voxels");
            cols[0].values[r] = double(s.count);
            cols[1].values[r] = double(s.faces);
            for (int a = 0; a < 3; ++a) {
                cols[2 + size_t(a)].values[r] = double(s.min[a]);
                cols[5 + size_t(a)].values[r] = double(s.max[a]);
                // Quotient and remainder: exact to the last bit of a double for any sum.
                cols[8 + size_t(a)].values[r] =
                    double(s.sum[a] / s.count) + (double(s.sum[a] % s.count) / double(s.count) + 0.5);
            }
        }
        for (AttributeColumn& c : cols) {
            Status s = table->addColumn(std::move(c));
            if (!s) return s;
        }
        return table;
    } catch (const std::bad_alloc&) {
        return Status::error("not enough memory for the attributes of every label");
    }
}

Result<AttributeTable> computeAttributes(const CsgvFile& file, int threads) {
    ComputeAttributesOptions o;
    o.threads = threads;
    if (file.hasAttributes) o.idToLabel = &file.attributes.labels;
    return computeAttributes(file.volume, o);
}

} // namespace csgv
