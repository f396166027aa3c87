// SPDX-License-Identifier: MIT
#include "csgv/codec/Encoder.h"
#include "csgv/base/FileUtil.h"
#include "csgv/base/Morton.h"

#include <algorithm>
#include <cstdio>
#include <functional>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <exception>
#include <new>
#include <optional>
#include <omp.h>
#include <unordered_map>

#include <sys/resource.h>
#include <unistd.h>

namespace csgv {

namespace {


/// Operation symbols of one brick before entropy coding, two per byte (high nibble first).
struct BrickSymbols {
    std::vector<uint8_t> packed;
    uint32_t count = 0;
    std::array<uint32_t, 9> levelStart{}; ///< symbol index where each level begins; [L] = count
    std::vector<uint32_t> palette;        ///< in append order
    std::array<uint32_t, 16> countsA{};   ///< symbols of levels 0..L-2
    std::array<uint32_t, 16> countsB{};   ///< symbols of the finest level

    void push(uint32_t s) {
        if ((count & 1) == 0) packed.push_back(uint8_t(s << 4));
        else packed.back() |= uint8_t(s);
        ++count;
    }
    uint32_t at(uint32_t i) const { return (packed[i >> 1] >> ((i & 1) ? 0 : 4)) & 15u; }
};

/// @brief Builds the level hierarchy of one brick and chooses its operations (one per thread).
class BrickEncoder {
public:
    BrickEncoder(uint32_t brickSize, uint32_t opMask) : m_B(brickSize), m_L(floorLog2(brickSize) + 1), m_mask(opMask) {
        uint32_t total = 0;
        for (uint32_t l = 0; l < m_L; ++l) {
            m_off[l] = total;
            total += 1u << (3 * l);
        }
        m_label.resize(total);
        m_inVolume.resize(total);
        m_constant.resize(total);
        m_open.resize(total);
        for (uint32_t i = 0; i < 128; ++i) m_spread[i] = mortonSpread(i);
    }

    /// Encodes the brick whose voxels are `extent` (<= B per axis) labels of `slab` starting at
    /// (ox, oy, 0) of a slab W x H wide.
    /// Encodes the brick at (ox, oy, z0) of `extent` from `band`: rows [y0, y0 + H) of W labels
    /// of slices z0.., x fastest.
    Status encode(const uint32_t* band, uint32_t W, uint32_t H, uint32_t y0, uint32_t ox, uint32_t oy, uint32_t z0,
                  const std::array<uint32_t, 3>& extent, BrickSymbols& out) {
        const uint32_t L = m_L, finest = L - 1;
        uint32_t* fin = m_label.data() + m_off[finest];
        uint8_t* finIn = m_inVolume.data() + m_off[finest];
        const uint32_t n = m_B * m_B * m_B;
        // Bricks inside the volume (most of them) need no in-volume flags at all.
        m_inside = extent[0] == m_B && extent[1] == m_B && extent[2] == m_B;
        if (!m_inside) std::memset(finIn, 0, n);
        for (uint32_t z = 0; z < extent[2]; ++z)
            for (uint32_t y = 0; y < extent[1]; ++y) {
                const uint32_t* row = band + (uint64_t(z) * H + (oy - y0) + y) * W + ox;
                const uint32_t myz = (m_spread[y] << 1) | (m_spread[z] << 2);
                // label + 1 wraps to 0 only for the reserved 0xFFFFFFFF: one min finds it in passing.
                uint32_t smallestPlusOne = ~0u;
                for (uint32_t x = 0; x < extent[0]; ++x) {
                    fin[myz | m_spread[x]] = row[x];
                    smallestPlusOne = std::min(smallestPlusOne, row[x] + 1u);
                }
                if (smallestPlusOne == 0) {
                    const uint32_t x = uint32_t(std::find(row, row + extent[0], kInvalidLabel) - row);
                    return Status::error("label 0xFFFFFFFF at voxel (" + std::to_string(ox + x) + ", " +
                                         std::to_string(oy + y) + ", " + std::to_string(z0 + z) +
                                         ") is reserved; relabel the volume");
                }
                if (!m_inside)
                    for (uint32_t x = 0; x < extent[0]; ++x) finIn[myz | m_spread[x]] = 1;
            }
        // Coarse labels bottom-up: mode of the in-volume children, ties to the lowest child index.
        // Finest-level nodes are constant by definition, so level L-2 needs no child flags.
        for (uint32_t l = finest; l-- > 0;) {
            const uint32_t* cl = m_label.data() + m_off[l + 1];
            const uint8_t* ci = m_inVolume.data() + m_off[l + 1];
            const uint8_t* cc = m_constant.data() + m_off[l + 1];
            const bool childrenConstant = l + 1 == finest;
            uint32_t* pl = m_label.data() + m_off[l];
            uint8_t* pi = m_inVolume.data() + m_off[l];
            uint8_t* pc = m_constant.data() + m_off[l];
            for (uint32_t m = 0, count = 1u << (3 * l); m < count; ++m) {
                const uint32_t b = m << 3;
                const uint32_t* c8 = cl + b;
                if (m_inside) {
                    const uint32_t v = c8[0];
                    const bool same = (c8[1] == v) & (c8[2] == v) & (c8[3] == v) & (c8[4] == v) & (c8[5] == v) &
                                      (c8[6] == v) & (c8[7] == v);
                    if (same) {
                        pl[m] = v;
                        uint64_t flags;
                        std::memcpy(&flags, cc + b, 8);
                        pc[m] = childrenConstant || flags == 0x0101010101010101ull;
                        continue;
                    }
                    pc[m] = 0;
                    pl[m] = modeOfChildren(c8, 8);
                    continue;
                }
                pi[m] = ci[b];
                if (!ci[b]) {
                    pl[m] = kInvalidLabel;
                    pc[m] = 0;
                    continue;
                }
                uint32_t lab[8];
                int k = 0;
                bool same = true, allConstant = true;
                for (uint32_t c = 0; c < 8; ++c)
                    if (ci[b + c]) {
                        lab[k] = cl[b + c];
                        same = same && lab[k] == lab[0];
                        allConstant = allConstant && (childrenConstant || cc[b + c]);
                        ++k;
                    }
                pc[m] = same && allConstant;
                pl[m] = same ? lab[0] : modeOfChildren(lab, k);
            }
        }
        chooseOperations(out);
        return Status::ok();
    }

private:
    bool inVolume(uint32_t l, uint32_t m) const { return m_inside || m_inVolume[m_off[l] + m]; }

