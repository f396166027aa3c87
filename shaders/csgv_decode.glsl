// SPDX-License-Identifier: MIT
// CSGV brick decoding on the GPU (CSGV-FORMAT.md sections 2 to 5), one invocation per brick,
// straight into the brick's cache region at the requested level of detail.
//
// Specialised per volume through defines (VulkanBackend/src/GpuVolume.cpp):
//   BRICK_SIZE, LEVELS, ENCODING (0 nibble, 1 rANS one table, 2 rANS two tables), LEGACY_DELTA,
//   VOLUME_DIM (uvec3), BRICK_GRID (uvec3), BRICKS_PER_ARRAY, CUM_A/CUM_B (uint[17]).
//
// Cache region of a brick decoded to inverse level T (grid 2^T per axis, 8^T words): the label
// of the level-l node with Morton index m lives in the last word of its Morton range,
// (m + 1) * W^3 - 1 with W = 2^(T - l), and its "children are visited" flag in the first word,
// m * W^3 (levels l < T). A child overwrites its parent's words only after their last read, so
// when level T is done the region holds exactly that level's labels in Morton order.
//
// Resumable: Mesa's llvmpipe ends any shader invocation's loops after 65535 iterations in total
// (its loop limiter), silently. Every loop here is therefore bounded by a per-dispatch step count:
// a step visits the root or one parent's 8 children; it runs at most 1 + 8 + 8 * 11 loop
// iterations (steps, children, PALETTE_D groups); symbol lookup and renormalisation are
// loop-free; the decoder's state is saved between dispatches. Real GPUs take all steps in one
// dispatch; CPU devices take 512 steps per dispatch (GpuVolume.cpp). The code stays small on
// purpose: llvmpipe compiles at the first dispatch, and unrolled variants took over a minute.
//
// Every read is bounds-checked; a violation ends the brick with an error code, never a hang.

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer Words { uint w[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer Addresses { uint64_t a[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer CacheWords { uint w[]; };

#include "csgv/codec/Layout.h" // kInvalidLabel, rANS constants, operation codes, decode results
#include "csgv/base/Morton.h"
#include "csgv/gpu/FrameLayout.h" // kNone, kDecodeNoDetail

// Cache paletting (CACHE_BITS < 32): the cache holds palette indices of CACHE_BITS bits, packed
// CACHE_PER_WORD to a word (never across words); all ones marks voxels outside the volume. Without
// it (CACHE_BITS 32) the cache holds labels. `region` and entries below count in cache entries.
#ifndef CACHE_BITS
#define CACHE_BITS 32
#endif
#if CACHE_BITS == 32
const uint CACHE_PER_WORD = 1u;
const uint CACHE_INVALID = kInvalidLabel;
uint cacheGet(CacheWords c, uint region, uint e) { return c.w[region + e]; }
void cacheSet(CacheWords c, uint region, uint e, uint v) { c.w[region + e] = v; }
#define PALETTE_VALUE(index, label) (label)
#else
const uint CACHE_PER_WORD = 32u / uint(CACHE_BITS);
const uint CACHE_MASK = (1u << uint(CACHE_BITS)) - 1u;
const uint CACHE_INVALID = CACHE_MASK;
uint cacheGet(CacheWords c, uint region, uint e) {
    const uint i = region + e;
    return (c.w[i / CACHE_PER_WORD] >> ((i % CACHE_PER_WORD) * uint(CACHE_BITS))) & CACHE_MASK;
}
void cacheSet(CacheWords c, uint region, uint e, uint v) { // one invocation owns a region's words
    const uint i = region + e;
    const uint word = i / CACHE_PER_WORD;
    const uint shift = (i % CACHE_PER_WORD) * uint(CACHE_BITS);
    c.w[word] = (c.w[word] & ~(CACHE_MASK << shift)) | ((v & CACHE_MASK) << shift);
}
#define PALETTE_VALUE(index, label) (index)
#endif

/// Everything a brick's decoding needs between two steps (also saved between dispatches).
struct DecodeState {
    uint level;    // level being decoded
    uint pm;       // next parent (level > 0) or 0 before the root
    uint x;        // rANS state
    uint pos;      // nibble: symbol position; rANS: byte index after the state word
    uint end;      // nibble: symbol limit; rANS: byte limit
    uint base;     // rANS: word of the current stream's state
    uint cursor;   // next PALETTE_ADV word
    uint appended; // palette entries appended so far
    uint status;   // kDecodeRunning until done
};

// Detail separation (SEPARATED 1, rANS two tables only): the arrays hold each brick without its
// finest-level stream (header, stream A, palette); that stream lies in the detail buffer
// (DetailStream.h), found through the detail table (uvec2 per brick: word offset, kNone when
// absent; words).
#ifndef SEPARATED
#define SEPARATED 0
#endif

struct Brick {
    Words words;
    uint start;        // first word of the brick in its array
    uint size;         // words
    uint paletteStart; // brick-relative word of the palette's first word
    uvec3 origin;
#if SEPARATED
    Words detail;      // the detail buffer
    uint detailStart;  // word of the detail buffer that stands for brick-relative word 0 (mod 2^32)
    uint detailEnd;    // brick-relative word where the finest-level stream ends
    bool hasDetail;    // its finest-level stream is in the detail buffer
#endif
};

/// Brick-relative word k of a stream, as in the whole encoding: the finest level's of a separated
/// volume from the detail buffer.
uint streamWord(Brick b, bool finest, uint k) {
#if SEPARATED
    if (finest) return b.detail.w[b.detailStart + k];
#endif
    return b.words.w[b.start + k];
}

// ---- symbol readers (loop-free) ----
#if ENCODING == 0
bool nextSymbol(Brick b, inout DecodeState st, bool tableB, out uint s) {
    if (st.pos >= st.end) return false;
    s = (b.words.w[b.start + (st.pos >> 3)] >> (28u - 4u * (st.pos & 7u))) & 15u;
    st.pos++;
    return true;
}
void beginLevelStream(Brick b, inout DecodeState st) {
    st.pos = b.words.w[b.start + st.level];
    st.end = st.level + 1u < LEVELS ? b.words.w[b.start + st.level + 1u] : b.paletteStart * 8u;
}
#else
const uint CUM_A_TABLE[17] = CUM_A;
#if ENCODING == 2
const uint CUM_B_TABLE[17] = CUM_B;
#endif
// The symbol s with cum[s] <= c < cum[s + 1], counted without a loop (cum is non-decreasing).
#define CSGV_LOOKUP(T, c)                                                                                              \
    (uint(c >= T[1]) + uint(c >= T[2]) + uint(c >= T[3]) + uint(c >= T[4]) + uint(c >= T[5]) + uint(c >= T[6]) +        \
     uint(c >= T[7]) + uint(c >= T[8]) + uint(c >= T[9]) + uint(c >= T[10]) + uint(c >= T[11]) + uint(c >= T[12]) +     \
     uint(c >= T[13]) + uint(c >= T[14]) + uint(c >= T[15]))

bool readByte(Brick b, inout DecodeState st) {
    if (st.pos >= st.end) return false;
    uint word = streamWord(b, st.level == LEVELS - 1u, st.base + 1u + (st.pos >> 2u));
    st.x = (st.x << 8u) | ((word >> (8u * (st.pos & 3u))) & 0xFFu);
    st.pos++;
    return true;
}

bool nextSymbol(Brick b, inout DecodeState st, bool tableB, out uint s) {
    const uint c = st.x & (kRansTotal - 1u);
    uint cum, next;
#if ENCODING == 2
    if (tableB) {
        s = CSGV_LOOKUP(CUM_B_TABLE, c);
        cum = CUM_B_TABLE[s];
        next = CUM_B_TABLE[s + 1u];
    } else
#endif
    {
        s = CSGV_LOOKUP(CUM_A_TABLE, c);
        cum = CUM_A_TABLE[s];
        next = CUM_A_TABLE[s + 1u];
    }
    st.x = (next - cum) * (st.x >> kRansProbBits) + c - cum;
    // From a state >= 2^23 the new state is >= 2^9: at most two bytes restore it.
    if (st.x < kRansLowerBound && !readByte(b, st)) return false;
    if (st.x < kRansLowerBound && !readByte(b, st)) return false;
    return st.x >= kRansLowerBound;
}
bool ransFinished(Brick b, DecodeState st) {
    if (st.x != kRansLowerBound || st.end - st.pos >= 4u) return false;
    // At most 3 padding bytes, all zero.
    bool zero = true;
    const bool finest = st.level == LEVELS - 1u;
    if (st.pos < st.end) zero = zero && ((streamWord(b, finest, st.base + 1u + (st.pos >> 2u)) >> (8u * (st.pos & 3u))) & 0xFFu) == 0u;
    if (st.pos + 1u < st.end) zero = zero && ((streamWord(b, finest, st.base + 1u + ((st.pos + 1u) >> 2u)) >> (8u * ((st.pos + 1u) & 3u))) & 0xFFu) == 0u;
    if (st.pos + 2u < st.end) zero = zero && ((streamWord(b, finest, st.base + 1u + ((st.pos + 2u) >> 2u)) >> (8u * ((st.pos + 2u) & 3u))) & 0xFFu) == 0u;
    return zero;
}
void beginRansStream(Brick b, inout DecodeState st, bool finest, uint startWord, uint endWord) {
    st.base = startWord;
    st.x = streamWord(b, finest, startWord);
    st.pos = 0u;
    st.end = (endWord - startWord - 1u) * 4u;
}
#endif

// ---- one node ----

/// Visits child c of parent pm at level l; writes its label (and flag below the target level).
uint visitChild(Brick b, inout DecodeState st, CacheWords cache, uint region, uint target, uint l, uint pm, uint c,
                bool parentOpen, uint parentLabel, uvec3 lim, uvec3 plim) {
    const uint shiftL = 3u * (target - l);
    const uint shiftP = shiftL + 3u;
    const bool finest = l == LEVELS - 1u;
    const bool tableB = ENCODING == 2 && finest;
    const uint m = (pm << 3u) | c;
    const uint slot = ((m + 1u) << shiftL) - 1u;
    const uint flagSlot = m << shiftL;
    if (!parentOpen) {
        cacheSet(cache, region, slot, parentLabel);
        if (l < target) cacheSet(cache, region, flagSlot, 0u);
        return kDecodeOk;
    }
    const uvec3 p = uvec3(mortonCompact(m), mortonCompact(m >> 1u), mortonCompact(m >> 2u));
    if (any(greaterThanEqual(p, lim))) {
        cacheSet(cache, region, slot, CACHE_INVALID);
        if (l < target) cacheSet(cache, region, flagSlot, 0u);
        return kDecodeOk;
    }
    uint s;
    if (!nextSymbol(b, st, tableB, s)) return kDecodeStreamEnd;
    if ((s & kStopBit) != 0u && finest) return kDecodeStopAtFinest;
    const uint op = s & kOpMask;
    const uint paletteSize = b.words.w[b.start + LEVELS];
    uint label;
    if (op == kOpParent) {
        label = parentLabel;
    } else if (op <= kOpNeighborZ) {
        const uint axis = op - kOpNeighborX;
        if (((c >> axis) & 1u) == 0u) {
            if ((m & mortonAxisMask(axis)) == 0u) return kDecodeBadNeighbour;
            label = cacheGet(cache, region, ((mortonDecrement(m, axis) + 1u) << shiftL) - 1u);
        } else {
            const uint coord = mortonCompact(pm >> axis) + 1u;
            if (coord >= (1u << (l - 1u)) || coord >= plim[axis]) return kDecodeBadNeighbour;
            label = cacheGet(cache, region, ((mortonIncrement(pm, axis) + 1u) << shiftP) - 1u);
        }
    } else if (op == kOpPaletteAdv) {
        if (st.appended >= paletteSize) return kDecodePaletteOverflow;
        label = b.words.w[b.start + st.cursor];
        if (label == kInvalidLabel) return kDecodePaletteOverflow;
        label = PALETTE_VALUE(st.appended, label);
        st.cursor--;
        st.appended++;
    } else if (op == kOpPaletteLast) {
        label = PALETTE_VALUE(st.appended - 1u, b.words.w[b.start + st.cursor + 1u]);
    } else if (op == kOpPaletteD) {
        uint v = 0u;
        uint g;
#if LEGACY_DELTA
        if (!nextSymbol(b, st, tableB, g)) return kDecodeStreamEnd;
        v = g;
#else
        bool more = true;
        for (uint groups = 0u; groups < kMaxDistanceGroups && more; ++groups) {
            if (!nextSymbol(b, st, tableB, g)) return kDecodeStreamEnd;
            if (v > 0x1FFFFFFFu) return kDecodeBadDistance; // would not fit 32 bits
            v = (v << 3u) | (g & 7u);
            more = (g & 8u) != 0u;
        }
        if (more) return kDecodeBadDistance; // more than 11 groups
#endif
        if (v + 2u > st.appended || v + 2u < v) return kDecodeBadDistance;
        label = PALETTE_VALUE(st.appended - 2u - v, b.words.w[b.start + st.cursor + 2u + v]);
    } else {
        return kDecodeBadOperation;
    }
    cacheSet(cache, region, slot, label);
    if (l < target) cacheSet(cache, region, flagSlot, (s & kStopBit) != 0u ? 0u : 1u);
    return kDecodeOk;
}

/// `detailTable` and `detailRing`: the detail table and buffer of a separated volume (else unused).
Brick openBrick(Addresses arrays, Words starts, uint brick, uint64_t detailTable, uint64_t detailRing) {
    Brick b;
    b.words = Words(arrays.a[brick / BRICKS_PER_ARRAY]);
    b.start = (brick > 0u && brick % BRICKS_PER_ARRAY == 0u) ? 0u : starts.w[brick];
    b.size = starts.w[brick + 1u] - b.start;
    b.paletteStart = b.size - b.words.w[b.start + LEVELS];
#if SEPARATED
    const uint entry = 2u * brick;
    const uint offset = Words(detailTable).w[entry], words = Words(detailTable).w[entry + 1u];
    const uint streamB = b.words.w[b.start + LEVELS - 1u] / 8u;
    b.detail = Words(detailRing);
    b.hasDetail = offset != kNone && words > 0u;
    b.detailStart = offset - streamB; // + streamB + k: word k of the stream
    b.detailEnd = streamB + words;
#endif
    const uvec3 bc = uvec3(brick % BRICK_GRID.x, (brick / BRICK_GRID.x) % BRICK_GRID.y, brick / (BRICK_GRID.x * BRICK_GRID.y));
    b.origin = bc * BRICK_SIZE;
    return b;
}

DecodeState initialState(Brick b) {
    DecodeState st;
    st.level = 0u;
    st.pm = 0u;
    st.x = 0u;
    st.pos = 0u;
    st.end = 0u;
    st.base = 0u;
    st.cursor = b.size - 1u;
    st.appended = 0u;
    st.status = kDecodeRunning;
#if ENCODING == 0
    beginLevelStream(b, st);
#elif ENCODING == 1
    beginRansStream(b, st, false, LEVELS + 1u, b.paletteStart);
#else
    beginRansStream(b, st, false, LEVELS + 1u, b.words.w[b.start + LEVELS - 1u] / 8u);
#endif
#if ENCODING != 0
    if (st.x < kRansLowerBound) st.status = kDecodeRansIntegrity; // a valid stream never starts lower
#endif
    return st;
}

/// Finishes level st.level: integrity checks, then the next level's stream or the end.
void endLevel(Brick b, inout DecodeState st, uint target) {
#if ENCODING == 1
    if (st.level == target) {
        st.status = (target == LEVELS - 1u && !ransFinished(b, st)) ? kDecodeRansIntegrity : kDecodeOk;
        return;
    }
#elif ENCODING == 2
    if (st.level == LEVELS - 2u && !ransFinished(b, st)) {
        st.status = kDecodeRansIntegrity;
        return;
    }
    if (st.level == target) {
        st.status = (target == LEVELS - 1u && !ransFinished(b, st)) ? kDecodeRansIntegrity : kDecodeOk;
        return;
    }
#if SEPARATED
    if (st.level + 1u == LEVELS - 1u) {
        if (!b.hasDetail) {
            st.status = kDecodeNoDetail;
            return;
        }
        beginRansStream(b, st, true, b.words.w[b.start + LEVELS - 1u] / 8u, b.detailEnd);
    }
#else
    if (st.level + 1u == LEVELS - 1u) beginRansStream(b, st, true, b.words.w[b.start + LEVELS - 1u] / 8u, b.paletteStart);
#endif
#else
    if (st.level == target) {
        st.status = kDecodeOk;
        return;
    }
#endif
    st.level++;
    st.pm = 0u;
#if ENCODING == 0
    beginLevelStream(b, st);
#endif
}

/// Runs at most `steps` steps of one brick's decoding.
void decodeSteps(Brick b, inout DecodeState st, uint target, CacheWords cache, uint region, uint steps) {
    for (uint step = 0u; step < steps && st.status == kDecodeRunning; ++step) {
        const uint l = st.level;
        if (l == 0u) { // the root
            uint s;
            if (!nextSymbol(b, st, false, s)) {
                st.status = kDecodeStreamEnd;
                break;
            }
            if ((s & kOpMask) != kOpPaletteAdv) {
                st.status = kDecodeBadRoot;
                break;
            }
            const uint label = b.words.w[b.start + st.cursor];
            if (label == kInvalidLabel) {
                st.status = kDecodePaletteOverflow;
                break;
            }
            st.cursor--;
            st.appended = 1u;
            cacheSet(cache, region, (1u << (3u * target)) - 1u, PALETTE_VALUE(0u, label));
            if (target > 0u) cacheSet(cache, region, 0u, (s & kStopBit) != 0u ? 0u : 1u);
            endLevel(b, st, target);
            continue;
        }
        const uint parents = 1u << (3u * (l - 1u));
        if (st.pm == parents) {
            endLevel(b, st, target);
            continue;
        }
        const uint shiftP = 3u * (target - l) + 3u;
        const uint width = BRICK_SIZE >> l;
        const uvec3 rest = VOLUME_DIM - b.origin;
        const uvec3 lim = min(uvec3(1u << l), (rest + width - 1u) / width);
        const uvec3 plim = min(uvec3(1u << (l - 1u)), (rest + 2u * width - 1u) / (2u * width));
        const uint pm = st.pm;
        // Read before child 0 and child 7 overwrite them.
        const uint parentLabel = cacheGet(cache, region, ((pm + 1u) << shiftP) - 1u);
        const bool parentOpen = cacheGet(cache, region, pm << shiftP) != 0u;
        uint r = kDecodeOk;
        for (uint c = 0u; c < 8u && r == kDecodeOk; ++c)
            r = visitChild(b, st, cache, region, target, l, pm, c, parentOpen, parentLabel, lim, plim);
        if (r != kDecodeOk) st.status = r;
        st.pm = pm + 1u;
    }
}

