// SPDX-License-Identifier: MIT
#include "csgv/codec/Extract.h"
#include "csgv/attributes/Attributes.h"
#include "csgv/base/Morton.h"

#include <algorithm>
#include <tuple>
#include <atomic>
#include <cmath>
#include <mutex>
#include <new>
#include <omp.h>
#include <unordered_map>

namespace csgv {

namespace {

constexpr size_t kListedUnknown = 5; ///< unknown labels an error names

std::string mib(uint64_t bytes) {
    if (bytes < (uint64_t(1) << 20)) return std::to_string(bytes) + (bytes == 1 ? " byte" : " bytes"); // not "0.0 MiB"
    char s[32];
    std::snprintf(s, sizeof s, "%.1f MiB", double(bytes) / double(1 << 20));
    return s;
}

/// The selection in the file's stored values: sorted, unique ids, and for each the label the user
/// named (for messages).
struct Selection {
    std::vector<uint32_t> ids;
    std::vector<int64_t> labels;
    bool contains(uint32_t id) const { return std::binary_search(ids.begin(), ids.end(), id); }
    /// Position of id in ids, or -1.
    int64_t find(uint32_t id) const {
        auto it = std::lower_bound(ids.begin(), ids.end(), id);
        return it != ids.end() && *it == id ? int64_t(it - ids.begin()) : -1;
    }
};

std::string listLabels(const std::vector<int64_t>& labels, bool unsigned64) {
    std::string s;
    for (size_t i = 0; i < labels.size() && i < kListedUnknown; ++i)
        s += (i ? ", " : "") + (unsigned64 ? std::to_string(uint64_t(labels[i])) : std::to_string(labels[i]));
    if (labels.size() > kListedUnknown) s += " (and " + std::to_string(labels.size() - kListedUnknown) + " more)";
    return s;
}

/// Step 1: original labels to stored ids. Labels a database lacks, or that cannot be stored
/// without one, go to `unknown`.
Result<Selection> selectIds(const CsgvFile& file, std::vector<int64_t> labels, uint64_t maxLabels,
                            std::vector<int64_t>& unknown) {
    if (labels.empty()) return Status::error("the selection is empty: name at least one label");
    std::sort(labels.begin(), labels.end());
    labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    if (labels.size() > maxLabels)
        return Status::error("the selection names " + std::to_string(labels.size()) + " labels, more than the limit of " +
                             std::to_string(maxLabels) + " (raise the limit, or select fewer)");
    std::vector<std::pair<uint32_t, int64_t>> pairs;
    pairs.reserve(labels.size());
    if (file.hasAttributes) {
        std::unordered_map<int64_t, uint32_t> idOf;
        idOf.reserve(file.attributes.labels.size());
        for (size_t id = 0; id < file.attributes.labels.size(); ++id) idOf.emplace(file.attributes.labels[id], uint32_t(id));
        for (int64_t l : labels) {
            auto it = idOf.find(l);
            if (it == idOf.end()) unknown.push_back(l);
            else pairs.emplace_back(it->second, l);
        }
    } else {
        for (int64_t l : labels) {
            if (l < 0 || l >= int64_t(kInvalidLabel)) unknown.push_back(l);
            else pairs.emplace_back(uint32_t(l), l);
        }
    }
    std::sort(pairs.begin(), pairs.end());
    Selection s;
    s.ids.reserve(pairs.size());
    s.labels.reserve(pairs.size());
    for (const auto& p : pairs) {
        s.ids.push_back(p.first);
        s.labels.push_back(p.second);
    }
    return s;
}

/// A part of the output: a box of level nodes (half-open) with its values, x fastest.
struct Piece {
    std::array<uint32_t, 3> lo{}, hi{};
    std::vector<uint32_t> labels;
    std::vector<uint8_t> mask;
    uint64_t count = 0;
};

/// The first error of a parallel loop by brick index, so that messages do not depend on timing.
struct FirstError {
    std::mutex mutex;
    uint64_t brick = ~uint64_t(0);
    Status status;
    std::atomic<bool> any{false};
    void set(uint64_t b, Status s) {
        std::lock_guard<std::mutex> lock(mutex);
        if (b < brick) {
            brick = b;
            status = std::move(s);
        }
        any = true;
    }
};

int threadCount(int threads, uint64_t work) {
    return int(std::max<uint64_t>(1, std::min<uint64_t>(threads > 0 ? uint64_t(threads) : uint64_t(omp_get_max_threads()), work)));
}

} // namespace

Geometry extractGeometry(const Geometry& corner, uint32_t lod, const std::array<uint32_t, 3>& offset) {
    Geometry g = corner;
    for (int c = 0; c < 3; ++c) g.spacing[c] = corner.spacing[c] * double(uint64_t(1) << lod);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) g.origin[r] += corner.direction[3 * r + c] * double(offset[c]) * g.spacing[c];
    return g;
}