    void chooseOperations(BrickSymbols& out) {
        const uint32_t L = m_L;
        const bool useD = (m_mask & kMaskPaletteD) != 0;
        const bool stops = (m_mask & kMaskStopBits) != 0;
        out = BrickSymbols{};
        out.packed.reserve(m_lastPacked); // bricks of a volume are alike: skip regrowing
        m_index.clear();
        auto emit = [&](uint32_t s, uint32_t level) {
            out.push(s);
            (level + 1 == L ? out.countsB : out.countsA)[s]++;
        };
        for (uint32_t l = 0; l < L; ++l) {
            out.levelStart[l] = out.count;
            const uint32_t* cur = m_label.data() + m_off[l];
            const uint8_t* cst = m_constant.data() + m_off[l];
            uint8_t* open = m_open.data() + m_off[l];
            const bool finest = l + 1 == L;
            if (l == 0) {
                const bool stop = stops && cst[0];
                emit(kOpPaletteAdv | (stop ? kStopBit : 0u), 0);
                out.palette.push_back(cur[0]);
                if (useD) m_index[cur[0]] = 0;
                open[0] = !stop;
                continue;
            }
            const uint32_t* par = m_label.data() + m_off[l - 1];
            const uint8_t* parOpen = m_open.data() + m_off[l - 1];
            const uint32_t parentGrid = 1u << (l - 1);
            for (uint32_t m = 0, count = 1u << (3 * l); m < count; ++m) {
                const uint32_t pm = m >> 3;
                if (!parOpen[pm]) { // a closed parent: none of its 8 children is visited
                    std::memset(open + m, 0, 8);
                    m += 7;
                    continue;
                }
                if (!inVolume(l, m)) {
                    open[m] = 0;
                    continue;
                }
                const uint32_t label = cur[m];
                uint32_t op = kOpPaletteAdv;
                uint64_t distance = 0;
                if ((m_mask & kMaskParent) && par[pm] == label) op = kOpParent;
                for (int axis = 0; axis < 3 && op == kOpPaletteAdv; ++axis) {
                    if (!(m_mask & (kMaskNeighborX << axis))) continue;
                    if (((m >> axis) & 1u) == 0) {
                        if ((m & mortonAxisMask(axis)) != 0 && cur[mortonDecrement(m, axis)] == label)
                            op = kOpNeighborX + axis;
                    } else if (mortonCompact(pm >> axis) + 1 < parentGrid) {
                        const uint32_t q = mortonIncrement(pm, axis);
                        if (inVolume(l - 1, q) && par[q] == label) op = kOpNeighborX + axis;
                    }
                }
                if (op == kOpPaletteAdv && (m_mask & kMaskPaletteLast) && out.palette.back() == label)
                    op = kOpPaletteLast;
                if (op == kOpPaletteAdv && useD) {
                    auto it = m_index.find(label);
                    // Distances count from the entry before the last one; without PALETTE_LAST the
                    // last entry is unreachable and gets appended again.
                    const uint64_t last = out.palette.size() - 1;
                    if (it != m_index.end() && it->second < last) {
                        op = kOpPaletteD;
                        distance = last - 1 - it->second;
                    }
                }
                const bool stop = stops && !finest && cst[m]; // cst of the finest level is never read
                emit(op | (stop ? kStopBit : 0u), l);
                if (op == kOpPaletteD) {
                    int groups = 1;
                    while (groups < int(kMaxDistanceGroups) && (distance >> (3 * groups)) != 0) ++groups;
                    for (int g = groups - 1; g >= 0; --g)
                        emit(uint32_t((distance >> (3 * g)) & 7u) | (g > 0 ? 8u : 0u), l);
                } else if (op == kOpPaletteAdv) {
                    if (useD) m_index[label] = uint32_t(out.palette.size());
                    out.palette.push_back(label);
                }
                open[m] = !stop;
            }
        }
        out.levelStart[L] = out.count;
        m_lastPacked = out.packed.size();
    }

    uint32_t m_B, m_L, m_mask;
    std::array<uint32_t, 8> m_off{};
    std::vector<uint32_t> m_label;
    std::vector<uint8_t> m_inVolume, m_constant, m_open;
    std::array<uint32_t, 128> m_spread{};
    bool m_inside = false; ///< the brick lies wholly inside the volume
    size_t m_lastPacked = 0;
    std::unordered_map<uint32_t, uint32_t> m_index; ///< label -> palette index (PALETTE_D)
};

/// Scales counts to a table summing to 16384 in which every counted symbol has frequency >= 1.
std::array<uint32_t, 16> normalizeFrequencies(const std::array<uint64_t, 16>& counts) {
    std::array<uint32_t, 16> f{};
    uint64_t total = 0;
    for (uint64_t c : counts) total += c;
    if (total == 0) {
        f[0] = kRansTotal; // nothing to code: any valid table
        return f;
    }
    int64_t sum = 0;
    for (int s = 0; s < 16; ++s) {
        if (!counts[s]) continue;
        f[s] = uint32_t(std::max<uint64_t>(1, (counts[s] * kRansTotal + total / 2) / total));
        sum += f[s];
    }
    // Fix the sum where it costs least: take from or give to the symbols with the most room.
    while (sum != int64_t(kRansTotal)) {
        int pick = -1;
        double bestCost = 1e300;
        for (int s = 0; s < 16; ++s) {
            if (!counts[s]) continue;
            if (sum > int64_t(kRansTotal) && f[s] <= 1) continue;
            // Change in coded bits of moving this symbol's frequency by one.
            const double nf = double(f[s]) + (sum > int64_t(kRansTotal) ? -1.0 : 1.0);
            const double cost = double(counts[s]) * (std::log2(double(f[s])) - std::log2(nf));
            if (cost < bestCost) {
                bestCost = cost;
                pick = s;
            }
        }
        if (sum > int64_t(kRansTotal)) {
            --f[pick];
            --sum;
        } else {
            ++f[pick];
            ++sum;
        }
    }
    return f;
}

/// Per-symbol constants that turn rANS's division by the frequency into a multiply and shift:
/// q = floor(x / f) = (x * rcp) >> (32 + shift) for x < 2^31, exact for every f in 1..16384.
struct RansSymbol {
    uint32_t xMax = 0, rcp = 0, shift = 0, bias = 0, complement = 0;
};

std::array<RansSymbol, 16> ransSymbols(const std::array<uint32_t, 16>& freq) {
    std::array<RansSymbol, 16> out{};
    uint32_t cum = 0;
    for (int s = 0; s < 16; ++s) {
        const uint32_t f = freq[s];
        RansSymbol& r = out[s];
        r.xMax = ((kRansLowerBound >> kRansProbBits) << 8) * f;
        r.complement = kRansTotal - f;
        if (f < 2) { // f == 1: q = x, so x' = x * 2^14 + cum, written as x + bias + q * complement
            r.rcp = ~0u;
            r.shift = 0;
            r.bias = cum + kRansTotal - 1;
        } else {
            uint32_t sh = 0;
            while (f > (1u << sh)) ++sh;
            r.rcp = uint32_t(((uint64_t(1) << (sh + 31)) + f - 1) / f);
            r.shift = sh - 1;
            r.bias = cum;
        }
        cum += f;
    }
    return out;
}

/// rANS-codes symbols [begin, end) of a brick (section 4.1): the final state word, then the bytes
/// the encoder wrote backwards, read forward, zero padded to a word.
void ransEncode(const BrickSymbols& sym, uint32_t begin, uint32_t end, const std::array<RansSymbol, 16>& table,
                std::vector<uint8_t>& scratch, std::vector<uint32_t>& out) {
    uint32_t x = kRansLowerBound;
    // A state below 2^31 sheds at most two bytes per symbol (the lower bound is 2^23).
    scratch.resize(size_t(end - begin) * 2 + 8);
    uint8_t* put = scratch.data();
    for (uint32_t i = end; i-- > begin;) {
        const RansSymbol& r = table[sym.at(i)];
        while (x >= r.xMax) {
            *put++ = uint8_t(x & 0xFF);
            x >>= 8;
        }
        const uint32_t q = uint32_t((uint64_t(x) * r.rcp) >> 32) >> r.shift;
        x = x + r.bias + q * r.complement;
    }
    out.push_back(x);
    const size_t bytes = size_t(put - scratch.data());
    const size_t first = out.size();
    out.resize(first + (bytes + 3) / 4, 0u);
    for (size_t j = 0; j < bytes; ++j) out[first + j / 4] |= uint32_t(scratch[bytes - 1 - j]) << (8 * (j % 4));
}

/// Final words of one brick.
void assembleBrick(const BrickSymbols& sym, uint32_t L, int32_t encoding, const std::array<RansSymbol, 16>& tableA,
                   const std::array<RansSymbol, 16>& tableB, std::vector<uint8_t>& scratch, std::vector<uint32_t>& w) {
    w.assign(L + 1, 0);
    for (uint32_t l = 0; l < L; ++l) w[l] = (L + 1) * 8 + sym.levelStart[l];
    w[L] = uint32_t(sym.palette.size());
    if (encoding == kEncodingNibble) {
        const size_t first = w.size();
        w.resize(first + (sym.count + 7) / 8, 0u);
        for (uint32_t i = 0; i < sym.count; ++i) w[first + i / 8] |= sym.at(i) << (28 - 4 * (i % 8));
    } else if (encoding == kEncodingRans1) {
        ransEncode(sym, 0, sym.count, tableA, scratch, w);
    } else {
        ransEncode(sym, 0, sym.levelStart[L - 1], tableA, scratch, w);
        w[L - 1] = uint32_t(w.size()) * 8;
        ransEncode(sym, sym.levelStart[L - 1], sym.count, tableB, scratch, w);
    }
    w.insert(w.end(), sym.palette.rbegin(), sym.palette.rend());
}

/// The container fields an encoding decides before any brick is seen.
Result<CompressedVolume> newVolume(SlabSource& source, const EncodeOptions& options) {
    Status s = checkEncodeOptions(options);
    if (!s) return s;
    CompressedVolume vol;
    vol.version = 16;
    vol.brickSize = options.brickSize;
    vol.dim = source.dimensions();
    vol.encoding = options.encoding;
    vol.opMask = options.opMask;
    for (int a = 0; a < 3; ++a)
        if (vol.dim[a] == 0) return Status::error("volume dimension " + std::to_string(a) + " is 0");
    if (vol.brickCount() > kMaxBricks) return Status::error("volume needs more than 2^40 bricks");
    return vol;
}

int threadsFor(const EncodeOptions& options) { return options.threads > 0 ? options.threads : omp_get_max_threads(); }

/// @brief Exceptions must not leave an OpenMP region (the process would end): the first one a
/// worker throws is kept and rethrown on the calling thread after the region, where
/// encodeToFile turns it into a Status.
class RegionExceptions {
public:
    template <typename Fn>
    void run(Fn&& fn) noexcept {
        try {
            fn();
        } catch (...) {
            std::lock_guard<std::mutex> lock(m_mutex);
            if (!m_first) m_first = std::current_exception();
        }
    }
    void rethrow() const {
        if (m_first) std::rethrow_exception(m_first);
    }

private:
    std::mutex m_mutex;
    std::exception_ptr m_first;
};

/// @brief How pass 1 reads the labels: bands of `rows` rows (whole brick rows) of `slabs`
/// brick-deep slabs at once, `depth` slices deep. A source that does not read rows gives whole
/// slabs, one at a time; one that does is read in bands of about maxBandBytes, as deep as its
/// chunks (chunkDepth()) so that no chunk is read twice.
struct BandShape {
    uint32_t rows = 0;
    uint32_t slabs = 1;
    /// Slices a band holds: the slabs' slices, never more than the volume has (a single slice
    /// in bricks of 32 is one slice of labels, not 32).
    uint32_t depth = 0;
};

BandShape bandShape(const SlabSource& source, uint32_t B, uint64_t maxBandBytes) {
    const auto dim = source.dimensions();
    BandShape shape;
    shape.rows = dim[1];
    if (source.readsRows() && !source.slabInMemory(0)) {
        const uint32_t slabsPerVolume = (dim[2] + B - 1) / B;
        shape.slabs = std::clamp<uint32_t>((source.chunkDepth() + B - 1) / B, 1, std::max(slabsPerVolume, 1u));
        const uint64_t brickRowBytes = uint64_t(dim[0]) * B * B * shape.slabs * sizeof(uint32_t);
        const uint64_t brickRows = std::max<uint64_t>(1, maxBandBytes / std::max<uint64_t>(brickRowBytes, 1));
        shape.rows = uint32_t(std::min<uint64_t>(dim[1], brickRows * B));
    }
    shape.depth = uint32_t(std::min<uint64_t>(uint64_t(shape.slabs) * B, dim[2]));
    return shape;
}

/// Bytes of a band of `shape` over slices `width` labels wide (saturating).
uint64_t bandBytes(const BandShape& shape, uint32_t width) {
    return mulSaturate(product3(width, shape.rows, shape.depth), sizeof(uint32_t));
}

/// The memory this process may use: the machine's, or the address-space limit (ulimit -v) where
/// that is smaller; `what` words it for messages.
uint64_t memoryAllowed(std::string* what) {
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    uint64_t memory = pages > 0 && page > 0 ? uint64_t(pages) * uint64_t(page) : ~uint64_t(0);
    std::string text = "this machine's " + std::to_string(memory >> 20) + " MiB of memory";
    struct rlimit rl {};
    if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && uint64_t(rl.rlim_cur) < memory) {
        memory = uint64_t(rl.rlim_cur);
        text = "the process's address-space limit of " + std::to_string(memory >> 20) + " MiB";
    }
    if (what) *what = text;
    return memory;
}

/// Pass 1's band of labels for `source` in bricks of B, refused before it is allocated when it
/// cannot fit the memory the process may use, and when its allocation fails: the message names
/// the band, the bytes it needs, the limit, and a brick size whose band fits, where one does.
class BandMemory {
public:
    BandMemory(const SlabSource& source, uint32_t B, uint64_t maxBandBytes)
        : m_source(source), m_B(B), m_maxBandBytes(maxBandBytes), m_shape(bandShape(source, B, maxBandBytes)) {}

