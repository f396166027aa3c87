// SPDX-License-Identifier: MIT
#pragma once
/// @file RendererImpl.h
/// @brief Renderer::Impl, the renderer's state, and the helpers and constants its rooms share:
/// Renderer.cpp (creation, frames, read-back) and RendererMaterials.cpp (material tables and
/// visibility) include it; nothing outside the backend's sources does.
#include "csgv/gpu/Renderer.h"
#include "BlueNoise.h"
#include "csgv/gpu/LabelLookup.h"
#include "csgv/gpu/DetailStream.h"

#include <functional>
#include <mutex>
#include "csgv/gpu/FrameLayout.h"

#include "csgv/base/Math.h"
#include "csgv/base/WorkerPool.h"
#include "csgv/codec/BrickGroups.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Layout.h"

#include <omp.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <future>
#include <limits>
#include <system_error>
#include <thread>
#include <tuple>


namespace csgv::gpu {

/// The renderer's internals (one named namespace: every room of the renderer sees the same types).
namespace renderer_detail {

/// A pipeline to make: the shader, its defines, its push-constant bytes, where its handle goes.
struct PipelineJob {
    const char* name;
    Defines defines;
    uint32_t pushBytes;
    uint64_t* out;
    uint32_t texelBindings = 0;
};

/// Compiles a shader with defines into a pipeline; with `profile`, says how long it took
/// (RendererPipelines.cpp, as the two below).
Result<uint64_t> makePipeline(Context& ctx, const char* name, const Defines& defines, uint32_t pushBytes,
                              uint32_t texelBindings, bool profile);
/// Makes the pipelines in parallel; the first error is returned.
Status makePipelines(Context& ctx, const std::vector<PipelineJob>& jobs, bool profile);
/// Lowers the calling thread's scheduling priority (background compilation).
void lowerThisThreadsPriority();

/// Texel sets over lists of buffers (one set a list, the bindings in list order), made again when
/// a buffer they view was made again (Buffer::serial: a new buffer may take a freed one's
/// address); none where not wanted or where a buffer is too large for one view (the passes then
/// read through buffer addresses).
struct TexelViews {
    std::vector<TexelSet> sets;
    std::vector<uint64_t> serials; // of the buffers viewed, list after list
    bool made = false;             // the last refresh made sets: what the pipelines were made for

    bool valid() const { return !sets.empty(); }
    /// Drops the views (before their buffers go); the next refresh makes them again.
    void clear() {
        sets.clear();
        serials.clear();
    }
    /// True when the sets came or went since the last refresh: pipelines made for the other case
    /// must be made again (views made again over new buffers change nothing for them).
    /// `wordsPerTexel`: Context::createTexelSet's, binding by binding (the same in every list).
    /// Whether a view of the whole buffer stays within the device's texel limit.
    static bool fits(const Context& ctx, const Buffer& b, uint32_t wordsPerTexel = 1) {
        return b.size() / (4u * wordsPerTexel) <= ctx.device().maxTexelBufferElements;
    }
    template <size_t N>
    Result<bool> refresh(Context& ctx, bool wanted, std::initializer_list<std::array<const Buffer*, N>> lists,
                         uint32_t wordsPerTexel = 1) {
        std::array<uint32_t, N> words;
        words.fill(wordsPerTexel);
        return refresh(ctx, wanted, lists, words);
    }
    template <size_t N>
    Result<bool> refresh(Context& ctx, bool wanted, std::initializer_list<std::array<const Buffer*, N>> lists,
                         const std::array<uint32_t, N>& wordsPerTexel) {
        bool fit = wanted, same = valid() && serials.size() == N * lists.size();
        size_t i = 0;
        for (const auto& list : lists)
            for (size_t k = 0; k < N; ++k) {
                const Buffer* b = list[k];
                fit = fit && b->valid() && fits(ctx, *b, wordsPerTexel[k]);
                same = same && serials[i++] == b->serial();
            }
        if (fit && same) return false;
        clear();
        if (fit) {
            for (const auto& list : lists) {
                Result<TexelSet> t = ctx.createTexelSet(std::vector<const Buffer*>(list.begin(), list.end()),
                                                        std::vector<uint32_t>(wordsPerTexel.begin(), wordsPerTexel.end()));
                if (!t) {
                    clear();
                    return t.status();
                }
                sets.push_back(std::move(*t));
                for (const Buffer* b : list) serials.push_back(b->serial());
            }
        }
        const bool changed = made != valid();
        made = valid();
        return changed;
    }
};

constexpr uint32_t kColormapSamples = 1024;

/// The host's pixel list (listPixels) orders its cells in tiles of this many cells across and
/// down (a SIMD group's lanes on CPU devices).
constexpr uint32_t kListTile[2] = {2, 4};
static_assert(kListTile[0] * kListTile[1] == kListLanes, "a tile is one SIMD group's entries");

/// Seconds a rendered pixel costs per ray before a renderer has measured its own frames (which
/// then replace this): CPU devices (lavapipe, two cores: 0.11 us for local shading on synthetic
/// 256^3 and the AAL atlas at 640x360), GPUs (an H200: 0.5 ns at 1920x1080).
constexpr double kPriorSecondsPerRay[2] = {1.5e-7, 2e-9};

inline void toFloat(const Mat4& m, float* out) {
    for (int i = 0; i < 16; ++i) out[i] = float(m[i]);
}

inline uint32_t log2u(uint32_t v) {
    uint32_t r = 0;
    while ((1u << (r + 1)) <= v) ++r;
    return r;
}

inline std::string uvec3Of(const std::array<uint32_t, 3>& v) {
    return "uvec3(" + std::to_string(v[0]) + "u," + std::to_string(v[1]) + "u," + std::to_string(v[2]) + "u)";
}

struct PackedMaterials;
struct MaterialMatcher;

/// The gamma a frame applies (FrameParams tone.z): the settings', 1 for none.
inline float frameGamma(const RenderSettings& st) { return st.gamma > 0 ? st.gamma : 1.0f; }

/// TONE_CURVES of render_common.glsl's toneMapped: 1 when the frame has ACES tone mapping or a
/// gamma other than 1, else 0 (passes compiled without either).
inline uint32_t toneCurves(const RenderSettings& st) { return st.toneMapping || frameGamma(st) != 1.0f ? 1 : 0; }

/// The pixels [x0, x1) x [y0, y1) where the index-space box [lo, hi] can appear: its corners
/// projected, widened by 2 pixels (jittered samples reach 1.5 pixels from their centres), the
/// origin a multiple of 8 so every pixel stride keeps the same pattern. The whole image when a
/// corner is behind the eye.
inline std::array<uint32_t, 4> footprintRect(const Mat4& indexToClip, const float lo[4], const float hi[4], uint32_t w,
                                      uint32_t h) {
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (int c = 0; c < 8; ++c) {
        const Vec4 q = transform(indexToClip, {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2], 1.0});
        if (!(q[3] > 1e-12)) return {0, 0, w, h};
        x0 = std::min(x0, q[0] / q[3]);
        x1 = std::max(x1, q[0] / q[3]);
        y0 = std::min(y0, q[1] / q[3]);
        y1 = std::max(y1, q[1] / q[3]);
    }
    auto pixel = [](double ndc, uint32_t n, double margin) {
        return uint32_t(std::clamp(std::floor((ndc + 1.0) * 0.5 * n + margin), 0.0, double(n)));
    };
    std::array<uint32_t, 4> r{pixel(x0, w, -2.0) & ~7u, pixel(y0, h, -2.0) & ~7u, pixel(x1, w, 3.0), pixel(y1, h, 3.0)};
    r[2] = std::max(r[2], r[0]);
    r[3] = std::max(r[3], r[1]);
    return r;
}

/// footprintRect's rows narrowed to the box's outline: for each row y of `rect`, the columns
/// [x0, x1) (two words a row; x0 == x1 for none) within 2 pixels of where the convex hull of the
/// box's projected corners crosses the row's pixels, widened by 2 pixels as the rectangle is and
/// within it. A pixel outside its row's span sees no part of the box. Empty when a corner is
/// behind the eye (the rectangle is the whole image then).
inline std::vector<uint32_t> footprintSpans(const Mat4& indexToClip, const float lo[4], const float hi[4], uint32_t w,
                                     uint32_t h, const std::array<uint32_t, 4>& rect) {
    using P = std::array<double, 2>;
    std::array<P, 8> corners;
    for (int c = 0; c < 8; ++c) {
        const Vec4 q = transform(indexToClip, {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2], 1.0});
        if (!(q[3] > 1e-12)) return {};
        corners[size_t(c)] = {(q[0] / q[3] + 1.0) * 0.5 * w, (q[1] / q[3] + 1.0) * 0.5 * h};
    }
    // The convex hull (monotone chain), counter-clockwise.
    std::sort(corners.begin(), corners.end());
    auto cross = [](const P& o, const P& a, const P& b) {
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    };
    std::vector<P> hull;
    for (int pass = 0; pass < 2; ++pass) {
        const size_t start = hull.size();
        for (int i = 0; i < 8; ++i) {
            const P& q = corners[size_t(pass == 0 ? i : 7 - i)];
            while (hull.size() >= start + 2 && cross(hull[hull.size() - 2], hull.back(), q) <= 0) hull.pop_back();
            hull.push_back(q);
        }
        hull.pop_back(); // the next chain starts with it
    }
    constexpr double kMargin = 2.0;
    std::vector<uint32_t> spans(2 * size_t(rect[3] - rect[1]), rect[0]);
    for (uint32_t y = rect[1]; y < rect[3]; ++y) {
        // The hull's extent along x within the row's pixels [y, y + 1], widened by the margin.
        const double ylo = y - kMargin, yhi = y + 1.0 + kMargin;
        double x0 = 1e300, x1 = -1e300;
        for (size_t i = 0; i < hull.size(); ++i) {
            const P& a = hull[i];
            const P& b = hull[(i + 1) % hull.size()];
            if (std::max(a[1], b[1]) < ylo || std::min(a[1], b[1]) > yhi) continue;
            double t0 = 0.0, t1 = 1.0;
            if (b[1] != a[1]) {
                const double ta = (ylo - a[1]) / (b[1] - a[1]), tb = (yhi - a[1]) / (b[1] - a[1]);
                t0 = std::max(0.0, std::min(ta, tb));
                t1 = std::min(1.0, std::max(ta, tb));
            }
            for (const double t : {t0, t1}) {
                const double x = a[0] + t * (b[0] - a[0]);
                x0 = std::min(x0, x);
                x1 = std::max(x1, x);
            }
        }
        if (x0 > x1) continue; // the row sees nothing of the box
        const size_t r = 2 * size_t(y - rect[1]);
        spans[r] = uint32_t(std::clamp(std::floor(x0 - kMargin), double(rect[0]), double(rect[2])));
        spans[r + 1] = uint32_t(std::clamp(std::floor(x1 + kMargin) + 1.0, double(spans[r]), double(rect[2])));
    }
    return spans;
}