Result<std::vector<Box>> selectionBoxes(const CsgvFile& file, const ExtractOptions& o, size_t maxBoxes) {
    const CompressedVolume& vol = file.volume;
    std::vector<int64_t> unknown;
    Result<Selection> sel = selectIds(file, o.labels, o.maxLabels, unknown);
    if (!sel) return sel.status();
    Box box;
    box.max = vol.dim;
    if (o.hasBox)
        for (int a = 0; a < 3; ++a) {
            box.min[a] = std::min(o.box.min[a], vol.dim[a]);
            box.max[a] = std::min(std::max(o.box.max[a], box.min[a]), vol.dim[a]);
        }
    const auto grid = vol.brickGrid();
    const uint32_t B = vol.brickSize;
    std::array<uint32_t, 3> glo{}, ghi{}; // the bricks the box meets
    for (int a = 0; a < 3; ++a) {
        glo[a] = box.min[a] / B;
        ghi[a] = box.max[a] > box.min[a] ? (box.max[a] - 1) / B + 1 : glo[a];
    }
    const uint32_t L = vol.levels();
    // Step 2's scan: the bricks in the box whose palettes hold a selected id.
    std::vector<uint8_t> held(size_t(vol.brickCount()), 0);
    std::vector<uint64_t> marked;
    sweepBricks(vol, kSweepBricks, [&](uint64_t from, uint64_t to) {
        for (uint64_t b = from; b < to; ++b) {
            const uint32_t c[3] = {uint32_t(b % grid[0]), uint32_t(b / grid[0] % grid[1]), uint32_t(b / grid[0] / grid[1])};
            if (c[0] < glo[0] || c[0] >= ghi[0] || c[1] < glo[1] || c[1] >= ghi[1] || c[2] < glo[2] || c[2] >= ghi[2]) continue;
            if (!brickSound(vol, b)) { // its decoder names it: extracted, it fails clearly
                held[size_t(b)] = 1;
                marked.push_back(b);
                continue;
            }
            const BrickWords bw = vol.brick(b);
            for (uint32_t k = 0, n = bw.words[L]; k < n; ++k)
                if (sel->contains(bw.words[bw.size - 1 - k])) {
                    held[size_t(b)] = 1;
                    marked.push_back(b);
                    break;
                }
        }
        return true;
    });
    // Groups of 26-connected held bricks, each as its box of bricks [lo, hi).
    struct Group {
        std::array<uint32_t, 3> lo, hi;
    };
    std::vector<Group> groups;
    std::vector<uint64_t> stack;
    for (uint64_t start : marked) {
        if (held[size_t(start)] != 1) continue;
        Group g{{~0u, ~0u, ~0u}, {0, 0, 0}};
        held[size_t(start)] = 2;
        stack.assign(1, start);
        while (!stack.empty()) {
            const uint64_t b = stack.back();
            stack.pop_back();
            const int64_t c[3] = {int64_t(b % grid[0]), int64_t(b / grid[0] % grid[1]), int64_t(b / grid[0] / grid[1])};
            for (int a = 0; a < 3; ++a) {
                g.lo[a] = std::min(g.lo[a], uint32_t(c[a]));
                g.hi[a] = std::max(g.hi[a], uint32_t(c[a]) + 1);
            }
            for (int dz = -1; dz <= 1; ++dz)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int64_t x = c[0] + dx, y = c[1] + dy, z = c[2] + dz;
                        if (x < 0 || y < 0 || z < 0 || x >= grid[0] || y >= grid[1] || z >= grid[2]) continue;
                        const uint64_t n = uint64_t(x) + uint64_t(grid[0]) * (uint64_t(y) + uint64_t(grid[1]) * uint64_t(z));
                        if (held[size_t(n)] == 1) {
                            held[size_t(n)] = 2;
                            stack.push_back(n);
                        }
                    }
        }
        groups.push_back(g);
    }
    auto overlap = [](const Group& p, const Group& q) {
        for (int a = 0; a < 3; ++a)
            if (p.hi[a] <= q.lo[a] || q.hi[a] <= p.lo[a]) return false;
        return true;
    };
    auto join = [](Group& into, const Group& g) {
        for (int a = 0; a < 3; ++a) {
            into.lo[a] = std::min(into.lo[a], g.lo[a]);
            into.hi[a] = std::max(into.hi[a], g.hi[a]);
        }
    };
    if (groups.size() > std::max<size_t>(maxBoxes, 1)) {
        // More groups than boxes: neighbours in Morton order of their corners joined, maxBoxes
        // runs of them (nearby groups share a box; far ones do not, unlike one box of them all).
        auto morton = [](const Group& g) {
            uint64_t m = 0;
            for (int bit = 0; bit < 21; ++bit)
                for (int a = 0; a < 3; ++a) m |= uint64_t((g.lo[a] >> bit) & 1u) << (3 * bit + a);
            return m;
        };
        std::sort(groups.begin(), groups.end(), [&](const Group& p, const Group& q) { return morton(p) < morton(q); });
        const size_t runs = std::max<size_t>(maxBoxes, 1);
        std::vector<Group> joined;
        for (size_t r = 0; r < runs; ++r) {
            const size_t from = groups.size() * r / runs, to = groups.size() * (r + 1) / runs;
            if (from == to) continue;
            Group u = groups[from];
            for (size_t i = from + 1; i < to; ++i) join(u, groups[i]);
            joined.push_back(u);
        }
        groups.swap(joined);
    }
    // Merged while two boxes overlap (a group nested in another's box would be extracted twice).
    for (bool merged = true; merged;) {
        merged = false;
        for (size_t i = 0; i < groups.size() && !merged; ++i)
            for (size_t j = i + 1; j < groups.size() && !merged; ++j)
                if (overlap(groups[i], groups[j])) {
                    join(groups[i], groups[j]);
                    groups.erase(groups.begin() + std::ptrdiff_t(j));
                    merged = true;
                }
    }
    std::vector<Box> out;
    for (const Group& g : groups) {
        Box v;
        for (int a = 0; a < 3; ++a) {
            v.min[a] = std::max(box.min[a], g.lo[a] * B);
            v.max[a] = std::min(box.max[a], uint32_t(std::min<uint64_t>(uint64_t(g.hi[a]) * B, vol.dim[a])));
        }
        out.push_back(v);
    }
    std::sort(out.begin(), out.end(), [](const Box& p, const Box& q) {
        return std::tie(p.min[2], p.min[1], p.min[0]) < std::tie(q.min[2], q.min[1], q.min[0]);
    });
    return out;
}

