// SPDX-License-Identifier: MIT
// Resolve stage, one invocation per pixel of the footprint rectangle (Frame rect), in passes
// (the define RESOLVE_PASS, a pipeline each); frames without denoising or upsampling skip it (kFlagResolveInRender):
//   0 gather (with tone mapping straight into the output when not denoising): average of the
//     accumulated samples; a pixel without samples shows its preview (render.comp), else copies
//     the nearest pixel of its stride block that has samples or a preview (upsampling);
//   1..3 edge-avoiding A-trous denoising with steps 1, 2, 4, guided by the G-buffer (same label,
//     same face, similar depth), fading out as samples accumulate; the last writes the output:
//     tone mapping (ACES fit), brightness, contrast, gamma; premultiplied, 8 bits a channel
//     (kSlotOutput's colour words).
// Pixels outside the rectangle keep what the clear filled in (Renderer.cpp addClear).
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "render_common.glsl"

layout(local_size_x = kGroupTile, local_size_y = kGroupTile) in;
layout(push_constant) uniform Push {
    CSGV_RESOLVE_PUSH_MEMBERS
} pc;

// The per-pixel words the passes read, through texel buffers where the renderer made them
// (RESOLVE_TEXELS: CPU devices fetch a texel for all lanes with one gather instruction, where a
// read through a buffer address loops over the lanes; the A-trous passes read nine neighbours).
// Each view's texel is a pixel's whole 16-byte record (R32G32B32A32_UINT): one fetch a record.
#ifndef RESOLVE_TEXELS
#define RESOLVE_TEXELS 0
#endif
#if RESOLVE_TEXELS
layout(set = 0, binding = kResolveTexelGBuffer) uniform usamplerBuffer gTexels;
layout(set = 0, binding = kResolveTexelAccum) uniform usamplerBuffer accumTexels;
layout(set = 0, binding = kResolveTexelSource) uniform usamplerBuffer srcTexels;
layout(set = 0, binding = kResolveTexelSpans) uniform usamplerBuffer spanTexels;
uvec4 gRaw(uint i) { return texelFetch(gTexels, int(i)); }
uint gRaw1(uint i) { return texelFetch(gTexels, int(i)).y; }
vec4 accumOf(uint i) { return uintBitsToFloat(texelFetch(accumTexels, int(i))); }
vec4 sourceOf(uint i) { return uintBitsToFloat(texelFetch(srcTexels, int(i))); }
uvec4 spanTexel(uint row, uint t) { return texelFetch(spanTexels, int(kOutlineRowWords / 4u * row + t)); }
#else
uint gRaw1(uint i) { return UintBuf(frameAddr[kSlotGBuffer]).w[4u * i + 1u]; }
uvec4 gRaw(uint i) { return uvec4(unpackUint2x32(U64Buf(frameAddr[kSlotGBuffer]).v[2u * i]),
                                    unpackUint2x32(U64Buf(frameAddr[kSlotGBuffer]).v[2u * i + 1u])); }
vec4 accumOf(uint i) { return loadVec4(frameAddr[kSlotAccum], i); }
vec4 sourceOf(uint i) { return loadVec4(frameAddr[pc.src], i); }
uvec4 spanTexel(uint row, uint t) {
    const uint i = kOutlineRowWords / 2u * row + 2u * t;
    return uvec4(unpackUint2x32(U64Buf(pc.spans).v[i]), unpackUint2x32(U64Buf(pc.spans).v[i + 1u]));
}
#endif

/// The pixels of row y this pass takes (pc.spans, its pair of words: Renderer.cpp's
/// kResolveReach); the rectangle's row without an outline.
uvec2 passSpan(uint y) {
    if (pc.spans == 0ul) return fv.rect.xz;
    const uvec4 t = spanTexel(y - fv.rect.y, uint(RESOLVE_PASS) >> 1u);
    return (RESOLVE_PASS & 1) != 0 ? t.zw : t.xy;
}

/// A pixel's G-buffer entry and its second word as this accumulation sees them (all 0 where
/// another wrote them: currentWord1).
uvec4 gWords(uint i) {
    const uvec4 w = gRaw(i);
    return currentWord1(w.y) != 0u ? w : uvec4(0u);
}
uint gWord1(uint i) { return currentWord1(gRaw1(i)); }
/// A pixel's valid samples (its G-buffer entry's second word).
uint samplesOf(uint i) { return gWord1(i) >> kGBufferCountShift; }

/// The nearest pixel of px's stride block (edge s) with samples (`sampled`) or with a preview;
/// kNone when there is none.
uint nearestInBlock(uvec2 px, uint s, bool sampled) {
    const uint W = fv.image.x, H = fv.image.y;
    // s is 1, 2, 4 or 8 (strides): masks and shifts, not divisions (CPU devices divide lane by lane).
    const uvec2 b0 = px & ~uvec2(s - 1u);
    const uint shift = uint(findLSB(s));
    uint best = kNone, from = kNone;
    for (uint k = 0u; k < s * s; ++k) {
        const uvec2 q = b0 + uvec2(k & (s - 1u), k >> shift);
        if (q.x >= W || q.y >= H) continue;
        const uint qi = q.y * W + q.x;
        const ivec2 dq = ivec2(q) - ivec2(px);
        const uint dist = uint(dq.x * dq.x + dq.y * dq.y);
        const bool shows = sampled ? samplesOf(qi) > 0u : (samplesOf(qi) == 0u && (gWord1(qi) & kGBufferPreview) != 0u);
        if (shows && dist < best) {
            best = dist;
            from = qi;
        }
    }
    return from;
}

