// SPDX-License-Identifier: MIT
// Render stage, one invocation per rendered pixel of the footprint rectangle (Frame rect: every
// pixel, or one of stride^2 with subsampling): casts the view ray with the stable DDA through cached bricks, shades the first
// opaque surface (local, shadow ray, ambient occlusion or path tracing) after compositing
// semi-transparent ones front to back, and accumulates one sample. A ray that needs a brick not
// in the cache marks it for the next frame and adds no sample, so accumulated images only ever
// contain complete samples; the k-th sample of a pixel is the same whichever frame computes it.
// A pixel without samples shows a preview meanwhile (no holes): its view ray goes on through
// missing bricks as blocks of one label (the coarsest level, from the encoding's palette: the
// host's kSlotVisible), or at the coarser level a brick stands in at while its finest-level stream
// is on its way (detail streaming), shaded locally; previews are never accumulated.
// With kFlagResolveInRender it also writes the pixel's output and counts (no gather pass).
// SHADING (a kShading* value of FrameLayout.h) is a define: each mode is its own pipeline and its
// code one function (shadeShadow, shadeAmbientOcclusion, shadePathTraced; local shading is what
// every surface gets). With PIXEL_LIST (host decoding: CPU devices) the invocations take the cells
// of a list instead of the rectangle's grid (pixel_list.comp): CPU devices run every branch of
// this shader for all lanes, so pixels that take no sample must not be in the dispatch at all.
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "render_common.glsl"

// ONE_SAMPLE 1: the frame's sample target is one sample and this pass resolves its pixels
// (Renderer.cpp's oneSample), so takeSample only ever takes a pixel's first and nothing reads its
// sum: the jitter and the sum's read and write are compiled out (CPU devices would run them, taken
// or not); the host starts the accumulation anew before a frame that would read the sums.
#ifndef ONE_SAMPLE
#define ONE_SAMPLE 0
#endif
// PREFETCH_OUTPUT 1 (CPU devices: texel buffers and a pixel list): each pixel reads its output
// word when it reads its sample count, and uses it in a way that changes nothing (Frame drawn.z
// is 0). A CPU device's store waits for its cache line, and a frame's output lines are far out of
// cache by the time its pixels are stored (the rays read megabytes in between); read early, the
// line comes in while the ray is traced, with the G-buffer's. synth 512^3 at 1280x720 on
// lavapipe (perf of the pass's code): the output's store took 8.9 % of the samples, 3.3 % with
// the early read (the G-buffer's two stores, whose lines the count read brings in, 2.7 % each).
#ifndef PREFETCH_OUTPUT
#define PREFETCH_OUTPUT (RENDER_TEXELS && PIXEL_LIST)
#endif
// DEPTH_INPUT 0: the frame has no opaque depth input (kFlagDepthInput): its reads compiled out.
#ifndef DEPTH_INPUT
#define DEPTH_INPUT 1
#endif

layout(local_size_x = kGroupTile, local_size_y = kGroupTile) in;
layout(push_constant) uniform Push { uint64_t frame; } pc;

Frame f;
ivec3 boxLo, boxHi;
// The frame's matrices and the world normals of the +x, +y, +z faces, loaded once per invocation
// (see frameAddr in render_common.glsl).
mat4 clipToIndex, indexToClip, indexToWorld, worldToIndex;
vec3 normalX, normalY, normalZ;

/// The frame's counters over an invocation's pixels, added to the kAlloc words once per subgroup
/// at its end (flushCounts): atomics and subgroup operations cost CPU devices a loop over the
/// lanes each, so not one set per pixel.
struct Counts {
    uint prevMin;  // kAllocPrevMin, read once
    uint minRow;   // kAllocMinRow: the first pixel with the previous minimum sample count
    uint added;    // kAllocNewSamples
    uint missing;  // kAllocMissing
    uint fewest;   // kAllocMinSamples (kFlagResolveInRender)
    uint previews; // kAllocPreviews
    uint holes;    // kAllocHoles
    uint kept;     // kAllocNextKept: fewest samples of the cells at the target (kFlagListNext)
    uvec2 next;    // kFlagListNext: bit j (of 64: PIXEL_BLOCK^2 cells) set when the invocation's j-th cell stays below the target
};
Counts count;

