// SPDX-License-Identifier: MIT
// Provision stage, one invocation: for each level whose free stack cannot serve all of its
// requests, hands out regions from the top of the cache; flags the cache as full when the top
// is reached. Also clears the decode count of the previous frame (CARRY_DECODES: starts it at
// the decodes the previous frame carried over, the first entries of this frame's list).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(local_size_x = 1) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

void main() {
    Frame f = Frame(pc.frame);
    loadFrameValues(f);
    UintBuf alloc = UintBuf(frameAddr[kSlotAlloc]);
#if CARRY_DECODES
    const uint carried = min(alloc.w[kAllocCarry], fv.limits.x);
    alloc.w[kAllocCarry] = 0u;
    alloc.w[kAllocCarriedEnded] = min(alloc.w[kAllocCarryEnded], carried); // overlapped: published, not decoded
    alloc.w[kAllocCarryEnded] = 0u;
#else
    const uint carried = 0u;
#endif
    alloc.w[kAllocDecodes] = carried;
    alloc.w[kAllocCarried] = carried;
    alloc.w[kAllocRequests] = min(alloc.w[kAllocRequests], fv.limits.x - carried);
    for (uint l = 0u; l < LEVELS; ++l) {
        const uint freeCount = min(alloc.w[kAllocFreeCount + l], fv.counts.y);
        alloc.w[kAllocFreeCount + l] = freeCount;
        const uint need = alloc.w[kAllocReqCount + l] > freeCount ? alloc.w[kAllocReqCount + l] - freeCount : 0u;
        const uint slot = regionWords(l);
        const uint top = alloc.w[kAllocTop];
        const uint room = (alloc.w[kAllocCapacity] - top) / slot;
        const uint take = min(need, room);
        alloc.w[kAllocProvBase + l] = top;
        alloc.w[kAllocProvCount + l] = take;
        alloc.w[kAllocTop] = top + take * slot;
        if (take < need) alloc.w[kAllocFull] = 1u;
    }
}
