// SPDX-License-Identifier: MIT
// When the materials change (LABEL_LOOKUP kLookupDense): the colour and opacity of every stored label
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
    const uint n = fv.counts.w;
    for (uint i = gl_GlobalInvocationID.x; i < n; i += gl_NumWorkGroups.x * kGroupLabels) {
        const uint label = i;
        const uint m = UintBuf(frameAddr[kSlotMaterialTable]).w[i];
        float emission;
        colors.v[i] = m == kNone ? vec4(0.0) : materialColorOf(f, m, label, emission);
    }
}
