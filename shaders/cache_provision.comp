// SPDX-License-Identifier: MIT
// Provision stage, one invocation: for each level whose free stack cannot serve all of its
// requests, hands out regions from the top of the cache; flags the cache as full when the top
// is reached. Also clears the decode count of the previous frame.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(local_size_x = 1) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

void main() {
    Frame f = Frame(pc.frame);
    loadFrameValues(f);
    UintBuf alloc = UintBuf(f.addr[A_ALLOC]);
    alloc.w[AL_DECODES] = 0u;
    alloc.w[AL_REQUESTS] = min(alloc.w[AL_REQUESTS], fv.limits.x);
    for (uint l = 0u; l < LEVELS; ++l) {
        const uint freeCount = min(alloc.w[AL_FREE_COUNT + l], fv.counts.y);
        alloc.w[AL_FREE_COUNT + l] = freeCount;
        const uint need = alloc.w[AL_REQ_COUNT + l] > freeCount ? alloc.w[AL_REQ_COUNT + l] - freeCount : 0u;
        const uint slot = regionWords(l);
        const uint top = alloc.w[AL_TOP];
        const uint room = (alloc.w[AL_CAPACITY] - top) / slot;
        const uint take = min(need, room);
        alloc.w[AL_PROV_BASE + l] = top;
        alloc.w[AL_PROV_COUNT + l] = take;
        alloc.w[AL_TOP] = top + take * slot;
        if (take < need) alloc.w[AL_FULL] = 1u;
    }
}