    /// Sizes `band` for the shape's labels.
    Status allocate(std::vector<uint32_t>& band) const {
        std::string what;
        const uint64_t limit = memoryAllowed(&what);
        const uint64_t bytes = bandBytes(m_shape, m_source.dimensions()[0]);
        if (bytes > limit) return refusal("more than " + what, limit);
        try {
            band.resize(size_t(bytes / sizeof(uint32_t)));
        } catch (const std::bad_alloc&) {
            return refusal("and the allocation failed (" + what + ")", limit);
        }
        return Status::ok();
    }

private:
    Status refusal(const std::string& why, uint64_t limit) const {
        const uint32_t W = m_source.dimensions()[0];
        std::string smaller;
        for (uint32_t b = m_B / 2; b >= 8 && smaller.empty(); b /= 2) {
            const uint64_t bytes = bandBytes(bandShape(m_source, b, m_maxBandBytes), W);
            if (bytes < bandBytes(m_shape, W) && (bytes <= limit || b == 8))
                smaller = (bytes <= limit ? "; bricks of " : "; even bricks of ") + std::to_string(b) + "^3 need " +
                          std::to_string(bytes) + " (--brick-size " + std::to_string(b) + ")";
        }
        if (smaller.empty())
            smaller = m_shape.depth < m_B ? "; a smaller --brick-size needs no less: the band is as deep as the volume"
                                          : "; bricks of 8^3 are the smallest";
        return Status::error("a band of " + std::to_string(W) + " x " + std::to_string(m_shape.rows) + " x " +
                             std::to_string(m_shape.depth) + " labels (bricks of " + std::to_string(m_B) +
                             "^3) needs " + std::to_string(bandBytes(m_shape, W)) + " bytes of memory, " + why +
                             smaller);
    }