void flushCounts() {
    UintBuf alloc = UintBuf(frameAddr[kSlotAlloc]);
    const uint minRow = subgroupMin(count.minRow), fewest = subgroupMin(count.fewest);
    const uint added = subgroupAdd(count.added), missing = subgroupAdd(count.missing);
    const uint previews = subgroupAdd(count.previews), holes = subgroupAdd(count.holes);
    const uint kept = subgroupMin(count.kept);
    if (kept != kNone && subgroupElect()) atomicMin(alloc.w[kAllocNextKept], kept);
    if (!subgroupElect()) return;
    if (minRow != kNone) atomicMin(alloc.w[kAllocMinRow], minRow);
    if (fewest != kNone) atomicMin(alloc.w[kAllocMinSamples], fewest);
    if (added > 0u) atomicAdd(alloc.w[kAllocNewSamples], added);
    if (missing > 0u) atomicAdd(alloc.w[kAllocMissing], missing);
    if (previews > 0u) atomicAdd(alloc.w[kAllocPreviews], previews);
    if (holes > 0u) atomicAdd(alloc.w[kAllocHoles], holes);
}

/// The world normal of a face (1 + 2 axis + (moving in -axis ? 1 : 0), as Walker.face): the
/// host's normal of a -axis face is exactly the negated +axis one.
vec3 faceNormal(uint face) {
    const uint axis = (face - 1u) / 2u;
    const vec3 n = axis == 0u ? normalX : (axis == 1u ? normalY : normalZ);
    return (face - 1u) % 2u == 0u ? -n : n;
}

vec3 transformPoint(mat4 m, vec3 p) { return (m * vec4(p, 1.0)).xyz; }

/// The walker stands in a brick that is not in the cache (march returned MARCH_MISSING): the
/// brick counts as one block of its preview label (kSlotVisible: its coarsest level, from the
/// encoding's palette). True with the label and its material: a surface. False when the ray
/// already is in that label (behind a semi-transparent block of it): a view ray's preview then
/// passes the brick whole (march's passMissing); a deep path-tracing bounce ends there.
bool coarseBlock(inout Walker w, out uint label, out uint material) {
    const uvec2 preview = visibleEntry(brickIndexOf(w.voxel));
    label = preview.x;
    material = preview.y;
    if (label == w.prevLabel) return false;
    w.prevLabel = label;
    return true;
}

#if IN_FLIGHT_PREVIEWS
/// The walker stands in a brick still being decoded whose coarser levels are complete
/// (kInFlightValid): a preview may sample it there (march, not exact).
bool inFlight(Walker w) {
    const uint b = brickIndexOf(w.voxel);
    return inFlightProgress(b, brickState(b)) != 0u;
}
#endif

/// The walker stands in a brick cached at a coarser level than the view wants, its finest-level
/// stream on its way (detail streaming): a preview may sample it there.
bool standsIn(Walker w) {
    const uvec4 s = Uvec4Buf(frameAddr[kSlotBricks]).v[brickIndexOf(w.voxel)];
    return s.w == kBrickStandIn && s.y != kNone;
}

/// Visibility along a secondary ray from the walker's voxel (start inside a free voxel): 1 clear,
/// 0 blocked, attenuated by semi-transparent surfaces. A brick not in the cache makes it -1 when
/// `complete` (the sample must not be counted), else it counts at its coarsest level (deep
/// path-tracing bounces: a small bias, as in the paper). `mark`: mark the bricks as used.
float visibility(inout Walker w, bool mark, bool complete) {
    float transmittance = 1.0;
    for (uint i = 0u; i < 64u; ++i) {
        uint label, material;
        const uint r = march(f, w, boxLo, boxHi, mark, complete, false, label, material);
        if (r == MARCH_OUT) return transmittance;
        if (r == MARCH_MISSING) {
            if (complete) return -1.0;
            if (!coarseBlock(w, label, material)) return transmittance; // beyond the request depth: its coarsest level
        }
        float e;
        transmittance *= 1.0 - materialColor(f, material, label, e).a;
        if (transmittance < 0.01) return 0.0;
    }
    return transmittance;
}

