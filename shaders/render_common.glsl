// SPDX-License-Identifier: MIT
// Shared by the frame pipeline's passes (cache_*.comp, render.comp, resolve.comp): the frame
// parameter block, the brick cache bookkeeping, materials, random numbers and the numerically
// stable multi-level DDA of the paper ("Ray marching").
//
// Specialised per volume through defines (Renderer.cpp): BRICK_SIZE, BRICK_SHIFT, LEVELS,
// VOLUME_DIM (uvec3), BRICK_GRID (uvec3), BRICKS_PER_ARRAY, CACHE_BITS.
//
// Coordinates: rays are marched in index space, where voxel (i, j, k) covers [i, i+1] x [j, j+1]
// x [k, k+1]. A walker's position is an integer voxel plus a sub-voxel offset `vpos` in
// [0, 1)^3, so distances to the next boundary are computed in that stable interval for any
// volume size. The float operations of stableStep() and startRay() are mirrored one for one by
// castRaysStable() in Core/src/RayCast.cpp; `precise` keeps the compiler from fusing them.

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "csgv/gpu/FrameLayout.h"      // kNone, flags, slots, alloc words, Frame and GpuMaterial layouts
#include "csgv/materials/Palette.h"    // labelHash, kLabelPalette
#include "csgv/base/Morton.h"          // mortonSpread (cache entries in Morton order)
#include "csgv/codec/Layout.h"         // kUniformShift (sub-blocks: uniformSubBlockOf, as brickMorton)

const float ONE_MINUS_EPSILON = 0.99999994; // the largest float below 1
// The distance to the planes of an axis the ray runs parallel to (its direction's component is
// 0, so (target - position) / 0 would be -inf or NaN, not +inf): larger than any real distance.
const float NEVER = 3.0e38;

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer Frame {
    CSGV_FRAME_MEMBERS
};

/// The Frame's vector members, loaded whole at the start of every pass. Mesa 22.3's lavapipe
/// miscompiles a component read of a buffer-reference struct member next to a read of its other
/// components (`f.v.xyz` and `f.v.w` merged into one load, `.w` then reads 0), so the shaders read
/// whole members once and take components from these copies.
struct FrameValues {
    vec4 lightWorld, lightIndex, environment, clipMin, clipMax, pixel, tone;
    uvec4 frame, image, limits, counts, rect, drawn;
};
FrameValues fv;
/// The frame's buffer addresses, loaded once per invocation like fv: CPU devices pay for every
/// load once per lane, uniform or not, so a hot loop must not reload them.
uint64_t frameAddr[kSlotCount];
void loadFrameValues(Frame f) {
    for (uint i = 0u; i < kSlotCount; ++i) frameAddr[i] = f.addr[i];
    fv.lightWorld = f.lightWorld;
    fv.lightIndex = f.lightIndex;
    fv.environment = f.environment;
    fv.clipMin = f.clipMin;
    fv.clipMax = f.clipMax;
    fv.pixel = f.pixel;
    fv.tone = f.tone;
    fv.frame = f.frame;
    fv.image = f.image;
    fv.limits = f.limits;
    fv.counts = f.counts;
    fv.rect = f.rect;
    fv.drawn = f.drawn;
}

/// A G-buffer entry's second word as this accumulation sees it: 0 (cleared) when another wrote it
/// (kGBufferEpochShift).
uint currentWord1(uint w1) { return ((w1 >> kGBufferEpochShift) & kGBufferEpochMask) == fv.frame.z ? w1 : 0u; }
/// The G-buffer epoch bits this accumulation writes.
uint epochBits() { return fv.frame.z << kGBufferEpochShift; }