    const SlabSource& m_source;
    uint32_t m_B;
    uint64_t m_maxBandBytes;
    BandShape m_shape;
};

/// @brief The symbols of constant bricks, made without their voxels: one template per brick
/// extent of the volume (inside, and cut at the far end of each axis: at most 8), encoded once
/// from a brick of label 0 by the same BrickEncoder as every brick. A constant brick's operations
/// do not depend on its label (every node carries it, so each choice compares equal labels, the
/// PALETTE_D index included), only its palette does, which holds the label in every entry. So a
/// copy of the template with the label in its palette is, symbol for symbol, what encoding the
/// brick's voxels gives.
class ConstantBricks {
public:
    ConstantBricks(const CompressedVolume& vol, uint32_t opMask) : m_B(vol.brickSize) {
        const uint32_t B = m_B;
        BrickEncoder enc(B, opMask);
        const std::vector<uint32_t> zeros(size_t(B) * B * B, 0u);
        for (uint32_t key = 0; key < 8; ++key) {
            std::array<uint32_t, 3> extent{};
            bool exists = true;
            for (int a = 0; a < 3; ++a) {
                const uint32_t cut = vol.dim[a] % B;
                const bool far = (key >> a) & 1u;
                exists = exists && (!far || cut != 0);
                extent[a] = far ? cut : B;
            }
            if (!exists) continue;
            Status s = enc.encode(zeros.data(), B, B, 0, 0, 0, 0, extent, m_templates[key]);
            (void)s; // label 0 is never the reserved one
        }
    }
    /// The symbols of the brick of this extent whose every voxel holds `label` (not 0xFFFFFFFF).
    void make(const std::array<uint32_t, 3>& extent, uint32_t label, BrickSymbols& out) const {
        uint32_t key = 0;
        for (int a = 0; a < 3; ++a) key |= extent[a] == m_B ? 0u : 1u << a;
        out = m_templates[key];
        std::fill(out.palette.begin(), out.palette.end(), label);
    }

private:
    uint32_t m_B;
    std::array<BrickSymbols, 8> m_templates;
};

/// @brief Where the bricks of one band of pass 1 lie: bricks x fastest, then brick rows, then
/// slabs (the pass-1 loop's order).
struct BandBricks {
    uint32_t z0 = 0, depth = 0, y0 = 0, rows = 0;
    uint64_t firstRow = 0, rowsHere = 0, slabs = 0; ///< brick rows: the first, how many; slabs
    uint64_t gridX = 0;                             ///< bricks along x
    uint64_t perSlab() const { return gridX * rowsHere; }
    uint64_t count() const { return perSlab() * slabs; }
};

/// A band brick no uniform box covers whole with one label (or one holding the reserved label,
/// which must be read for its error).
constexpr uint64_t kScanBrick = ~uint64_t(0);

/// For each brick of `band` (BandBricks order): the label of the uniform boxes that cover it whole
/// with one label, else kScanBrick. Boxes are disjoint (SlabSource::uniformBoxes), so a brick is
/// covered when the voxels they share with it add up to its own. Time: the bricks each box touches.
void uniformBricks(const std::vector<UniformBox>& boxes, const BandBricks& band, const CompressedVolume& vol,
                   std::vector<uint64_t>& label, std::vector<uint64_t>& covered) {
    const uint64_t B = vol.brickSize;
    constexpr uint64_t kUnset = uint64_t(1) << 63;
    label.assign(size_t(band.count()), kUnset);
    covered.assign(size_t(band.count()), 0);
    // 64-bit coordinates: a brick's far end may lie past 2^32.
    const std::array<uint64_t, 3> lo = {0, band.y0, band.z0};
    const std::array<uint64_t, 3> hi = {vol.dim[0], uint64_t(band.y0) + band.rows, uint64_t(band.z0) + band.depth};
    for (const UniformBox& box : boxes) {
        std::array<uint64_t, 3> a{}, b{}; // the box within the band
        for (int k = 0; k < 3; ++k) {
            a[k] = std::max<uint64_t>(box.lo[k], lo[k]);
            b[k] = std::min<uint64_t>(box.hi[k], hi[k]);
        }
        if (a[0] >= b[0] || a[1] >= b[1] || a[2] >= b[2]) continue;
        const bool valid = box.value < kInvalidLabel;
        const auto overlap = [&](int k, uint64_t start) { return std::min(b[k], start + B) - std::max(a[k], start); };
        for (uint64_t bz = (a[2] - band.z0) / B; band.z0 + bz * B < b[2]; ++bz)
            for (uint64_t by = a[1] / B; by * B < b[1]; ++by)
                for (uint64_t bx = a[0] / B; bx * B < b[0]; ++bx) {
                    const size_t i = size_t(bz * band.perSlab() + (by - band.firstRow) * band.gridX + bx);
                    covered[i] += overlap(0, bx * B) * overlap(1, by * B) * overlap(2, band.z0 + bz * B);
                    label[i] = !valid || (label[i] != kUnset && label[i] != box.value) ? kScanBrick : box.value;
                }
    }
    for (uint64_t i = 0; i < band.count(); ++i) {
        const uint64_t k = i / band.perSlab(), by = band.firstRow + i % band.perSlab() / band.gridX,
                       bx = i % band.gridX;
        const uint64_t voxels = std::min<uint64_t>(B, vol.dim[0] - bx * B) * std::min<uint64_t>(B, vol.dim[1] - by * B) *
                                std::min<uint64_t>(B, vol.dim[2] - (band.z0 + k * B));
        if (label[size_t(i)] == kUnset || covered[size_t(i)] != voxels) label[size_t(i)] = kScanBrick;
    }
}

/// Pass 1, band by band (bandShape): level hierarchy, operations and symbols of every brick,
/// handed to `take(bz, slabSymbols)` slab by slab in order (bricks x fastest, then y). Bricks the
/// source's uniform boxes cover (EncodeOptions::useUniformBoxes) are made by ConstantBricks; only
/// the brick rows of a band that hold another brick are read, none when there is none.
Status symbolsBySlab(SlabSource& source, const CompressedVolume& vol, const EncodeOptions& options,
                     uint64_t maxBandBytes, const std::function<Status(uint32_t, std::vector<BrickSymbols>&)>& take) {
    const uint32_t B = vol.brickSize, W = vol.dim[0], H = vol.dim[1], D = vol.dim[2];
    const auto grid = vol.brickGrid();
    const uint64_t perSlab = uint64_t(grid[0]) * grid[1];
    const BandShape shape = bandShape(source, B, maxBandBytes);
    // Allocated at the first read: a volume of uniform boxes never needs it.
    std::vector<uint32_t> band;
    const uint64_t brickRowsPerBand = (shape.rows + B - 1) / B;
    const int nThreads =
        int(std::min<uint64_t>(uint64_t(threadsFor(options)), uint64_t(grid[0]) * brickRowsPerBand * shape.slabs));
    std::vector<std::vector<BrickSymbols>> symbols(shape.slabs);
    std::vector<UniformBox> boxes;
    std::vector<uint64_t> uniform, covered;
    std::optional<ConstantBricks> constants;
    for (uint32_t bz0 = 0; bz0 < grid[2]; bz0 += shape.slabs) {
        const uint32_t slabs = std::min(shape.slabs, grid[2] - bz0);
        const uint32_t z0 = bz0 * B, depth = std::min(slabs * B, D - z0);
        for (uint32_t k = 0; k < slabs; ++k) symbols[k].assign(size_t(perSlab), BrickSymbols{});
        for (uint32_t y0 = 0; y0 < H; y0 += shape.rows) {
            const uint32_t rows = std::min(shape.rows, H - y0);
            BandBricks bb;
            bb.z0 = z0;
            bb.depth = depth;
            bb.y0 = y0;
            bb.rows = rows;
            bb.firstRow = y0 / B;
            bb.rowsHere = (rows + B - 1) / B;
            bb.slabs = slabs;
            bb.gridX = grid[0];
            const uint64_t bandBricks = bb.count();
            // The rows to read: the brick rows holding a brick that no uniform box covers.
            uint32_t readY0 = y0, readRows = rows;
            boxes.clear();
            if (options.useUniformBoxes) source.uniformBoxes(z0, depth, y0, rows, boxes);
            if (boxes.empty()) {
                uniform.assign(size_t(bandBricks), kScanBrick);
            } else {
                uniformBricks(boxes, bb, vol, uniform, covered);
                uint64_t firstScan = bb.rowsHere, lastScan = 0;
                for (uint64_t i = 0; i < bandBricks; ++i)
                    if (uniform[size_t(i)] == kScanBrick) {
                        const uint64_t r = i % bb.perSlab() / bb.gridX;
                        firstScan = std::min(firstScan, r);
                        lastScan = std::max(lastScan, r);
                    }
                if (firstScan == bb.rowsHere) readRows = 0;
                else if (source.readsRows()) {
                    readY0 = y0 + uint32_t(firstScan) * B;
                    readRows = std::min(y0 + rows, y0 + uint32_t(lastScan + 1) * B) - readY0;
                }
                if (!constants && std::count(uniform.begin(), uniform.end(), kScanBrick) < std::ptrdiff_t(bandBricks))
                    constants.emplace(vol, options.opMask);
            }
            const uint32_t* bandData = source.slabInMemory(z0);
            if (bandData) {
                readY0 = y0;
                readRows = rows;
            } else if (readRows > 0) {
                if (band.empty())
                    if (Status s = BandMemory(source, B, maxBandBytes).allocate(band); !s) return s;
                Status s = readRows == H ? source.readSlab(z0, depth, band.data())
                                         : source.readRows(z0, depth, readY0, readRows, band.data());
                if (!s) return s;
                bandData = band.data();
            }
            // Bricks of the band: x fastest, then y, then the slab; errors reported for the first
            // brick in file order (slab, then y, then x).
            const uint64_t firstRow = bb.firstRow, bandRowsHere = bb.rowsHere;
            const auto brickOf = [&](uint64_t i, uint32_t& k, uint64_t& inSlab, std::array<uint32_t, 3>& extent) {
                k = uint32_t(i / (grid[0] * bandRowsHere));
                inSlab = firstRow * grid[0] + i % (grid[0] * bandRowsHere);
                const uint32_t bx = uint32_t(inSlab % grid[0]), by = uint32_t(inSlab / grid[0]);
                extent = {std::min(B, W - bx * B), std::min(B, H - by * B), std::min(B, D - (z0 + k * B))};
            };
            if (readRows == 0) {
                // Every brick constant: copies of a template, cheaper than waking the workers
                // (whose spinning at the region's end cost ten times the work on a busy machine).
                for (uint64_t i = 0; i < bandBricks; ++i) {
                    uint32_t k = 0;
                    uint64_t inSlab = 0;
                    std::array<uint32_t, 3> extent{};
                    brickOf(i, k, inSlab, extent);
                    constants->make(extent, uint32_t(uniform[size_t(i)]), symbols[k][size_t(inSlab)]);
                }
                continue;
            }
            std::mutex mutex;
            Status error;
            uint64_t errorBrick = ~uint64_t(0);
            RegionExceptions thrown;
#pragma omp parallel num_threads(nThreads)
            {
                std::optional<BrickEncoder> enc;
                thrown.run([&] { enc.emplace(B, options.opMask); });
#pragma omp for schedule(dynamic, 1)
                for (int64_t i = 0; i < int64_t(bandBricks); ++i) {
                    uint32_t k = 0;
                    uint64_t inSlab = 0;
                    std::array<uint32_t, 3> extent{};
                    brickOf(uint64_t(i), k, inSlab, extent);
                    const uint32_t bx = uint32_t(inSlab % grid[0]), by = uint32_t(inSlab / grid[0]);
                    const uint32_t zk = z0 + k * B;
                    BrickSymbols& out = symbols[k][size_t(inSlab)];
                    if (uniform[size_t(i)] != kScanBrick) {
                        thrown.run([&] { constants->make(extent, uint32_t(uniform[size_t(i)]), out); });
                        continue;
                    }
                    if (!enc) continue;
                    const uint32_t* slabData = bandData + uint64_t(k) * B * readRows * W;
                    Status st;
                    thrown.run([&] { st = enc->encode(slabData, W, readRows, readY0, bx * B, by * B, zk, extent, out); });
                    if (!st) {
                        std::lock_guard<std::mutex> lock(mutex);
                        const uint64_t order = uint64_t(k) * perSlab + inSlab;
                        if (order < errorBrick) {
                            errorBrick = order;
                            error = st;
                        }
                    }
                }
            }
            thrown.rethrow();
            if (!error.isOk()) return error;
        }
        for (uint32_t k = 0; k < slabs; ++k)
            if (Status s = take(bz0 + k, symbols[k]); !s) return s;
    }
    return Status::ok();
}

/// Adds one brick's symbols to `counts` (order independent, so any thread count gives the same
/// tables).
void addSymbols(SymbolCounts& counts, const BrickSymbols& sym, int32_t encoding) {
    for (int k = 0; k < 16; ++k) {
        if (encoding == kEncodingRans1) counts.a[k] += uint64_t(sym.countsA[k]) + sym.countsB[k];
        else {
            counts.a[k] += sym.countsA[k];
            counts.b[k] += sym.countsB[k];
        }
    }
}

/// The frequency tables: the caller's fixed ones (checked against what the volume needs) or
/// normalised counts, of the whole volume when the caller shares counts between pieces.
Status chooseTables(const EncodeOptions& options, const SymbolCounts& pieceCounts, CompressedVolume& vol) {
    SymbolCounts counts = pieceCounts;
    if (options.shareCounts) {
        Result<SymbolCounts> shared = options.shareCounts(pieceCounts);
        if (!shared) return shared.status();
        counts = *shared;
        for (int k = 0; k < 16; ++k)
            if (counts.a[k] < pieceCounts.a[k] || counts.b[k] < pieceCounts.b[k])
                return Status::error("the shared symbol counts are smaller than this piece's own");
    }
    if (!options.fixedTables) {
        if (vol.encoding != kEncodingNibble) vol.freqA = normalizeFrequencies(counts.a);
        if (vol.encoding == kEncodingRans2) vol.freqB = normalizeFrequencies(counts.b);
        return Status::ok();
    }
    vol.freqA = options.tableA;
    vol.freqB = options.tableB;
    for (int k = 0; k < 16; ++k)
        if ((counts.a[k] && !vol.freqA[k] && vol.encoding != kEncodingNibble) ||
            (counts.b[k] && !vol.freqB[k] && vol.encoding == kEncodingRans2))
            return Status::error("the given frequency tables lack symbol " + std::to_string(k) +
                                 ", which the volume needs");
    if (vol.encoding == kEncodingNibble) vol.freqA = vol.freqB = {};
    if (vol.encoding == kEncodingRans1) vol.freqB = {};
    uint64_t sumA = 0, sumB = 0;
    for (int k = 0; k < 16; ++k) {
        sumA += vol.freqA[k];
        sumB += vol.freqB[k];
    }
    if ((vol.encoding != kEncodingNibble && sumA != kRansTotal) || (vol.encoding == kEncodingRans2 && sumB != kRansTotal))
        return Status::error("the given frequency tables do not sum to 16384");
    return Status::ok();
}

/// @brief Pass 2's entropy coder: the final words of bricks, with the volume's tables.
class BrickAssembler {
public:
    explicit BrickAssembler(const CompressedVolume& vol)
        : m_L(vol.levels()), m_encoding(vol.encoding), m_symA(ransSymbols(vol.freqA)), m_symB(ransSymbols(vol.freqB)) {}
    /// words[i] = the encoding of symbols[i] (the symbols are released), in parallel; what a
    /// worker throws is rethrown here.
    void assemble(std::vector<BrickSymbols>& symbols, std::vector<std::vector<uint32_t>>& words, int threads) const {
        words.resize(symbols.size());
        RegionExceptions thrown;
#pragma omp parallel num_threads(int(std::max<size_t>(1, std::min<size_t>(size_t(threads), symbols.size()))))
        {
            std::vector<uint8_t> scratch;
#pragma omp for schedule(dynamic, 4)
            for (int64_t i = 0; i < int64_t(symbols.size()); ++i) {
                thrown.run([&] {
                    assembleBrick(symbols[size_t(i)], m_L, m_encoding, m_symA, m_symB, scratch, words[size_t(i)]);
                    symbols[size_t(i)] = BrickSymbols{};
                });
            }
        }
        thrown.rethrow();
    }

private:
    uint32_t m_L;
    int32_t m_encoding;
    std::array<RansSymbol, 16> m_symA, m_symB;
};

/// Words an encoding array may hold under these options.
uint64_t arrayLimitOf(const EncodeOptions& options) {
    return std::min<uint64_t>(std::max<uint32_t>(options.maxArrayWords, 1), kMaxWordsPerArray);
}

/// @brief A temporary file beside the output, unlinked as soon as it is open (nothing is left
/// behind, whatever happens), written front to back and then read back front to back.
class ScratchFile {
public:
    ~ScratchFile() {
        if (m_file) std::fclose(m_file);
    }
    Status open(const std::string& near, const char* what) {
        m_name = temporaryNameFor(near) + "-" + what;
        m_file = std::fopen(m_name.c_str(), "w+b");
        if (!m_file) return Status::error("cannot create the scratch file '" + m_name + "': " + errnoText());
        std::remove(m_name.c_str());
        return Status::ok();
    }
    Status write(const void* data, size_t bytes) {
        if (bytes && std::fwrite(data, 1, bytes, m_file) != bytes)
            return Status::error("cannot write the scratch file '" + m_name + "': " + errnoText());
        m_bytes += bytes;
        return Status::ok();
    }
    Status rewind() {
        if (std::fflush(m_file) != 0 || std::fseek(m_file, 0, SEEK_SET) != 0)
            return Status::error("cannot rewind the scratch file '" + m_name + "': " + errnoText());
        return Status::ok();
    }
    Status read(void* data, size_t bytes) {
        if (bytes && std::fread(data, 1, bytes, m_file) != bytes)
            return Status::error("cannot read back the scratch file '" + m_name + "'");
        return Status::ok();
    }
    uint64_t bytes() const { return m_bytes; }

private:
    std::string m_name;
    std::FILE* m_file = nullptr;
    uint64_t m_bytes = 0;
};

/// @brief Bytes written front to back, then read back front to back: in memory, in blocks
/// allocated at their full size (no vector doubling, no copy, no heap fragments), up to a limit;
/// past it, everything moves to a ScratchFile and the blocks are freed.
class Spool {
public:
    static constexpr size_t kBlockBytes = size_t(16) << 20;