/// A walker for a secondary ray leaving the surface the walker `w` just entered, in direction
/// dIndex (index space), reaching at most tEnd.
bool leaveSurface(Walker w, vec3 dIndex, float tEnd, out Walker s) {
    s = w;
    s.d = dIndex;
    s.invD = vec3(1.0) / dIndex;
    s.t = 0.0;
    s.tEnd = tEnd;
    s.prevLabel = kNone;
    s.lastBrick = kNone;
    s.secondary = true;
    if (w.face != 0u) { // start in the voxel in front of the face
        const uint axis = (w.face - 1u) / 2u;
        if ((w.face - 1u) % 2u == 0u) {
            s.voxel[axis] -= 1;
            s.vpos[axis] = ONE_MINUS_EPSILON;
        } else {
            s.voxel[axis] += 1;
            s.vpos[axis] = 0.0;
        }
    }
    return !(any(lessThan(s.voxel, boxLo)) || any(greaterThanEqual(s.voxel, boxHi)));
}

/// The 64x64 blue-noise tile (VulkanBackend/src/BlueNoise.h), a byte per pixel.
float blueNoise(uvec2 p) {
    const uint i = (p.y & 63u) * 64u + (p.x & 63u);
    return (float((blueNoiseWord(i >> 2u) >> (8u * (i & 3u))) & 255u) + 0.5) * (1.0 / 256.0);
}

/// Two numbers in [0, 1) for a pixel's k-th sample: the blue-noise tile (per pair of dimensions
/// a different offset) shifted by the R2 sequence over samples, so one frame's samples are
/// spread as blue noise over the image and a pixel's samples as a low-discrepancy sequence.
vec2 blueSample(uvec2 px, uint sampleIndex, uint pair) {
    const uvec2 o = uvec2(pair * 17u, pair * 41u);
    const vec2 b = vec2(blueNoise(px + o), blueNoise(px + o + uvec2(32u, 7u)));
    return fract(b + float(sampleIndex) * vec2(0.7548776662, 0.5698402910));
}

vec3 cosineSampleUV(vec3 n, float u, float v) {
    const float r = sqrt(u), phi = 6.2831853 * v;
    const vec3 t = normalize(abs(n.x) > 0.5 ? cross(n, vec3(0, 1, 0)) : cross(n, vec3(1, 0, 0)));
    const vec3 b = cross(n, t);
    return normalize(t * (r * cos(phi)) + b * (r * sin(phi)) + n * sqrt(max(0.0, 1.0 - u)));
}


vec3 toIndexDir(vec3 worldDir) { return (worldToIndex * vec4(worldDir, 0.0)).xyz; }

/// Direct light from the key light at a surface (with a shadow ray when `shadow`); -1 in x when a
/// brick is missing and `complete`.
vec3 directLight(Walker w, vec3 n, bool shadow, bool mark, bool complete) {
    const float cosL = dot(n, fv.lightWorld.xyz);
    if (cosL <= 0.0) return vec3(0.0);
    float vis = 1.0;
    if (shadow) {
        Walker s;
        if (leaveSurface(w, fv.lightIndex.xyz, 1e30, s)) vis = visibility(s, mark, complete);
        if (vis < 0.0) return vec3(-1.0);
    }
    return vec3(fv.lightWorld.w * cosL * vis);
}

/// A surface of colour `c` lit by the ambient light and `direct` from the key light, plus its
/// emission: local shading (direct without a shadow ray) and shadow shading (with one).
vec3 lit(vec4 c, float emission, vec3 direct) { return c.rgb * (fv.lightIndex.w + direct) + emission * c.rgb; }

// ---------------------------------------------------------------------------------------------
// Shading modes: one function each for the first opaque surface a view ray meets (the walker `w`
// has just entered it; `n` its world normal, `c` and `emission` its material). Each returns false
// when a secondary ray finds a brick missing that the sample must have (the sample is lost, its
// bricks are requested when `request`), else true with the surface's radiance in `shaded`.
// Local shading needs none: it is the `local` every surface gets (traceView).
// ---------------------------------------------------------------------------------------------

/// Shadow: the key light through a shadow ray.
bool shadeShadow(Walker w, vec3 n, vec4 c, float emission, bool request, out vec3 shaded) {
    const vec3 direct = directLight(w, n, true, request, true);
    if (direct.x < 0.0) return false;
    shaded = lit(c, emission, direct);
    return true;
}