Status extractByBoxes(const CsgvFile& file, const ExtractOptions& options,
                      const std::function<Status(ExtractResult&)>& take, uint64_t* bricksDecoded) {
    Result<std::vector<Box>> boxes = selectionBoxes(file, options);
    if (!boxes) return boxes.status();
    if (boxes->empty()) boxes->push_back(options.hasBox ? options.box : Box{{0, 0, 0}, file.volume.dim});
    ExtractOptions o = options;
    o.hasBox = true;
    const double n = double(boxes->size());
    for (size_t k = 0; k < boxes->size(); ++k) {
        o.box = (*boxes)[k];
        if (options.progress) o.progress = [&options, k, n](double f) { return options.progress((double(k) + f) / n); };
        Result<ExtractResult> r = extractLabels(file, o);
        if (!r) return r.status();
        if (bricksDecoded) *bricksDecoded += r->bricksDecoded;
        if (r->empty()) continue;
        if (Status s = take(*r); !s) return s;
    }
    return Status::ok();
}

Result<ExtractResult> extractLabels(const CsgvFile& file, const ExtractOptions& o) {
    const CompressedVolume& vol = file.volume;
    const uint32_t L = vol.levels();
    if (o.lod >= L)
        return Status::error("level " + std::to_string(o.lod) + " is out of range 0.." + std::to_string(L - 1) +
                             " (brick size " + std::to_string(vol.brickSize) + ")");
    // The box in full-resolution voxels, then as level nodes that overlap it.
    Box box;
    box.max = vol.dim;
    if (o.hasBox) {
        static const char* axis = "xyz";
        for (int a = 0; a < 3; ++a)
            if (o.box.min[a] >= o.box.max[a] || o.box.max[a] > vol.dim[a])
                return Status::error(std::string("the box's ") + axis[a] + " range [" + std::to_string(o.box.min[a]) +
                                     ", " + std::to_string(o.box.max[a]) + ") is empty or outside the volume's [0, " +
                                     std::to_string(vol.dim[a]) + ")");
        box = o.box;
    }
    const auto ldim = lodDimensions(vol.dim, o.lod);
    std::array<uint32_t, 3> lo{}, hi{};
    for (int a = 0; a < 3; ++a) {
        lo[a] = box.min[a] >> o.lod;
        hi[a] = uint32_t(std::min<uint64_t>(ldim[a], (uint64_t(box.max[a]) + (uint64_t(1) << o.lod) - 1) >> o.lod));
    }

    std::vector<int64_t> unknown;
    Result<Selection> sel = selectIds(file, o.labels, o.maxLabels, unknown);
    if (!sel) return sel.status();
    const bool unsigned64 = file.hasAttributes && file.attributes.labelsUnsigned64;
    if (!unknown.empty() && file.hasAttributes)
        return Status::error(std::to_string(unknown.size()) + " of the " + std::to_string(unknown.size() + sel->ids.size()) +
                             " selected labels are not in " + file.attributes.path + ": " + listLabels(unknown, unsigned64));

    ExtractResult r;
    r.lod = o.lod;
    r.labelsSelected = sel->ids.size() + unknown.size();
    r.bricksTotal = vol.brickCount();

    // Step 2: palettes. Every brick is scanned (labels no brick holds are unknown when there is no
    // database); those in the box that hold a selected id become candidates.
    const auto grid = vol.brickGrid();
    const uint32_t edge = vol.brickSize >> o.lod;
    auto inBox = [&](uint64_t b) {
        const uint64_t c[3] = {b % grid[0], (b / grid[0]) % grid[1], b / (uint64_t(grid[0]) * grid[1])};
        for (int a = 0; a < 3; ++a)
            if (c[a] * edge >= hi[a] || (c[a] + 1) * edge <= lo[a]) return false;
        return true;
    };
    const size_t nSel = sel->ids.size();
    const int scanThreads = threadCount(o.threads, r.bricksTotal / 256 + 1);
    std::vector<std::vector<uint64_t>> candidatesOf(static_cast<size_t>(scanThreads));
    std::vector<std::vector<uint8_t>> foundOf(static_cast<size_t>(scanThreads)), foundInBoxOf(static_cast<size_t>(scanThreads));
    std::atomic<uint64_t> inBoxCount{0};
    std::atomic<bool> scanFailed{false};
#pragma omp parallel num_threads(scanThreads)
    {
        const size_t t = size_t(omp_get_thread_num());
        try {
            foundOf[t].assign(nSel, 0);
            foundInBoxOf[t].assign(nSel, 0);
        } catch (const std::bad_alloc&) {
            scanFailed = true;
        }
        uint64_t boxed = 0;
#pragma omp for schedule(dynamic, 256)
        for (int64_t bi = 0; bi < int64_t(r.bricksTotal); ++bi) {
            if (scanFailed.load(std::memory_order_relaxed)) continue;
            const uint64_t b = uint64_t(bi);
            const bool boxedBrick = inBox(b);
            boxed += boxedBrick;
            const BrickWords bw = vol.brick(b);
            // An unsound brick in the box is a candidate: its decoder names what is wrong with it.
            const bool sound = brickSound(vol, b);
            const uint32_t n = sound ? bw.words[L] : 0;
            bool hit = !sound;
            for (uint32_t k = 0; k < n; ++k) {
                const int64_t at = sel->find(bw.words[bw.size - 1 - k]);
                if (at < 0) continue;
                foundOf[t][size_t(at)] = 1;
                if (boxedBrick) foundInBoxOf[t][size_t(at)] = 1;
                hit = true;
            }
            if (hit && boxedBrick) {
                try {
                    candidatesOf[t].push_back(b);
                } catch (const std::bad_alloc&) {
                    scanFailed = true;
                }
            }
        }
        inBoxCount += boxed;
    }
    if (scanFailed) throw std::bad_alloc();
    r.bricksInBox = inBoxCount;
    std::vector<uint8_t> found(nSel, 0), foundInBox(nSel, 0);
    for (size_t t = 0; t < foundOf.size(); ++t)
        for (size_t i = 0; i < nSel; ++i) {
            found[i] |= foundOf[t][i];
            foundInBox[i] |= foundInBoxOf[t][i];
        }
    foundOf.clear();
    foundInBoxOf.clear();
    if (!file.hasAttributes) {
        for (size_t i = 0; i < nSel; ++i)
            if (!found[i]) unknown.push_back(sel->labels[i]);
        if (!unknown.empty()) {
            std::sort(unknown.begin(), unknown.end());
            return Status::error(std::to_string(unknown.size()) + " of the " + std::to_string(r.labelsSelected) +
                                 " selected labels occur nowhere in the volume (no brick's palette holds them): " +
                                 listLabels(unknown, false));
        }
    }
    for (uint8_t f : foundInBox) r.labelsFound += f;
    if (o.checkOnly) return r;
    std::vector<uint64_t> candidates;
    for (auto& c : candidatesOf) candidates.insert(candidates.end(), c.begin(), c.end());
    candidatesOf.clear();
    std::sort(candidates.begin(), candidates.end());
    r.bricksDecoded = candidates.size();

    // Step 3: decode the candidates; keep the tight box of each one's selected nodes.
    const std::vector<uint32_t>* map = file.decodeOptions().idToLabel;
    // Unselected nodes: 0, or kInvalidLabel where values are ids that may be 0 (wide labels).
    const uint32_t background = file.hasAttributes && file.wideLabels ? kInvalidLabel : 0;
    std::array<uint32_t, 128> spread{};
    for (uint32_t i = 0; i < 128; ++i) spread[i] = mortonSpread(i);
    std::vector<Piece> pieces(candidates.size());
    FirstError error;
    std::atomic<uint64_t> done{0};
    std::atomic<bool> cancelled{false};
    const int64_t nCand = int64_t(candidates.size());
#pragma omp parallel num_threads(threadCount(o.threads, candidates.size()))
    {
        BrickDecoder dec(vol);
        std::vector<uint32_t> local;
#pragma omp for schedule(dynamic, 1)
        for (int64_t ci = 0; ci < nCand; ++ci) {
            if (error.any.load(std::memory_order_relaxed) || cancelled.load(std::memory_order_relaxed)) continue;
            const uint64_t b = candidates[size_t(ci)];
            try {
                if (Status st = dec.decode(b, o.lod); !st) {
                    error.set(b, st);
                    continue;
                }
                // This brick's selected ids: usually one or a few, so lookups stay in cache.
                const BrickWords bw = vol.brick(b);
                local.clear();
                for (uint32_t k = 0, n = bw.words[L]; k < n; ++k) {
                    const uint32_t id = bw.words[bw.size - 1 - k];
                    if (sel->contains(id)) local.push_back(id);
                }
                std::sort(local.begin(), local.end());
                local.erase(std::unique(local.begin(), local.end()), local.end());
                const uint32_t single = local[0];
                const bool one = local.size() == 1;
                auto selected = [&](uint32_t v) {
                    return one ? v == single : std::binary_search(local.begin(), local.end(), v);
                };
                const uint32_t org[3] = {uint32_t(b % grid[0]) * edge, uint32_t((b / grid[0]) % grid[1]) * edge,
                                         uint32_t(b / (uint64_t(grid[0]) * grid[1])) * edge};
                uint32_t blo[3], bhi[3];
                for (int a = 0; a < 3; ++a) {
                    blo[a] = std::max(org[a], lo[a]);
                    bhi[a] = uint32_t(std::min<uint64_t>(uint64_t(org[a]) + edge, hi[a]));
                }
                const uint32_t* labels = dec.labels();
                Piece p;
                p.lo = {bhi[0], bhi[1], bhi[2]};
                p.hi = {blo[0], blo[1], blo[2]};
                for (uint32_t z = blo[2]; z < bhi[2]; ++z)
                    for (uint32_t y = blo[1]; y < bhi[1]; ++y) {
                        const uint32_t myz = (spread[y - org[1]] << 1) | (spread[z - org[2]] << 2);
                        for (uint32_t x = blo[0]; x < bhi[0]; ++x)
                            if (selected(labels[myz | spread[x - org[0]]])) {
                                ++p.count;
                                const uint32_t c[3] = {x, y, z};
                                for (int a = 0; a < 3; ++a) {
                                    p.lo[a] = std::min(p.lo[a], c[a]);
                                    p.hi[a] = std::max(p.hi[a], c[a] + 1);
                                }
                            }
                    }
                if (p.count) {
                    const size_t n = size_t(p.hi[0] - p.lo[0]) * (p.hi[1] - p.lo[1]) * (p.hi[2] - p.lo[2]);
                    if (o.mask) p.mask.assign(n, 0);
                    else p.labels.assign(n, background);
                    size_t i = 0;
                    for (uint32_t z = p.lo[2]; z < p.hi[2]; ++z)
                        for (uint32_t y = p.lo[1]; y < p.hi[1]; ++y) {
                            const uint32_t myz = (spread[y - org[1]] << 1) | (spread[z - org[2]] << 2);
                            for (uint32_t x = p.lo[0]; x < p.hi[0]; ++x, ++i) {
                                const uint32_t v = labels[myz | spread[x - org[0]]];
                                if (!selected(v)) continue;
                                if (o.mask) {
                                    p.mask[i] = 1;
                                } else if (map) {
                                    if (v >= map->size()) {
                                        error.set(b, Status::error("brick " + std::to_string(b) + ": id " + std::to_string(v) +
                                                                   " has no entry in the attribute database (" +
                                                                   std::to_string(map->size()) + " labels)"));
                                        break;
                                    }
                                    p.labels[i] = (*map)[v];
                                } else {
                                    p.labels[i] = v;
                                }
                            }
                        }
                    pieces[size_t(ci)] = std::move(p);
                }
            } catch (const std::bad_alloc&) {
                error.set(b, Status::error("brick " + std::to_string(b) + ": out of memory while extracting"));
            }
            const uint64_t d = ++done;
            if (o.progress && omp_get_thread_num() == 0 && !o.progress(double(d) / double(nCand))) cancelled = true;
        }
    }
    if (error.any) return error.status;
    if (cancelled) return Status::error("extraction cancelled");

    // Step 4: the union of the kept boxes is the output.
    std::array<uint32_t, 3> olo{{~0u, ~0u, ~0u}}, ohi{{0, 0, 0}};
    for (const Piece& p : pieces) {
        if (!p.count) continue;
        ++r.bricksWithVoxels;
        r.voxels += p.count;
        for (int a = 0; a < 3; ++a) {
            olo[a] = std::min(olo[a], p.lo[a]);
            ohi[a] = std::max(ohi[a], p.hi[a]);
        }
    }
    if (r.voxels == 0) return r;
    for (int a = 0; a < 3; ++a) r.dim[a] = ohi[a] - olo[a];
    r.offset = olo;
    const uint64_t nodes = uint64_t(r.dim[0]) * r.dim[1] * r.dim[2];
    const uint64_t bytes = nodes * (o.mask ? 1 : 4);
    if (bytes > o.maxOutputBytes)
        return Status::error("the selection's bounding box at level " + std::to_string(o.lod) + " is " +
                             std::to_string(r.dim[0]) + " x " + std::to_string(r.dim[1]) + " x " + std::to_string(r.dim[2]) +
                             (o.mask ? " (a mask of " : " (a label image of ") + mib(bytes) +
                             "), more than the output limit of " + mib(o.maxOutputBytes) +
                             " (raise the limit, narrow the box, or choose a coarser level)");
    if (o.mask) r.mask.assign(size_t(nodes), 0);
    else r.labels.assign(size_t(nodes), background);
    for (Piece& p : pieces) {
        if (!p.count) continue;
        const uint32_t w = p.hi[0] - p.lo[0];
        size_t i = 0;
        for (uint32_t z = p.lo[2]; z < p.hi[2]; ++z)
            for (uint32_t y = p.lo[1]; y < p.hi[1]; ++y, i += w) {
                const size_t at = size_t(p.lo[0] - olo[0]) +
                                  size_t(r.dim[0]) * (size_t(y - olo[1]) + size_t(r.dim[1]) * size_t(z - olo[2]));
                if (o.mask) std::copy_n(p.mask.data() + i, w, r.mask.data() + at);
                else std::copy_n(p.labels.data() + i, w, r.labels.data() + at);
            }
        p = Piece();
    }
    return r;
}

std::vector<int64_t> originalLabels(const ExtractResult& r, const CsgvFile& file) {
    std::vector<int64_t> out(r.labels.size());
    for (size_t i = 0; i < out.size(); ++i) out[i] = r.labels[i] == kInvalidLabel ? 0 : file.originalLabel(r.labels[i]);
    return out;
}

Result<std::vector<int64_t>> labelsMatchingQuery(const CsgvFile& file, const std::string& query) {
    if (!file.hasAttributes)
        return Status::error("no attribute database (" + attributeDbPathFor(file.path) +
                             ") to query; select labels by value instead");
    Result<AttributeTable> table = attributesFromDatabase(file.attributes);
    if (!table) return table.status();
    Result<std::vector<int64_t>> labels = labelsWhere(*table, query);
    if (!labels) return Status::error("query: " + labels.message());
    return labels;
}

} // namespace csgv
