// SPDX-License-Identifier: MIT
// Assign stage, one invocation per request: takes a region from the level's free stack, else
// from the regions provisioned at the top, records it for the brick and queues its decoding.
// Requests that find no region stay undecoded (the cache is full; see Renderer.cpp).
// CARRY_DECODES: the brick's level is set when its decoding ends (decode_bricks.comp), maybe
// frames later; until then the region is the brick's (x) and the rays find it missing (y kNone).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(local_size_x = kGroupBricks) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

void main() {
    Frame f = Frame(pc.frame);
    loadFrameValues(f);
    UintBuf alloc = UintBuf(frameAddr[kSlotAlloc]);
    const uint i = gl_GlobalInvocationID.x;
    if (i >= alloc.w[kAllocRequests]) return;
    UintBuf req = UintBuf(frameAddr[kSlotRequests]);
    const uint b = req.w[2u * i];
    const uint l = req.w[2u * i + 1u];
    const uint k = atomicAdd(alloc.w[kAllocPops + l], 1u);
    const uint freeCount = alloc.w[kAllocFreeCount + l];
    uint offset;
    if (k < freeCount) {
        offset = UintBuf(frameAddr[kSlotFree]).w[l * fv.counts.y + freeCount - 1u - k];
    } else {
        const uint j = k - freeCount;
        if (j >= alloc.w[kAllocProvCount + l]) return;
        offset = alloc.w[kAllocProvBase + l] + j * regionWords(l);
    }
    Uvec4Buf bricks = Uvec4Buf(frameAddr[kSlotBricks]);
    bricks.v[b].x = offset;
#if !CARRY_DECODES
    bricks.v[b].y = l;
#else
    inFlightWords().w[b] = 0u; // nothing of this decoding is complete yet (decode_bricks.comp)
#endif
    const uint d = atomicAdd(alloc.w[kAllocDecodes], 1u);
    UintBuf dec = UintBuf(frameAddr[kSlotDecodes]);
    dec.w[kDecodeEntryWords * d] = b;
    dec.w[kDecodeEntryWords * d + 1u] = LEVELS - 1u - l;
    dec.w[kDecodeEntryWords * d + 2u] = offset;
}