/// Ambient occlusion: the visibility along one cosine-distributed ray (blue noise over the
/// sample's pixel) up to the radius (Frame environment.w) scales the ambient light plus half the
/// key light's intensity; the other half of the key light is its direct light without a shadow ray.
bool shadeAmbientOcclusion(Walker w, vec3 n, vec4 c, float emission, bool request, uvec2 px, uint samples,
                           out vec3 shaded) {
    Walker s;
    float vis = 1.0;
    const vec2 uv = blueSample(px, samples, 1u);
    const vec3 dir = toIndexDir(cosineSampleUV(n, uv.x, uv.y));
    if (leaveSurface(w, dir / length(dir), fv.environment.w, s)) vis = visibility(s, request, true);
    if (vis < 0.0) return false;
    const vec3 direct = directLight(w, n, false, false, false);
    shaded = c.rgb * ((fv.lightIndex.w + 0.5 * fv.lightWorld.w) * vis + 0.5 * direct) + emission * c.rgb;
    return true;
}

/// Path tracing: the key light with a shadow ray, then up to Frame limits.w diffuse bounces
/// (cosine-distributed; the first by blue noise, the others by the pixel's random numbers), each
/// lit by the key light with a shadow ray and by the sky (Frame environment.rgb) when it leaves
/// the volume. Semi-transparent surfaces along a bounce interact with the probability of their
/// opacity. Only the first bounce requests bricks and must find them all; deeper ones see missing
/// bricks at their coarsest level. Russian roulette from the third bounce.
bool shadePathTraced(Walker w, vec3 n, vec4 c, float emission, bool request, uvec2 px, uint pixel, uint samples,
                     out vec3 shaded) {
    const vec3 direct = directLight(w, n, true, request, true);
    if (direct.x < 0.0) return false;
    Rng rng = rngFor(pixel, samples);
    vec3 pt = c.rgb * direct + emission * c.rgb;
    vec3 throughput = c.rgb;
    Walker at = w;
    vec3 atN = n;
    for (uint bounce = 1u; bounce <= fv.limits.w; ++bounce) {
        const bool req = request && bounce == 1u; // only the first bounce requests bricks
        const bool complete = bounce == 1u;        // ... and must find them all
        Walker s;
        const vec2 uv = bounce == 1u ? blueSample(px, samples, 1u) : vec2(rngNext(rng), rngNext(rng));
        const vec3 dirW = cosineSampleUV(atN, uv.x, uv.y);
        if (!leaveSurface(at, toIndexDir(dirW), 1e30, s)) {
            pt += throughput * fv.environment.rgb;
            break;
        }
        uint l2 = kNone, m2 = kNone;
        uint r2 = MARCH_OUT;
        for (uint pass = 0u; pass < 64u; ++pass) {
            r2 = march(f, s, boxLo, boxHi, req, complete, false, l2, m2);
            if (r2 == MARCH_MISSING && !complete) { // deep bounces: the brick's coarsest level
                r2 = coarseBlock(s, l2, m2) ? MARCH_SURFACE : MARCH_OUT;
            }
            if (r2 != MARCH_SURFACE) break;
            float e2;
            if (rngNext(rng) < materialColor(f, m2, l2, e2).a) break; // interacts
        }
        if (r2 == MARCH_MISSING) return false;
        if (r2 == MARCH_OUT) {
            pt += throughput * fv.environment.rgb;
            break;
        }
        float e2;
        const vec3 c2 = materialColor(f, m2, l2, e2).rgb;
        const vec3 n2 = s.face != 0u ? faceNormal(s.face) : -dirW;
        const vec3 d2 = directLight(s, n2, true, false, false);
        pt += throughput * (c2 * max(d2, vec3(0.0)) + e2 * c2);
        throughput *= c2;
        if (bounce >= 3u) { // Russian roulette
            const float p = max(throughput.r, max(throughput.g, throughput.b));
            if (rngNext(rng) >= p) break;
            throughput /= p;
        }
        at = s;
        atN = n2;
    }
    shaded = pt;
    return true;
}

/// The first opaque surface shaded in the pipeline's mode (SHADING, one pipeline per mode: the
/// other modes' code is dropped at compile time); `local` is its local shading.
bool shadeSurface(Walker w, vec3 n, vec4 c, float emission, vec3 local, bool request, uvec2 px, uint pixel,
                  uint samples, out vec3 shaded) {
    const uint mode = SHADING;
    if (mode == kShadingShadow) return shadeShadow(w, n, c, emission, request, shaded);
    if (mode == kShadingAo) return shadeAmbientOcclusion(w, n, c, emission, request, px, samples, shaded);
    if (mode == kShadingPt) return shadePathTraced(w, n, c, emission, request, px, pixel, samples, shaded);
    shaded = local;
    return true;
}

// ---------------------------------------------------------------------------------------------
// A sample: the view ray, the surfaces along it, the stores.
// ---------------------------------------------------------------------------------------------

