// SPDX-License-Identifier: MIT
// Decodes a list of brick requests (brick index, inverse level, cache word offset), one
// invocation per request, at most `steps` steps per dispatch (see csgv_decode.glsl); the state,
// and in the end the result code, of request i live in words [12 i, 12 i + 9) of `states`.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "csgv_decode.glsl"

layout(local_size_x = 32) in;

layout(buffer_reference, std430, buffer_reference_align = 4) buffer Uints { uint w[]; };

// Only addresses are push constants. Counts live in memory: lavapipe specialises (and unrolls)
// shaders on push-constant values used in loop conditions, recompiling for every new value.
layout(push_constant) uniform Push {
    uint64_t arrays;   // Addresses: one device address per encoding array
    uint64_t starts;   // Words: brick starts
    uint64_t requests; // Uints: 3 words per request
    uint64_t cache;    // CacheWords
    uint64_t states;   // Uints: 12 words per request
    uint64_t params;   // Uints: unused, steps in this dispatch, 1 on the first dispatch
    uint64_t count;    // Uints: the request count in its first word (written by the GPU in frames)
} pc;

void main() {
    const uint i = gl_GlobalInvocationID.x;
    Uints params = Uints(pc.params);
    const uint count = Uints(pc.count).w[0];
    const uint steps = params.w[1];
    const uint first = params.w[2];
    if (i >= count) return;
    Uints req = Uints(pc.requests);
    const uint brick = req.w[3u * i];
    const uint target = req.w[3u * i + 1u];
    const uint region = req.w[3u * i + 2u] * CACHE_PER_WORD; // words -> cache entries
    Brick b = openBrick(Addresses(pc.arrays), Words(pc.starts), brick);
    Uints saved = Uints(pc.states);
    const uint o = 12u * i;
    DecodeState st;
    if (first != 0u) {
        st = initialState(b);
    } else {
        st = DecodeState(saved.w[o], saved.w[o + 1u], saved.w[o + 2u], saved.w[o + 3u], saved.w[o + 4u],
                         saved.w[o + 5u], saved.w[o + 6u], saved.w[o + 7u], saved.w[o + 8u]);
    }
    if (st.status == kDecodeRunning) decodeSteps(b, st, target, CacheWords(pc.cache), region, steps);
    saved.w[o] = st.level;
    saved.w[o + 1u] = st.pm;
    saved.w[o + 2u] = st.x;
    saved.w[o + 3u] = st.pos;
    saved.w[o + 4u] = st.end;
    saved.w[o + 5u] = st.base;
    saved.w[o + 6u] = st.cursor;
    saved.w[o + 7u] = st.appended;
    saved.w[o + 8u] = st.status;
}