/// A pass's result: tone-mapped into the output, or into a denoising buffer. RESOLVE_OUTPUT
/// (kResolveToOutput, kResolveToBuffer, kResolveToEither: the push constant's dst) says which
/// at compile time where the host knows (Renderer.cpp's resolveTarget): CPU devices run both
/// writes, and the tone mapping, where the shader decides.
void writeResult(Frame f, uint pixel, vec4 c) {
    const bool toOutput = RESOLVE_OUTPUT == kResolveToEither ? pc.dst == kSlotOutput : RESOLVE_OUTPUT == kResolveToOutput;
    if (toOutput) UintBuf(f.addr[kSlotOutput]).w[2u * pixel] = packUnorm4x8(toneMapped(c));
    else storeVec4(f.addr[pc.dst], pixel, c);
}

void resolvePixel(Frame f, uvec2 px) {
    const uint W = fv.image.x, H = fv.image.y;
    if (px.x >= fv.rect.z || px.y >= fv.rect.w) return;
    const uint pixel = px.y * W + px.x;
    // With the box's outline, a pass takes the pixels within its reach of it (the others are
    // misses whose result is colour 0: their output keeps the clear's).
    const uvec2 span = passSpan(px.y);
    if (px.x < span.x || px.x >= span.y) return;
    if (RESOLVE_PASS == kResolveGather) {
        uint n = samplesOf(pixel);
        const uint fewest = subgroupMin(n); // one atomic per subgroup
        if (subgroupElect()) atomicMin(UintBuf(frameAddr[kSlotAlloc]).w[kAllocMinSamples], fewest);
        U64Buf g = U64Buf(frameAddr[kSlotGBuffer]); // two words a read or write (see storeVec4)
        // What the pixel shows: its own samples, else (upsampling) the nearest pixel of its stride
        // block with samples, else its own preview, else the nearest preview of the block.
        const uint s = uint(fv.pixel.z); // the upsampling block: the coarsest stride of this accumulation
        uint from = n > 0u ? pixel : (s > 1u ? nearestInBlock(px, s, true) : kNone);
        bool preview = false;
        if (from == kNone) {
            if ((gWord1(pixel) & kGBufferPreview) != 0u) from = pixel;
            else if (s > 1u) from = nearestInBlock(px, s, false);
            preview = from != kNone;
        }
        const bool shows = from != kNone;
        if (!shows) from = pixel;
        if (from != pixel) {
            n = samplesOf(from);
            UintBuf words = UintBuf(frameAddr[kSlotOutput]); // the depth words (odd), as they are
            words.w[2u * pixel + 1u] = words.w[2u * from + 1u];
            // What the pixel shows, it also answers to picking (its own first sample replaces it);
            // a preview answers nothing (and stays its block neighbour's).
            // Its sample count stays its own (none): the copy answers picking, it adds no samples.
            if (!preview) {
                const uvec2 w01 = unpackUint2x32(g.v[2u * from]);
                g.v[2u * pixel] = packUint2x32(uvec2(w01.x, w01.y & ((1u << kGBufferCountShift) - 1u)));
                g.v[2u * pixel + 1u] = g.v[2u * from + 1u];
            }
        }
        const uint previews = subgroupAdd(preview ? 1u : 0u);
        if (subgroupElect() && previews > 0u) atomicAdd(UintBuf(frameAddr[kSlotAlloc]).w[kAllocPreviews], previews);
        const uint holes = subgroupAdd(shows ? 0u : 1u); // one atomic per subgroup
        if (subgroupElect() && holes > 0u) atomicAdd(UintBuf(frameAddr[kSlotAlloc]).w[kAllocHoles], holes);
        const vec4 c = shows ? accumOf(from) / float(max(n, 1u)) : vec4(0.0);
        writeResult(f, pixel, c); // into the output without denoising (one pass), else the first denoising buffer
        return;
    }
    const vec4 centre = sourceOf(pixel);
    {
        const uint n = samplesOf(pixel);
        const uvec3 gc = gWords(pixel).xyz;
        const float dc = uintBitsToFloat(gc.z);
        const int step = 1 << (RESOLVE_PASS - kResolveAtrous1);
        const float kernel[3] = float[3](0.25, 0.5, 0.25);
        vec4 sum = vec4(0.0);
        float weights = 0.0;
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                const ivec2 q = ivec2(px) + ivec2(dx, dy) * step;
                // Outside the rectangle nothing is ever gathered: only pixels inside take part.
                if (any(lessThan(q, ivec2(fv.rect.xy))) || any(greaterThanEqual(q, ivec2(fv.rect.zw)))) continue;
                const uint qi = uint(q.y) * W + uint(q.x);
                const uvec3 gq = gWords(qi).xyz;
                float wgt = kernel[dx + 1] * kernel[dy + 1];
                if (gq.x != gc.x || (gq.y & 7u) != (gc.y & 7u)) wgt = 0.0;
                wgt *= exp(-abs(uintBitsToFloat(gq.z) - dc) * 2000.0);
                sum += wgt * sourceOf(qi);
                weights += wgt;
            }
        const vec4 filtered = weights > 0.0 ? sum / weights : centre;
        const float keep = (fv.frame.y & kFlagDenoise) != 0u ? float(n) / float(n + 4u) : 1.0;
        const vec4 result = mix(filtered, centre, keep);
        writeResult(f, pixel, result);
    }
}

void main() {
    Frame f = Frame(pc.frame);
    loadFrameValues(f);
    // PIXEL_BLOCK^2 pixels per invocation: lavapipe spends about 0.1 us on each invocation itself.
    for (uint j = 0u; j < PIXEL_BLOCK * PIXEL_BLOCK; ++j)
        resolvePixel(f, fv.rect.xy + gl_GlobalInvocationID.xy * PIXEL_BLOCK + uvec2(j % PIXEL_BLOCK, j / PIXEL_BLOCK));
}