    Spool(std::string near, const char* what, uint64_t maxHeldBytes)
        : m_near(std::move(near)), m_what(what), m_maxHeld(maxHeldBytes) {}

    Status write(const void* data, size_t bytes) {
        if (m_inFile) return m_file.write(data, bytes);
        if (m_bytes + bytes > m_maxHeld) {
            Status s = m_file.open(m_near, m_what);
            for (size_t i = 0; s && i < m_blocks.size(); ++i)
                s = m_file.write(m_blocks[i].get(), size_t(std::min<uint64_t>(kBlockBytes, m_bytes - i * kBlockBytes)));
            if (!s) return s;
            m_blocks.clear();
            m_inFile = true;
            return m_file.write(data, bytes);
        }
        const auto* p = static_cast<const uint8_t*>(data);
        while (bytes > 0) {
            const size_t at = size_t(m_bytes % kBlockBytes);
            if (at == 0) m_blocks.push_back(std::make_unique<uint8_t[]>(kBlockBytes));
            const size_t n = std::min(bytes, kBlockBytes - at);
            std::memcpy(m_blocks.back().get() + at, p, n);
            p += n;
            bytes -= n;
            m_bytes += n;
        }
        return Status::ok();
    }
    Status rewind() {
        m_read = 0;
        return m_inFile ? m_file.rewind() : Status::ok();
    }
    Status read(void* data, size_t bytes) {
        if (m_inFile) return m_file.read(data, bytes);
        if (m_read + bytes > m_bytes) return Status::error("the held symbols ended early");
        auto* p = static_cast<uint8_t*>(data);
        while (bytes > 0) {
            const size_t at = size_t(m_read % kBlockBytes);
            const size_t n = std::min(bytes, kBlockBytes - at);
            std::memcpy(p, m_blocks[size_t(m_read / kBlockBytes)].get() + at, n);
            p += n;
            bytes -= n;
            m_read += n;
        }
        return Status::ok();
    }

private:
    std::string m_near;
    const char* m_what;
    uint64_t m_maxHeld;
    std::vector<std::unique_ptr<uint8_t[]>> m_blocks;
    uint64_t m_bytes = 0, m_read = 0;
    bool m_inFile = false;
    ScratchFile m_file;
};

Status spill(Spool& spool, const BrickSymbols& s) {
    const uint32_t head[2] = {s.count, uint32_t(s.palette.size())};
    Status st = spool.write(head, sizeof head);
    if (st) st = spool.write(s.levelStart.data(), sizeof s.levelStart);
    if (st) st = spool.write(s.packed.data(), s.packed.size());
    if (st) st = spool.write(s.palette.data(), 4 * s.palette.size());
    return st;
}

Status unspill(Spool& spool, BrickSymbols& s) {
    uint32_t head[2];
    Status st = spool.read(head, sizeof head);
    if (!st) return st;
    s.count = head[0];
    s.packed.resize((size_t(head[0]) + 1) / 2);
    s.palette.resize(head[1]);
    st = spool.read(s.levelStart.data(), sizeof s.levelStart);
    if (st) st = spool.read(s.packed.data(), s.packed.size());
    if (st) st = spool.read(s.palette.data(), 4 * s.palette.size());
    return st;
}

class MemorySlabSource : public SlabSource {
public:
    explicit MemorySlabSource(const LabelVolume& v) : m_v(v) {}
    std::array<uint32_t, 3> dimensions() const override { return m_v.dim; }
    Status readSlab(uint32_t z0, uint32_t depth, uint32_t* out) override {
        const size_t slice = size_t(m_v.dim[0]) * m_v.dim[1];
        std::memcpy(out, m_v.labels.data() + slice * z0, slice * depth * 4);
        return Status::ok();
    }
    const uint32_t* slabInMemory(uint32_t z0) const override {
        return m_v.labels.data() + size_t(m_v.dim[0]) * m_v.dim[1] * z0;
    }

private:
    const LabelVolume& m_v;
};

} // namespace