/// A sample in the making: what the view ray gathered front to back and its first opaque surface,
/// or, until one is met, its first semi-transparent one (the G-buffer entry).
struct Sample {
    vec3 radiance;
    float transmittance;
    bool translucent; // the hit below is a semi-transparent surface's: no opaque one (yet)
    uint label;       // the first opaque surface's original label (kNone: none) ...
    uint face;        // ... its entry face (0: none) ...
    float depth;      // ... its window depth ...
    float distance;   // ... and its world distance from the ray's origin
    float firstDepth; // window depth of the first surface, semi-transparent or not (1: none)
    bool valid;       // false: a brick the sample needs is not in the cache
    // What a pixel without samples shows when a secondary ray loses the sample.
    vec3 previewRadiance;
    float previewTransmittance;
};

/// The view ray of a pixel's sample `samples` in index space, from `rayO` (the near plane) along
/// `rayD` (to the far plane at t = 1), ending at `tEnd` (before the opaque depth input): sample 0
/// through the pixel centre, later ones jittered (Gaussian, sigma 0.4, an approximation of the
/// Blackman-Harris filter) by blue noise.
void viewRay(uvec2 px, uint pixel, uint samples, out vec3 rayO, out vec3 rayD, out float tEnd) {
    vec2 jitter = vec2(0.0);
#if !ONE_SAMPLE
    if ((fv.frame.y & kFlagJitter) != 0u && samples > 0u) {
        const vec2 uv = blueSample(px, samples, 0u);
        const float u = max(uv.x, 1e-7);
        jitter = clamp(0.4 * sqrt(-2.0 * log(u)) * vec2(cos(6.2831853 * uv.y), sin(6.2831853 * uv.y)), -1.5, 1.5);
    }
#endif
    precise float ndcX = (float(px.x) + 0.5 + jitter.x) * fv.pixel.x - 1.0;
    precise float ndcY = (float(px.y) + 0.5 + jitter.y) * fv.pixel.y - 1.0;
    const mat4 M = clipToIndex;
    precise vec4 a, b;
    for (int r = 0; r < 4; ++r) {
        a[r] = M[0][r] * ndcX + M[1][r] * ndcY - M[2][r] + M[3][r];
        b[r] = M[0][r] * ndcX + M[1][r] * ndcY + M[2][r] + M[3][r];
    }
    precise vec3 o = a.xyz * (1.0 / a.w);
    precise vec3 e = b.xyz * (1.0 / b.w);
    precise vec3 d = e - o;
    tEnd = 1.0;
#if DEPTH_INPUT
    if ((fv.frame.y & kFlagDepthInput) != 0u) {
        const float z = depthInAt(pixel);
        if (z < 1.0) {
            const vec4 q = M * vec4(ndcX, ndcY, 2.0 * z - 1.0, 1.0);
            tEnd = min(tEnd, dot(q.xyz / q.w - o, d) / dot(d, d));
        }
    }
#endif
    rayO = o;
    rayD = d;
}

