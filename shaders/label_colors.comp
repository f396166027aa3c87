// SPDX-License-Identifier: MIT
// When the materials change (LABEL_LOOKUP dense or hashed): the colour and opacity of every label
// of the label -> material table under its material, with materialColorOf, into
// kSlotLabelColors, from which the render pass reads them (materialColor).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(local_size_x = kGroupLabels) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

void main() {
    Frame f = Frame(pc.frame);
    loadFrameValues(f);
    Vec4Buf colors = Vec4Buf(frameAddr[kSlotLabelColors]);
#if LABEL_LOOKUP == 1
    const uint n = fv.counts.w;
#else
    const uint n = LABEL_MASK + 1u;
#endif
    for (uint i = gl_GlobalInvocationID.x; i < n; i += gl_NumWorkGroups.x * kGroupLabels) {
#if LABEL_LOOKUP == 1
        const uint label = i;
        const uint m = UintBuf(frameAddr[kSlotMaterialTable]).w[i];
#else
        const uvec2 e = Uvec2Buf(frameAddr[kSlotMaterialTable]).v[i];
        const uint label = e.x;
        const uint m = e.x == kNone ? kNone : e.y;
#endif
        float emission;
        colors.v[i] = m == kNone ? vec4(0.0) : materialColorOf(f, m, label, emission);
    }
}
