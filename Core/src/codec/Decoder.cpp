// SPDX-License-Identifier: MIT
#include "csgv/codec/Decoder.h"
#include "csgv/base/Cancel.h"
#include "csgv/base/MappedFile.h"
#include "csgv/base/Morton.h"

#include <algorithm>
#include <atomic>
#include <mutex>
#include <omp.h>

namespace csgv {

namespace {

std::string place(uint64_t brick, uint32_t level, uint32_t levels, int64_t node) {
    std::string s = "brick " + std::to_string(brick) + ", level " + std::to_string(level) + " (lod " +
                    std::to_string(levels - 1 - level) + ")";
    if (node >= 0) s += ", node " + std::to_string(node);
    return s;
}

/// Raw 4-bit symbols of one level (mode 0), bounded by the next level's start or the palette.
struct NibbleReader {
    WordPtr words;
    uint64_t pos;
    uint64_t end;
    bool next(uint32_t& s) {
        if (pos >= end) return false;
        s = (words[pos >> 3] >> (28 - 4 * (pos & 7))) & 15u;
        ++pos;
        return true;
    }
};

} // namespace

/// rANS decoder over one stream (section 4.1): state word first, then bytes read forward. Byte j
/// of the stream sits at bits 8*(j mod 4) of word j/4 after the state, which on a little-endian
/// host (Words.h) is byte j of memory: the reader takes bytes as they lie, at any alignment.
struct RansReader {
    const uint8_t* bytes; ///< the stream's first byte after the state word
    uint32_t x;
    uint64_t bytePos = 0;
    uint64_t byteEnd;
    const uint8_t* slotSymbol;
    const uint32_t* freq;
    const uint32_t* cum;

    RansReader(WordPtr w, uint32_t startWord, uint32_t endWord, const BrickDecoder::RansTable& t)
        : bytes(static_cast<const uint8_t*>((w + startWord + 1).bytes())), x(w[startWord]),
          byteEnd(uint64_t(endWord - startWord - 1) * 4),
          slotSymbol(t.symbol.data()), freq(t.freq.data()), cum(t.cum.data()) {}