/// An outline's `spans` (footprintSpans, rows of `rect`) widened by `widen` pixels each way, the
/// rows within as many taking part (the pixels within `widen` of the outline, as a square
/// reaches), within the rectangle.
inline std::vector<uint32_t> widenSpans(const std::vector<uint32_t>& spans, const std::array<uint32_t, 4>& rect, uint32_t widen) {
    const int64_t rows = int64_t(spans.size() / 2), w = widen;
    std::vector<uint32_t> out(spans.size(), rect[0]);
    for (int64_t r = 0; r < rows; ++r) {
        int64_t x0 = std::numeric_limits<int64_t>::max(), x1 = std::numeric_limits<int64_t>::min();
        for (int64_t q = std::max<int64_t>(0, r - w); q <= std::min(rows - 1, r + w); ++q)
            if (spans[size_t(2 * q)] < spans[size_t(2 * q + 1)]) {
                x0 = std::min<int64_t>(x0, int64_t(spans[size_t(2 * q)]) - w);
                x1 = std::max<int64_t>(x1, int64_t(spans[size_t(2 * q + 1)]) + w);
            }
        if (x0 > x1) continue; // none
        out[size_t(2 * r)] = uint32_t(std::clamp<int64_t>(x0, rect[0], rect[2]));
        out[size_t(2 * r + 1)] = uint32_t(std::clamp<int64_t>(x1, rect[0], rect[2]));
    }
    return out;
}

/// Denoised frames with an outline: the pixels each resolve pass takes (ResolvePush::spans), those
/// within this reach of the outline. Beyond the outline every pixel is a miss, and an A-trous
/// pass's result there differs from a miss's colour 0 only within the reach of the passes so far
/// (steps 1, 2, 4: 1, 3, 7 pixels): the step-4 pass writes the output within 7, reading the
/// step-2 pass's results within 7 + 4, which reads the step-1 pass's within 11 + 2, which reads
/// the gather's and the G-buffer within 13 + 1: so far the render pass samples the misses too.
constexpr uint32_t kResolveReach[kResolveAtrous4 + 1] = {14, 13, 11, 7};
static_assert(kOutlineRowWords == 2 * (kResolveAtrous4 + 1), "a span of two words a resolve pass");

