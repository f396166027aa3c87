// SPDX-License-Identifier: MIT
// Assign stage, one invocation per request: takes a region from the level's free stack, else
// from the regions provisioned at the top, records it for the brick and queues its decoding.
// Requests that find no region stay undecoded (the cache is full; see Renderer.cpp).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

void main() {
    Frame f = Frame(pc.frame);
    loadFrameValues(f);
    UintBuf alloc = UintBuf(f.addr[A_ALLOC]);
    const uint i = gl_GlobalInvocationID.x;
    if (i >= alloc.w[AL_REQUESTS]) return;
    UintBuf req = UintBuf(f.addr[A_REQUESTS]);
    const uint b = req.w[2u * i];
    const uint l = req.w[2u * i + 1u];
    const uint k = atomicAdd(alloc.w[AL_POPS + l], 1u);
    const uint freeCount = alloc.w[AL_FREE_COUNT + l];
    uint offset;
    if (k < freeCount) {
        offset = UintBuf(f.addr[A_FREE]).w[l * fv.counts.y + freeCount - 1u - k];
    } else {
        const uint j = k - freeCount;
        if (j >= alloc.w[AL_PROV_COUNT + l]) return;
        offset = alloc.w[AL_PROV_BASE + l] + j * regionWords(l);
    }
    Uvec4Buf bricks = Uvec4Buf(f.addr[A_BRICKS]);
    bricks.v[b].x = offset;
    bricks.v[b].y = l;
    const uint d = atomicAdd(alloc.w[AL_DECODES], 1u);
    UintBuf dec = UintBuf(f.addr[A_DECODES]);
    dec.w[3u * d] = b;
    dec.w[3u * d + 1u] = LEVELS - 1u - l;
    dec.w[3u * d + 2u] = offset;
}
