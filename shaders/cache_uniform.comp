// SPDX-License-Identifier: MIT
// After GPU decoding, one workgroup per decoded brick, one invocation per sub-block
// (csgv/codec/Layout.h): marks the sub-blocks of bricks decoded at the finest level that lie
// inside the volume and hold one label (Frame slot kSlotUniform; march() steps over them whole)
// and, with UNIFORM_LEVELS, writes every cache word's uniform level above its label: the largest
// aligned cube around the voxel inside the volume with one label (march() steps over that cube
// whole). Host decoding computes the same (Renderer.cpp's masks, csgv/codec/UniformLevels.h's
// levels in GpuVolume::decodeRegion), as Core's castRaysStable does.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

shared uint bits[2];
#if UNIFORM_LEVELS
shared uint subLabel[64]; // sub-block j's label when it is one uniform cube inside the volume, else kNone
#endif

/// Cache entry e of the region at word `offset` (a label, or a palette index with paletting).
uint entryAt(UintBuf cache, uint offset, uint e) {
#if CACHE_BITS == 32
    return cache.w[offset + e];
#else
    return (cache.w[offset + e / CACHE_PER_WORD] >> ((e % CACHE_PER_WORD) * uint(CACHE_BITS))) & CACHE_MASK;
#endif
}

#if UNIFORM_LEVELS
/// The uniform level a word holds so far (kNone words hold none).
uint wordLevel(uint word) { return word == kNone ? 0u : word >> kUniformLevelShift; }

/// Sets the level of the words [first, first + n) of the cache to `level` (kNone words stay).
void setLevels(UintBuf cache, uint first, uint n, uint level) {
    for (uint e = first; e < first + n; ++e) {
        const uint word = cache.w[e];
        if (word != kNone) cache.w[e] = (word & kUniformLabelMask) | (level << kUniformLevelShift);
    }
}

/// UniformLevels.h's uniformLevels within sub-block j (its run of n words from `base`; the
/// brick's lowest voxel b): level by level the run's cubes that lie inside and whose eight octants
/// are uniform with one label, their level written into their first word; then each run of eight
/// takes the largest level of the cubes around it (a cube's first word read after an earlier run
/// rewrote it still says whether that cube is uniform: a cube inside a uniform one is).
void levelsOfSubBlock(UintBuf cache, uint base, uint j, uint n, uvec3 b) {
    for (uint k = 1u; k <= uint(SUB_SHIFT); ++k) {
        const uint run = 1u << (3u * k), part = run >> 3u;
        for (uint first = 0u; first < n; first += run) {
            if (!uniformSubBlockInside((j * n + first) >> (3u * k), k, b.x, b.y, b.z, VOLUME_DIM.x, VOLUME_DIM.y, VOLUME_DIM.z))
                continue;
            const uint label = wordLabel(cache.w[base + first]);
            bool same = label != kNone;
            for (uint c = 0u; c < 8u && same; ++c) {
                const uint word = cache.w[base + first + c * part];
                same = wordLevel(word) + 1u >= k && wordLabel(word) == label;
            }
            if (same) cache.w[base + first] = label | (k << kUniformLevelShift);
        }
    }
    for (uint first = 0u; first < n; first += 8u) {
        uint level = 0u;
        for (uint k = uint(SUB_SHIFT); k >= 1u && level == 0u; --k)
            if (wordLevel(cache.w[base + (first & ~((1u << (3u * k)) - 1u))]) >= k) level = k;
        setLevels(cache, base + first, 8u, level);
    }
}
#endif

void main() {
    Frame f = Frame(pc.frame);
    const uint i = gl_WorkGroupID.x, j = gl_LocalInvocationID.x;
    // Groups past this frame's decodes leave first, whole (CPU devices pay for every load).
    if (i >= min(UintBuf(f.addr[kSlotAlloc]).w[kAllocDecodes], f.limits.x)) return;
    loadFrameValues(f);
    if (j < 2u) bits[j] = 0u;
    barrier();
    UintBuf dec = UintBuf(frameAddr[kSlotDecodes]);
    const uint code = dec.w[kDecodeEntryWords * i + 1u]; // inverse level, kDecodeEntryFailed
    const bool finest = code == LEVELS - 1u;
    const uint brick = dec.w[kDecodeEntryWords * i];
#if CARRY_DECODES
    if (Uvec4Buf(frameAddr[kSlotBricks]).v[brick].y == kNone) return; // still being decoded (the whole group)
#endif
    const uint offset = dec.w[kDecodeEntryWords * i + 2u];
    UintBuf cache = UintBuf(frameAddr[kSlotCache]);
    if ((code & kDecodeEntryFailed) != 0u) {
        // Its decoding failed (decode_bricks.comp): the region reads as outside the volume (drawn
        // empty), every invocation a share of it, no uniform sub-blocks.
        const uint edge = BRICK_SIZE >> (LEVELS - 1u - (code & ~kDecodeEntryFailed));
        const uint words = (edge * edge * edge + CACHE_PER_WORD - 1u) / CACHE_PER_WORD;
        for (uint k = j; k < words; k += 64u) cache.w[offset + k] = 0xFFFFFFFFu;
        if (j == 0u) Uvec2Buf(frameAddr[kSlotUniform]).v[brick] = uvec2(0u);
        return;
    }
    const uvec3 b = uvec3(brick % BRICK_GRID.x, (brick / BRICK_GRID.x) % BRICK_GRID.y, brick / (BRICK_GRID.x * BRICK_GRID.y)) *
                    BRICK_SIZE;
    const uint n = SUB_SHIFT >= 0 ? 1u << (3u * uint(max(SUB_SHIFT, 0))) : 0u, first = j * n;
    const bool inside = finest && SUB_SHIFT >= 0 &&
                        uniformSubBlockInside(j, uint(SUB_SHIFT), b.x, b.y, b.z, VOLUME_DIM.x, VOLUME_DIM.y, VOLUME_DIM.z);
    if (inside) {
        const uint v = entryAt(cache, offset, first);
        bool same = true;
        for (uint e = 1u; e < n && same; ++e) same = entryAt(cache, offset, first + e) == v;
        if (same) atomicOr(bits[j >> 5u], 1u << (j & 31u));
    }
#if UNIFORM_LEVELS
    // Levels up to the sub-block's within each sub-block, then those of the cubes of 8 and 64
    // sub-blocks (the brick) from every sub-block's label.
    if (finest && SUB_SHIFT >= 0) levelsOfSubBlock(cache, offset + first, j, n, b);
    subLabel[j] = inside && wordLevel(cache.w[offset + first]) >= uint(SUB_SHIFT) ? wordLabel(cache.w[offset + first]) : kNone;
    barrier();
    uint top = 0u;
    for (uint g = 1u; g <= kUniformShift; ++g) {
        const uint size = 1u << (3u * g), from = j & ~(size - 1u);
        bool same = uniformSubBlockInside(j >> (3u * g), uint(SUB_SHIFT) + g, b.x, b.y, b.z, VOLUME_DIM.x, VOLUME_DIM.y, VOLUME_DIM.z);
        for (uint c = 0u; c < size && same; ++c) same = subLabel[from + c] != kNone && subLabel[from + c] == subLabel[from];
        if (same) top = uint(SUB_SHIFT) + g;
    }
    if (finest && top > 0u) setLevels(cache, offset + first, n, top);
#endif
    barrier();
    if (finest && j == 0u) Uvec2Buf(frameAddr[kSlotUniform]).v[brick] = uvec2(bits[0], bits[1]);
}
