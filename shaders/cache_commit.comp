// SPDX-License-Identifier: MIT
// After Assign, one invocation: removes the regions taken from each free stack and clears the
// request counters for the next frame.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(local_size_x = 1) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

void main() {
    Frame f = Frame(pc.frame);
    loadFrameValues(f);
    UintBuf alloc = UintBuf(frameAddr[kSlotAlloc]);
    for (uint l = 0u; l < LEVELS; ++l) {
        const uint freeCount = alloc.w[kAllocFreeCount + l];
        alloc.w[kAllocFreeCount + l] = freeCount - min(alloc.w[kAllocPops + l], freeCount);
        alloc.w[kAllocPops + l] = 0u;
        alloc.w[kAllocReqCount + l] = 0u;
    }
    alloc.w[kAllocRequests] = 0u;
}
