// SPDX-License-Identifier: MIT
// The sub-blocks march() steps over whole (Frame slot kSlotSkip) of bricks cached at the finest
// level, one workgroup per brick, one invocation per sub-block (csgv/codec/Layout.h): those inside
// the volume that hold one label (kSlotUniform: cache_uniform.comp or host decoding wrote them
// first) or no label a material draws (no surface can be inside either: a walker passing such a
// sub-block voxel by voxel finds none, and the first voxel after it differs from every label in
// it or is not drawn). The second kind depends on the materials:
//   SKIP_ALL 0: the bricks decoded this frame (the decode list), after their uniform masks;
//   SKIP_ALL 1: every brick of the table cached at the finest level, kSkipGroupBricks a group in
//               turn (the materials changed; this also covers the bricks decoded this frame).
// Core's castRaysStable marks the same sub-blocks and steps alike, so images stay exact.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

#ifndef SKIP_ALL
#define SKIP_ALL 0u
#endif

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

shared uint bits[2];

/// The label of cache entry e of the region at word `offset` (paletted: its palette's entry).
uint labelAt(UintBuf cache, uint offset, uint e, PaletteRef palette) {
#if CACHE_BITS == 32
    return cache.w[offset + e];
#else
    const uint index = (cache.w[offset + e / CACHE_PER_WORD] >> ((e % CACHE_PER_WORD) * uint(CACHE_BITS))) & CACHE_MASK;
    return index == CACHE_MASK ? kNone : UintBuf(palette.array).w[palette.end - 1u - index];
#endif
}

/// Marks brick's skippable sub-blocks; its finest labels start at cache word `offset`.
void markBrick(Frame f, uint brick, uint offset) {
    const uint j = gl_LocalInvocationID.x;
    if (j < 2u) bits[j] = 0u;
    barrier();
    const uvec3 b = uvec3(brick % BRICK_GRID.x, (brick / BRICK_GRID.x) % BRICK_GRID.y, brick / (BRICK_GRID.x * BRICK_GRID.y)) *
                    BRICK_SIZE;
    const uvec2 uniformSubs = Uvec2Buf(frameAddr[kSlotUniform]).v[brick];
    bool skip = (((j < 32u ? uniformSubs.x : uniformSubs.y) >> (j & 31u)) & 1u) != 0u;
    if (!skip && uniformSubBlockInside(j, uint(SUB_SHIFT), b.x, b.y, b.z, VOLUME_DIM.x, VOLUME_DIM.y, VOLUME_DIM.z)) {
        UintBuf cache = UintBuf(frameAddr[kSlotCache]);
        PaletteRef palette;
        palette.array = 0ul;
        palette.end = 0u;
#if CACHE_BITS != 32
        palette = paletteOf(f, brick);
#endif
        const uint n = 1u << (3u * uint(SUB_SHIFT)), first = j * n;
        skip = true;
        for (uint e = 0u; e < n && skip; ++e) skip = materialOf(f, labelAt(cache, offset, first + e, palette)) == kNone;
    }
    if (skip) atomicOr(bits[j >> 5u], 1u << (j & 31u));
    barrier();
    if (j == 0u) Uvec2Buf(frameAddr[kSlotSkip]).v[brick] = uvec2(bits[0], bits[1]);
    barrier(); // bits is cleared for the next brick only after it was written
}

void main() {
    Frame f = Frame(pc.frame);
    if (SUB_SHIFT < 0) return;
    if (SKIP_ALL != 0u) {
        const uint brickCount = BRICK_GRID.x * BRICK_GRID.y * BRICK_GRID.z;
        if (gl_WorkGroupID.x * kSkipGroupBricks >= brickCount) return;
        loadFrameValues(f);
        Uvec4Buf bricks = Uvec4Buf(frameAddr[kSlotBricks]);
        for (uint k = 0u; k < kSkipGroupBricks; ++k) {
            const uint brick = gl_WorkGroupID.x * kSkipGroupBricks + k;
            if (brick >= brickCount) break;
            const uvec4 s = bricks.v[brick];
            if (s.y == 0u) markBrick(f, brick, s.x); // the same for the whole group: barriers stay uniform
        }
        return;
    }
    const uint i = gl_WorkGroupID.x;
    // Groups past this frame's decodes leave first, whole (CPU devices pay for every load).
    if (i >= min(UintBuf(f.addr[kSlotAlloc]).w[kAllocDecodes], f.limits.x)) return;
    loadFrameValues(f);
    UintBuf dec = UintBuf(frameAddr[kSlotDecodes]);
    if (dec.w[kDecodeEntryWords * i + 1u] == LEVELS - 1u) // inverse level: decoded at the finest
        markBrick(f, dec.w[kDecodeEntryWords * i], dec.w[kDecodeEntryWords * i + 2u]);
}