/// The pixels [r0, r2) x [r1, r3) of kSlotOutput's words (colour, then depth bits ^
/// kOutputDepthXor, per pixel) of an image `width` wide, into 8-bit colours and depths of the same
/// layout (either may be null: not wanted).
inline void readColorDepth(const uint32_t* words, uint32_t width, const std::array<uint32_t, 4>& r, uint32_t* rgba8,
                    float* depth) {
    for (uint32_t y = r[1]; y < r[3]; ++y)
        for (size_t i = size_t(y) * width + r[0], end = size_t(y) * width + r[2]; i < end; ++i) {
            if (rgba8) rgba8[i] = words[2 * i];
            if (depth) {
                const uint32_t bits = words[2 * i + 1] ^ kOutputDepthXor;
                std::memcpy(&depth[i], &bits, 4);
            }
        }
}

/// Where a resolve pass writes (resolve.comp's RESOLVE_OUTPUT): the gather into the output
/// without denoising, else into the first denoising buffer; the A-trous passes from one buffer
/// into the other, the last into the output (addDenoisePasses).
constexpr uint32_t resolveTarget(uint32_t pass) {
    return pass == kResolveGather ? kResolveToEither : pass == kResolveAtrous4 ? kResolveToOutput : kResolveToBuffer;
}

/// Pixels a frame renders at a pixel stride (one of stride^2 per block).
inline double renderedPixels(const FrameInput& in, uint32_t stride) {
    return double((in.width + stride - 1) / stride) * double((in.height + stride - 1) / stride);
}

/// Cache pressure (applyCachePolicy): the first eviction age (frames unused), frames without a
/// full cache before eviction stops, and the fewest frames between defragmentation resets.
constexpr uint32_t kEvictAgeStart = 8, kQuietFrames = 8, kDefragInterval = 64;
/// A full cache counts as fragmented when its free stacks hold this share of it or more (regions
/// of other levels than those requested).
constexpr uint32_t kFragmentedShare = 4; // 1/4

/// Room the cache leaves for the per-pixel buffers when a renderer is made under a tight
/// budget: a 1280x720 image at 92 bytes a pixel (allocateImage's buffers take 84 with a pixel
/// list: some to spare), or a quarter of what is left.
constexpr uint64_t kImageReserveBytes = 92ull * 1280 * 720;

/// @brief The accumulation: what the frames since the last clear gathered for one camera, size,
/// opaque depth and settings. Its invariants:
/// - clearPending: the next frame clears first (no samples, an empty G-buffer, a transparent
///   output); resetAccumulation() sets it, and every other field returns to its start with it.
/// - converged implies !clearPending: the output holds the sample target at every pixel and
///   nothing changed since, so render() returns it without a frame.
/// - coarseStride == 0 until render()'s first frame of the accumulation chooses it; shownWhole
///   once every pixel showed a sample (its own or its coarse block's): frames then go on at the
///   settings' stride, and the coarse block stays the upsampling block (FrameParams pixel.z).
/// - sumsStale: frames since the clear ran ONE_SAMPLE and kept no sums, so a frame that would read
///   them (another sample target, a gather) clears first (frame()).
/// - nextList.valid: the last frame's render pass listed the cells left below the sample target
///   (kFlagListNext) at word width * height of pixelList, with the fewest samples of the others;
///   the next frame takes them as its list when its grid and target are the same (listPixels).
struct Accumulation {
    bool clearPending = true;
    uint32_t accumulatedFrames = 0; ///< frames since the clear
    uint32_t prevMinSamples = 0;    ///< the fewest samples of a pixel after the last frame
    bool sumsStale = false;
    struct NextList {
        bool valid = false;
        std::array<uint32_t, 4> grid{}; ///< cells across, down, stride, sample target
        uint32_t count = 0, kept = kNone;
    } nextList;
    bool hadDepth = false; ///< the last frame had an opaque depth input (now in depthIn)
    bool converged = false;
    uint32_t coarseStride = 0;
    bool shownWhole = false;
    Mat4 lastWorldToClip{}; ///< the camera the accumulation is for
};

/// @brief Denoising in the still loop. deferDenoise holds only inside render()'s loop (frames
/// gather without denoising, render() denoises once after them); denoisePending: the last frame
/// gathered and nothing denoised since; gatheredValid: denoiseA holds the gathered image of all
/// the accumulation's samples, so a frame may gather in its render pass (gatherInRender, this
/// frame's kFlagGatherInRender, set by packParams). A failed frame clears all four.
struct Denoising {
    bool deferDenoise = false;
    bool denoisePending = false;
    bool gatheredValid = false;
    bool gatherInRender = false;
};

/// @brief What new materials ask of the next frame's cache passes. labelColorsPending: it
/// computes labelColors first (label_colors.comp); hiddenAllPending: kSlotHidden is filled with 0,
/// then (hiddenLabels) made for every cached brick; hiddenLabels: the volume holds several labels
/// no material draws, so cache_hidden.comp marks their sub-blocks. The fingerprints (0: none
/// known) tell whether new materials change what is drawn at all.
struct MaterialState {
    bool labelColorsPending = false;
    bool hiddenAllPending = false;
    bool hiddenLabels = false;
    uint64_t drawnFingerprint = 0;     ///< which entries of the label table the materials draw
    uint64_t materialsFingerprint = 0; ///< of what setMaterials uploaded
};

/// @brief The brick cache between frames; it outlives resets of the accumulation (a camera move
/// keeps the cache and what was learnt about its pressure). cacheEmpty: no brick decoded since
/// the cache was made or reset (HIDDEN_ALL has nothing to do); newCache: no frame since the cache
/// was made or resized (a prefetch may fill it whole: prefetches()); cacheResetPending: the next frame
/// empties it first (defragmentation); prefetchPending: the next frame asks for every visible
/// brick (kFlagPrefetch) when they fit (prefetches()), set by a new cache or new visibility;
/// visibilityChanged: uploadVisibility ran since the last frame (kFlagVisibilityChanged). Under
/// pressure (applyCachePolicy): bricks unused for evictAge frames are evicted (0: none), and with
/// limitRequests only the pixel rows [bandRow, bandRow + bandHeight) request bricks.
struct CacheState {
    bool cacheEmpty = true;
    bool newCache = true;
    bool cacheResetPending = false;
    bool prefetchPending = true;
    bool visibilityChanged = true;
    uint32_t evictAge = 0;
    uint32_t quietFrames = 0;                     ///< frames since the cache last ran full
    uint32_t framesSinceDefrag = kDefragInterval; ///< frames since the last defragmentation reset
    bool limitRequests = false;
    uint32_t bandRow = 0, bandHeight = 0;
};

/// @brief The per-pixel buffers. imageDirty: they are new or resized, so the next clear fills
/// them whole; gbufferFill: the next clear fills the G-buffer (new buffers, or the epochs
/// wrapped); gbufferEpoch: the accumulation's G-buffer epoch (kGBufferEpochShift; Frame frame.z).
struct ImageState {
    bool imageDirty = true;
    uint32_t gbufferEpoch = 0;
    bool gbufferFill = false;
};

