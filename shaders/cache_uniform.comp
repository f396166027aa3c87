// SPDX-License-Identifier: MIT
// After GPU decoding, one workgroup per decoded brick, one invocation per sub-block
// (csgv/codec/Layout.h): marks the sub-blocks of bricks decoded at the finest level that lie
// inside the volume and hold one label (Frame slot kSlotUniform; march() steps over them whole).
// Host decoding computes the same in Renderer.cpp.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

shared uint bits[2];

/// Cache entry e of the region at word `offset` (a label, or a palette index with paletting).
uint entryAt(UintBuf cache, uint offset, uint e) {
#if CACHE_BITS == 32
    return cache.w[offset + e];
#else
    return (cache.w[offset + e / CACHE_PER_WORD] >> ((e % CACHE_PER_WORD) * uint(CACHE_BITS))) & CACHE_MASK;
#endif
}

void main() {
    Frame f = Frame(pc.frame);
    const uint i = gl_WorkGroupID.x, j = gl_LocalInvocationID.x;
    // Groups past this frame's decodes leave first, whole (CPU devices pay for every load).
    if (i >= min(UintBuf(f.addr[kSlotAlloc]).w[kAllocDecodes], f.limits.x)) return;
    loadFrameValues(f);
    if (j < 2u) bits[j] = 0u;
    barrier();
    UintBuf dec = UintBuf(frameAddr[kSlotDecodes]);
    const bool finest = dec.w[kDecodeEntryWords * i + 1u] == LEVELS - 1u; // inverse level
    if (finest && SUB_SHIFT >= 0) {
        const uint brick = dec.w[kDecodeEntryWords * i];
        const uint offset = dec.w[kDecodeEntryWords * i + 2u];
        const uvec3 b = uvec3(brick % BRICK_GRID.x, (brick / BRICK_GRID.x) % BRICK_GRID.y, brick / (BRICK_GRID.x * BRICK_GRID.y)) *
                        BRICK_SIZE;
        if (uniformSubBlockInside(j, uint(SUB_SHIFT), b.x, b.y, b.z, VOLUME_DIM.x, VOLUME_DIM.y, VOLUME_DIM.z)) {
            UintBuf cache = UintBuf(frameAddr[kSlotCache]);
            const uint n = 1u << (3u * uint(SUB_SHIFT)), first = j * n;
            const uint v = entryAt(cache, offset, first);
            bool same = true;
            for (uint e = 1u; e < n && same; ++e) same = entryAt(cache, offset, first + e) == v;
            if (same) atomicOr(bits[j >> 5u], 1u << (j & 31u));
        }
    }
    barrier();
    if (finest && j == 0u) Uvec2Buf(frameAddr[kSlotUniform]).v[dec.w[kDecodeEntryWords * i]] = uvec2(bits[0], bits[1]);
}
