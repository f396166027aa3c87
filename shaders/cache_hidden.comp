// SPDX-License-Identifier: MIT
// The sub-blocks (csgv/codec/Layout.h) of cached bricks that lie inside the volume and hold no
// label a material draws at the level the brick is cached at (Frame slot kSlotHidden; levels whose
// nodes are no larger than a sub-block): march() steps over them whole without reading a label,
// and over a 2x2x2 group of them (Morton-consecutive) at once. No surface can be inside: a
// walker passing such a sub-block voxel by voxel meets only labels without a material, and the
// first voxel after it shows a surface exactly when its label is drawn, whatever it passed. One
// workgroup per brick, one invocation per sub-block; the renderer runs it where the volume holds
// several undrawn labels (else the masks stay 0: such sub-blocks hold the one undrawn label,
// uniform ones, kSlotUniform):
//   HIDDEN_ALL 0: the bricks decoded this frame (the decode list);
//   HIDDEN_ALL 1: every brick of the table cached at such a level, kHiddenGroupBricks a group in
//                 turn (the materials changed; this also covers the bricks decoded this frame).
// It reads the cache, brick table and label table through the render pass's texel buffers where
// the renderer made them (RENDER_TEXELS: one gather for eight lanes on CPU devices).
// Core's castRaysStable marks the same sub-blocks and steps alike, so images stay exact.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

#ifndef HIDDEN_ALL
#define HIDDEN_ALL 0u
#endif

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

shared uint bits[2];

/// Marks the brick's sub-blocks without drawn labels; its labels at `level` start at cache word
/// `offset`, a sub-block's nodes one Morton run of them.
void markBrick(Frame f, uint brick, uint offset, uint level) {
    const uint j = gl_LocalInvocationID.x;
    if (j < 2u) bits[j] = 0u;
    barrier();
    const uvec3 b = uvec3(brick % BRICK_GRID.x, (brick / BRICK_GRID.x) % BRICK_GRID.y, brick / (BRICK_GRID.x * BRICK_GRID.y)) *
                    BRICK_SIZE;
    if (uniformSubBlockInside(j, uint(SUB_SHIFT), b.x, b.y, b.z, VOLUME_DIM.x, VOLUME_DIM.y, VOLUME_DIM.z)) {
        PaletteRef palette;
        palette.array = 0ul;
        palette.end = 0u;
#if CACHE_BITS != 32
        palette = paletteOf(f, brick);
#endif
        const uint n = 1u << (3u * (uint(SUB_SHIFT) - level)), first = j * n;
        bool hidden = true;
        for (uint e = 0u; e < n && hidden; ++e) hidden = materialOf(f, entryLabel(offset, first + e, palette)) == kNone;
        if (hidden) atomicOr(bits[j >> 5u], 1u << (j & 31u));
    }
    barrier();
    if (j == 0u) Uvec2Buf(frameAddr[kSlotHidden]).v[brick] = uvec2(bits[0], bits[1]);
    barrier(); // bits is cleared for the next brick only after it was written
}

void main() {
    Frame f = Frame(pc.frame);
    if (SUB_SHIFT < 0) return;
    if (HIDDEN_ALL != 0u) {
        const uint brickCount = BRICK_GRID.x * BRICK_GRID.y * BRICK_GRID.z;
        if (gl_WorkGroupID.x * kHiddenGroupBricks >= brickCount) return;
        loadFrameValues(f);
        for (uint k = 0u; k < kHiddenGroupBricks; ++k) {
            const uint brick = gl_WorkGroupID.x * kHiddenGroupBricks + k;
            if (brick >= brickCount) break;
            const uvec4 s = brickState(brick);
            if (s.y <= uint(SUB_SHIFT)) markBrick(f, brick, s.x, s.y); // the same for the whole group: barriers stay uniform
        }
        return;
    }
    const uint i = gl_WorkGroupID.x;
    // Groups past this frame's decodes leave first, whole (CPU devices pay for every load).
    if (i >= min(UintBuf(f.addr[kSlotAlloc]).w[kAllocDecodes], f.limits.x)) return;
    loadFrameValues(f);
    UintBuf dec = UintBuf(frameAddr[kSlotDecodes]);
    const uint level = LEVELS - 1u - min(dec.w[kDecodeEntryWords * i + 1u] & ~kDecodeEntryFailed, LEVELS - 1u); // from the inverse level
#if CARRY_DECODES
    if (Uvec4Buf(frameAddr[kSlotBricks]).v[dec.w[kDecodeEntryWords * i]].y == kNone) return; // still being decoded
#endif
    if (level <= uint(SUB_SHIFT)) markBrick(f, dec.w[kDecodeEntryWords * i], dec.w[kDecodeEntryWords * i + 2u], level);
}