uint64_t encoderBandBytes(const SlabSource& source, uint32_t brickSize, uint64_t maxBandBytes) {
    if (source.slabInMemory(0)) return 0;
    const BandShape shape = bandShape(source, brickSize, maxBandBytes);
    return bandBytes(shape, source.dimensions()[0]);
}

/// Bricks of a volume (saturating: 2^32 voxels a side in bricks of 8 would be 2^87).
static uint64_t bricksOf(const std::array<uint32_t, 3>& dim, uint32_t brickSize) {
    const uint64_t B = std::max<uint32_t>(brickSize, 1);
    const auto along = [&](int a) { return (uint64_t(dim[a]) + B - 1) / B; };
    return product3(along(0), along(1), along(2));
}

uint64_t encoderIndexBytes(const std::array<uint32_t, 3>& dim, uint32_t brickSize) {
    return mulSaturate(8, bricksOf(dim, brickSize));
}

uint64_t automaticIndexLimit(std::string* why) {
    std::string what;
    const uint64_t memory = memoryAllowed(&what);
    if (why) *why = "half of " + what;
    return memory / 2;
}

Status checkEncoderIndex(const std::array<uint32_t, 3>& dim, uint32_t brickSize, uint64_t maxIndexBytes) {
    std::string why = "the encoder's index limit";
    const uint64_t limit = maxIndexBytes ? maxIndexBytes : automaticIndexLimit(&why);
    const uint64_t need = encoderIndexBytes(dim, brickSize);
    if (need <= limit) return Status::ok();
    std::string larger;
    for (uint32_t b = brickSize * 2; b <= 128 && larger.empty(); b *= 2)
        if (const uint64_t n = encoderIndexBytes(dim, b); n <= limit)
            larger = "; bricks of " + std::to_string(b) + "^3 need " + std::to_string(n) + " (--brick-size " +
                     std::to_string(b) + ")";
    return Status::error("a " + std::to_string(dim[0]) + "x" + std::to_string(dim[1]) + "x" + std::to_string(dim[2]) +
                         " volume in bricks of " + std::to_string(brickSize) + "^3 needs " + std::to_string(need) +
                         " bytes of brick index in memory (8 for each of its " + std::to_string(bricksOf(dim, brickSize)) +
                         " bricks), more than the limit of " + std::to_string(limit) + " bytes (" + why + ")" + larger);
}