layout(buffer_reference, std430, buffer_reference_align = 4) buffer UintBuf { uint w[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer FloatBuf { float f[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Vec4Buf { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Uvec4Buf { uvec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) buffer Uvec2Buf { uvec2 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) buffer U64Buf { uint64_t v[]; };
/// Per-pixel vectors are written (and read) two words at a time: CPU devices write a vector
/// through a buffer address as a loop over the lanes per component, 64 bits as one component.
void storeUvec4(uint64_t addr, uint i, uvec4 u) {
    U64Buf b = U64Buf(addr);
    b.v[2u * i] = packUint2x32(u.xy);
    b.v[2u * i + 1u] = packUint2x32(u.zw);
}
void storeVec4(uint64_t addr, uint i, vec4 v) { storeUvec4(addr, i, floatBitsToUint(v)); }
vec4 loadVec4(uint64_t addr, uint i) {
    U64Buf b = U64Buf(addr);
    return uintBitsToFloat(uvec4(unpackUint2x32(b.v[2u * i]), unpackUint2x32(b.v[2u * i + 1u])));
}
layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer AddrBuf { uint64_t a[]; };

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MaterialBuf { GpuMaterial m[]; };

// The render pass reads its hottest words (those of every step, and the per-pixel ones) through
// texel buffers where the renderer made them (RENDER_TEXELS, RendererOptions::renderTexels): CPU
// devices fetch a texel for all lanes with one gather instruction, where a read through a buffer
// address loops over the lanes.
#ifndef RENDER_TEXELS
#define RENDER_TEXELS 0
#endif
// A binding's texels are 1, 2 or 4 words (Renderer's kRenderTexelWords): a record is one fetch.
#if RENDER_TEXELS
layout(set = 0, binding = kTexelCache) uniform usamplerBuffer cacheTexels;
layout(set = 0, binding = kTexelBricks) uniform usamplerBuffer brickTexels;
layout(set = 0, binding = kTexelUniform) uniform usamplerBuffer uniformTexels;
layout(set = 0, binding = kTexelHidden) uniform usamplerBuffer hiddenTexels;
layout(set = 0, binding = kTexelEmptyGroups) uniform usamplerBuffer emptyGroupTexels;
layout(set = 0, binding = kTexelMaterialTable) uniform usamplerBuffer tableTexels;
layout(set = 0, binding = kTexelLabelColors) uniform usamplerBuffer colorTexels;
layout(set = 0, binding = kTexelGBuffer) uniform usamplerBuffer gbufferTexels;
layout(set = 0, binding = kTexelPixelList) uniform usamplerBuffer listTexels;
layout(set = 0, binding = kTexelMaterials) uniform usamplerBuffer materialTexels;
layout(set = 0, binding = kTexelLabelMap) uniform usamplerBuffer labelMapTexels;
layout(set = 0, binding = kTexelDepthIn) uniform usamplerBuffer depthInTexels;
layout(set = 0, binding = kTexelBlueNoise) uniform usamplerBuffer blueNoiseTexels;
layout(set = 0, binding = kTexelVisible) uniform usamplerBuffer visibleTexels;
layout(set = 0, binding = kTexelOutput) uniform usamplerBuffer outputTexels;
uint cacheWord(uint i) { return texelFetch(cacheTexels, int(i)).x; }
uint tableWord(uint i) { return texelFetch(tableTexels, int(i)).x; }
vec4 labelColor(uint e) { return uintBitsToFloat(texelFetch(colorTexels, int(e))); }
uint sampleCount(uint pixel) { return currentWord1(texelFetch(gbufferTexels, int(4u * pixel + 1u)).x) >> kGBufferCountShift; }
uint listedCell(uint i) { return texelFetch(listTexels, int(i)).x; }
/// A brick's cache entry (x offset, y level, w flags; z is its last use).
uvec4 brickState(uint b) { return texelFetch(brickTexels, int(b)); }
uvec2 uniformMask(uint b) { return texelFetch(uniformTexels, int(b)).xy; }
uvec2 hiddenMask(uint b) { return texelFetch(hiddenTexels, int(b)).xy; }
uint emptyGroupLevel(uint b) { return texelFetch(emptyGroupTexels, int(b)).x; }
float materialEmission(uint m) { return uintBitsToFloat(texelFetch(materialTexels, int(kMaterialWords * m + kMaterialEmissionWord)).x); }
uint labelMapWord(uint label) { return texelFetch(labelMapTexels, int(label)).x; }
float depthInAt(uint pixel) { return uintBitsToFloat(texelFetch(depthInTexels, int(pixel)).x); }
uint blueNoiseWord(uint i) { return texelFetch(blueNoiseTexels, int(i)).x; }
uvec2 visibleEntry(uint b) { return texelFetch(visibleTexels, int(b)).xy; }
uint outputWord(uint pixel) { return texelFetch(outputTexels, int(pixel)).x; }
#else
uint cacheWord(uint i) { return UintBuf(frameAddr[kSlotCache]).w[i]; }
uint tableWord(uint i) { return UintBuf(frameAddr[kSlotMaterialTable]).w[i]; }
vec4 labelColor(uint e) { return Vec4Buf(frameAddr[kSlotLabelColors]).v[e]; }
uint sampleCount(uint pixel) { return currentWord1(UintBuf(frameAddr[kSlotGBuffer]).w[4u * pixel + 1u]) >> kGBufferCountShift; }
uint listedCell(uint i) { return UintBuf(frameAddr[kSlotPixelList]).w[i]; }
uvec4 brickState(uint b) { return Uvec4Buf(frameAddr[kSlotBricks]).v[b]; }
uvec2 uniformMask(uint b) { return Uvec2Buf(frameAddr[kSlotUniform]).v[b]; }
uvec2 hiddenMask(uint b) { return Uvec2Buf(frameAddr[kSlotHidden]).v[b]; }
uint emptyGroupLevel(uint b) { return UintBuf(frameAddr[kSlotEmptyGroups]).w[b]; }
float materialEmission(uint m) { return MaterialBuf(frameAddr[kSlotMaterials]).m[m].extra.x; }
uint labelMapWord(uint label) { return UintBuf(frameAddr[kSlotLabelMap]).w[label]; }
float depthInAt(uint pixel) { return FloatBuf(frameAddr[kSlotDepthIn]).f[pixel]; }
uint blueNoiseWord(uint i) { return UintBuf(frameAddr[kSlotBlueNoise]).w[i]; }
uvec2 visibleEntry(uint b) { return unpackUint2x32(U64Buf(frameAddr[kSlotVisible]).v[b]); }
#endif


// ---------------------------------------------------------------------------------------------
// Random numbers: PCG (a hash of pixel, sample and dimension), deterministic per pixel and
// valid-sample count, so an image after N samples is reproducible. The first dimensions (jitter,
// the first bounce) come from a blue-noise tile instead (render.comp, blueSample()).

uint pcgHash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
struct Rng { uint state; };
Rng rngFor(uint pixel, uint sampleIndex) { return Rng(pcgHash(pixel * 9781u + pcgHash(sampleIndex + 0x9E3779B9u))); }
float rngNext(inout Rng r) {
    r.state = pcgHash(r.state);
    return float(r.state >> 8u) * (1.0 / 16777216.0);
}

// ---------------------------------------------------------------------------------------------
// Materials

uint originalLabel(Frame f, uint label) {
    if ((fv.frame.y & kFlagLabelMap) != 0u && label < fv.counts.z) return labelMapWord(label);
    return label;
}

float attributeValue(Frame f, uint attr, uint label) {
    if (attr == kNone) return float(originalLabel(f, label));
    if (label >= fv.counts.z) return uintBitsToFloat(0x7FC00000u); // NaN: matches no interval
    return FloatBuf(AddrBuf(frameAddr[kSlotAttributes]).a[attr]).f[label];
}

#ifndef LABEL_LOOKUP
#define LABEL_LOOKUP 0 // kLookupScan
#endif

/// The first material whose filter holds the label, or kNone (invisible): from the host's table
/// (LABEL_LOOKUP, LabelLookup.h), which it fills with the same comparisons as the scan below.
uint materialOf(Frame f, uint label) {
    if (label == kNone) return kNone;
#if LABEL_LOOKUP == 1 // kLookupDense: every stored label is below the table's end
    return label < fv.counts.w ? tableWord(label) : kNone;
#else
    // Precomputed by the host with the same comparisons when the stored labels are few (up to
    // the largest label of the renderer's bricks; an MPI piece's stand-ins for other ranks'
    // bricks may hold larger ones: they take the comparisons below).
    if (label < fv.counts.w) return tableWord(label);
    MaterialBuf mats = MaterialBuf(frameAddr[kSlotMaterials]);
    const uint n = fv.counts.x;
    for (uint i = 0u; i < n; ++i) {
        const uvec4 flt = mats.m[i].select;
        if (flt.x == kNone) {
            const uint l = originalLabel(f, label);
            if (l >= flt.y && l <= flt.z) return i;
        } else {
            const float v = attributeValue(f, flt.x, label);
            const vec2 r = mats.m[i].range.xy;
            if (v >= r.x && v <= r.y) return i;
        }
    }
    return kNone;
#endif
}

vec3 paletteColor(uint h) { return kLabelPalette[h % kLabelPaletteSize]; }

vec3 colormapAt(Frame f, uint offset, uint samples, float t) {
    Vec4Buf cm = Vec4Buf(frameAddr[kSlotColormaps]);
    const float x = clamp(t, 0.0, 1.0) * float(samples - 1u);
    const uint i = min(uint(x), samples - 2u);
    return mix(cm.v[offset + i].rgb, cm.v[offset + i + 1u].rgb, x - float(i));
}

/// Colour (rgb), opacity (a) and emission of a label under material m, computed.
vec4 materialColorOf(Frame f, uint m, uint label, out float emission) {
    const GpuMaterial mat = MaterialBuf(frameAddr[kSlotMaterials]).m[m];
    emission = mat.extra.x;
    vec3 rgb = mat.rgba.rgb;
    if (mat.select.w == kColorColormap) {
        float t = (attributeValue(f, mat.colour.x, label) - mat.range.z) / (mat.range.w - mat.range.z);
        if (isnan(t)) t = 0.0;
        if (mat.colour.y == 1u) t -= floor(t);
        rgb = colormapAt(f, mat.colour.z, mat.colour.w, t);
    } else if (mat.select.w == kColorRandom) {
        const uint h = labelHash(originalLabel(f, label));
        rgb = mat.colour.w == 0u ? paletteColor(h) : colormapAt(f, mat.colour.z, mat.colour.w, float(h) / 4294967295.0);
    }
    return vec4(rgb, mat.rgba.a);
}

/// Colour (rgb), opacity (a) and emission of a label under material m (its material): with a
/// dense label table (LABEL_LOOKUP kLookupDense) read from the colours label_colors.comp computed
/// with materialColorOf when the materials changed, so a ray step does not evaluate colour modes
/// (CPU devices run every branch of them at every call).
vec4 materialColor(Frame f, uint m, uint label, out float emission) {
#if LABEL_LOOKUP == 1
    emission = materialEmission(m);
    return labelColor(label);
#else
    return materialColorOf(f, m, label, emission);
#endif
}

vec3 aces(vec3 x) { return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); }

#ifndef TONE_CURVES
#define TONE_CURVES 1
#endif
/// Tone mapping, brightness, contrast and gamma of a premultiplied colour (the output's last step).
/// TONE_CURVES 0: the frame has neither ACES tone mapping nor a gamma other than 1 (the host's
/// toneCurves): CPU devices would run both, taken or not, for every pixel.
vec4 toneMapped(vec4 c) {
    if (c.a <= 0.0) return c;
    vec3 rgb = c.rgb / c.a;
#if TONE_CURVES
    if (fv.tone.w != 0.0) rgb = aces(rgb);
#endif
    rgb *= fv.tone.x;
    rgb = (rgb - 0.5) * fv.tone.y + 0.5;
    rgb = clamp(rgb, 0.0, 1.0);
#if TONE_CURVES
    if (fv.tone.z != 1.0) rgb = pow(rgb, vec3(1.0 / fv.tone.z));
#endif
    return vec4(rgb * c.a, c.a);
}

/// The pixel of `cell` in the grid of rendered pixels of the frame's footprint rectangle (every
/// pixel, or one of stride^2 at the frame's phase); false when it lies beyond the rectangle.
bool cellPixel(uvec2 cell, out uvec2 px) {
    // The stride is 1, 2, 4 or 8 (Renderer::frame refuses others): shifts, not divisions (CPU
    // devices divide lane by lane).
    const uint stride = fv.image.z, phase = fv.image.w, shift = uint(findLSB(stride));
    px = fv.rect.xy + cell * stride + uvec2(phase & (stride - 1u), phase >> shift);
    return px.x < fv.rect.z && px.y < fv.rect.w;
}

/// Whether a pixel with n samples takes another: below the frame's sample target (0: none), and
/// below the most its G-buffer entry counts (kGBufferCountMax).
bool wantsSample(uint n) { return (fv.frame.w == 0u || n < fv.frame.w) && n < kGBufferCountMax; }

/// Cells of that grid along x and y.
uvec2 cellGrid() { return (fv.rect.zw - fv.rect.xy + fv.image.z - 1u) >> uint(findLSB(fv.image.z)); }

// ---------------------------------------------------------------------------------------------
// Bricks and the cache

/// Sub-blocks (csgv/codec/Layout.h: uniform, hidden) have edge 1 << SUB_SHIFT; none when negative.
const int SUB_SHIFT = int(BRICK_SHIFT) - int(kUniformShift);

uint brickIndexOf(ivec3 voxel) {
    const uvec3 b = uvec3(voxel) >> BRICK_SHIFT;
    return b.x + BRICK_GRID.x * (b.y + BRICK_GRID.y * b.z);
}

// Cache paletting (CACHE_BITS < 32, see csgv_decode.glsl): entries are packed palette indices.
#if CACHE_BITS == 32
const uint CACHE_PER_WORD = 1u;
#else
const uint CACHE_PER_WORD = 32u / uint(CACHE_BITS);
const uint CACHE_MASK = (1u << uint(CACHE_BITS)) - 1u;
#endif

/// Cache words of a brick decoded at `lod`.
uint regionWords(uint lod) {
    const uint edge = BRICK_SIZE >> lod;
    return (edge * edge * edge + CACHE_PER_WORD - 1u) / CACHE_PER_WORD;
}

/// Where a brick's palette ends in its encoding array: entry i is at word end - 1 - i.
struct PaletteRef {
    uint64_t array;
    uint end;
};
PaletteRef paletteOf(Frame f, uint brick) {
    PaletteRef p;
    p.array = AddrBuf(frameAddr[kSlotArrays]).a[brick / BRICKS_PER_ARRAY];
    p.end = UintBuf(frameAddr[kSlotStarts]).w[brick + 1u];
    return p;
}

#ifndef UNIFORM_LEVELS
#define UNIFORM_LEVELS 0
#endif
#if UNIFORM_LEVELS && CACHE_BITS != 32
#error uniform levels ride on 32-bit cache words
#endif

/// The label of a cache word of 32 bits: with UNIFORM_LEVELS (GpuVolume::uniformLevels) the words
/// of bricks at the finest level hold their uniform level above it (csgv/codec/Layout.h); kNone
/// (outside the volume) stays kNone.
uint wordLabel(uint word) {
#if UNIFORM_LEVELS
    return word == kNone ? kNone : word & kUniformLabelMask;
#else
    return word;
#endif
}

#if CACHE_BITS == 32
/// Word of entry e (Morton order) of a cached region starting at cache word `offset`.
uint entryWord(uint offset, uint e) {
    const uint i = offset + e;
    const uint word = cacheWord(i);
    // Never kNone (the cache has fewer words, Renderer.cpp): a second use of the index, so CPU
    // devices compute it once for all lanes, not lane by lane inside a buffer-address read's loop
    // over the lanes (without RENDER_TEXELS: 7 % of a frame).
    return i == kNone ? kNone : word;
}
#endif

/// Label of entry e (Morton order) of a cached region starting at cache word `offset` (the
/// render pass's voxels, cache_hidden.comp's sub-block runs).
uint entryLabel(uint offset, uint e, PaletteRef palette) {
#if CACHE_BITS == 32
    return wordLabel(entryWord(offset, e));
#else
    const uint word = cacheWord(offset + e / CACHE_PER_WORD);
    const uint index = (word >> ((e % CACHE_PER_WORD) * uint(CACHE_BITS))) & CACHE_MASK;
    return index == CACHE_MASK ? kNone : UintBuf(palette.array).w[palette.end - 1u - index];
#endif
}

/// The Morton code of a voxel inside its brick at the finest level: entry e of the brick at
/// level `lod` holds the voxel when e = code >> 3 lod, and its sub-block is code >> 3 SUB_SHIFT
/// (one code a step serves both). Only the spreading stages BRICK_SHIFT bits need (mortonSpread
/// of Morton.h has all four): CPU devices run each of them for every ray step.
uint brickMorton(ivec3 voxel) {
    uvec3 v = uvec3(voxel) & uvec3(BRICK_SIZE - 1u);
    if (BRICK_SHIFT > 8u) v = (v | (v << 16u)) & 0x030000FFu;
    if (BRICK_SHIFT > 4u) v = (v | (v << 8u)) & 0x0300F00Fu;
    if (BRICK_SHIFT > 2u) v = (v | (v << 4u)) & 0x030C30C3u;
    if (BRICK_SHIFT > 1u) v = (v | (v << 2u)) & 0x09249249u;
    return v.x | (v.y << 1u) | (v.z << 2u);
}

/// Level of detail for a brick: one voxel of that level about one pixel (footprint at the brick's
/// centre), shifted by the bias; 0 everywhere with kFlagFinest.
uint lodForBrick(Frame f, uint brick) {
    if ((fv.frame.y & kFlagFinest) != 0u) return 0u;
    const uvec3 b = uvec3(brick % BRICK_GRID.x, (brick / BRICK_GRID.x) % BRICK_GRID.y, brick / (BRICK_GRID.x * BRICK_GRID.y));
    const vec3 centre = (vec3(b) + 0.5) * float(BRICK_SIZE);
    const vec4 clip = f.indexToClip * vec4(centre, 1.0);
    const vec4 back = f.clipToIndex * clip;
    // One pixel in NDC is 2/H; at this point it spans footprintFactor * |w_clip / w_index| voxels.
    const float footprint = fv.clipMax.w * abs(clip.w / back.w);
    const float l = floor(log2(max(footprint, 1e-30)) + fv.clipMin.w);
    return uint(clamp(l, 0.0, float(LEVELS - 1u)));
}

// ---------------------------------------------------------------------------------------------
// The stable multi-level DDA

struct Walker {
    ivec3 voxel;    // current voxel (finest level)
    vec3 vpos;      // position inside it, [0, 1)^3
    float t;        // ray parameter where the walker entered the voxel
    uint face;      // face it entered through: 1 + 2 axis + (moving in -axis ? 1 : 0); 0 at the start
    vec3 d;         // ray direction (index space, per unit of t)
    vec3 invD;      // 1 / d (infinite for 0)
    float tEnd;     // stop after this t
    uint prevLabel; // label of the previous voxel (surface events happen when it changes)
    uint lastBrick; // last brick marked as used
    bool secondary; // a shadow, ambient-occlusion or path-tracing ray (leaveSurface), not a view ray
};

/// Leaves the current voxel of the level with 2^k voxels per edge (k = 0: finest; k = BRICK_SHIFT:
/// the whole brick) through its nearest face.
void stableStep(inout Walker w, uint k) {
    // 2^k and 2^-k built from their exponents: the same values as float(1 << k) and 1 / that,
    // without a conversion and a division at every step.
    const float s = uintBitsToFloat((127u + k) << 23u);
    const float invS = uintBitsToFloat((127u - k) << 23u);
    const ivec3 cv = w.voxel >> k;
    precise vec3 cp = (vec3(w.voxel - (cv << k)) + w.vpos) * invS;
    cp = min(cp, vec3(ONE_MINUS_EPSILON));
    const vec3 target = vec3(greaterThan(w.d, vec3(0.0)));
    precise vec3 dist = (target - cp) * (w.invD * s);
    dist = mix(dist, vec3(NEVER), equal(w.d, vec3(0.0))); // a ray parallel to an axis never crosses its planes
    // The nearest plane's axis (the first of equals), chosen by selects: a vector indexed by a
    // per-lane axis is a round trip through memory on CPU devices, at every step.
    const bool overX = dist.y < dist.x;
    const float nearXY = overX ? dist.y : dist.x;
    const bool isZ = dist.z < nearXY;
    const bvec3 crossed = bvec3(!isZ && !overX, !isZ && overX, isZ);
    const uint axis = isZ ? 2u : (overX ? 1u : 0u);
    const float dt = isZ ? dist.z : nearXY;
    const bvec3 up = greaterThan(w.d, vec3(0.0));
    precise vec3 np = cp + (w.d * invS) * dt;
    np = clamp(np, vec3(0.0), vec3(ONE_MINUS_EPSILON));
    np = mix(np, mix(vec3(ONE_MINUS_EPSILON), vec3(0.0), up), crossed);
    const ivec3 ncv = cv + mix(ivec3(0), mix(ivec3(-1), ivec3(1), up), crossed);
    precise vec3 fine = np * s;
    const vec3 fl = floor(fine);
    w.voxel = (ncv << k) + ivec3(fl);
    w.vpos = fine - fl;
    w.t = w.t + dt;
    w.face = 1u + 2u * axis + ((isZ ? up.z : (overX ? up.y : up.x)) ? 0u : 1u);
}

/// Sets up a walker for the ray o + t d, t in [0, tEnd], clipped to the box [lo, hi) (voxels).
/// False when the ray misses the box.
bool startRay(vec3 o, vec3 d, float tEnd, ivec3 lo, ivec3 hi, out Walker w) {
    w.d = d;
    w.invD = vec3(1.0) / d;
    w.tEnd = tEnd;
    w.prevLabel = kNone;
    w.lastBrick = kNone;
    w.secondary = false;
    w.face = 0u;
    precise float t0 = 0.0;
    precise float t1 = tEnd;
    int entryAxis = -1;
    for (int k = 0; k < 3; ++k) {
        if (d[k] == 0.0) {
            if (o[k] < float(lo[k]) || o[k] > float(hi[k])) return false;
            continue;
        }
        precise float ta = (float(lo[k]) - o[k]) * w.invD[k];
        precise float tb = (float(hi[k]) - o[k]) * w.invD[k];
        const float tlo = min(ta, tb);
        const float thi = max(ta, tb);
        if (tlo > t0) {
            t0 = tlo;
            entryAxis = k;
        }
        t1 = min(t1, thi);
    }
    if (t0 > t1) return false;
    precise vec3 p = o + d * t0;
    w.voxel = clamp(ivec3(floor(p)), lo, hi - 1);
    precise vec3 fr = p - vec3(w.voxel);
    w.vpos = clamp(fr, vec3(0.0), vec3(ONE_MINUS_EPSILON));
    if (entryAxis >= 0) {
        const bool up = d[entryAxis] > 0.0;
        w.voxel[entryAxis] = up ? lo[entryAxis] : hi[entryAxis] - 1;
        w.vpos[entryAxis] = up ? 0.0 : ONE_MINUS_EPSILON;
        w.face = 1u + 2u * uint(entryAxis) + (up ? 0u : 1u);
    }
    w.t = t0;
    w.tEnd = t1;
    return true;
}

#ifndef CARRY_DECODES
#define CARRY_DECODES 0
#endif
#ifndef IN_FLIGHT_PREVIEWS
#define IN_FLIGHT_PREVIEWS 0 // 1: previews read bricks still being decoded (RendererOptions::inFlightPreviews)
#endif
#if IN_FLIGHT_PREVIEWS && CACHE_BITS != 32
#error in-flight previews read 32-bit cache words (a paletted brick's palette is read only once it is cached)
#endif
#if CARRY_DECODES
/// The words after the brick table: each brick's decoding progress while it carries over frames
/// (kInFlightValid).
UintBuf inFlightWords() { return UintBuf(frameAddr[kSlotBricks] + inFlightWordsOffset(BRICK_GRID.x * BRICK_GRID.y * BRICK_GRID.z)); }
#endif
#if IN_FLIGHT_PREVIEWS
/// Brick b's decoding progress (kInFlightValid) where previews may read it (its state `s`: visible,
/// a region and no level, a decoding in flight with a level complete), else 0.
uint inFlightProgress(uint b, uvec4 s) {
    return s.w != 0u && s.y == kNone && s.x != kNone ? inFlightWords().w[b] : 0u;
}
#endif

/// Detail streaming (Renderer.cpp): bricks may stand in at a coarser level (kBrickStandIn).
#ifndef DETAIL_STREAMING
#define DETAIL_STREAMING 0
#endif
#ifndef ABSENT_BRICKS
#define ABSENT_BRICKS 0 // 1: the volume is an MPI rank's piece (kBrickAbsent bricks)
#endif

// Results of march().
const uint MARCH_OUT = 0u;     // left the box or passed tEnd
const uint MARCH_SURFACE = 1u; // entered a voxel of a visible label different from the previous one
const uint MARCH_MISSING = 2u; // reached a visible brick that is not in the cache
// Brick state word w while march passes a missing brick whole (`passMissing`); never stored:
// kSlotBricks holds 0, 1, kBrickStandIn, kBrickAbsent.
const uint BRICK_PASSED = 4u;

/// An MPI rank's piece (kSlotGhost, Renderer::setGhostFaces): the label a walker that just
/// entered the piece (through face w.face) from the volume beyond it, inside the ray's box
/// [lo, hi), left there, from the ghost faces; kNone when it came from inside or started there.
uint ghostLabelLeft(Walker w, ivec3 lo, ivec3 hi) {
    UintBuf g = UintBuf(frameAddr[kSlotGhost]);
    const ivec3 plo = ivec3(g.w[0], g.w[1], g.w[2]);
    const ivec3 phi = ivec3(g.w[3], g.w[4], g.w[5]);
    if (w.face == 0u || any(lessThan(w.voxel, plo)) || any(greaterThanEqual(w.voxel, phi))) return kNone;
    const uint axis = (w.face - 1u) / 2u;
    const bool up = ((w.face - 1u) & 1u) == 0u; // moving towards +axis: entered through the - side
    ivec3 prev = w.voxel;
    prev[axis] += up ? -1 : 1;
    if (prev[axis] >= plo[axis] && prev[axis] < phi[axis]) return kNone;         // came from inside
    if (any(lessThan(prev, lo)) || any(greaterThanEqual(prev, hi))) return kNone; // started there
    const uint off = g.w[6u + 2u * axis + (up ? 0u : 1u)];
    if (off == 0u) return kNone;
    const uint u = axis == 0u ? 1u : 0u;
    const uint v = axis == 2u ? 1u : 2u;
    return g.w[off + uint(prev[u] - plo[u]) + uint(phi[u] - plo[u]) * uint(prev[v] - plo[v])];
}

/// A walker that just entered an MPI rank's piece from the volume beyond it takes the label it
/// left (ghostLabelLeft), as one process walking the whole volume would have it, when that label
/// is drawn semi-transparent: a translucent label continuing across the boundary is no new layer.
/// Other labels keep kNone: an opaque label continuing there was hit in front by the rank before
/// (the nearest hit wins: behindOtherRank), and near a brick edge the voxel left may not be the
/// one the whole volume's walk came from (the ray's voxel path across bricks is not canonical),
/// where taking it could hide a surface.
void ghostEntry(Frame f, inout Walker w, ivec3 lo, ivec3 hi) {
    const uint label = ghostLabelLeft(w, lo, hi);
    const uint m = label == kNone ? kNone : materialOf(f, label);
    float e;
    if (m != kNone && materialColor(f, m, label, e).a < 1.0) w.prevLabel = label;
}

/// A view ray's opaque surface of `label` (its walker `w` has just entered it) where the ray
/// entered the piece from a voxel of that label: the rank whose piece it left was inside the
/// label there, so it met the label's surface (or one before it) first, and the compositing
/// keeps that one. The surface is lit locally: its secondary rays, at the entry face of every
/// label continuing across the piece's boundary (a far piece's whole face), would be spent on a
/// sample no one sees (path tracing at 2 ranks cost the far rank 3-4 times a whole volume's frame).
bool behindOtherRank(Walker w, uint label, ivec3 lo, ivec3 hi) {
    return frameAddr[kSlotGhost] != 0ul && label != kNone && ghostLabelLeft(w, lo, hi) == label;
}

/// The walker enters a voxel of label `l`: a surface event when the label changes to one a
/// material draws (then `label` and `material` say which).
bool entersSurface(Frame f, inout Walker w, uint l, inout uint label, inout uint material) {
    if (l == w.prevLabel) return false;
    w.prevLabel = l;
    const uint m = materialOf(f, l);
    if (m == kNone) return false;
    label = l;
    material = m;
    return true;
}

/// The walker enters a voxel of label `l`: a candidate for a surface event when the label
/// changes to one within the interval that holds every drawn label (Frame drawn; `label` then
/// says which). march looks a candidate's material up once the steps' loop has let it go: a step
/// reads no material table (CPU devices run every line of that loop at every step, taken or not).
bool entersCandidate(inout Walker w, uint l, inout uint label) {
    if (l == w.prevLabel) return false;
    w.prevLabel = l;
    if (l < fv.drawn.x || l > fv.drawn.y) return false;
    label = l;
    return true;
}

/// Walks until a surface event, the end, or a missing brick. `request`: mark the bricks the ray
/// needs as used (so the next frame's request pass keeps or decodes them). `exact`: a brick that
/// stands in at a coarser level than the view wants (kBrickStandIn) counts as missing; previews
/// and deep bounces sample it. `passMissing`: the walker stands in a missing brick whose preview
/// label it is in already (a preview behind a semi-transparent block of it): the brick is passed
/// whole, the label going on. On MARCH_SURFACE, `label` and `material` describe the voxel entered.
uint march(Frame f, inout Walker w, ivec3 lo, ivec3 hi, bool request, bool exact, bool passMissing, out uint label,
           out uint material) {
    Uvec4Buf bricks = Uvec4Buf(frameAddr[kSlotBricks]);
    label = kNone;
    material = kNone;
    // A round per brick (and one more after a candidate no material draws, walking on from it in
    // the same brick): its state is read once, then an inner loop steps through it. CPU devices
    // run every line of a loop body at every step, masked or not, and a read there is a loop over
    // the lanes: the brick's reads (its cache entry, sub-block masks, palette) and its use mark
    // belong here, not in the steps.
    bool resumed = false; // this round walks on from a candidate no material draws (same brick)
    for (uint it = 0u; it < 60000u;) {
        if (w.t > w.tEnd) return MARCH_OUT;
        const uint b = brickIndexOf(w.voxel);
#if ABSENT_BRICKS
        if (!resumed && w.face != 0u && frameAddr[kSlotGhost] != 0ul) ghostEntry(f, w, lo, hi);
#endif
        resumed = false;
        uvec4 s = brickState(b);
        if (request && s.w != 0u && b != w.lastBrick) {
            // Stored only when no ray marked it yet this frame (its mark is in the state read): a
            // brick's rays all wrote the same word, from both threads of a CPU device.
            if (s.z != fv.frame.x + 1u) bricks.v[b].z = fv.frame.x + 1u;
            w.lastBrick = b;
        }
#if DETAIL_STREAMING
        if (exact && s.w == kBrickStandIn) s.y = kNone; // not at the view's level yet: missing
#endif
        if (passMissing && s.w != 0u && s.y == kNone) s.w = BRICK_PASSED;
        passMissing = false;
        // Uniform sub-blocks are marked at the finest level, hidden ones at every level whose
        // nodes are no larger than a sub-block.
        const bool subBlocks = s.w != 0u && s.y != kNone && int(s.y) <= SUB_SHIFT;
#if !UNIFORM_LEVELS
        const uvec2 uniformSubs = subBlocks && s.y == 0u ? uniformMask(b) : uvec2(0u);
#endif
        const uvec2 hiddenSubs = subBlocks ? hiddenMask(b) : uvec2(0u);
#if IN_FLIGHT_PREVIEWS
        // A preview reads a brick still being decoded (a region, no level) at the finest level its
        // decoding completed: the region is laid out for level s.y, a node's label in the last
        // word of its Morton range (inFlightMask), the steps go by nodes of edge 2^inFlightStep.
        // No sub-blocks are known for it (subBlocks above is false).
        uint inFlightMask = 0u, inFlightStep = 0u;
        if (!exact && s.w != BRICK_PASSED) {
            const uint p = inFlightProgress(b, s);
            if (p != 0u) {
                s.y = p & 0xFFu;
                inFlightStep = (p >> 8u) & 0xFFu;
                inFlightMask = (1u << (3u * (inFlightStep - s.y))) - 1u;
            }
        }
#else
        const uint inFlightMask = 0u, inFlightStep = 0u;
#endif
        // A brick no material draws is passed whole, with its aligned group of 2^g bricks a side
        // when none of them is drawn either (kSlotEmptyGroups).
        const uint emptyLevel = s.w == 0u ? emptyGroupLevel(b) : 0u;
#if ABSENT_BRICKS
        // A secondary ray meets another rank's brick at its level of detail, or the finest level
        // kSlotCoarse holds when that is coarser (absentLevel): that level's labels start at word
        // absentLabels, absentDim.x nodes a row, absentDim.y a slice (0: a view ray passes it);
        // absentMask keeps a word's label where the words carry uniform levels above it.
        uint absentLevel = 0u, absentLabels = 0u, absentMask = kNone;
        uvec2 absentDim = uvec2(0u);
        if (s.w == kBrickAbsent && w.secondary && frameAddr[kSlotCoarse] != 0ul) {
            UintBuf c = UintBuf(frameAddr[kSlotCoarse]);
            absentLevel = max(lodForBrick(f, b), c.w[0]);
            const uint e = kCoarseHeaderWords + kCoarseLevelWords * (absentLevel - c.w[0]);
            absentLabels = c.w[e];
            absentDim = uvec2(c.w[e + 1u], c.w[e + 1u] * c.w[e + 2u]);
            if (c.w[2] != 0u) absentMask = kUniformLabelMask;
        }
#endif
        bool candidate = false;
        PaletteRef palette;
        palette.array = 0ul;
        palette.end = 0u;
#if CACHE_BITS != 32
        if (s.w != 0u && s.y != kNone) palette = paletteOf(f, b);
#endif
        for (; it < 60000u; ++it) {
            // One step at the level k of the node the walker stands in: the body holds one
            // stableStep (at k = 0 its scalings are by 1: exact).
            uint k = BRICK_SHIFT; // an empty brick (and another rank's, for a view ray) is passed whole
            if (s.w == 0u) {
                w.prevLabel = kNone;
                k += emptyLevel;
            } else if (s.w == BRICK_PASSED) { // passed whole, its label going on
#if ABSENT_BRICKS
            } else if (s.w == kBrickAbsent) { // another rank's brick (an MPI piece)
                if (absentDim.x == 0u) { // view rays pass: its owner draws it
                    w.prevLabel = kNone;
                } else { // secondary rays meet it at its level of detail (kSlotCoarse holds the coarse ones)
                    // A candidate as in the rank's own bricks: its material is looked up once the
                    // steps' loop has let it go.
                    const uvec3 n = uvec3(w.voxel) >> absentLevel;
                    const uint word = UintBuf(frameAddr[kSlotCoarse]).w[absentLabels + n.x + absentDim.x * n.y + absentDim.y * n.z];
                    if (entersCandidate(w, word == kNone ? kNone : word & absentMask, label)) {
                        candidate = true;
                        break;
                    }
                    // On past the largest uniform cube of nodes around it (no surface inside).
                    k = absentLevel + (word == kNone || absentMask == kNone ? 0u : word >> kUniformLevelShift);
                }
#endif
            } else {
                if (s.y == kNone) return MARCH_MISSING;
                // Coarser levels step by their nodes, the finest by voxels, or over a sub-block
                // whole: one without drawn labels (kSlotHidden, at levels whose nodes are no
                // larger: its label need not be read; with its 2x2x2 group, the Morton-consecutive
                // byte of the mask, when all are), or at the finest level a uniform one after its
                // label (kSlotUniform; with UNIFORM_LEVELS the largest uniform cube around the voxel, its
                // level in the word). No surface lies inside either; the CPU mirror (finest
                // level) steps alike.
                k = max(s.y, inFlightStep);
                bool hidden = false;
                uint j = 0u;
                const uint code = brickMorton(w.voxel);
                if (int(k) <= SUB_SHIFT) {
                    j = code >> (3u * uint(SUB_SHIFT));
                    const uint h = j < 32u ? hiddenSubs.x : hiddenSubs.y;
                    hidden = ((h >> (j & 31u)) & 1u) != 0u;
                    if (hidden) k = ((h >> (j & 24u)) & 0xFFu) == 0xFFu ? uint(SUB_SHIFT) + 1u : uint(SUB_SHIFT);
                }
                if (hidden) {
                    w.prevLabel = kNone; // whatever it holds is not drawn: the next drawn label is a surface
                } else {
                    const uint entry = (code >> (3u * s.y)) | inFlightMask;
#if IN_FLIGHT_PREVIEWS
                    // A node of a brick in flight whose children the decoder has visited holds its
                    // last child's label in its last word: kNone where that child lies outside the
                    // volume (a brick at the volume's upper faces). It then shows the brick's
                    // preview label: its first child's word may be written by a decode running
                    // beside this pass (RendererOptions::overlapDecodes) and read stale, a label
                    // of the region's previous brick.
                    const uint inFlightNone = visibleEntry(b).x;
#endif
#if UNIFORM_LEVELS
                    uint word = entryWord(s.x, entry); // the label, its uniform level above it
#if IN_FLIGHT_PREVIEWS
                    if (inFlightMask != 0u && word == kNone) word = inFlightNone; // level 0
#endif
                    const uint voxelLabel = wordLabel(word);
#else
                    uint voxelLabel = entryLabel(s.x, entry, palette);
#if IN_FLIGHT_PREVIEWS
                    if (inFlightMask != 0u && voxelLabel == kNone) voxelLabel = inFlightNone;
#endif
#endif
                    if (entersCandidate(w, voxelLabel, label)) {
                        candidate = true;
                        break;
                    }
#if UNIFORM_LEVELS
                    // At the finest level, on past the largest uniform cube around the voxel (a bad
                    // brick's kNone words pass the brick).
                    if (k == 0u) k = min(word >> kUniformLevelShift, BRICK_SHIFT);
#else
                    if (k == 0u && SUB_SHIFT >= 0 && (((j < 32u ? uniformSubs.x : uniformSubs.y) >> (j & 31u)) & 1u) != 0u)
                        k = uint(SUB_SHIFT);
#endif
                }
            }
            stableStep(w, k);
            if (any(lessThan(w.voxel, lo)) || any(greaterThanEqual(w.voxel, hi))) return MARCH_OUT;
            if (w.t > w.tEnd) return MARCH_OUT;
            if (brickIndexOf(w.voxel) != b) { // the next brick's round
                ++it;
                break;
            }
        }
        if (candidate) { // a surface if a material draws the label; else the next round walks on from it
            material = materialOf(f, label);
            if (material != kNone) return MARCH_SURFACE;
            label = kNone;
            resumed = true;
        }
    }
    return MARCH_OUT;
}

/// The index-space point where the walker entered its voxel.
vec3 walkerPoint(Walker w) { return vec3(w.voxel) + w.vpos; }

vec3 faceNormalIndex(uint face) {
    vec3 n = vec3(0.0);
    if (face != 0u) n[(face - 1u) / 2u] = ((face - 1u) % 2u == 0u) ? -1.0 : 1.0;
    return n;
}