/// @brief RendererOptions and the environment, resolved once by create(); constant afterwards.
struct ResolvedOptions {
    bool profileDispatches = false; ///< CSGV_PROFILE_DISPATCHES
    bool hostDecode = false;        ///< RendererOptions::decode
    bool texelsWanted = true;       ///< RendererOptions::renderTexels
    bool hiddenWanted = true;       ///< RendererOptions::hiddenSubBlocks
    bool outlineWanted = true;      ///< RendererOptions::outlineSpans
    uint64_t prefetchVoxels = 0;    ///< RendererOptions::prefetchVoxels
    /// RendererOptions::decodeStepsPerFrame: GPU decodes carry over frames (CARRY_DECODES), each
    /// taking this many steps a frame (0: every decode ends in its frame).
    uint32_t carrySteps = 0;
    bool overlapDecodes = false; ///< RendererOptions::overlapDecodes (with carrySteps)
};

} // namespace renderer_detail

using namespace renderer_detail;

struct Renderer::Impl {
    Context& ctx;
    // The renderer's state, in the named parts above (each with its invariants).
    ResolvedOptions resolved;
    Accumulation accumulation;
    Denoising denoising;
    MaterialState materialState;
    CacheState cacheState;
    ImageState imageState;
    uint64_t budget = 0;              // device-memory budget (RendererOptions::deviceMemoryBytes resolved)
    MemoryKind cacheKind = MemoryKind::DeviceLocal;
    std::shared_ptr<GpuVolume> volume;
    uint32_t brickCount = 0, levels = 0;
    uint64_t pRequest = 0, pProvision = 0, pAssign = 0, pCommit = 0, pUniform = 0;
    uint64_t pHidden = 0, pHiddenAll = 0; // cache_hidden.comp: the bricks decoded this frame; every cached one (HIDDEN_ALL)
    // Per TONE_CURVES (toneCurves; render.comp also ONE_SAMPLE, DEPTH_INPUT: renderVariant) and resolve pass
    // or shading mode, compiled on first use.
    uint64_t pResolve[2][kResolveAtrous4 + 1] = {};
    uint64_t pRender[8][kShadingModes] = {}; // [renderVariant][shadingIndex]
    uint32_t curves = 0; // the frame's TONE_CURVES: the resolve passes' pipelines (addResolve)
    Defines defines;
    Buffer params, bricks, cache, alloc, freeStacks, requests, decodes, decodeStates, visible, uniformSubs, hiddenSubs, detailRequests;
    /// The render pass's texel buffers (RENDER_TEXELS, RendererOptions::renderTexels), or none.
    TexelViews renderTexels;
    /// The resolve passes' (RESOLVE_TEXELS): a set per source, denoiseA then denoiseB.
    TexelViews resolveTexels;
    Buffer accum, gbuffer, depthIn, colorDepth, denoiseA, denoiseB;
    /// Where the host sees the per-frame buffers through copies (viaCopies): the output's rows
    /// copied into host memory before the host reads them, the host's mirror of the cache
    /// counters (kSlotAlloc), copied to the device before each submission and back after it, and
    /// the frame parameters the host writes, copied to the device before each submission.
    Buffer readback, allocHost, paramsHost;
    /// Host decoding with the cache in device memory (GPUs): the bricks a frame decodes, staged in
    /// host memory (not the device's: not in memory()), and their copies into the cache
    /// (stagedCacheCopies of them) and the uniform sub-block masks.
    bool stagedDecode = false;
    Buffer decodeStaging;
    std::vector<Context::CopyRegion> stagedCopies;
    uint32_t stagedCacheCopies = 0;
    /// RendererOptions::readBackThroughCopy, or a GPU: the G-buffer, the output and the counters
    /// live in device memory (every frame's passes write and read them; their atomics stay on
    /// the device) and the host reads and writes copies.
    bool viaCopies = false;
    Buffer materials, colormaps, attributeTable, labelMap, blueNoise, materialTable;
    Buffer emptyGroups;               // kSlotEmptyGroups (uploadVisibility)
    Buffer labelColors;               // vec4 per materialTable entry (label_colors.comp), with a label table
    Buffer pixelList;                 // PIXEL_LIST: the cells the render pass runs over (pixel_list.comp)
    Buffer outlineRows;               // PIXEL_LIST: the resolve passes' spans (ResolvePush::spans), kOutlineRowWords a row
    bool usesPixelList = false;       // host decoding (CPU devices): two submissions, the render pass sized between them
    uint64_t pPixelList = 0;          // pixel_list.comp, made on first use
    uint64_t pLabelColors = 0;        // label_colors.comp, made on first use (with a label table)
    std::array<uint32_t, 3> listedGrid{}; // the cell grid (x, y) and stride the host's list holds (0: none)
    std::vector<uint32_t> listedSpans;    // ... its rows' spans (listPixels; empty: whole rows)
    uint32_t listedCount = 0;             // ... and its cells
    size_t renderDispatch = 0;        // the render pass's index in `dispatches`
    size_t hiddenDispatch = SIZE_MAX; // the decoded bricks' cache_hidden.comp in `dispatches` (host decoding sizes it)
    Buffer ghost;  // setGhostFaces (empty: not a piece)
    Buffer coarse; // setCoarseStandIns (empty: none)
    uint32_t materialTableSize = 0;   // entries of a dense materialTable (Frame counts.w)
    /// Stored labels [first, last] hold every label a material draws (Frame drawn): the ray
    /// steps' candidates for a surface (render_common.glsl's entersCandidate).
    uint32_t drawnFirst = 0, drawnLast = kNone - 1;
    std::vector<Buffer> attributes;
    uint32_t materialCount = 0, labelCount = 0;
    bool hasLabelMap = false;
    LabelLookup lookup;               // how the shaders find a label's material (planned once)
    Geometry geometry;
    uint32_t width = 0, height = 0;
    uint64_t imageCapacity = 0;       // pixels the per-pixel buffers hold
    uint32_t fillBlock = 0;           // upsampling block of the resolve (0: the frame's stride)
    std::array<uint32_t, 4> rect{};   // the frame's footprint rectangle (FrameParams rect)
    std::vector<uint32_t> spans;      // its rows' spans (footprintSpans; empty: whole rows or not wanted)
    std::array<uint32_t, 4> drawnRect{}; // the union of the footprints since the last clear (FrameOutput::rect)
    uint32_t maxRequests = 0;
    uint32_t pixelBlock = 1;          // PIXEL_BLOCK of render.comp and resolve.comp
    uint32_t requestBlock = 1;        // REQUEST_BLOCK of cache_request.comp (bricks per invocation)
    uint32_t visibleBricks = 0;       // bricks a material draws (uploadVisibility)
    uint32_t frameIndex = 1;          // global, never reset (bricks remember the frame of last use)
    // GPU decoding of the frame's requests: the passes' parameters and dispatches, made once. Where
    // decodes carry over frames (resolved.carrySteps) the decode list and states are two, a frame
    // decoding from one (decodeParity) and carrying into the other: a set for each.
    // The frames after a view's first one until every pixel holds a sample, and frames under
    // cache pressure (evictions, limited requests), take every step instead (the second set,
    // [parity][1]): the first full image comes as soon as without carrying, and a thrashing
    // cache needs each brick soon.
    GpuVolume::FrameDecode frameDecode[2][2];
    std::vector<Context::Dispatch> decodeDispatches[2][2];
    uint32_t decodeParity = 0;
    bool decodeWhole = false; ///< the frame being built decodes with every step (its set [parity][1])
    /// The decode list (or its states, `states`) a frame of parity `parity` decodes from.
    uint64_t decodeList(uint32_t parity, bool states = false) const {
        const Buffer& b = states ? decodeStates : decodes;
        return b.address() + (resolved.carrySteps ? parity * (b.size() / 2) : 0);
    }
    /// The decode dispatches of both parities (GPU decoding), for the current cache.
    Status makeFrameDecodes() {
        for (uint32_t parity = 0; parity < 2; ++parity)
            for (uint32_t whole = 0; whole < 2; ++whole) {
                decodeDispatches[parity][whole].clear();
                frameDecode[parity][whole] = GpuVolume::FrameDecode{};
                if (resolved.hostDecode || ((parity == 1 || whole == 1) && !resolved.carrySteps)) continue;
                GpuVolume::Carry carry;
                if (resolved.carrySteps)
                    carry = {whole ? 0u : resolved.carrySteps, alloc.address(), bricks.address(), decodeList(parity ^ 1),
                             decodeList(parity ^ 1, true), resolved.overlapDecodes};
                Status s = volume->appendFrameDecode(decodeList(parity), alloc.address() + 4 * kAllocDecodes, cache.address(),
                                                     decodeList(parity, true), maxRequests, frameDecode[parity][whole],
                                                     decodeDispatches[parity][whole], detail.get(), &carry);
                if (!s) return s;
            }
        return Status::ok();
    }
    // Detail streaming (GPU decoding of a separated volume): the finest-level streams the frames
    // ask for, uploaded between frames; bricks wait for theirs at the next coarser level.
    std::unique_ptr<DetailStream> detail;
    uint32_t detailUploads = 0;       // bricks whose stream the last commit made resident
    std::vector<std::unique_ptr<BrickDecoder>> decoders; // one per worker, for host decoding
    std::vector<std::unique_ptr<BrickDecoder>> finestDecoders; // with tiers: of the file, for level 0
    /// Host decoding's decoder of `worker` for a brick at `lod` (tiers: the finest level is the file's).
    BrickDecoder& decoderFor(unsigned worker, uint32_t lod) {
        return lod == 0 && volume->tiers() ? *finestDecoders[worker] : *decoders[worker];
    }
    /// Whether host decoding reads a brick at `lod` from the file (tiers: the finest level, and
    /// every level where no coarse tier is resident), counting it when so.
    bool readsFile(uint32_t brick, uint32_t lod) const {
        const TieredVolume* t = volume->tiers();
        if (!t || (lod != 0 && t->hasCoarseTier())) return false;
        t->noteRead(brick);
        return true;
    }
    /// With tiers, after host decoding: the pages of the bricks decoded from the file leave the
    /// process, and the bricks decoded one level coarser are read ahead (the next frames refine
    /// them).
    void afterHostDecode(const uint32_t* list, uint32_t n);
    /// Runs `decode(i, worker)` for the first `n` entries of the decode list on the host workers;
    /// with tiers in batches, each followed by afterHostDecode.
    void decodeInBatches(uint32_t n, const std::function<void(uint64_t, unsigned)>& decode);
    /// Host decoding's failed bricks: counted, the first error kept.
    std::mutex badMutex;
    uint64_t badBricks = 0;
    uint32_t frameBadBricks = 0;
    std::string firstBadBrick;
    void noteBadBrick(const Status& s) {
        std::lock_guard<std::mutex> lock(badMutex);
        ++badBricks;
        ++frameBadBricks;
        if (firstBadBrick.empty()) firstBadBrick = s.message();
    }
    /// GPU decoding's failed bricks of the frame just finished (decode_bricks.comp counts them in
    /// its dispatches' host-visible parameters, which are cleared here for the next frame).
    void noteGpuDecodeFailures() {
        const GpuVolume::FrameDecode& ran = frameDecode[decodeParity][decodeWhole];
        auto* p = static_cast<uint32_t*>(ran.params.mapped());
        for (size_t k = 0; p && k < ran.pushes.size(); ++k) {
            uint32_t* w = p + k * kDecodeParamWords;
            if (w[kDecodeParamFailures] == 0) continue;
            std::lock_guard<std::mutex> lock(badMutex);
            badBricks += w[kDecodeParamFailures];
            frameBadBricks += w[kDecodeParamFailures];
            if (firstBadBrick.empty())
                firstBadBrick = "brick " + std::to_string(w[kDecodeParamFailedBrick] - 1) +
                                ", GPU decode: " + decodeResultText(w[kDecodeParamFailedCode]);
            w[kDecodeParamFailures] = w[kDecodeParamFailedBrick] = w[kDecodeParamFailedCode] = 0;
        }
    }
    std::unique_ptr<WorkerPool> workers; // host decoding's threads: asleep, not spinning, between frames
    double finishSeconds = 0;         // render(): what follows the frames (denoising, read-back), measured
    ModeCosts costs;                  // render(): a frame's seconds per rendered pixel, per shading mode
    ModeCosts drawCosts;              // recordDraw(): the caller's whole draw of a frame, per output pixel
    FrameOutput output;               // what output() returns
    uint32_t outputParts = 0;         // OutputParts of `output` read since the last frame
    // The rectangle of the device image that `output`'s colour and depth were last read from:
    // outside it they hold empty pixels, as the device does outside its drawn rectangle.
    std::array<uint32_t, 4> outputRect{};
    /// Reads `output`'s 8-bit colour and depth: the rows and columns of the drawn rectangle and of
    /// the one read last (outside both the device and `output` hold empty pixels), all of them
    /// when the image's size changed.
    void readImage();
    // The frame's dispatch list and the push constants it points to (rebuilt every frame).
    std::vector<Context::Dispatch> dispatches;
    std::vector<ResolvePush> resolvePushes;
    size_t cacheStages = 0;           // dispatches before the decoding (host decoding submits them first)
    uint64_t frameAddress = 0;        // push constant of the cache and render passes (params.address())

