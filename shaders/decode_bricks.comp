// SPDX-License-Identifier: MIT
// Decodes a list of brick requests (brick index, inverse level, cache word offset), one
// invocation per request, at most `steps` steps per dispatch (see csgv_decode.glsl); the state,
// and in the end the result code, of request i live in words [12 i, 12 i + 9) of `states`. A
// decode that fails leaves its region outside the volume (drawn empty; in frames cache_uniform.comp
// fills it, kDecodeParamMarkFailed) and counts in the dispatch's parameters (kDecodeParamFailures:
// the renderer's bad bricks).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "csgv_decode.glsl" // (with csgv/gpu/FrameLayout.h: the decode lists and push constants)

// DECODE_GROUP (GpuVolume.cpp decodeGroup): decodes per workgroup, 1 on GPUs (a brick's decoder
// branches on every symbol: bricks sharing a warp wait for each other's paths), kGroupDecodes on
// CPU devices.
layout(local_size_x = DECODE_GROUP) in;

layout(buffer_reference, std430, buffer_reference_align = 4) buffer Uints { uint w[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Uvec4s { uvec4 v[]; };

layout(push_constant) uniform Push {
    CSGV_DECODE_PUSH_MEMBERS
} pc;

void main() {
    const uint i = gl_GlobalInvocationID.x;
    Uints params = Uints(pc.params);
    Uints req = Uints(pc.requests);
    Uints saved = Uints(pc.states);
    uint o = kDecodeStateWords * i;
    Uints progress = Uints(pc.bricks + inFlightWordsOffset(BRICK_GRID.x * BRICK_GRID.y * BRICK_GRID.z));
    if (params.w[kDecodeParamPublish] != 0u) {
        // A frame's first dispatch, before its request pass (which then treats these bricks as
        // cached: a level the view no longer wants is evicted before any ray samples it): the
        // decodes the previous frame carried into this list (kAllocCarry, its first entries) that
        // ended are published, those still running show their progress (previews; see below).
        if (i >= Uints(pc.alloc).w[kAllocCarry]) return;
        const uint brick = req.w[kDecodeEntryWords * i];
        const uint target = req.w[kDecodeEntryWords * i + 1u] & ~kDecodeEntryFailed;
        if (saved.w[o + kDecodeStateStatus] != kDecodeRunning)
            Uvec4s(pc.bricks).v[brick].y = LEVELS - 1u - target;
        else if (saved.w[o] >= 1u)
            progress.w[brick] = kInFlightValid | ((LEVELS - saved.w[o]) << 8u) | (LEVELS - 1u - target);
        return;
    }
    const uint count = Uints(pc.count).w[0];
    const uint steps = params.w[1];
    const uint first = params.w[2];
    if (i >= count) return;
    const uint brick = req.w[kDecodeEntryWords * i];
    const uint target = req.w[kDecodeEntryWords * i + 1u] & ~kDecodeEntryFailed;
    const uint region = req.w[kDecodeEntryWords * i + 2u] * CACHE_PER_WORD; // words -> cache entries
    // Decodes that carry over frames (pc.alloc set, RendererOptions::decodeStepsPerFrame): the
    // list's first kAllocCarried entries continue from the previous frame, their states saved.
    const bool carry = pc.alloc != 0ul;
    // Overlapped: the frame's render runs beside this dispatch and must read nothing it writes.
    const bool defer = params.w[kDecodeParamDefer] != 0u;
    Brick b = openBrick(Addresses(pc.arrays), Words(pc.starts), brick, pc.detail, pc.ring);
    DecodeState st;
    const bool starts = first != 0u && (!carry || i >= Uints(pc.alloc).w[kAllocCarried]);
    if (starts) {
        st = initialState(b); // may fail at once (a stream's first state word too small)
    } else {
        st = DecodeState(saved.w[o], saved.w[o + 1u], saved.w[o + 2u], saved.w[o + 3u], saved.w[o + 4u],
                         saved.w[o + 5u], saved.w[o + 6u], saved.w[o + 7u], saved.w[o + kDecodeStateStatus]);
    }
    const bool running = st.status == kDecodeRunning;
    if (running) decodeSteps(b, st, target, CacheWords(pc.cache), region, steps);
    const bool ended = st.status != kDecodeRunning && (running || starts); // in this dispatch
    if (ended && st.status != kDecodeOk) {
        // Failed (a corrupt stream): the region reads as outside the volume (drawn empty),
        // and the dispatch's parameters tell the host (the first failure named).
        if (params.w[kDecodeParamMarkFailed] != 0u) { // frames: cache_uniform.comp fills it
            req.w[kDecodeEntryWords * i + 1u] = target | kDecodeEntryFailed;
        } else {
            const uint edge = BRICK_SIZE >> (LEVELS - 1u - target);
            const uint words = (edge * edge * edge + CACHE_PER_WORD - 1u) / CACHE_PER_WORD;
            CacheWords cache = CacheWords(pc.cache);
            for (uint k = 0u; k < words; ++k) cache.w[region / CACHE_PER_WORD + k] = 0xFFFFFFFFu;
        }
        if (atomicAdd(params.w[kDecodeParamFailures], 1u) == 0u) {
            params.w[kDecodeParamFailedBrick] = brick + 1u;
            params.w[kDecodeParamFailedCode] = st.status;
        }
    }
    // Ended (or failed: drawn empty): the rays may read it (deferred: the next frame's first
    // dispatch publishes it).
    if (carry && !defer && ended)
        Uvec4s(pc.bricks).v[brick].y = LEVELS - 1u - target;
    if (carry && !defer && st.status == kDecodeRunning && st.level >= 1u) {
        // Its progress for previews (kInFlightValid, after the brick table): the levels above
        // st.level are complete, nodes of edge 2^(LEVELS - st.level) finest voxels; the region
        // is laid out for level LEVELS - 1 - target. Decoding the next level overwrites a node's
        // last word with its last child's label: a label of that node, or kNone where that child
        // lies outside the volume (march then shows the brick's preview label).
        progress.w[brick] = kInFlightValid | ((LEVELS - st.level) << 8u) | (LEVELS - 1u - target);
    }
    if (carry && (st.status == kDecodeRunning || (defer && ended)) && params.w[kDecodeParamCarry] != 0u) {
        // The frame's steps are spent: on in the next frame's list (deferred: ended too, for the
        // next frame to publish, failed ones marked).
        const uint k = atomicAdd(Uints(pc.alloc).w[kAllocCarry], 1u);
        if (st.status != kDecodeRunning) atomicAdd(Uints(pc.alloc).w[kAllocCarryEnded], 1u); // ended (deferred)
        Uints next = Uints(pc.next);
        next.w[kDecodeEntryWords * k] = brick;
        next.w[kDecodeEntryWords * k + 1u] = req.w[kDecodeEntryWords * i + 1u];
        next.w[kDecodeEntryWords * k + 2u] = req.w[kDecodeEntryWords * i + 2u];
        saved = Uints(pc.nextStates);
        o = kDecodeStateWords * k;
    }
    saved.w[o] = st.level;
    saved.w[o + 1u] = st.pm;
    saved.w[o + 2u] = st.x;
    saved.w[o + 3u] = st.pos;
    saved.w[o + 4u] = st.end;
    saved.w[o + 5u] = st.base;
    saved.w[o + 6u] = st.cursor;
    saved.w[o + 7u] = st.appended;
    saved.w[o + kDecodeStateStatus] = st.status;
}