/// The view ray's surfaces front to back: semi-transparent ones composited with local shading,
/// the first opaque one shaded in the pipeline's mode (shadeSurface). A ray that meets a missing
/// brick loses the sample; for a pixel without samples (`samples` 0) it goes on for a preview:
/// missing bricks as blocks of their coarsest level (coarseBlock), local shading, nothing requested.
Sample traceView(uvec2 px, uint pixel, uint samples, bool request, vec3 o, vec3 d, float tEnd) {
    Sample s = Sample(vec3(0.0), 1.0, false, kNone, 0u, 1.0, 0.0, 1.0, true, vec3(0.0), 1.0);
    const bool previews = samples == 0u;
    Walker w;
    bool passMissing = false; // a preview's next march passes the missing brick it stands in
    vec3 glassPoint = vec3(0.0); // where the first semi-transparent surface was entered
    if (!startRay(o, d, tEnd, boxLo, boxHi, w)) return s;
    for (uint layer = 0u; layer < 256u; ++layer) {
        uint label, material;
        const uint r = march(f, w, boxLo, boxHi, request && s.valid, s.valid, passMissing, label, material);
        passMissing = false;
        if (r == MARCH_OUT) break;
        if (r == MARCH_MISSING) {
            s.valid = false;
            if (!previews) break;
#if DETAIL_STREAMING
            if (standsIn(w)) continue; // the preview goes on through the brick at its coarser level
#endif
#if IN_FLIGHT_PREVIEWS
            if (inFlight(w)) continue; // ... at the coarser levels its decoding completed
#endif
            if (!coarseBlock(w, label, material)) {
                // Already behind a semi-transparent block of this label (the brick before,
                // or the voxels the ray came through): on past the brick.
                passMissing = true;
                continue;
            }
        }
        float emission;
        const vec4 c = materialColor(f, material, label, emission);
        const vec3 q = walkerPoint(w);
        const vec4 clip = indexToClip * vec4(q, 1.0);
        const float depth = clamp(clip.z / clip.w * 0.5 + 0.5, 0.0, 1.0);
        if (s.firstDepth == 1.0) s.firstDepth = depth;
        vec3 n = w.face != 0u ? faceNormal(w.face) : -normalize((indexToWorld * vec4(d, 0.0)).xyz);
        const vec3 local = lit(c, emission, directLight(w, n, false, false, false));
        if (c.a < 1.0) { // semi-transparent: local shading, then on through the surface
            if (s.label == kNone && s.valid && c.a > 0.0) { // the hit, should the ray meet no opaque surface
                s.translucent = true;
                s.label = label; // stored: made original after the loop (CPU devices run this masked, every layer)
                s.face = w.face;
                s.depth = depth;
                glassPoint = q;
            }
            s.radiance += s.transmittance * c.a * local;
            s.transmittance *= 1.0 - c.a;
            if (s.transmittance < 0.01) break;
            continue;
        }
        if (!s.valid) { // a preview: local shading only
            s.radiance += s.transmittance * local;
            s.transmittance = 0.0;
            break;
        }
        s.translucent = false;
        s.label = originalLabel(f, label);
        s.face = w.face;
        s.depth = depth;
        s.distance = length((indexToWorld * vec4(q - o, 0.0)).xyz);
        if (SHADING != kShadingLocal) { // should a secondary ray find a brick missing, the preview is this surface lit locally
            s.previewRadiance = s.radiance + s.transmittance * local;
            s.previewTransmittance = 0.0;
        }
        vec3 shaded = local;
#if ABSENT_BRICKS
        const bool hidden = behindOtherRank(w, label, boxLo, boxHi);
#else
        const bool hidden = false;
#endif
        if (!hidden && !shadeSurface(w, n, c, emission, local, request, px, pixel, samples, shaded)) {
            s.valid = false;
            break;
        }
        s.radiance += s.transmittance * mix(local, shaded, fv.pixel.w);
        s.transmittance = 0.0;
        break;
    }
    if (s.translucent) { // no opaque surface: the first semi-transparent one is the hit
        s.label = originalLabel(f, s.label);
        s.distance = length((indexToWorld * vec4(glassPoint - o, 0.0)).xyz);
    }
    return s;
}

/// Stores sample `samples` of pixel `pixel`: accumulates it and writes the G-buffer, or, when it
/// is lost, a pixel without samples' preview (no sample yet: its accumulation word is free; the
/// G-buffer's kGBufferPreview), or nothing. One set of stores for both outcomes (CPU devices run
/// every store, taken or not, as a loop over the lanes). Returns the sample's validity, with the
/// new sum (or the preview) in `total` and the window depth of its first surface in `surfaceDepth`.
bool storeSample(uint pixel, uint samples, Sample s, out vec4 total, out bool preview, out float surfaceDepth) {
    preview = false;
    surfaceDepth = 1.0;
    const bool previews = samples == 0u;
    if (!s.valid) {
        ++count.missing;
        if (s.label == kNone || s.translucent) { // lost on the view ray: the preview is what it gathered
            s.previewRadiance = s.radiance;
            s.previewTransmittance = s.transmittance;
        }
        total = vec4(s.previewRadiance, 1.0 - s.previewTransmittance);
        preview = previews;
    } else {
        total = vec4(s.radiance, 1.0 - s.transmittance);
#if !ONE_SAMPLE
        if (samples > 0u) total += loadVec4(frameAddr[kSlotAccum], pixel); // the first sample need not read the cleared sum
#endif
        ++count.added;
    }
    if (s.valid || previews) {
        uvec4 hit = uvec4(s.label, s.face | (s.translucent ? kGBufferTranslucent : 0u), floatBitsToUint(s.depth), floatBitsToUint(s.distance));
#if !ONE_SAMPLE
        storeVec4(frameAddr[kSlotAccum], pixel, total);
        // The first hit stays the first sample's: its ray is the pixel centre's (later ones are
        // jittered), so the label image does not change with the samples taken, and a pick that
        // unprojects along the centre's ray names the voxel whose label it reports.
        if (samples > 0u) {
            hit = floatBitsToUint(loadVec4(frameAddr[kSlotGBuffer], pixel));
            hit.y &= ((1u << kGBufferEpochShift) - 1u) | kGBufferTranslucent; // the face and the flag
        }
#endif
        // The sample count rides in the second word (kGBufferCountShift): one store for both.
        storeUvec4(frameAddr[kSlotGBuffer], pixel, s.valid ? uvec4(hit.x, hit.y | kGBufferSampled | epochBits() | ((samples + 1u) << kGBufferCountShift), hit.zw)
                                                          : uvec4(kNone, kGBufferPreview | epochBits(), floatBitsToUint(1.0), 0u));
        surfaceDepth = s.firstDepth;
    }
    return s.valid;
}

