// SPDX-License-Identifier: MIT
// PIXEL_LIST (CPU devices): lists the cells of the frame's footprint grid whose pixel takes a
// sample this frame (below the sample target), so that the render pass runs over those alone.
// CPU devices run every branch of a shader for all lanes, so a render pass over the whole grid
// costs a frame that samples a few pixels (the still loop's later frames) as much as the first.
// The host reads the count between the frame's two submissions and sizes the render dispatch.
// Pixels left out count towards the frame's smallest sample count here, as the render pass
// would count them.
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "render_common.glsl"

layout(local_size_x = kGroupList) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

/// Cell c of a grid gx cells wide: c / gx through a float division, off by at most one for rows
/// below 2^16 (cells pack y in 16 bits), then corrected: CPU devices divide integers lane by lane.
uvec2 cellOf(uint c, uint gx) {
    uint y = uint((float(c) + 0.5) / float(gx));
    if (y * gx > c) --y;
    else if ((y + 1u) * gx <= c) ++y;
    return uvec2(c - y * gx, y);
}

void main() {
    Frame f = Frame(pc.frame);
    loadFrameValues(f);
    UintBuf alloc = UintBuf(frameAddr[kSlotAlloc]);
    UintBuf list = UintBuf(frameAddr[kSlotPixelList]);
    UintBuf gbuffer = UintBuf(frameAddr[kSlotGBuffer]); // sample counts in the second words
    const uvec2 grid = cellGrid();
    const uint cells = grid.x * grid.y;
    // kListBlock rounds per invocation (lavapipe pays per invocation); in each round the lanes
    // of a group take consecutive cells.
    for (uint k = 0u; k < kListBlock; ++k) {
        const uint c = (gl_WorkGroupID.x * kListBlock + k) * kGroupList + gl_LocalInvocationID.x;
        const uvec2 cell = cellOf(c, max(grid.x, 1u));
        uvec2 px;
        bool sampling = false;
        uint kept = kNone; // the sample count of a pixel left out
        if (c < cells && cellPixel(cell, px)) {
            const uint n = currentWord1(gbuffer.w[4u * (px.y * fv.image.x + px.x) + 1u]) >> kGBufferCountShift;
            sampling = wantsSample(n);
            if (!sampling) kept = n;
        }
        const uint one = sampling ? 1u : 0u;
        const uint total = subgroupAdd(one);
        const uint before = subgroupExclusiveAdd(one);
        uint base = 0u;
        if (subgroupElect() && total > 0u) base = atomicAdd(alloc.w[kAllocListCount], total);
        base = subgroupMax(base);
        if (sampling) list.w[base + before] = cell.x | (cell.y << 16u);
        const uint fewest = subgroupMin(kept);
        if (subgroupElect() && fewest != kNone) {
            atomicMin(alloc.w[kAllocMinSamples], fewest);
            atomicMin(alloc.w[kAllocNextKept], fewest); // left out of the next frame's list too (kFlagListNext)
        }
    }
}