    /// Decodes the GPU's decode list (brick, inverse level, cache word offset) with Core's decoder
    /// straight into the host-visible cache; a brick whose stream fails reads as outside. Where
    /// the cache lives in device memory (stagedDecode: GPUs), into a host buffer instead, whose
    /// regions the next submission copies into the cache and the uniform sub-block masks first
    /// (stagedCopies); false when that buffer cannot be had.
    Status decodeOnHost();
    /// The copies of what decodeOnHost staged, in front of `count` dispatches from `first`.
    std::vector<Context::Dispatch> withStagedCopies(const Context::Dispatch* first, size_t count) const;
    /// The host decoding's worker pool, with a decoder per worker.
    WorkerPool& hostWorkers();
    /// Detail streaming between frames: the streams the last frame asked for are queued (copied
    /// on a host thread meanwhile); commitDetail() makes them resident before the next frame.
    Status requestDetail(FrameStats& stats);
    Status commitDetail();
    /// A brick's finest labels (Morton order) -> its uniform sub-blocks (csgv/codec/Layout.h; as
    /// cache_uniform.comp computes them after GPU decoding).
    uint64_t uniformSubBlocks(const uint32_t* labels, uint32_t brick) const;

    explicit Impl(Context& c) : ctx(c) {}

    // Frame policy (RendererFramePolicy.cpp).
    /// The finest pixel stride (the settings' one or coarser) at which a frame of `pixels` in this
    /// shading mode, at the cost per pixel measured so far, takes at most `frameSeconds`. Before
    /// any frame was measured: a prior per device kind (kPriorSecondsPerRay, local shading's
    /// frames on lavapipe and NVIDIA rounded up), scaled by the rays each mode casts.
    uint32_t strideFor(const RenderSettings& st, uint64_t pixels, double frameSeconds) const;
    /// A still render's coarse stride: coarse enough that a frame takes at most an eighth of the
    /// budget, so the first image (every pixel showing a sample or a preview, a few frames as
    /// bricks arrive) comes in a fraction of it. Later frames take the settings' own: every
    /// frame at a coarse stride costs a full-resolution gather besides its rays, so the finest
    /// stride converges fastest.
    uint32_t stillCoarseStride(const RenderSettings& st, uint64_t pixels, double budgetSeconds) const;
    /// The time model learns a frame's cost.
    void measureFrame(const RenderSettings& st, const FrameInput& in, const FrameStats& stats);