Status SlabSource::readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint32_t* out) {
    if (y0 == 0 && rows == dimensions()[1]) return readSlab(z0, depth, out);
    return Status::error("this label source reads whole slices only");
}

Result<uint32_t> parseOperationMask(const std::string& text) {
    if (text == "default") return uint32_t(kMaskDefault);
    if (text == "all") return uint32_t(kMaskAll);
    if (text.empty()) return Status::error("empty operation list (use default, all, or letters of pxyznlds)");
    uint32_t m = 0;
    for (char c : text) {
        switch (c) {
        case 'p': m |= kMaskParent; break;
        case 'x': m |= kMaskNeighborX; break;
        case 'y': m |= kMaskNeighborY; break;
        case 'z': m |= kMaskNeighborZ; break;
        case 'n': m |= kMaskNeighborX | kMaskNeighborY | kMaskNeighborZ; break;
        case 'l': m |= kMaskPaletteLast; break;
        case 'd': m |= kMaskPaletteD; break;
        case 's': m |= kMaskStopBits; break;
        default:
            return Status::error(std::string("unknown operation letter '") + c +
                                 "' (p parent, x y z or n neighbours, l palette last, d palette delta, s stop bits)");
        }
    }
    return m;
}

Status checkEncodeOptions(const EncodeOptions& o) {
    if (o.brickSize < 8 || o.brickSize > 128 || (o.brickSize & (o.brickSize - 1)))
        return Status::error("brick size " + std::to_string(o.brickSize) + " is not a power of two from 8 to 128");
    if (o.encoding != kEncodingNibble && o.encoding != kEncodingRans1 && o.encoding != kEncodingRans2)
        return Status::error("encoding " + std::to_string(o.encoding) + " cannot be written (nibble, rans1 or rans2)");
    const uint32_t known = kMaskParent | kMaskNeighborX | kMaskNeighborY | kMaskNeighborZ | kMaskPaletteLast |
                           kMaskPaletteD | kMaskStopBits;
    if (o.opMask & ~known)
        return Status::error("operation mask 0x" + std::to_string(o.opMask) + " has bits this writer does not set");
    return Status::ok();
}

Result<CompressedVolume> encodeVolume(const LabelVolume& volume, const EncodeOptions& options) {
    if (volume.labels.size() != volume.voxelCount())
        return Status::error("label volume holds " + std::to_string(volume.labels.size()) + " labels, expected " +
                             std::to_string(volume.voxelCount()));
    MemorySlabSource src(volume);
    return encodeVolume(src, options);
}

namespace {

/// encodeVolume's steps; may throw std::bad_alloc (symbols, words), which encodeVolume turns
/// into a Status.
Result<CompressedVolume> encodeVolumeSteps(SlabSource& source, const EncodeOptions& options, uint64_t maxOutputBytes) {
    Result<CompressedVolume> made = newVolume(source, options);
    if (!made) return made.status();
    CompressedVolume& vol = *made;
    const uint64_t bricks = vol.brickCount();
    const auto grid = vol.brickGrid();
    const uint64_t perSlab = uint64_t(grid[0]) * grid[1];

    std::vector<BrickSymbols> symbols(static_cast<size_t>(bricks));
    SymbolCounts counts;
    Status s = symbolsBySlab(source, vol, options, EncodeToFileOptions().maxBandBytes,
                             [&](uint32_t bz, std::vector<BrickSymbols>& slab) {
        for (size_t i = 0; i < slab.size(); ++i) {
            addSymbols(counts, slab[i], vol.encoding);
            symbols[size_t(bz * perSlab + i)] = std::move(slab[i]);
        }
        return Status::ok();
    });
    if (!s) return s;
    s = chooseTables(options, counts, vol);
    if (!s) return s;

    std::vector<std::vector<uint32_t>> words;
    BrickAssembler(vol).assemble(symbols, words, threadsFor(options));
    std::vector<BrickSymbols>().swap(symbols);
    std::vector<uint32_t> sizes(words.size());
    for (size_t i = 0; i < words.size(); ++i) {
        sizes[i] = uint32_t(words[i].size());
        vol.maxPalette = std::max(vol.maxPalette, words[i][vol.levels()]);
    }
    s = fillArrays(vol, sizes, arrayLimitOf(options), maxOutputBytes, [&](uint64_t i, std::vector<uint32_t>& arr) {
        arr.insert(arr.end(), words[size_t(i)].begin(), words[size_t(i)].end());
        std::vector<uint32_t>().swap(words[size_t(i)]); // released as copied
    });
    if (!s) return s;
    return vol;
}

} // namespace

Result<CompressedVolume> encodeVolume(SlabSource& source, const EncodeOptions& options, uint64_t maxOutputBytes) {
    // Errors are values across Core's boundary, an allocation failure included.
    try {
        return encodeVolumeSteps(source, options, maxOutputBytes);
    } catch (const std::bad_alloc&) {
        return Status::error("out of memory while encoding a volume in memory");
    } catch (const std::exception& e) {
        return Status::error(std::string("encoding failed: ") + e.what());
    }
}