    bool next(uint32_t& s) {
        const uint32_t c = x & (kRansTotal - 1);
        s = slotSymbol[c];
        x = freq[s] * (x >> kRansProbBits) + c - cum[s];
        while (x < kRansLowerBound) {
            if (bytePos >= byteEnd) return false;
            x = (x << 8) | bytes[bytePos];
            ++bytePos;
        }
        return true;
    }
    /// The end-of-stream integrity check: back in the initial state with only padding left.
    bool finished() const {
        if (x != kRansLowerBound || byteEnd - bytePos >= 4) return false;
        for (uint64_t p = bytePos; p < byteEnd; ++p)
            if (bytes[p]) return false;
        return true;
    }
};

std::array<uint32_t, 3> lodDimensions(const std::array<uint32_t, 3>& dim, uint32_t lod) {
    std::array<uint32_t, 3> d{};
    for (int a = 0; a < 3; ++a) d[a] = lod >= 32 ? 1 : ((dim[a] - 1) >> lod) + 1;
    return d;
}

BrickDecoder::BrickDecoder(const CompressedVolume& vol) : m_vol(vol), m_levels(vol.levels()) {
    uint32_t total = 0;
    for (uint32_t l = 0; l < m_levels && l < 8; ++l) {
        m_levelOffset[l] = total;
        total += 1u << (3 * l);
    }
    m_labels.resize(total);
    m_open.resize(total);
    auto build = [](RansTable& t, const std::array<uint32_t, 16>& f) {
        t.symbol.assign(kRansTotal, 0);
        t.cum[0] = 0;
        for (int s = 0; s < 16; ++s) {
            t.freq[s] = f[s];
            t.cum[s + 1] = t.cum[s] + f[s];
            for (uint32_t c = t.cum[s]; c < t.cum[s + 1] && c < kRansTotal; ++c) t.symbol[c] = uint8_t(s);
        }
    };
    if (vol.encoding == kEncodingRans1 || vol.encoding == kEncodingRans2) build(m_tableA, vol.freqA);
    if (vol.encoding == kEncodingRans2) build(m_tableB, vol.freqB);
}

template <typename Reader>
Status BrickDecoder::decodeLevels(uint64_t index, const BrickWords& bw, Reader& reader, uint32_t firstLevel,
                                  uint32_t lastLevel) {
    const uint32_t L = m_levels;
    const WordPtr w = bw.words;
    const uint32_t paletteSize = w[L];
    const auto& dim = m_vol.dim;
    for (uint32_t l = firstLevel; l <= lastLevel; ++l) {
        uint32_t* cur = m_labels.data() + m_levelOffset[l];
        uint8_t* curOpen = m_open.data() + m_levelOffset[l];
        const bool finest = l == L - 1;
        uint32_t sym = 0;
        if (l == 0) {
            if (!reader.next(sym)) return Status::error(place(index, 0, L, 0) + ": the stream runs past its end");
            if ((sym & 7) != kOpPaletteAdv)
                return Status::error(place(index, 0, L, 0) + ": root operation " + std::to_string(sym & 7) +
                                     " is not PALETTE_ADV");
            cur[0] = w[m_paletteCursor--];
            m_appended = 1;
            if (cur[0] == kInvalidLabel)
                return Status::error(place(index, 0, L, 0) + ": palette entry 0 is the reserved label 0xFFFFFFFF");
            curOpen[0] = (sym & kStopBit) ? 0 : 1;
            continue;
        }
        const uint32_t* par = m_labels.data() + m_levelOffset[l - 1];
        const uint8_t* parOpen = m_open.data() + m_levelOffset[l - 1];
        const uint32_t width = m_vol.brickSize >> l;
        const uint32_t parentGrid = 1u << (l - 1);
        uint32_t lim[3], plim[3];
        bool inside = true;
        for (int a = 0; a < 3; ++a) {
            const uint64_t rest = dim[a] - m_origin[a]; // 64-bit: dimensions may approach 2^32
            lim[a] = uint32_t(std::min<uint64_t>(1u << l, (rest + width - 1) / width));
            plim[a] = uint32_t(std::min<uint64_t>(parentGrid, (rest + 2 * width - 1) / (2 * width)));
            inside = inside && lim[a] == (1u << l);
        }
        const uint32_t parents = 1u << (3 * (l - 1));
        for (uint32_t pm = 0; pm < parents; ++pm) {
            const uint32_t base = pm << 3;
            if (!parOpen[pm]) {
                const uint32_t v = par[pm];
                for (uint32_t c = 0; c < 8; ++c) {
                    cur[base + c] = v;
                    curOpen[base + c] = 0;
                }
                continue;
            }
            for (uint32_t c = 0; c < 8; ++c) {
                const uint32_t m = base + c;
                if (!inside && (mortonX(m) >= lim[0] || mortonY(m) >= lim[1] || mortonZ(m) >= lim[2])) {
                    cur[m] = kInvalidLabel;
                    curOpen[m] = 0;
                    continue;
                }
                if (!reader.next(sym)) return Status::error(place(index, l, L, m) + ": the stream runs past its end");
                if ((sym & kStopBit) && finest)
                    return Status::error(place(index, l, L, m) + ": stop bit at the finest level");
                uint32_t label = 0;
                switch (sym & 7) {
                case kOpParent: label = par[pm]; break;
                case kOpNeighborX:
                case kOpNeighborY:
                case kOpNeighborZ: {
                    const int axis = int(sym & 7) - 1;
                    if (((c >> axis) & 1u) == 0) {
                        if ((m & mortonAxisMask(axis)) == 0)
                            return Status::error(place(index, l, L, m) + ": neighbour " + char('x' + axis) +
                                                 "-1 is outside the brick");
                        label = cur[mortonDecrement(m, axis)];
                    } else {
                        const uint32_t coord = mortonCompact(pm >> axis) + 1;
                        if (coord >= parentGrid)
                            return Status::error(place(index, l, L, m) + ": neighbour " + char('x' + axis) +
                                                 "+1 is outside the brick");
                        if (coord >= plim[axis])
                            return Status::error(place(index, l, L, m) + ": neighbour " + char('x' + axis) +
                                                 "+1 is not in the volume");
                        label = par[mortonIncrement(pm, axis)];
                    }
                    break;
                }
                case kOpPaletteAdv:
                    if (m_appended >= paletteSize)
                        return Status::error(place(index, l, L, m) + ": more PALETTE_ADV than the palette size " +
                                             std::to_string(paletteSize));
                    label = w[m_paletteCursor--];
                    if (label == kInvalidLabel)
                        return Status::error(place(index, l, L, m) + ": palette entry " + std::to_string(m_appended) +
                                             " is the reserved label 0xFFFFFFFF");
                    ++m_appended;
                    break;
                case kOpPaletteLast: label = w[m_paletteCursor + 1]; break; // the root always appended one
                case kOpPaletteD: {
                    uint64_t v = 0;
                    uint32_t g = 0;
                    if (m_vol.legacyDelta()) {
                        if (!reader.next(g))
                            return Status::error(place(index, l, L, m) + ": the stream runs past its end");
                        v = g;
                    } else {
                        for (int groups = 0;; ++groups) {
                            if (groups == kMaxDistanceGroups)
                                return Status::error(place(index, l, L, m) + ": PALETTE_D distance has more than " + std::to_string(kMaxDistanceGroups) + " groups");
                            if (!reader.next(g))
                                return Status::error(place(index, l, L, m) + ": the stream runs past its end");
                            v = (v << 3) | (g & 7);
                            if (!(g & 8)) break;
                        }
                    }
                    if (v + 2 > m_appended)
                        return Status::error(place(index, l, L, m) + ": PALETTE_D distance " + std::to_string(v) +
                                             " points past the palette (" + std::to_string(m_appended) +
                                             " entries appended)");
                    label = w[m_paletteCursor + 2 + uint32_t(v)];
                    break;
                }
                default: return Status::error(place(index, l, L, m) + ": operation symbol 7 is invalid");
                }
                cur[m] = label;
                curOpen[m] = (sym & kStopBit) ? 0 : 1;
            }
        }
    }
    return Status::ok();
}

Status BrickDecoder::decode(uint64_t index, uint32_t lod) {
    Status s = decodeBrick(index, lod);
    // A mapped file cut short under the decoder reads zeros past its new end (MappedFile's
    // guard), which may even decode: such a brick is an error whatever it decoded to.
    if (index < m_vol.brickCount()) {
        const BrickWords bw = m_vol.brick(index);
        // A failure asks the file's size too: the page that holds a new end reads zeros past it
        // without a fault.
        if (s ? MappedFile::damagedAt(bw.words.bytes(), size_t(bw.size) * 4)
              : MappedFile::cutShortAt(bw.words.bytes(), size_t(bw.size) * 4))
            return Status::error("brick " + std::to_string(index) +
                                 ": the file changed on disk while it was open (it was cut short)");
        // A file written over in place reads its new bytes through the mapping: say so, not only
        // what the decoder found wrong (an attack pass saw "level 0 start is 3465706103").
        if (!s && MappedFile::rewrittenAt(bw.words.bytes()))
            return Status::error("brick " + std::to_string(index) +
                                 ": the file changed on disk while it was open (it was written over); open it "
                                 "again (" + s.message() + ")");
    }
    return s;
}

Status BrickDecoder::decodeBrick(uint64_t index, uint32_t lod) {
    const uint32_t L = m_levels;
    if (index >= m_vol.brickCount())
        return Status::error("brick " + std::to_string(index) + " does not exist (" +
                             std::to_string(m_vol.brickCount()) + " bricks)");
    if (lod >= L)
        return Status::error("level of detail " + std::to_string(lod) + " is out of range 0.." + std::to_string(L - 1));
    // A parse checks the layout only: the brick's header words are checked when it is reached.
    if (Status c = checkBrick(m_vol, index); !c) return c;
    const auto grid = m_vol.brickGrid();
    m_origin = {uint32_t(index % grid[0]) * m_vol.brickSize, uint32_t((index / grid[0]) % grid[1]) * m_vol.brickSize,
                uint32_t(index / (uint64_t(grid[0]) * grid[1])) * m_vol.brickSize};
    const BrickWords bw = m_vol.brick(index);
    const WordPtr w = bw.words;
    const uint32_t target = L - 1 - lod;
    const uint32_t paletteStart = bw.size - w[L];
    m_paletteCursor = bw.size - 1;
    m_appended = 0;
    m_decodedLevel = target;
    Status s;
    switch (m_vol.encoding) {
    case kEncodingNibble:
        for (uint32_t l = 0; l <= target && s; ++l) {
            const uint64_t end = (l + 1 < L) ? uint64_t(w[l + 1]) : uint64_t(paletteStart) * 8;
            NibbleReader r{w, w[l], end};
            s = decodeLevels(index, bw, r, l, l);
        }
        return s;
    case kEncodingRans1: {
        RansReader r(w, L + 1, paletteStart, m_tableA);
        if (r.x < kRansLowerBound) return Status::error(place(index, 0, L, -1) + ": rANS state below 2^23");
        s = decodeLevels(index, bw, r, 0, target);
        if (s && target == L - 1 && !r.finished())
            return Status::error(place(index, target, L, -1) + ": the rANS stream fails its end-of-stream check");
        return s;
    }
    case kEncodingRans2: {
        const uint32_t bStart = w[L - 1] / 8;
        RansReader a(w, L + 1, bStart, m_tableA);
        if (a.x < kRansLowerBound) return Status::error(place(index, 0, L, -1) + ": rANS stream A state below 2^23");
        s = decodeLevels(index, bw, a, 0, std::min(target, L - 2));
        if (!s) return s;
        if (target >= L - 2 && !a.finished())
            return Status::error(place(index, L - 2, L, -1) + ": rANS stream A fails its end-of-stream check");
        if (target == L - 1) {
            RansReader b(w, bStart, paletteStart, m_tableB);
            if (b.x < kRansLowerBound) return Status::error(place(index, L - 1, L, -1) + ": rANS stream B state below 2^23");
            s = decodeLevels(index, bw, b, L - 1, L - 1);
            if (s && !b.finished())
                return Status::error(place(index, L - 1, L, -1) + ": rANS stream B fails its end-of-stream check");
        }
        return s;
    }
    default: return Status::error("encoding mode " + std::to_string(m_vol.encoding) + " cannot be decoded");
    }
}

namespace {

/// Runs fn(decoder, brickIndex) over bricks in parallel; returns the error of the lowest brick.
/// After an error only bricks above the lowest failed one are skipped, so that the lowest is
/// always decoded and the message does not depend on which thread failed first.
template <typename Fn>
Status forEachBrick(const CompressedVolume& vol, const std::vector<uint64_t>& bricks, int threads, Fn fn) {
    std::atomic<uint64_t> lowestFailed{~uint64_t(0)};
    std::mutex mutex;
    uint64_t errorBrick = ~uint64_t(0);
    Status error;
    const int64_t n = int64_t(bricks.size());
    // Never more threads than bricks: idle OpenMP workers spin and steal time from busy ones.
    const int nThreads = int(std::max<int64_t>(1, std::min<int64_t>(threads > 0 ? threads : omp_get_max_threads(), n)));
#pragma omp parallel num_threads(nThreads)
    {
        BrickDecoder decoder(vol);
#pragma omp for schedule(dynamic, 4)
        for (int64_t i = 0; i < n; ++i) {
            if (bricks[size_t(i)] > lowestFailed.load(std::memory_order_relaxed)) continue;
            // The tool's Ctrl-C (no progress callback here): the remaining bricks are skipped, so a
            // decode of gigabytes ends in milliseconds rather than at the watchdog's deadline.
            Status s = cancelRequested() ? Status::error("interrupted") : fn(decoder, bricks[size_t(i)]);
            if (!s) {
                std::lock_guard<std::mutex> lock(mutex);
                if (bricks[size_t(i)] < errorBrick) {
                    errorBrick = bricks[size_t(i)];
                    error = s;
                    lowestFailed = errorBrick;
                }
            }
        }
    }
    return error;
}

} // namespace

Result<LabelVolume> decodeRegion(const CompressedVolume& vol, uint32_t lod, const Box& box,
                                 const DecodeOptions& options) {
    const uint32_t L = vol.levels();
    if (lod >= L)
        return Status::error("level of detail " + std::to_string(lod) + " is out of range 0.." + std::to_string(L - 1));
    const auto ldim = lodDimensions(vol.dim, lod);
    for (int a = 0; a < 3; ++a)
        if (box.min[a] >= box.max[a] || box.max[a] > ldim[a])
            return Status::error("region [" + std::to_string(box.min[a]) + ", " + std::to_string(box.max[a]) +
                                 ") along axis " + std::to_string(a) + " is empty or outside the level image of " +
                                 std::to_string(ldim[a]));
    LabelVolume out;
    for (int a = 0; a < 3; ++a) out.dim[a] = box.max[a] - box.min[a];
    if (out.voxelCount() > options.maxOutputBytes / 4)
        return Status::error("decoding " + std::to_string(out.dim[0]) + " x " + std::to_string(out.dim[1]) + " x " +
                             std::to_string(out.dim[2]) + " voxels needs more than the output limit of " +
                             std::to_string(options.maxOutputBytes) + " bytes");
    out.labels.resize(size_t(out.voxelCount()));

    const uint32_t edge = vol.brickSize >> lod; // brick edge in level-image voxels
    const auto grid = vol.brickGrid();
    std::vector<uint64_t> bricks;
    for (uint32_t bz = box.min[2] / edge; bz <= (box.max[2] - 1) / edge; ++bz)
        for (uint32_t by = box.min[1] / edge; by <= (box.max[1] - 1) / edge; ++by)
            for (uint32_t bx = box.min[0] / edge; bx <= (box.max[0] - 1) / edge; ++bx)
                bricks.push_back(bx + uint64_t(grid[0]) * (by + uint64_t(grid[1]) * bz));

    std::array<uint32_t, 128> spread{};
    for (uint32_t i = 0; i < 128; ++i) spread[i] = mortonSpread(i);
    const std::vector<uint32_t>* map = options.idToLabel;

    Status s = forEachBrick(vol, bricks, options.threads, [&](BrickDecoder& dec, uint64_t b) -> Status {
        Status st = dec.decode(b, lod);
        if (!st) return st;
        const uint32_t o[3] = {uint32_t(b % grid[0]) * edge, uint32_t((b / grid[0]) % grid[1]) * edge,
                               uint32_t(b / (uint64_t(grid[0]) * grid[1])) * edge};
        uint32_t lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::max(o[a], box.min[a]);
            hi[a] = uint32_t(std::min<uint64_t>(uint64_t(o[a]) + edge, box.max[a]));
        }
        const uint32_t* labels = dec.labels();
        for (uint32_t z = lo[2]; z < hi[2]; ++z)
            for (uint32_t y = lo[1]; y < hi[1]; ++y) {
                const uint32_t myz = (spread[y - o[1]] << 1) | (spread[z - o[2]] << 2);
                uint32_t* row = out.labels.data() + out.index(lo[0] - box.min[0], y - box.min[1], z - box.min[2]);
                for (uint32_t x = lo[0]; x < hi[0]; ++x) {
                    uint32_t v = labels[myz | spread[x - o[0]]];
                    if (map) {
                        if (v >= map->size())
                            return Status::error("brick " + std::to_string(b) + ": id " + std::to_string(v) +
                                                 " has no entry in the attribute database (" +
                                                 std::to_string(map->size()) + " labels)");
                        v = (*map)[v];
                    }
                    *row++ = v;
                }
            }
        return Status::ok();
    });
    if (!s) return s;
    return out;
}