/// The next sample (index `samples`) of pixel px: accumulates it, writes the G-buffer, and
/// returns true with the new sum in `total` and the window depth of its first surface in
/// `surfaceDepth`; false when a brick it needs is not in the cache: then nothing is written,
/// except for a pixel without samples, whose preview is (its accumulation word, the G-buffer's
/// kGBufferPreview), with `preview` true, the preview in `total` and its depth in
/// `surfaceDepth`. The caller writes the depth (with the colour: one store).
bool takeSample(uvec2 px, uint pixel, uint samples, out vec4 total, out bool preview, out float surfaceDepth) {
    if (samples == count.prevMin) count.minRow = min(count.minRow, pixel);
    const bool request = (fv.frame.y & kFlagLimitRequests) == 0u || (pixel >= fv.limits.y && pixel < fv.limits.z);
    vec3 o, d;
    float tEnd;
    viewRay(px, pixel, samples, o, d, tEnd);
    const Sample s = traceView(px, pixel, samples, request, o, d, tEnd);
    return storeSample(pixel, samples, s, total, preview, surfaceDepth);
}

/// The pixel at `cell` in the grid of rendered pixels of the footprint rectangle (all, or one
/// of stride^2): its next sample unless it has reached the sample target; with
/// kFlagResolveInRender also what the gather would do for it (output colour, counts), with
/// kFlagGatherInRender what the gather would write to the first denoising buffer (and counts).
/// Returns whether the cell stays below the sample target (kFlagListNext lists it for the next frame).
bool renderPixel(uvec2 cell) {
    uvec2 px;
    if (!cellPixel(cell, px)) return false;
    const uint pixel = px.y * fv.image.x + px.x;
    const uint samples = sampleCount(pixel);
#if PREFETCH_OUTPUT
    const uint early = outputWord(pixel);
#endif
    uint n = samples;
    vec4 total = vec4(0.0);
    bool preview = false;
    float depth = 1.0;
    if (wantsSample(samples) && takeSample(px, pixel, samples, total, preview, depth)) n = samples + 1u;
    const bool below = n < fv.frame.w;
    if (!below) count.kept = min(count.kept, n);
    // A sample or a preview changes the pixel's output: its depth, and its colour where this pass
    // resolves (one 64-bit store: CPU devices run each store as a loop over the lanes). ONE_SAMPLE
    // frames always resolve here.
    const bool wrote = n != samples || preview;
    const uint depthWord = floatBitsToUint(depth) ^ kOutputDepthXor;
    const bool gathers = ONE_SAMPLE == 0 && (fv.frame.y & kFlagGatherInRender) != 0u;
    if (ONE_SAMPLE == 0 && (fv.frame.y & kFlagResolveInRender) == 0u) {
        if (wrote) UintBuf(frameAddr[kSlotOutput]).w[2u * pixel + 1u] = depthWord;
        if (!gathers) return below;
        // The gather's value (resolve.comp): the average of the samples, a preview, or nothing
        // (a hole). A pixel that took nothing new keeps the value the last frame left (the host
        // sets the flag only while the buffer holds it).
        if (wrote || n == 0u) storeVec4(frameAddr[kSlotDenoiseA], pixel, wrote ? total / float(max(n, 1u)) : vec4(0.0));
    } else if (wrote) {
        U64Buf(frameAddr[kSlotOutput]).v[pixel] = packUint2x32(uvec2(packUnorm4x8(toneMapped(total / float(max(n, 1u)))), depthWord));
    }
    count.fewest = min(count.fewest, n);
#if PREFETCH_OUTPUT
    count.kept = min(count.kept, kNone - (early & fv.drawn.z)); // drawn.z is 0: no change, but the read stays
#endif
    if (n == 0u) {
        if (preview) ++count.previews;
        else ++count.holes;
    }
    return below;
}

