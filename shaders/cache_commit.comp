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
    UintBuf alloc = UintBuf(f.addr[A_ALLOC]);
    for (uint l = 0u; l < LEVELS; ++l) {
        const uint freeCount = alloc.w[AL_FREE_COUNT + l];
        alloc.w[AL_FREE_COUNT + l] = freeCount - min(alloc.w[AL_POPS + l], freeCount);
        alloc.w[AL_POPS + l] = 0u;
        alloc.w[AL_REQ_COUNT + l] = 0u;
    }
    alloc.w[AL_REQUESTS] = 0u;
}