    // The steps of a frame, in order (renderFrame and render).
    Status validate(const FrameInput& in, const RenderSettings& st, Mat4& clipToWorld) const;
    Status detectChanges(const FrameInput& in);
    Result<FrameStats> frame(const FrameInput& in, const RenderSettings& st, const Mat4& clipToWorld);
    /// The pipelines this frame's settings use that are not made yet (the render pass's for the
    /// shading mode, the resolve passes, the cache passes, ...): made together, in parallel.
    Status ensurePipelines(const RenderSettings& st, bool depthInput);
    /// What ensurePipelines makes for these settings (the pipelines not made yet, their outputs
    /// pointing at this Impl's handles); reads the state only.
    std::vector<PipelineJob> pipelineJobs(const RenderSettings& st, bool depthInput);
    /// Renderer::warmShadingModes's compilation on a thread of its own (it touches the context
    /// only, never this state); stopWarming asks it to stop between pipelines.
    std::future<void> warming;
    std::atomic<bool> stopWarming{false};
    /// When the last frame's device work began or ended (steady clock ticks, Impl::frame): on a
    /// CPU device the warming makes a pipeline only once frames have paused (kWarmAfterIdle).
    std::atomic<std::chrono::steady_clock::rep> lastFrameTicks{0};
    ~Impl() {
        stopWarming = true;
        if (warming.valid()) warming.wait();
    }
    Status packParams(const FrameInput& in, const RenderSettings& st, const Mat4& clipToWorld);
    void packState(const FrameInput& in, const RenderSettings& st, FrameParams& p);
    void buildDispatches(const FrameInput& in, const RenderSettings& st, uint64_t renderPipeline);
    void addDispatch(uint64_t pipeline, const void* push, uint32_t bytes, uint32_t gx, uint32_t gy);
    /// One resolve pass over the footprint rectangle.
    void addResolve(uint32_t pass, uint32_t src, uint32_t dst);
    /// The A-trous passes and tone mapping from the gathered image (denoise A) into the output.
    void addDenoisePasses();
    /// A new accumulation: no samples, an empty G-buffer, a transparent output at the far plane.
    void addClear(const FrameInput& in);
    bool denoises(const RenderSettings& st) const;
    /// The settings ask for denoising (ambient occlusion and path tracing; denoises() also stops
    /// it once every pixel has 64 samples).
    static bool denoisedShading(const RenderSettings& st) {
        return st.denoise && shadingMode(st.shading).denoised;
    }
    /// render.comp's ONE_SAMPLE: the sample target is one sample and the render pass resolves its
    /// pixels, so every sample it takes is a pixel's first and nothing reads its sum afterwards:
    /// no jitter, no sum read or written (sumsStale).
    bool oneSample(const RenderSettings& st) const { return st.sampleTarget == 1 && resolvesInRender(st); }
    /// render.comp's pipeline variant: TONE_CURVES | ONE_SAMPLE << 1 | DEPTH_INPUT << 2 (the frame
    /// has an opaque depth input, kFlagDepthInput).
    uint32_t renderVariant(const RenderSettings& st, bool depthInput) const {
        return toneCurves(st) | (oneSample(st) ? 2u : 0u) | (depthInput ? 4u : 0u);
    }
    /// The frame's render pass resolves its own pixels (no gather pass): kFlagResolveInRender.
    bool resolvesInRender(const RenderSettings& st) const;
    /// A frame that takes only the pixels within the box's outline (footprintSpans): the host
    /// lists the pixels (CPU devices), RendererOptions::outlineSpans, and every pixel takes its
    /// own samples (stride 1, no upsampling: a coarse stride's block would copy a sample into
    /// pixels outside the outline, which later frames would then not take again).
    bool outlineFrame(const RenderSettings& st) const {
        return usesPixelList && resolved.outlineWanted && st.subsampling == 1 && fillBlock <= 1;
    }
    /// The denoising passes over the last frame's gathered image into the output (a still render
    /// defers them to its last frame: the frames before are never shown).
    Status denoiseOutput();
    Status submit();
    /// The grid of rendered pixels (cells) of the footprint rectangle at a subsampling stride, as
    /// render_common.glsl's cellGrid.
    std::array<uint32_t, 2> cellGrid(uint32_t stride) const {
        return {(rect[2] - rect[0] + stride - 1) / stride, (rect[3] - rect[1] + stride - 1) / stride};
    }
    /// PIXEL_LIST: lists the cells the render pass runs over (every cell, or pixel_list.comp's
    /// dispatch for those below the sample target).
    void listPixels(const RenderSettings& st);
    /// Host decoding, after the first submission: the groups of the decoded bricks' cache_hidden.comp
    /// and (PIXEL_LIST) of the render pass for the cells listed.
    void sizeRenderDispatch();
    /// Whether this frame marks the hidden sub-blocks of every cached brick (the materials changed
    /// since bricks were decoded), not only of those it decodes.
    bool hiddenAll() const { return materialState.hiddenAllPending && materialState.hiddenLabels && !cacheState.cacheEmpty; }
    /// Returns true when it changed how the next frame treats the cache (FrameStats::cacheAdapting).
    bool applyCachePolicy(const FrameStats& stats, const FrameInput& in, uint32_t stride);
    /// The free stacks hold a large share of the cache (kFragmentedShare) although it ran full.
    bool fragmented();
    // setMaterials' steps.
    Status uploadDeviceLocal(Buffer& dst, const void* data, uint64_t bytes);
    Status uploadMaterials(const PackedMaterials& packed, const std::map<std::string, std::vector<float>>& attributeArrays,
                           const std::vector<uint32_t>& storedToOriginal, uint64_t labels);
    Status uploadVisibility(const MaterialMatcher& materialOf);
    /// Device memory the new materials take (the old ones are freed only after the new ones exist).
    uint64_t materialBytes(const PackedMaterials& packed, const std::map<std::string, std::vector<float>>& attributeArrays,
                           const std::vector<uint32_t>& storedToOriginal);