namespace {

/// encodeToFile's steps; may throw std::bad_alloc (symbols, sizes, layout), which encodeToFile
/// turns into a Status.
Status encodeToFileSteps(SlabSource& source, const EncodeOptions& options, const std::string& path,
                         const EncodeToFileOptions& fileOptions, uint64_t* outputBytes) {
    // Memory (Encoder.h): symbols held up to heldSymbolBytes, then spilled; words go to a second
    // scratch file, then into the container.
    Result<CompressedVolume> made = newVolume(source, options);
    if (!made) return made.status();
    CompressedVolume& vol = *made;
    if (Status s = checkEncoderIndex(vol.dim, vol.brickSize, fileOptions.maxIndexBytes); !s) return s;
    const uint64_t bricks = vol.brickCount();
    const auto grid = vol.brickGrid();
    const uint64_t perSlab = uint64_t(grid[0]) * grid[1];
    const auto progress = [&](double f) { return !fileOptions.progress || fileOptions.progress(f); };
    const Status cancelled = Status::error("cancelled");

    // Pass 1: symbols, serialized into a spool (held up to heldSymbolBytes, then in a scratch
    // file), and their counts.
    Spool symbols(path, "symbols", fileOptions.heldSymbolBytes);
    SymbolCounts counts;
    Status s = symbolsBySlab(source, vol, options, fileOptions.maxBandBytes,
                             [&](uint32_t bz, std::vector<BrickSymbols>& slab) -> Status {
                                 for (const BrickSymbols& b : slab) {
                                     addSymbols(counts, b, vol.encoding);
                                     if (Status st = spill(symbols, b); !st) return st;
                                 }
                                 return progress(0.8 * (bz + 1) / grid[2]) ? Status::ok() : cancelled;
                             });
    if (!s) return s;
    s = chooseTables(options, counts, vol);
    if (!s) return s;
    if (!(s = symbols.rewind())) return s;

    // Pass 2: words, slab by slab of bricks, into the words scratch file.
    const BrickAssembler assembler(vol);
    ScratchFile wordFile;
    if (!(s = wordFile.open(path, "words"))) return s;
    std::vector<uint32_t> sizes(static_cast<size_t>(bricks));
    std::vector<BrickSymbols> batch;
    std::vector<std::vector<uint32_t>> words;
    for (uint64_t first = 0; first < bricks; first += perSlab) {
        const uint64_t n = std::min(perSlab, bricks - first);
        batch.resize(size_t(n));
        for (BrickSymbols& b : batch)
            if (!(s = unspill(symbols, b))) return s;
        assembler.assemble(batch, words, threadsFor(options));
        for (uint64_t i = 0; i < n; ++i) {
            const std::vector<uint32_t>& w = words[size_t(i)];
            sizes[size_t(first + i)] = uint32_t(w.size());
            vol.maxPalette = std::max(vol.maxPalette, w[vol.levels()]);
            if (!(s = wordFile.write(w.data(), 4 * w.size()))) return s;
        }
        if (!progress(0.8 + 0.1 * double(first + n) / double(bricks))) return cancelled;
    }
    std::vector<BrickSymbols>().swap(batch);
    words.clear();
    Result<ArrayLayout> layout = layoutArrays(sizes, arrayLimitOf(options), fileOptions.maxOutputBytes);
    if (!layout) return layout.status();
    std::vector<uint32_t>().swap(sizes);
    const std::vector<uint64_t> arrayWords = std::move(layout->arrayWords);
    applyLayout(std::move(*layout), vol);

    // The container: header and brick starts, then each array's words copied from the scratch file.
    if (!(s = wordFile.rewind())) return s;
    std::vector<uint32_t> buffer(size_t(1) << 20);
    uint64_t written = 0, total = 0;
    for (uint64_t w : arrayWords) total += w;
    Limits limits;
    limits.maxOutputBytes = fileOptions.maxOutputBytes;
    bool stopped = false;
    s = writeCsgvStreamed(path, vol, arrayWords, limits, [&](size_t a, const ByteSink& out) -> Status {
        for (uint64_t left = arrayWords[a]; left > 0;) {
            const size_t n = size_t(std::min<uint64_t>(left, buffer.size()));
            Status st = wordFile.read(buffer.data(), 4 * n);
            if (st) st = out(buffer.data(), 4 * n);
            if (!st) return st;
            left -= n;
            written += n;
            if (!progress(0.9 + 0.1 * double(written) / double(std::max<uint64_t>(total, 1)))) {
                stopped = true;
                return cancelled;
            }
        }
        return Status::ok();
    });
    if (!s) return stopped ? cancelled : s;
    if (outputBytes) *outputBytes = vol.serializedSize() + 8 * arrayWords.size() + 4 * total;
    return Status::ok();
}

} // namespace

Status encodeToFile(SlabSource& source, const EncodeOptions& options, const std::string& path,
                    const EncodeToFileOptions& fileOptions, uint64_t* outputBytes) {
    // Errors are values across Core's boundary: an allocation failure (a huge brick grid, the
    // held symbols) becomes a message, and the scratch files and the temporary output are
    // already gone when the stack unwinds (unlinked while open; AtomicFile).
    try {
        return encodeToFileSteps(source, options, path, fileOptions, outputBytes);
    } catch (const std::bad_alloc&) {
        return Status::error("out of memory while encoding '" + path + "'");
    } catch (const std::exception& e) {
        return Status::error("encoding '" + path + "' failed: " + e.what());
    }
}

Result<CompressedVolume> embedPiece(const CompressedVolume& piece, const BrickBox& box, const std::array<uint32_t, 3>& dim) {
    try {
        const uint32_t B = piece.brickSize;
        CompressedVolume vol = piece.headerFields(); // placed in `dim`; palette and arrays below
        vol.dim = dim;
        if (vol.brickCount() > kMaxBricks) return Status::error("the volume needs more than 2^40 bricks");
        const std::array<uint32_t, 3> grid = vol.brickGrid();
        for (int a = 0; a < 3; ++a) {
            if (box.empty() || box.hi[a] > grid[a])
                return Status::error("piece of bricks [" + std::to_string(box.lo[a]) + ", " + std::to_string(box.hi[a]) +
                                     ") along axis " + std::to_string(a) + " is empty or outside the " +
                                     std::to_string(grid[a]) + " bricks of the volume");
            const uint32_t size = std::min(box.hi[a] * B, dim[a]) - box.lo[a] * B;
            if (piece.dim[a] != size)
                return Status::error("the piece is " + std::to_string(piece.dim[a]) + " voxels along axis " +
                                     std::to_string(a) + ", its bricks cover " + std::to_string(size));
        }
        // An absent brick: label 0 encoded with the piece's tables, once per brick extent (bricks
        // at the volume's far ends are cut).
        EncodeOptions o;
        o.brickSize = B;
        o.encoding = piece.encoding;
        o.opMask = piece.opMask & ~kMaskLegacyDelta;
        o.fixedTables = piece.encoding != kEncodingNibble;
        o.tableA = piece.freqA;
        o.tableB = piece.freqB;
        o.threads = 1;
        std::map<std::array<uint32_t, 3>, std::vector<uint32_t>> absent;
        auto absentWords = [&](const std::array<uint32_t, 3>& extent) -> Result<const std::vector<uint32_t>*> {
            auto it = absent.find(extent);
            if (it != absent.end()) return &it->second;
            LabelVolume zeros;
            zeros.dim = extent;
            zeros.labels.assign(size_t(zeros.voxelCount()), 0u);
            Result<CompressedVolume> one = encodeVolume(zeros, o);
            if (!one) return Status::error("an absent brick cannot be encoded with the piece's tables: " + one.message());
            const BrickWords bw = one->brick(0);
            return &(absent[extent] = std::vector<uint32_t>(bw.words, bw.words + bw.size));
        };
        const uint64_t bricks = vol.brickCount();
        std::vector<uint32_t> sizes(static_cast<size_t>(bricks));
        std::vector<WordPtr> from(static_cast<size_t>(bricks));
        const uint32_t L = vol.levels();
        const uint64_t pw = box.hi[0] - box.lo[0], ph = box.hi[1] - box.lo[1];
        vol.maxPalette = 1;
        for (uint64_t i = 0; i < bricks; ++i) {
            const uint32_t x = uint32_t(i % grid[0]), y = uint32_t(i / grid[0] % grid[1]), z = uint32_t(i / grid[0] / grid[1]);
            if (box.contains(x, y, z)) {
                const uint64_t own = (x - box.lo[0]) + pw * ((y - box.lo[1]) + ph * (z - box.lo[2]));
                const BrickWords bw = piece.brick(own);
                sizes[size_t(i)] = bw.size;
                from[size_t(i)] = bw.words;
                // A damaged brick's palette word means nothing (it is drawn empty): it placed the
                // whole piece apart, numbered as a volume of its own (attack pass 8).
                if (brickSound(piece, own)) vol.maxPalette = std::max(vol.maxPalette, bw.words[L]);
                continue;
            }
            const std::array<uint32_t, 3> extent = {std::min(B, dim[0] - x * B), std::min(B, dim[1] - y * B),
                                                    std::min(B, dim[2] - z * B)};
            Result<const std::vector<uint32_t>*> words = absentWords(extent);
            if (!words) return words.status();
            sizes[size_t(i)] = uint32_t((*words)->size());
            from[size_t(i)] = (*words)->data();
        }
        Status s = fillArrays(vol, sizes, kMaxWordsPerArray, ~uint64_t(0), [&](uint64_t i, std::vector<uint32_t>& arr) {
            appendWords(arr, from[size_t(i)], sizes[size_t(i)]);
        });
        if (!s) return s;
        // The layout, not each brick: a damaged brick of the piece stays one (drawn empty and
        // named by its place in the volume), where it placed the whole piece apart.
        s = checkLayout(vol);
        if (!s) return s;
        return vol;
    } catch (const std::bad_alloc&) {
        return Status::error("out of memory while placing a piece in its volume");
    }
}

} // namespace csgv