#if PIXEL_LIST
/// The list entry of the invocation's j-th round. CPU devices run eight consecutive invocations
/// as one SIMD group: the group takes eight consecutive entries a round (a tile of the host's
/// list, kListTile) and PIXEL_BLOCK^2 consecutive tiles in its rounds (neighbours, whose rays read
/// the same bricks); the workgroup's 32 groups take consecutive runs of those.
uint listIndex(uint j) {
    const uint lane = gl_LocalInvocationIndex % kListLanes, simd = gl_LocalInvocationIndex / kListLanes;
    return ((gl_WorkGroupID.x * (kGroupTile * kGroupTile / kListLanes) + simd) * PIXEL_BLOCK * PIXEL_BLOCK + j) * kListLanes + lane;
}

/// kFlagListNext: the cells of this invocation that stay below the sample target (count.next),
/// appended to the next frame's list (from word width * height of kSlotPixelList) with one
/// atomic per subgroup, so that frame needs no pixel_list.comp pass over the whole grid. Cells
/// are few there (the pixels that met missing bricks): the loop runs as often as the most any
/// lane has.
void listNext() {
    const uint n = bitCount(count.next.x) + bitCount(count.next.y);
    const uint total = subgroupAdd(n);
    const uint before = subgroupExclusiveAdd(n);
    uint base = 0u;
    if (subgroupElect() && total > 0u) base = atomicAdd(UintBuf(frameAddr[kSlotAlloc]).w[kAllocNextCount], total);
    base = subgroupMax(base) + fv.image.x * fv.image.y + before;
    UintBuf list = UintBuf(frameAddr[kSlotPixelList]);
    for (uint word = 0u; word < 2u; ++word)
        for (uint m = count.next[word]; m != 0u; m &= m - 1u) list.w[base++] = listedCell(listIndex(32u * word + uint(findLSB(m))));
}
#endif

void main() {
    f = Frame(pc.frame);
    loadFrameValues(f);
    clipToIndex = f.clipToIndex;
    indexToClip = f.indexToClip;
    indexToWorld = f.indexToWorld;
    if (SHADING == kShadingAo || SHADING == kShadingPt) worldToIndex = f.worldToIndex; // toIndexDir's modes
    normalX = f.faceNormals[1].xyz;
    normalY = f.faceNormals[3].xyz;
    normalZ = f.faceNormals[5].xyz;
    boxLo = ivec3(fv.clipMin.xyz);
    boxHi = ivec3(fv.clipMax.xyz);
    count = Counts(UintBuf(frameAddr[kSlotAlloc]).w[kAllocPrevMin], kNone, 0u, 0u, kNone, 0u, 0u, kNone, uvec2(0u));
    // PIXEL_BLOCK^2 pixels per invocation: lavapipe spends about 0.1 us on each invocation itself.
#if PIXEL_LIST
    // The cells listed (all by the host, or those below the sample target by pixel_list.comp;
    // the host sized the dispatch to their number): each round, the eight lanes of a SIMD group
    // take consecutive entries (listIndex).
    const uint listed = UintBuf(frameAddr[kSlotAlloc]).w[kAllocListCount];
    for (uint j = 0u; j < PIXEL_BLOCK * PIXEL_BLOCK; ++j) {
        const uint i = listIndex(j);
        // Later rounds take later entries: a lane past the list's end is done, and CPU devices
        // leave the loop once every lane is (a short list costs its rounds, not PIXEL_BLOCK^2).
        if (i >= listed) break;
        const uint cell = listedCell(i);
        if (renderPixel(uvec2(cell & 0xFFFFu, cell >> 16u))) count.next[j >> 5u] |= 1u << (j & 31u);
    }
    if ((fv.frame.y & kFlagListNext) != 0u) listNext();
#else
    for (uint j = 0u; j < PIXEL_BLOCK * PIXEL_BLOCK; ++j)
        renderPixel(gl_GlobalInvocationID.xy * PIXEL_BLOCK + uvec2(j % PIXEL_BLOCK, j / PIXEL_BLOCK));
#endif
    flushCounts();
}