    void resetAccumulation() {
        accumulation.clearPending = true;
        accumulation.coarseStride = 0;
        accumulation.shownWhole = false;
        accumulation.accumulatedFrames = 0;
        accumulation.prevMinSamples = 0;
        accumulation.converged = false;
    }

    /// The per-pixel buffers for a new size, all or nothing: a failure keeps the old size whole.
    /// Buffers that hold the new size already are kept: a view switching between its reduced
    /// interactive size and its full size allocates nothing.
    Status allocateImage(uint32_t w, uint32_t h) {
        const uint64_t n = uint64_t(w) * h;
        imageState.imageDirty = true;
        if (n <= imageCapacity && (!usesPixelList || outlineRows.size() >= 4ull * kOutlineRowWords * h)) {
            width = w;
            height = h;
            output = FrameOutput{};
            outputParts = 0;
            return Status::ok();
        }
        renderTexels.clear(); // views go before their buffers
        resolveTexels.clear();
        struct Part {
            Buffer* target;
            uint64_t bytes;
            MemoryKind kind;
        };
        const Part parts[] = {{&accum, n * 16, MemoryKind::DeviceLocal},
                              {&gbuffer, n * 16, MemoryKind::DeviceLocal},  {&depthIn, n * 4, MemoryKind::HostVisible},
                              {&colorDepth, n * 8, MemoryKind::DeviceLocal},
                              {&readback, viaCopies ? n * 8 : 0, MemoryKind::HostVisible},
                              {&denoiseA, n * 16, MemoryKind::DeviceLocal}, {&denoiseB, n * 16, MemoryKind::DeviceLocal},
                              {&pixelList, usesPixelList ? n * 8 : 0, MemoryKind::HostVisible}, // this frame's list, the next's
                              {&outlineRows, usesPixelList ? 4ull * kOutlineRowWords * h : 0, MemoryKind::HostVisible}};
        uint64_t bytes = 0;
        for (const Part& part : parts) bytes += std::max<uint64_t>(part.bytes, 16);
        if (usedBytes() + bytes > budget) {
            // Under the budget, the old image goes first (its size is lost if the new one fails).
            for (const Part& part : parts) *part.target = Buffer{};
            imageCapacity = 0;
            width = height = 0; // no image now: the next frame allocates whatever its size
            output = FrameOutput{};
            outputParts = 0;
            Status s = makeRoom(bytes, "a " + std::to_string(w) + "x" + std::to_string(h) + " image");
            if (!s) return s;
        }
        std::vector<Buffer> made;
        for (const Part& part : parts) {
            Result<Buffer> r = ctx.createBuffer(std::max<uint64_t>(part.bytes, 16), part.kind);
            if (!r) return Status(r.status()).prefix("allocating a " + std::to_string(w) + "x" + std::to_string(h) + " image");
            made.push_back(std::move(*r));
        }
        for (size_t i = 0; i < made.size(); ++i) *parts[i].target = std::move(made[i]);
        listedGrid = {};
        imageCapacity = n;
        width = w;
        height = h;
        output = FrameOutput{};
        outputParts = 0;
        return Status::ok();
    }

    /// The cache counters as the host reads and writes them between submissions (run() carries
    /// them to the device and back where they live there).
    uint32_t* allocWords() { return static_cast<uint32_t*>((viaCopies ? allocHost : alloc).mapped()); }
    /// Submits dispatches (Context::run), with the counters' copies around them where the host
    /// works on a mirror (viaCopies).
    Status run(const Context::Dispatch* first, size_t count) {
        if (!viaCopies) return ctx.run(first, count);
        std::vector<Context::Dispatch> list(count + 3);
        list[0].copyFrom = &paramsHost; // the frame parameters in
        list[0].copyTo = &params;
        list[0].copyBytes = sizeof(FrameParams);
        list[1].copyFrom = list.back().copyTo = &allocHost; // the counters in, and out at the end
        list[1].copyTo = list.back().copyFrom = &alloc;
        list[1].copyBytes = list.back().copyBytes = kAllocWords * 4;
        std::copy(first, first + count, list.begin() + 2);
        return ctx.run(list);
    }
    /// The frame parameters as the host writes them (run() carries them to the device where they
    /// live there).
    FrameParams& hostParams() { return *static_cast<FrameParams*>((viaCopies ? paramsHost : params).mapped()); }
    Status run(const std::vector<Context::Dispatch>& list) { return run(list.data(), list.size()); }
    /// A G-buffer entry's second word as the last accumulation sees it (render_common.glsl's
    /// currentWord1): 0 where another accumulation wrote it.
    uint32_t currentWord1(uint32_t w1) const {
        return ((w1 >> kGBufferEpochShift) & kGBufferEpochMask) == imageState.gbufferEpoch ? w1 : 0u;
    }

