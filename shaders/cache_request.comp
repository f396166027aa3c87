// SPDX-License-Identifier: MIT
// Request stage, one invocation per REQUEST_BLOCK bricks: frees the cache regions of bricks that became
// invisible, that need another level of detail (used or not: a ray must never sample a brick at
// another level than the view wants, or converged images would depend on what the cache held
// before), or (under cache pressure) that no ray used for
// kAllocEvictAge frames (least recently used first: the host lowers the age while the cache stays
// full), onto their level's free stack; and requests bricks the previous frame's rays needed but
// did not find (with kFlagPrefetch: every visible brick not cached), at the level their centre's
// distance asks for (with detail streaming, the next coarser one while the finest level's stream
// is not on the device).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(local_size_x = kGroupBricks) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

Frame f;

/// Marked by the previous frame's rays (frame index + 1), or every brick (kFlagPrefetch: the
/// visible ones are asked for below).
bool usedBrick(uvec4 s) { return s.z == fv.frame.x || (fv.frame.y & kFlagPrefetch) != 0u; }

/// Most bricks of a large volume are neither cached nor needed: nothing to do for them, unless
/// the materials changed which bricks are visible (their flags follow in requestBrick).
bool needsWork(uvec4 s) { return usedBrick(s) || s.y != kNone || (fv.frame.y & kFlagVisibilityChanged) != 0u; }

void requestBrick(uint b) {
    Uvec4Buf bricks = Uvec4Buf(frameAddr[kSlotBricks]);
    uvec4 s = bricks.v[b];
    const bool used = usedBrick(s);
    if (!needsWork(s)) return;
#if ABSENT_BRICKS
    // Another rank's brick: never requested or cached here; its flag tells the rays.
    const uvec2 preview = Uvec2Buf(frameAddr[kSlotVisible]).v[b];
    if (preview.x == kNone && preview.y == kBrickAbsent) {
        if (s.w != kBrickAbsent) bricks.v[b].w = kBrickAbsent;
        return;
    }
#endif
    UintBuf alloc = UintBuf(frameAddr[kSlotAlloc]);
    const bool visible = UintBuf(frameAddr[kSlotVisible]).w[2u * b] != kNone;
    const uint wanted = lodForBrick(f, b);
    uint level = wanted;
#if DETAIL_STREAMING
    // The finest level needs the brick's stream in the detail buffer, unless the brick holds it
    // decoded already: until the stream is there the brick stands in at the next coarser level
    // (exact rays treat it as missing), and the stream is asked for (the host uploads it between
    // frames).
    const bool noDetail = wanted == 0u && s.y != 0u && UintBuf(frameAddr[kSlotDetail]).w[2u * b] == kNone;
    if (noDetail) level = 1u;
    if (noDetail && used && visible) {
        const uint k = atomicAdd(alloc.w[kAllocDetailRequests], 1u);
        if (k < fv.limits.x) UintBuf(frameAddr[kSlotDetailRequests]).w[k] = b;
    }
#endif
    const uint flag = visible ? (level != wanted ? kBrickStandIn : 1u) : 0u;
    if (s.w != flag) bricks.v[b].w = flag; // materials changed, or the brick's detail
#if CARRY_DECODES
    // Being decoded (a region, no level yet): left alone until its decoding ends (overlapped
    // decodes: until the frame's first dispatch publishes it, which runs before this pass).
    if (s.y == kNone && s.x != kNone) return;
#endif
    if (s.y != kNone) {
        // s.z is the frame index + 1 of the last use: the age is 0 for the previous frame's bricks.
        const uint evictAge = alloc.w[kAllocEvictAge];
        const bool stale = evictAge != 0u && fv.frame.x - s.z >= evictAge;
        const bool evict = !visible || s.y != level || stale;
        if (!evict) return;
        const uint k = atomicAdd(alloc.w[kAllocFreeCount + s.y], 1u);
        // A full stack cannot happen (a level never has more regions than bricks); if it did, the
        // region would only be dead space until the next cache reset.
        if (k < fv.counts.y) UintBuf(frameAddr[kSlotFree]).w[s.y * fv.counts.y + k] = s.x;
#if CARRY_DECODES
        bricks.v[b].xy = uvec2(kNone); // no region: not being decoded either
#else
        bricks.v[b].y = kNone;
#endif
        s.y = kNone;
    }
    if (!used || !visible) return;
    const uint r = atomicAdd(alloc.w[kAllocRequests], 1u);
#if CARRY_DECODES
    if (r + min(alloc.w[kAllocCarry], fv.limits.x) >= fv.limits.x) return; // the list holds carried decodes first
#endif
    if (r >= fv.limits.x) return; // over this frame's decode budget: asked again next frame
    atomicAdd(alloc.w[kAllocReqCount + level], 1u);
    UintBuf req = UintBuf(frameAddr[kSlotRequests]);
    req.w[2u * r] = b;
    req.w[2u * r + 1u] = level;
}

void main() {
    f = Frame(pc.frame);
    loadFrameValues(f);
    // REQUEST_BLOCK bricks per invocation: CPU devices pay for every invocation. They also run
    // every line of a called function for every SIMD lane, masked or not: requestBrick's whole
    // body for each of a large volume's bricks (8.6 ms a frame over 2048^3's 262,144 bricks on
    // two cores, most of a moving camera's time). So the cheap test first, for all of the
    // invocation's bricks, and the work for the few that pass.
    if (REQUEST_BLOCK > 1u) {
        uint todo[REQUEST_BLOCK];
        uint n = 0u;
        for (uint k = 0u; k < REQUEST_BLOCK; ++k) {
            const uint b = gl_GlobalInvocationID.x * REQUEST_BLOCK + k;
            if (b < fv.counts.y && needsWork(Uvec4Buf(frameAddr[kSlotBricks]).v[b])) todo[n++] = b;
        }
        for (uint i = 0u; i < n; ++i) requestBrick(todo[i]);
        return;
    }
    const uint b = gl_GlobalInvocationID.x;
    if (b < fv.counts.y) requestBrick(b);
}