Result<LabelVolume> decodeVolume(const CompressedVolume& vol, uint32_t lod, const DecodeOptions& options) {
    if (lod >= vol.levels())
        return Status::error("level of detail " + std::to_string(lod) + " is out of range 0.." +
                             std::to_string(vol.levels() - 1));
    Box box;
    box.max = lodDimensions(vol.dim, lod);
    return decodeRegion(vol, lod, box, options);
}

Result<uint32_t> decodeVoxel(const CompressedVolume& vol, std::array<uint32_t, 3> pos, uint32_t lod,
                             const DecodeOptions& options) {
    DecodeOptions one = options;
    one.threads = 1;
    Box box;
    for (int a = 0; a < 3; ++a) {
        box.min[a] = pos[a];
        box.max[a] = pos[a] + 1;
    }
    Result<LabelVolume> r = decodeRegion(vol, lod, box, one);
    if (!r) return r.status();
    return r->labels[0];
}

Status validateStreams(const CompressedVolume& vol, int threads) {
    std::vector<uint64_t> bricks(static_cast<size_t>(vol.brickCount()));
    for (size_t i = 0; i < bricks.size(); ++i) bricks[i] = i;
    return forEachBrick(vol, bricks, threads, [](BrickDecoder& dec, uint64_t b) { return dec.decode(b, 0); });
}

} // namespace csgv