    /// The smallest cache a renderer works with: one brick at full resolution.
    uint64_t smallestCacheBytes() const { return std::max<uint64_t>(volume->regionWords(0) * 4, 4096); }
    /// Every buffer of this renderer, the encoding included (Renderer::memory()).
    MemoryReport memory() const;
    uint64_t usedBytes() const;
    /// Makes room for `bytes` more of device memory within the budget, shrinking the brick cache
    /// (it then fills anew) when there is not enough; an error says what does not fit.
    Status makeRoom(uint64_t bytes, const std::string& what) {
        const uint64_t used = usedBytes();
        if (used + bytes <= budget) return Status::ok();
        const uint64_t over = used + bytes - budget;
        if (cache.size() < over + smallestCacheBytes())
            return Status::error(what + " needs " + mebibytes(bytes) + " of device memory; the device-memory budget of " +
                                 mebibytes(budget) + " has " + mebibytes(budget - std::min(budget, used - cache.size())) +
                                 " left beside the encoding and tables, and the brick cache needs at least " +
                                 mebibytes(smallestCacheBytes()));
        return resizeCache((cache.size() - over) & ~uint64_t(3));
    }
    /// Words a texel of each render-pass binding (render_common.glsl reads a record with one
    /// fetch: CPU devices pay for a fetch about as much whatever its width): a brick's entry and
    /// a label's colour are four, the sub-block masks, the preview entries and a pixel's output two.
    static constexpr std::array<uint32_t, kRenderTexelCount> kRenderTexelWords = [] {
        std::array<uint32_t, kRenderTexelCount> w{};
        for (uint32_t& x : w) x = 1u;
        w[kTexelBricks] = w[kTexelLabelColors] = 4u;
        w[kTexelUniform] = w[kTexelHidden] = w[kTexelVisible] = w[kTexelOutput] = 2u;
        return w;
    }();
    /// The texel buffers of the render and resolve passes (FrameLayout.h's kTexel* bindings) for
    /// the buffers of this frame. Pipelines made with them differ from those made without: a
    /// change drops those.
    Status viewBuffers() {
        // The label colours exist with a label table only, the pixel list with host decoding, the
        // label map and the opaque depth when there are some: the parameter block stands in for
        // what is absent (unread).
        std::array<const Buffer*, kRenderTexelCount> render{};
        render[kTexelCache] = &cache;
        render[kTexelBricks] = &bricks;
        render[kTexelUniform] = &uniformSubs;
        render[kTexelHidden] = &hiddenSubs;
        render[kTexelEmptyGroups] = &emptyGroups;
        render[kTexelMaterialTable] = &materialTable;
        render[kTexelLabelColors] = labelColors.valid() ? &labelColors : &params;
        render[kTexelGBuffer] = &gbuffer;
        render[kTexelPixelList] = pixelList.valid() ? &pixelList : &params;
        render[kTexelMaterials] = materials.valid() ? &materials : &params;
        render[kTexelLabelMap] = labelMap.valid() ? &labelMap : &params;
        render[kTexelDepthIn] = depthIn.valid() ? &depthIn : &params;
        render[kTexelBlueNoise] = blueNoise.valid() ? &blueNoise : &params;
        render[kTexelVisible] = visible.valid() ? &visible : &params;
        render[kTexelOutput] = &colorDepth;
        Result<bool> changed = renderTexels.refresh(ctx, resolved.texelsWanted, {render}, kRenderTexelWords);
        if (!changed) return Status(changed.status()).prefix("viewing the render pass's buffers");
        if (*changed) {
            std::fill(&pRender[0][0], &pRender[0][0] + std::size(pRender) * std::size(pRender[0]), uint64_t(0));
            pHidden = pHiddenAll = 0; // they read through the same views
        }
        std::array<const Buffer*, kResolveTexelCount> resolve{};
        resolve[kResolveTexelGBuffer] = &gbuffer;
        resolve[kResolveTexelAccum] = &accum;
        resolve[kResolveTexelSpans] = outlineRows.valid() ? &outlineRows : &params;
        std::array<const Buffer*, kResolveTexelCount> fromB = resolve;
        resolve[kResolveTexelSource] = &denoiseA;
        fromB[kResolveTexelSource] = &denoiseB;
        changed = resolveTexels.refresh(ctx, resolved.texelsWanted, {resolve, fromB}, 4); // a pixel's 16 bytes a texel
        if (!changed) return Status(changed.status()).prefix("viewing the resolve passes' buffers");
        if (*changed)
            std::fill(&pResolve[0][0], &pResolve[0][0] + std::size(pResolve) * std::size(pResolve[0]), uint64_t(0));
        return Status::ok();
    }
    /// A new, smaller brick cache: the old one is freed first (the budget holds at every moment)
    /// and every brick is forgotten (they are requested again by the next frames).
    Status resizeCache(uint64_t bytes) {
        renderTexels.clear(); // its view goes before the buffer
        cache = Buffer{};
        for (auto& lists : decodeDispatches)
            for (auto& list : lists) list.clear();
        for (auto& sets : frameDecode)
            for (auto& d : sets) d = GpuVolume::FrameDecode{};
        Result<Buffer> b = ctx.createBuffer(bytes, cacheKind);
        if (!b) return Status(b.status()).prefix("allocating the brick cache");
        cache = std::move(*b);
        Status s;
        if (!(s = makeFrameDecodes())) return s;
        allocWords()[kAllocCapacity] = uint32_t(bytes / 4);
        cacheState.newCache = true;
        return resetCacheNow();
    }

    /// Forgets every cached brick (defragmentation); bricks keep their marks of last use so they
    /// are requested again by the next frame.
    Status resetCacheNow() {
        std::vector<uint32_t> words(size_t(brickCount) * 4);
        Status s = ctx.download(bricks, 0, words.data(), words.size() * 4);
        if (!s) return s;
        for (size_t b = 0; b < brickCount; ++b) words[4 * b] = words[4 * b + 1] = kNone;
        if (!(s = ctx.upload(bricks, 0, words.data(), words.size() * 4))) return s;
        uint32_t* a = allocWords();
        const uint32_t capacity = a[kAllocCapacity];
        std::fill(a, a + kAllocWords, 0u);
        a[kAllocCapacity] = capacity;
        cacheState.prefetchPending = true;
        cacheState.cacheEmpty = true;
        return Status::ok();
    }
    /// Whether a frame asks for every visible brick at once (RendererOptions::prefetchVoxels). A
    /// new view otherwise finds its bricks one layer a frame: AAL (129 visible bricks of 32^3) at 1280x720
    /// on lavapipe took six frames, 0.60 s, to its first complete image, 0.46 s in one frame with
    /// it. Only for small volumes, where decoding bricks no view ray needs costs little: a
    /// synthetic 256^3 (512 bricks) decodes in 130 ms on two cores, what a view needs in 22 ms.
    /// The bricks, at the finest level, fit a new cache whole, or a quarter of one that has held
    /// bricks (new visibility, an emptied cache after defragmentation: room is left for the regions
    /// of other levels the next views take; filled whole there, each defragmentation would bring
    /// another prefetch of every visible brick). A new cache that holds a view but not four times
    /// the volume was left to find each view's bricks one layer a frame: an 8-view orbit of synthA
    /// at 160x120 took 20 frames under a 13 MiB cache, 8 without one.
    bool prefetches() const {
        const uint64_t edge = volume->volume().brickSize;
        const uint64_t voxels = uint64_t(visibleBricks) * edge * edge * edge;
        const uint64_t bytes = uint64_t(visibleBricks) * volume->regionWords(0) * 4;
        const uint64_t room = cacheState.newCache ? cache.size() : cache.size() / 4;
        return !detail && voxels <= resolved.prefetchVoxels && visibleBricks <= maxRequests && bytes <= room;
    }
};

} // namespace csgv::gpu
