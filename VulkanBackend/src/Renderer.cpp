// SPDX-License-Identifier: MIT
#include "csgv/gpu/Renderer.h"
#include "BlueNoise.h"
#include "csgv/gpu/LabelLookup.h"
#include "csgv/gpu/DetailStream.h"
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

namespace {

/// Compiles a shader with defines into a pipeline; with `profile`, says how long it took.
Result<uint64_t> makePipeline(Context& ctx, const char* name, const Defines& defines, uint32_t pushBytes,
                              uint32_t texelBindings, bool profile) {
    const auto t0 = std::chrono::steady_clock::now();
    Result<std::vector<uint32_t>> spirv = compileComputeShader(name, defines);
    if (!spirv) return spirv.status();
    Result<uint64_t> p = ctx.createComputePipeline(*spirv, pushBytes, texelBindings);
    if (!p) return Status(p.status()).prefix(name);
    if (profile)
        std::fprintf(stderr, "pipeline %s (%s): %.1f ms\n", name, defines.back().first.c_str(),
                     std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    return p;
}

/// Lowers the calling thread's scheduling priority (Linux: a thread's own nice value), so that
/// background compilation yields to frames and the GUI on a CPU device.
void lowerThisThreadsPriority() {
#ifdef __linux__
    (void)setpriority(PRIO_PROCESS, id_t(syscall(SYS_gettid)), 10);
#endif
}

/// A pipeline to make: the shader, its defines, its push-constant bytes, where its handle goes.
struct PipelineJob {
    const char* name;
    Defines defines;
    uint32_t pushBytes;
    uint64_t* out;
    uint32_t texelBindings = 0;
};

/// Makes the pipelines in parallel, on threads of their own for as long as it takes (a CPU
/// device's compiler takes about 120 ms for the render pipeline, the others a few ms each: the
/// first frame waits for the longest, not for the sum; no pool or decoder is made for it, which a
/// GPU renderer would never use again); the first error is returned.
Status makePipelines(Context& ctx, const std::vector<PipelineJob>& jobs, bool profile) {
    std::vector<Status> results(jobs.size());
    auto make = [&](size_t i) {
        Result<uint64_t> p =
            makePipeline(ctx, jobs[i].name, jobs[i].defines, jobs[i].pushBytes, jobs[i].texelBindings, profile);
        if (p) *jobs[i].out = *p;
        else results[i] = p.status();
    };
    std::atomic<size_t> next{1}; // job 0, the render pipeline (the longest), is this thread's
    auto work = [&] {
        for (size_t i = next++; i < jobs.size(); i = next++) make(i);
    };
    const size_t cores = std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> helpers;
    for (size_t t = 1; t < std::min(cores, jobs.size()); ++t) helpers.emplace_back(work);
    make(0);
    work();
    for (std::thread& t : helpers) t.join();
    for (const Status& r : results)
        if (!r) return r;
    return Status::ok();
}

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
    /// `wordsPerTexel`: Context::createTexelSet's (every buffer of the lists).
    /// Whether a view of the whole buffer stays within the device's texel limit.
    static bool fits(const Context& ctx, const Buffer& b, uint32_t wordsPerTexel = 1) {
        return b.size() / (4u * wordsPerTexel) <= ctx.device().maxTexelBufferElements;
    }
    template <size_t N>
    Result<bool> refresh(Context& ctx, bool wanted, std::initializer_list<std::array<const Buffer*, N>> lists,
                         uint32_t wordsPerTexel = 1) {
        bool fit = wanted, same = valid() && serials.size() == N * lists.size();
        size_t i = 0;
        for (const auto& list : lists)
            for (const Buffer* b : list) {
                fit = fit && b->valid() && fits(ctx, *b, wordsPerTexel);
                same = same && serials[i++] == b->serial();
            }
        if (fit && same) return false;
        clear();
        if (fit) {
            for (const auto& list : lists) {
                Result<TexelSet> t = ctx.createTexelSet(std::vector<const Buffer*>(list.begin(), list.end()), wordsPerTexel);
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

static_assert(uint32_t(Shading::Local) == kShadingLocal && uint32_t(Shading::Shadow) == kShadingShadow &&
                  uint32_t(Shading::AmbientOcclusion) == kShadingAo && uint32_t(Shading::PathTracing) == kShadingPt,
              "Shading must match FrameLayout.h");

void toFloat(const Mat4& m, float* out) {
    for (int i = 0; i < 16; ++i) out[i] = float(m[i]);
}

uint32_t log2u(uint32_t v) {
    uint32_t r = 0;
    while ((1u << (r + 1)) <= v) ++r;
    return r;
}

std::string uvec3Of(const std::array<uint32_t, 3>& v) {
    return "uvec3(" + std::to_string(v[0]) + "u," + std::to_string(v[1]) + "u," + std::to_string(v[2]) + "u)";
}

struct PackedMaterials;
struct MaterialMatcher;

} // namespace

const char* shadingName(Shading s) {
    switch (s) {
    case Shading::Local: return "local";
    case Shading::Shadow: return "shadow";
    case Shading::AmbientOcclusion: return "ao";
    case Shading::PathTracing: return "pt";
    }
    return "local";
}

Result<Shading> parseShading(const std::string& name) {
    for (Shading s : {Shading::Local, Shading::Shadow, Shading::AmbientOcclusion, Shading::PathTracing})
        if (name == shadingName(s)) return s;
    return Status::error("unknown shading mode '" + name + "' (local, shadow, ao, pt)");
}

uint64_t MemoryReport::total() const {
    uint64_t n = 0;
    for (const auto& b : buffers) n += b.second;
    return n;
}

namespace {
/// The gamma a frame applies (FrameParams tone.z): the settings', 1 for none.
float frameGamma(const RenderSettings& st) { return st.gamma > 0 ? st.gamma : 1.0f; }

/// TONE_CURVES of render_common.glsl's toneMapped: 1 when the frame has ACES tone mapping or a
/// gamma other than 1, else 0 (passes compiled without either).
uint32_t toneCurves(const RenderSettings& st) { return st.toneMapping || frameGamma(st) != 1.0f ? 1 : 0; }

/// The pixels [x0, x1) x [y0, y1) where the index-space box [lo, hi] can appear: its corners
/// projected, widened by 2 pixels (jittered samples reach 1.5 pixels from their centres), the
/// origin a multiple of 8 so every pixel stride keeps the same pattern. The whole image when a
/// corner is behind the eye.
std::array<uint32_t, 4> footprintRect(const Mat4& indexToClip, const float lo[4], const float hi[4], uint32_t w,
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
std::vector<uint32_t> footprintSpans(const Mat4& indexToClip, const float lo[4], const float hi[4], uint32_t w,
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
std::vector<uint32_t> widenSpans(const std::vector<uint32_t>& spans, const std::array<uint32_t, 4>& rect, uint32_t widen) {
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
void readColorDepth(const uint32_t* words, uint32_t width, const std::array<uint32_t, 4>& r, uint32_t* rgba8,
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
double renderedPixels(const FrameInput& in, uint32_t stride) {
    return double((in.width + stride - 1) / stride) * double((in.height + stride - 1) / stride);
}
} // namespace

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

struct Renderer::Impl {
    Context& ctx;
    uint64_t budget = 0;              // device-memory budget (RendererOptions::deviceMemoryBytes resolved)
    MemoryKind cacheKind = MemoryKind::DeviceLocal;
    std::shared_ptr<GpuVolume> volume;
    uint32_t brickCount = 0, levels = 0;
    uint64_t pRequest = 0, pProvision = 0, pAssign = 0, pCommit = 0, pUniform = 0;
    uint64_t pHidden = 0, pHiddenAll = 0; // cache_hidden.comp: the bricks decoded this frame; every cached one (HIDDEN_ALL)
    // Per TONE_CURVES (toneCurves; render.comp also ONE_SAMPLE, DEPTH_INPUT: renderVariant) and resolve pass
    // or shading mode, compiled on first use.
    uint64_t pResolve[2][kResolveAtrous4 + 1] = {};
    uint64_t pRender[8][4] = {}; // [renderVariant][shading]
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
    bool labelColorsPending = false;  // the materials changed: the next frame computes labelColors first
    bool hiddenAllPending = false;    // ... and kSlotHidden is filled with 0, then (hiddenLabels) made for every cached brick
    bool hiddenLabels = false;        // the volume holds several labels no material draws: cache_hidden.comp marks their sub-blocks
    uint64_t drawnFingerprint = 0;    // which entries of the label table the materials draw (0: none known)
    bool cacheEmpty = true;           // no brick decoded since the cache was made or reset: HIDDEN_ALL has nothing to do
    size_t hiddenDispatch = SIZE_MAX; // the decoded bricks' cache_hidden.comp in `dispatches` (host decoding sizes it)
    Buffer ghost;  // setGhostFaces (empty: not a piece)
    Buffer coarse; // setCoarseStandIns (empty: none)
    uint32_t materialTableSize = 0;   // entries of a dense materialTable (Frame counts.w)
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
    bool imageDirty = true;           // the per-pixel buffers are new or resized: the next clear fills them whole
    uint32_t gbufferEpoch = 0;        // the accumulation's G-buffer epoch (kGBufferEpochShift; Frame frame.z)
    bool gbufferFill = false;         // the next clear fills the G-buffer (new buffers, or the epochs wrapped)
    uint32_t maxRequests = 0;
    uint32_t pixelBlock = 1;          // PIXEL_BLOCK of render.comp and resolve.comp
    uint32_t requestBlock = 1;        // REQUEST_BLOCK of cache_request.comp (bricks per invocation)
    bool visibilityChanged = true;    // uploadVisibility ran since the last frame (kFlagVisibilityChanged)
    uint32_t visibleBricks = 0;       // bricks a material draws (uploadVisibility)
    uint64_t prefetchVoxels = 0;      // RendererOptions::prefetchVoxels
    // The next frame asks for every visible brick (kFlagPrefetch) when they fit (prefetches()):
    // set by a new cache or new visibility.
    bool prefetchPending = true;
    Mat4 lastWorldToClip{};
    uint32_t frameIndex = 1;          // global, never reset (bricks remember the frame of last use)
    uint32_t accumulatedFrames = 0;   // since the last reset of the accumulation
    bool clearPending = true;
    /// Frames since the last clear ran ONE_SAMPLE and kept no sums: a frame that would read them
    /// (another sample target, a gather) starts the accumulation anew first (frame()).
    bool sumsStale = false;
    /// kFlagListNext: the cells the last frame's render pass left below the sample target, at
    /// word width * height of pixelList, and the fewest samples of the others; the next frame
    /// takes them as its list when its grid and target are the same (listPixels).
    struct NextList {
        bool valid = false;
        std::array<uint32_t, 4> grid{}; // cells across, down, stride, sample target
        uint32_t count = 0, kept = kNone;
    } nextList;
    bool hadDepth = false;            // the last frame had an opaque depth input (now in depthIn)
    bool cacheResetPending = false;
    // Cache pressure (applyCachePolicy); it outlives resets of the accumulation: a camera move
    // keeps the cache and what was learnt about its pressure.
    uint32_t evictAge = 0;            // evict bricks unused for this many frames (0: no eviction)
    uint32_t quietFrames = 0;         // frames since the cache last ran full
    uint32_t framesSinceDefrag = kDefragInterval; // frames since the last defragmentation reset
    bool limitRequests = false;
    uint32_t bandRow = 0, bandHeight = 0, prevMinSamples = 0;
    GpuVolume::FrameDecode frameDecode; // the decode passes' parameters, made once
    std::vector<Context::Dispatch> decodeDispatches; // GPU decoding of the frame's requests (same every frame)
    bool profileDispatches = false;   // CSGV_PROFILE_DISPATCHES, read once
    bool hostDecode = false;          // RendererOptions::decode resolved
    bool texelsWanted = true;         // RendererOptions::renderTexels
    bool hiddenWanted = true;         // RendererOptions::hiddenSubBlocks
    bool outlineWanted = true;        // RendererOptions::outlineSpans
    // Detail streaming (GPU decoding of a separated volume): the finest-level streams the frames
    // ask for, uploaded between frames; bricks wait for theirs at the next coarser level.
    std::unique_ptr<DetailStream> detail;
    uint32_t detailUploads = 0;       // bricks whose stream the last commit made resident
    std::vector<std::unique_ptr<BrickDecoder>> decoders; // one per worker, for host decoding
    std::unique_ptr<WorkerPool> workers; // host decoding's threads: asleep, not spinning, between frames
    bool converged = false;           // the last render() reached the sample target; nothing changed since
    uint64_t materialsFingerprint = 0; // of what setMaterials uploaded (0: nothing yet)
    // render()'s coarse pixel stride of this accumulation: frames start at it until every pixel
    // shows a sample (its own or its coarse block's), then go on at the settings' stride; the
    // coarse block stays the upsampling block (FrameParams pixel.z). 0: chosen at the first frame.
    uint32_t coarseStride = 0;
    bool shownWhole = false;
    double finishSeconds = 0;         // render(): what follows the frames (denoising, read-back), measured
    double secondsPerPixel[4] = {};   // render(): a frame's seconds per rendered pixel, per shading mode
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
    Status decodeOnHost() {
        stagedCopies.clear();
        stagedCacheCopies = 0;
        const uint32_t n = std::min(allocWords()[kAllocDecodes], maxRequests);
        const uint32_t* list = static_cast<const uint32_t*>(decodes.mapped());
        const uint32_t L = levels;
        if (n == 0) return Status::ok();
        auto entry = [&](uint64_t i, uint32_t& brick, uint32_t& lod, uint32_t& offset) {
            const uint32_t* e = list + kDecodeEntryWords * i;
            brick = e[0];
            lod = L - 1 - std::min(e[1], L - 1);
            offset = e[2];
            return uint64_t(offset) + volume->regionWords(lod) <= cache.size() / 4 && brick < brickCount;
        };
        if (!stagedDecode) {
            uint32_t* cacheWords = static_cast<uint32_t*>(cache.mapped());
            uint64_t* uniformMasks = static_cast<uint64_t*>(uniformSubs.mapped());
            hostWorkers().parallelFor(n, [&](uint64_t i, unsigned worker) {
                BrickDecoder& d = *decoders[worker];
                uint32_t brick, lod, offset;
                if (!entry(i, brick, lod, offset)) return;
                const bool ok = volume->decodeRegion(d, brick, lod, cacheWords + offset);
                if (lod == 0) uniformMasks[brick] = ok ? uniformSubBlocks(d.labels(), brick) : 0;
            });
            return Status::ok();
        }
        // Each brick's labels, then (decoded at the finest level) its uniform sub-block mask, one
        // after another in the host buffer; the copies take them to the cache and the masks.
        struct Staged {
            uint32_t brick = 0, lod = 0, offset = 0;
            uint64_t at = 0, labelBytes = 0; // labelBytes 0: an entry that is not decoded
        };
        std::vector<Staged> staged(n);
        uint64_t bytes = 0;
        for (uint64_t i = 0; i < n; ++i) {
            Staged& e = staged[i];
            if (!entry(i, e.brick, e.lod, e.offset)) continue;
            e.at = bytes;
            e.labelBytes = uint64_t(volume->regionWords(e.lod)) * 4;
            bytes += e.labelBytes + (e.lod == 0 ? 8 : 0);
        }
        if (decodeStaging.size() < bytes) {
            const uint64_t grown = std::max<uint64_t>(bytes, decodeStaging.size() * 2);
            decodeStaging = Buffer{};
            Result<Buffer> b = ctx.createBuffer(grown, MemoryKind::HostVisible);
            if (!b) return Status(b.status()).prefix("allocating host memory for decoded bricks");
            decodeStaging = std::move(*b);
        }
        uint8_t* host = static_cast<uint8_t*>(decodeStaging.mapped());
        hostWorkers().parallelFor(n, [&](uint64_t i, unsigned worker) {
            const Staged& e = staged[i];
            if (e.labelBytes == 0) return;
            BrickDecoder& d = *decoders[worker];
            const bool ok = volume->decodeRegion(d, e.brick, e.lod, reinterpret_cast<uint32_t*>(host + e.at));
            if (e.lod == 0) {
                const uint64_t mask = ok ? uniformSubBlocks(d.labels(), e.brick) : 0;
                std::memcpy(host + e.at + e.labelBytes, &mask, 8);
            }
        });
        for (const Staged& e : staged)
            if (e.labelBytes) stagedCopies.push_back({e.at, uint64_t(e.offset) * 4, e.labelBytes});
        stagedCacheCopies = uint32_t(stagedCopies.size());
        for (const Staged& e : staged)
            if (e.labelBytes && e.lod == 0) stagedCopies.push_back({e.at + e.labelBytes, uint64_t(e.brick) * 8, 8});
        return Status::ok();
    }
    /// The copies of what decodeOnHost staged, in front of `count` dispatches from `first`.
    std::vector<Context::Dispatch> withStagedCopies(const Context::Dispatch* first, size_t count) const {
        std::vector<Context::Dispatch> list;
        Context::Dispatch c;
        c.copyFrom = &decodeStaging;
        c.copyTo = &cache;
        c.copyRegions = stagedCopies.data();
        c.copyRegionCount = stagedCacheCopies;
        if (c.copyRegionCount) list.push_back(c);
        c.copyTo = &uniformSubs;
        c.copyRegions = stagedCopies.data() + stagedCacheCopies;
        c.copyRegionCount = uint32_t(stagedCopies.size()) - stagedCacheCopies;
        if (c.copyRegionCount) list.push_back(c);
        list.insert(list.end(), first, first + count);
        return list;
    }

    /// The host decoding's worker pool, with a decoder per worker.
    WorkerPool& hostWorkers() {
        if (!workers) workers = std::make_unique<WorkerPool>();
        while (decoders.size() < workers->size()) decoders.push_back(std::make_unique<BrickDecoder>(volume->volume()));
        return *workers;
    }

    /// Detail streaming between frames: the streams the last frame asked for are queued (copied
    /// on a host thread meanwhile); commitDetail() makes them resident before the next frame.
    Status requestDetail(FrameStats& stats) {
        const uint32_t n = std::min(allocWords()[kAllocDetailRequests], maxRequests);
        stats.detailRequests = n;
        return detail->request(static_cast<const uint32_t*>(detailRequests.mapped()), n);
    }
    Status commitDetail() {
        const uint64_t before = detail->counts().uploadedBricks;
        Status s = detail->commit();
        detailUploads = uint32_t(detail->counts().uploadedBricks - before);
        return s;
    }

    /// A brick's finest labels (Morton order) -> its uniform sub-blocks (csgv/codec/Layout.h; as
    /// cache_uniform.comp computes them after GPU decoding).
    uint64_t uniformSubBlocks(const uint32_t* labels, uint32_t brick) const {
        const CompressedVolume& vol = volume->volume();
        const uint32_t shift = log2u(vol.brickSize);
        if (shift < kUniformShift) return 0;
        const uint32_t subShift = shift - kUniformShift, n = 1u << (3 * subShift);
        const std::array<uint32_t, 3> grid = vol.brickGrid();
        const uint32_t b[3] = {brick % grid[0] << shift, brick / grid[0] % grid[1] << shift, brick / (grid[0] * grid[1]) << shift};
        uint64_t mask = 0;
        for (uint32_t j = 0; j < 64; ++j) {
            if (!uniformSubBlockInside(j, subShift, b[0], b[1], b[2], vol.dim[0], vol.dim[1], vol.dim[2])) continue;
            const uint32_t* run = labels + size_t(j) * n;
            if (std::all_of(run + 1, run + n, [&](uint32_t l) { return l == run[0]; })) mask |= uint64_t(1) << j;
        }
        return mask;
    }

    explicit Impl(Context& c) : ctx(c) {}

    /// The finest pixel stride (the settings' one or coarser) at which a frame of `pixels` in this
    /// shading mode, at the cost per pixel measured so far, takes at most `frameSeconds`. Before
    /// any frame was measured: a prior per device kind (kPriorSecondsPerRay, local shading's
    /// frames on lavapipe and NVIDIA rounded up), scaled by the rays each mode casts.
    uint32_t strideFor(const RenderSettings& st, uint64_t pixels, double frameSeconds) const {
        const uint32_t mode = uint32_t(st.shading) & 3;
        const double rays[4] = {1, 2, 2, 4};
        double seconds = secondsPerPixel[mode];
        if (seconds <= 0) { // not measured in this mode: a measured one, scaled by the rays each casts
            for (uint32_t m = 0; m < 4; ++m)
                if (secondsPerPixel[m] > 0) seconds = std::max(seconds, secondsPerPixel[m] / rays[m] * rays[mode]);
        }
        if (seconds <= 0) seconds = kPriorSecondsPerRay[ctx.device().type == "cpu" ? 0 : 1] * rays[mode];
        uint32_t stride = std::max<uint32_t>(1, st.subsampling);
        while (stride < 8 && double(pixels) * seconds / (stride * stride) > frameSeconds) stride *= 2;
        return stride;
    }
    /// A still render's coarse stride: coarse enough that a frame takes at most an eighth of the
    /// budget, so the first image (every pixel showing a sample or a preview, a few frames as
    /// bricks arrive) comes in a fraction of it. Later frames take the settings' own: every
    /// frame at a coarse stride costs a full-resolution gather besides its rays, so the finest
    /// stride converges fastest.
    uint32_t stillCoarseStride(const RenderSettings& st, uint64_t pixels, double budgetSeconds) const {
        return std::max(std::max<uint32_t>(1, st.subsampling), strideFor(st, pixels, std::max(budgetSeconds, 0.1) / 8));
    }
    void measureFrame(const RenderSettings& st, const FrameInput& in, const FrameStats& stats) {
        if (stats.milliseconds <= 0) return; // nothing was submitted
        const double s = stats.milliseconds / 1000 / std::max(1.0, renderedPixels(in, st.subsampling));
        double& avg = secondsPerPixel[uint32_t(st.shading) & 3];
        avg = avg > 0 ? 0.5 * (avg + s) : s;
    }

    // The steps of a frame, in order (renderFrame and render).
    Status validate(const FrameInput& in, const RenderSettings& st, Mat4& clipToWorld) const;
    Status detectChanges(const FrameInput& in);
    Result<FrameStats> frame(const FrameInput& in, const RenderSettings& st, const Mat4& clipToWorld);
    bool deferDenoise = false;        // frame(): gather only; render() denoises once after its frames
    bool denoisePending = false;      // the last frame gathered without denoising
    // denoiseA holds the gathered image of the accumulation so far (the last frame gathered and
    // nothing denoised since): a frame may then gather in its render pass (kFlagGatherInRender).
    bool gatheredValid = false;
    bool gatherInRender = false;      // this frame's kFlagGatherInRender (packParams)
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
        return st.denoise && (st.shading == Shading::AmbientOcclusion || st.shading == Shading::PathTracing);
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
        return usesPixelList && outlineWanted && st.subsampling == 1 && fillBlock <= 1;
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
    bool hiddenAll() const { return hiddenAllPending && hiddenLabels && !cacheEmpty; }
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
        clearPending = true;
        coarseStride = 0;
        shownWhole = false;
        accumulatedFrames = 0;
        prevMinSamples = 0;
        converged = false;
    }

    /// The per-pixel buffers for a new size, all or nothing: a failure keeps the old size whole.
    /// Buffers that hold the new size already are kept: a view switching between its reduced
    /// interactive size and its full size allocates nothing.
    Status allocateImage(uint32_t w, uint32_t h) {
        const uint64_t n = uint64_t(w) * h;
        imageDirty = true;
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
        return ((w1 >> kGBufferEpochShift) & kGBufferEpochMask) == gbufferEpoch ? w1 : 0u;
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
        Result<bool> changed = renderTexels.refresh(ctx, texelsWanted, {render});
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
        changed = resolveTexels.refresh(ctx, texelsWanted, {resolve, fromB}, 4); // a pixel's 16 bytes a texel
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
        decodeDispatches.clear();
        frameDecode = GpuVolume::FrameDecode{};
        Result<Buffer> b = ctx.createBuffer(bytes, cacheKind);
        if (!b) return Status(b.status()).prefix("allocating the brick cache");
        cache = std::move(*b);
        Status s;
        if (!hostDecode &&
            !(s = volume->appendFrameDecode(decodes.address(), alloc.address() + 4 * kAllocDecodes, cache.address(),
                                            decodeStates.address(), maxRequests, frameDecode, decodeDispatches,
                                            detail.get())))
            return s;
        allocWords()[kAllocCapacity] = uint32_t(bytes / 4);
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
        prefetchPending = true;
        cacheEmpty = true;
        return Status::ok();
    }
    /// Whether a frame asks for every visible brick at once (RendererOptions::prefetchVoxels). A
    /// new view otherwise finds its bricks one layer a frame: AAL (129 visible bricks of 32^3) at 1280x720
    /// on lavapipe took six frames, 0.60 s, to its first complete image, 0.46 s in one frame with
    /// it. Only for small volumes, where decoding bricks no view ray needs costs little: a
    /// synthetic 256^3 (512 bricks) decodes in 130 ms on two cores, what a view needs in 22 ms.
    bool prefetches() const {
        const uint64_t edge = volume->volume().brickSize;
        const uint64_t voxels = uint64_t(visibleBricks) * edge * edge * edge;
        const uint64_t bytes = uint64_t(visibleBricks) * volume->regionWords(0) * 4;
        return !detail && voxels <= prefetchVoxels && visibleBricks <= maxRequests && bytes <= cache.size() / 4;
    }
};

Renderer::~Renderer() = default;

bool decodesOnHost(RendererOptions::Decode decode, const DeviceInfo& device) {
    return decode == RendererOptions::Decode::Host || (decode == RendererOptions::Decode::Auto && device.type == "cpu");
}

bool decodesOnHost(RendererOptions::Decode decode, const DeviceInfo& device, const CompressedVolume& volume, uint64_t budget) {
    if (decodesOnHost(decode, device)) return true;
    if (decode != RendererOptions::Decode::Auto) return false;
    if (budget == 0) budget = automaticDeviceMemoryBudget(device);
    return GpuVolume::gpuDecodingBytes(volume, budget) > budget / 4 * 3;
}

Result<std::unique_ptr<Renderer>> Renderer::create(Context& context, std::shared_ptr<GpuVolume> volume,
                                                   const RendererOptions& options) {
    if (!volume) return Status::error("no volume to render");
    std::unique_ptr<Renderer> r(new Renderer());
    r->m_volume = volume;
    r->m_impl = std::make_unique<Impl>(context);
    Impl& im = *r->m_impl;
    im.volume = volume;
    const CompressedVolume& v = volume->volume();
    if (v.brickCount() > (uint64_t(1) << 28)) return Status::error("more than 2^28 bricks cannot be rendered");
    im.brickCount = uint32_t(v.brickCount());
    im.levels = v.levels();

    Defines d;
    d.emplace_back("BRICK_SIZE", std::to_string(v.brickSize) + "u");
    d.emplace_back("BRICK_SHIFT", std::to_string(log2u(v.brickSize)) + "u");
    d.emplace_back("LEVELS", std::to_string(v.levels()) + "u");
    d.emplace_back("VOLUME_DIM", uvec3Of(v.dim));
    d.emplace_back("BRICK_GRID", uvec3Of(v.brickGrid()));
    d.emplace_back("BRICKS_PER_ARRAY", std::to_string(v.bricksPerArray) + "u");
    d.emplace_back("CACHE_BITS", std::to_string(volume->cacheBits()));
    // Pixels per render and resolve invocation along each axis: CPU devices pay per invocation
    // (16 pixels against 4: 10-15 % less time a frame on lavapipe, local shading).
    constexpr uint32_t kCpuPixelBlock = 4;
    static_assert(kCpuPixelBlock * kCpuPixelBlock <= 32, "render.comp's listNext keeps a bit per pixel of an invocation");
    im.pixelBlock = context.device().type == "cpu" ? kCpuPixelBlock : 1;
    d.emplace_back("PIXEL_BLOCK", std::to_string(im.pixelBlock) + "u");
    im.requestBlock = context.device().type == "cpu" ? 64 : 1;
    d.emplace_back("REQUEST_BLOCK", std::to_string(im.requestBlock) + "u");
    if (volume->hostDecoding() && options.decode == RendererOptions::Decode::Gpu)
        return Status::error("GPU decoding was asked for, but the volume was uploaded for host decoding");
    im.hostDecode = volume->hostDecoding() || decodesOnHost(options.decode, context.device());
    // With host decoding a frame is two submissions: the render pass can be sized between them to
    // the pixels that take samples (CPU devices run every branch for all lanes: a pass over the
    // whole footprint would cost a few pixels' frame as much as a full one).
    im.usesPixelList = im.hostDecode;
    d.emplace_back("PIXEL_LIST", im.usesPixelList ? "1" : "0");
    const bool streaming = volume->separated() && !im.hostDecode; // host decoding reads every level from host memory
    d.emplace_back("DETAIL_STREAMING", streaming ? "1" : "0");
    d.emplace_back("ABSENT_BRICKS", volume->owned().empty() ? "0" : "1"); // an MPI rank's piece
    im.budget = options.deviceMemoryBytes ? options.deviceMemoryBytes : automaticDeviceMemoryBudget(context.device());
    im.lookup = planLabelLookup(volume->largestStoredLabel(), !volume->owned().empty(), im.budget);
    d.emplace_back("LABEL_LOOKUP", std::to_string(im.lookup.kind)); // tested by #if: no suffix
    im.defines = d;
    im.profileDispatches = std::getenv("CSGV_PROFILE_DISPATCHES") != nullptr;
    // CSGV_READ_THROUGH_COPIES=1: as on GPUs on any device (the tests run the renderer's suite so).
    const char* copies = std::getenv("CSGV_READ_THROUGH_COPIES");
    im.viaCopies = options.readBackThroughCopy || context.device().type != "cpu" || (copies && std::string(copies) == "1");

    auto make = [&](Buffer& b, uint64_t bytes, MemoryKind kind, const char* what) -> Status {
        Result<Buffer> res = context.createBuffer(std::max<uint64_t>(bytes, 16), kind);
        if (!res) return Status(res.status()).prefix(std::string("allocating the ") + what);
        b = std::move(*res);
        return Status::ok();
    };
    Status s;
    // The cache: a budget, within one allocation and 32-bit word offsets.
    // (Entries are counted in 32 bits: with cache paletting, fewer words.)
    const uint64_t maxBytes = std::min<uint64_t>(context.device().maxAllocation,
                                                 ((uint64_t(1) << 32) / volume->cacheEntriesPerWord()) * 4 - 4);
    im.maxRequests = std::max<uint32_t>(1, std::min<uint32_t>(options.maxRequestsPerFrame, im.brickCount));
    im.prefetchVoxels = options.prefetchVoxels;
    const MemoryKind hostOrDevice = im.hostDecode ? MemoryKind::HostVisible : MemoryKind::DeviceLocal;
    // Host decoding writes the cache and the masks itself, unless they live in device memory
    // (viaCopies: GPUs), where the render pass reads them at every step: then through copies.
    im.stagedDecode = im.hostDecode && im.viaCopies;
    const MemoryKind cacheKind = im.stagedDecode ? MemoryKind::DeviceLocal : hostOrDevice;
    im.cacheKind = cacheKind;
    // Everything but the cache and the images, sized once: summed for the budget, then allocated.
    struct Table {
        Buffer* buffer;
        uint64_t bytes;
        MemoryKind kind;
        const char* what;
    };
    const uint64_t bricks = im.brickCount, requests = im.maxRequests;
    const Table tables[] = {{&im.params, sizeof(FrameParams), im.viaCopies ? MemoryKind::DeviceLocal : MemoryKind::HostVisible, "frame parameters"},
                            {&im.paramsHost, im.viaCopies ? sizeof(FrameParams) : 0, MemoryKind::HostVisible, "frame parameters' host copy"},
                            {&im.bricks, bricks * 16, MemoryKind::DeviceLocal, "brick table"},
                            {&im.visible, bricks * 8, MemoryKind::DeviceLocal, "brick visibility"},
                            {&im.emptyGroups, bricks * 4, MemoryKind::DeviceLocal, "empty brick groups"},
                            {&im.uniformSubs, bricks * 8, cacheKind, "uniform sub-block masks"},
                            {&im.hiddenSubs, bricks * 8, MemoryKind::DeviceLocal, "hidden sub-block masks"},
                            {&im.alloc, kAllocWords * 4, im.viaCopies ? MemoryKind::DeviceLocal : MemoryKind::HostVisible, "cache counters"},
                            {&im.allocHost, im.viaCopies ? kAllocWords * 4 : 0, MemoryKind::HostVisible, "cache counters' host copy"},
                            {&im.freeStacks, bricks * im.levels * 4, MemoryKind::DeviceLocal, "free stacks"},
                            {&im.requests, requests * 8, MemoryKind::DeviceLocal, "request list"},
                            {&im.decodes, requests * kDecodeEntryWords * 4, hostOrDevice, "decode list"},
                            {&im.decodeStates, requests * kDecodeStateWords * 4, MemoryKind::DeviceLocal, "decoder states"},
                            {&im.blueNoise, sizeof(kBlueNoise64), MemoryKind::DeviceLocal, "blue-noise tile"},
                            {&im.detailRequests, streaming ? requests * 4 : 0, MemoryKind::HostVisible, "detail request list"}};
    // The budget: the encoding and the tables are fixed; the cache takes what they leave beside
    // room for an image, and shrinks later if images or materials need more.
    uint64_t fixed = volume->deviceBytes();
    for (const Table& t : tables) fixed += std::max<uint64_t>(t.bytes, 16); // as make() allocates
    const uint64_t smallestCache = im.smallestCacheBytes();
    // Detail streaming, unless the options say: a ring for the streams of two frames' requests of
    // average length (a stream is only needed until its brick is decoded), at most every stream
    // and a quarter of what the encoding and tables leave, at least twice the longest stream.
    uint64_t ringBytes = 0;
    if (streaming) {
        const uint64_t smallest = volume->detailSizes().smallestBytes, all = volume->detailSizes().streamBytes;
        const uint64_t left = im.budget > fixed + smallestCache ? im.budget - fixed - smallestCache : 0;
        const uint64_t twoFrames = 2 * requests * (all / std::max<uint64_t>(bricks, 1));
        ringBytes = options.detailBufferBytes ? std::max(options.detailBufferBytes, smallest)
                                              : std::max(smallest, std::min({twoFrames, all, left / 4}));
        fixed += DetailStream::deviceBytes(v, ringBytes);
    }
    if (fixed + smallestCache > im.budget)
        return Status::error("the device-memory budget of " + mebibytes(im.budget) + " is too small: the encoding takes " +
                             mebibytes(volume->deviceBytes()) + " and the brick tables" +
                             (streaming ? std::string(" and the detail buffer ") : std::string(" ")) +
                             mebibytes(fixed - volume->deviceBytes()) + ", and the brick cache needs at least " +
                             mebibytes(smallestCache));
    if (streaming) {
        Result<std::unique_ptr<DetailStream>> ds = DetailStream::create(context, v, ringBytes, &volume->detailSizes());
        if (!ds) return ds.status();
        im.detail = std::move(*ds);
    }
    const uint64_t wantedCache = options.cacheBytes ? options.cacheBytes : automaticCacheBytes(context.device());
    const uint64_t imageRoom = std::min<uint64_t>(kImageReserveBytes, (im.budget - fixed - smallestCache) / 4);
    const uint64_t cacheBytes =
        std::max(smallestCache, std::min({std::max<uint64_t>(wantedCache, 4096), maxBytes, im.budget - fixed - imageRoom})) &
        ~uint64_t(3);
    if (!(s = make(im.cache, cacheBytes, cacheKind, "brick cache"))) return s;
    im.texelsWanted = options.renderTexels;
    im.hiddenWanted = options.hiddenSubBlocks;
    im.outlineWanted = options.outlineSpans;
    for (const Table& t : tables)
        if (!(s = make(*t.buffer, t.bytes, t.kind, t.what))) return s;
    if (!(s = context.upload(im.blueNoise, 0, kBlueNoise64, sizeof(kBlueNoise64)))) return s;
    im.frameAddress = im.params.address();
    // The GPU decoding passes read the request list the frame wrote: the same dispatches every frame.
    if (!im.hostDecode &&
        !(s = volume->appendFrameDecode(im.decodes.address(), im.alloc.address() + 4 * kAllocDecodes, im.cache.address(),
                                        im.decodeStates.address(), im.maxRequests, im.frameDecode, im.decodeDispatches,
                                        im.detail.get())))
        return s;
    std::vector<uint32_t> brickWords(size_t(im.brickCount) * 4, 0u);
    for (size_t b = 0; b < im.brickCount; ++b) brickWords[4 * b] = brickWords[4 * b + 1] = kNone;
    if (!(s = context.upload(im.bricks, 0, brickWords.data(), brickWords.size() * 4))) return s;
    const std::vector<uint64_t> noMasks(im.brickCount, 0);
    if (!(s = context.upload(im.uniformSubs, 0, noMasks.data(), noMasks.size() * 8))) return s;
    if (!(s = context.upload(im.hiddenSubs, 0, noMasks.data(), noMasks.size() * 8))) return s;
    uint32_t* a = im.allocWords();
    std::fill(a, a + kAllocWords, 0u);
    a[kAllocCapacity] = uint32_t(cacheBytes / 4);
    if (!(s = r->setMaterials(defaultMaterials()))) return s;
    return r;
}

void Renderer::setGeometry(const Geometry& g) {
    Impl& im = *m_impl;
    if (g.origin == im.geometry.origin && g.spacing == im.geometry.spacing && g.direction == im.geometry.direction) return;
    im.geometry = g;
    resetAccumulation();
}

namespace {

/// Materials as the shaders read them, with the colormap samples and the attributes they name.
struct PackedMaterials {
    std::vector<GpuMaterial> materials;
    std::vector<std::array<float, 4>> colormapSamples;
    std::vector<std::string> attributeNames; ///< index = GpuMaterial's attribute number

    uint32_t attributeIndex(const std::string& name) {
        if (name == "label") return kNone;
        for (size_t i = 0; i < attributeNames.size(); ++i)
            if (attributeNames[i] == name) return uint32_t(i);
        attributeNames.push_back(name);
        return uint32_t(attributeNames.size() - 1);
    }
};

/// The number of labels that per-label arrays cover (they must agree), or an error.
Result<uint64_t> perLabelCount(const std::map<std::string, std::vector<float>>& attributes,
                               const std::vector<uint32_t>& storedToOriginal) {
    uint64_t labelCount = storedToOriginal.size();
    for (const auto& a : attributes) {
        if (labelCount != 0 && a.second.size() != labelCount)
            return Status::error("attribute '" + a.first + "' has " + std::to_string(a.second.size()) +
                                 " values, other per-label arrays have " + std::to_string(labelCount));
        labelCount = a.second.size();
    }
    if (labelCount >= kNone) return Status::error("too many labels with attributes");
    return labelCount;
}

/// One material in the GPU's layout; colormaps are sampled into `out.colormapSamples`.
Result<GpuMaterial> packMaterial(const Material& m, size_t index, PackedMaterials& out) {
    GpuMaterial g{};
    g.select[0] = out.attributeIndex(m.filterAttribute);
    // Label filters compare integers: [ceil(min), floor(max)] within 32 bits (empty: min > max).
    const double lo = std::ceil(std::max(m.filterMin, 0.0)), hi = std::floor(std::min(m.filterMax, 4294967295.0));
    g.select[1] = lo > 4294967295.0 ? kNone : uint32_t(lo);
    g.select[2] = hi < 0 ? 0u : uint32_t(hi);
    if (lo > hi) g.select[1] = 1, g.select[2] = 0;
    g.select[3] = m.colorMode == Material::ColorMode::Constant   ? kColorConstant
                  : m.colorMode == Material::ColorMode::Colormap ? kColorColormap
                                                                 : kColorRandom;
    g.range[0] = float(m.filterMin);
    g.range[1] = float(m.filterMax);
    g.range[2] = float(m.colorMin);
    g.range[3] = float(m.colorMax);
    g.rgba[0] = m.rgb[0];
    g.rgba[1] = m.rgb[1];
    g.rgba[2] = m.rgb[2];
    g.rgba[3] = std::clamp(m.opacity, 0.0f, 1.0f);
    g.colour[0] = m.colorMode == Material::ColorMode::Colormap ? out.attributeIndex(m.colorAttribute) : kNone;
    g.colour[1] = m.wrap == Material::Wrap::Repeat ? 1u : 0u;
    const std::string which = "material " + std::to_string(index + 1) + (m.name.empty() ? "" : " ('" + m.name + "')");
    if (!m.colormap.points.empty()) {
        if (m.colormap.points.size() < 2) return Status::error(which + ": a colormap needs two points");
        g.colour[2] = uint32_t(out.colormapSamples.size());
        g.colour[3] = kColormapSamples;
        for (uint32_t k = 0; k < kColormapSamples; ++k) {
            const auto c = m.colormap.at(double(k) / (kColormapSamples - 1));
            out.colormapSamples.push_back({c[0], c[1], c[2], 1.0f});
        }
    } else if (m.colorMode == Material::ColorMode::Colormap) {
        if (!m.colormap.name.empty())
            return Status::error(which + ": colormap '" + m.colormap.name + "' is not resolved to points");
        return Status::error(which + ": colormap mode without a colormap");
    }
    g.extra[0] = std::max(m.emission, 0.0f);
    return g;
}

Result<PackedMaterials> packMaterials(const MaterialDocument& doc) {
    PackedMaterials out;
    for (size_t i = 0; i < doc.materials.size(); ++i) {
        Result<GpuMaterial> g = packMaterial(doc.materials[i], i, out);
        if (!g) return g.status();
        out.materials.push_back(*g);
    }
    return out;
}

/// The first material whose filter holds a stored label, with the GPU's own comparisons
/// (integers for `label`, floats for attributes): what render_common.glsl's materialOf does.
struct MaterialMatcher {
    const PackedMaterials& packed;
    const std::map<std::string, std::vector<float>>& attributes;
    const std::vector<uint32_t>& storedToOriginal;
    uint64_t labelCount;

    uint32_t operator()(uint32_t stored) const {
        if (stored == kNone) return kNone;
        for (size_t i = 0; i < packed.materials.size(); ++i) {
            const GpuMaterial& g = packed.materials[i];
            if (g.select[0] == kNone) {
                const uint32_t l = !storedToOriginal.empty() && stored < labelCount ? storedToOriginal[stored] : stored;
                if (l >= g.select[1] && l <= g.select[2]) return uint32_t(i);
            } else {
                if (stored >= labelCount) continue;
                const float v = attributes.at(packed.attributeNames[g.select[0]])[stored];
                if (v >= g.range[0] && v <= g.range[1]) return uint32_t(i);
            }
        }
        return kNone;
    }
};

/// The per-label arrays and the label map as the shaders index them where the volume stores
/// labels as ids (GpuVolume::labelIds; `byId`): value i is the given one of label ids[i] (NaN past
/// the given arrays' `count` labels, as the shaders read an attribute there), and the label map
/// gives each id its original label (the given map's, or the label itself).
struct PerStored {
    bool byId = false;
    std::map<std::string, std::vector<float>> attributes;
    std::vector<uint32_t> storedToOriginal;
};
PerStored inStoredLabels(const std::vector<uint32_t>& ids, const std::map<std::string, std::vector<float>>& attributes,
                         const std::vector<uint32_t>& storedToOriginal, uint64_t count) {
    PerStored out;
    if (ids.empty()) return out;
    out.byId = true;
    out.storedToOriginal.resize(ids.size());
    for (size_t i = 0; i < ids.size(); ++i)
        out.storedToOriginal[i] = !storedToOriginal.empty() && ids[i] < count ? storedToOriginal[ids[i]] : ids[i];
    for (const auto& [name, values] : attributes) {
        std::vector<float>& v = out.attributes[name];
        v.resize(ids.size());
        for (size_t i = 0; i < ids.size(); ++i) v[i] = ids[i] < count ? values[ids[i]] : std::numeric_limits<float>::quiet_NaN();
    }
    return out;
}

/// A 64-bit digest of everything setMaterials uploads (the packed materials, their colormap
/// samples, the attribute arrays they name, the label map and count): equal digests, equal images.
uint64_t materialsFingerprint(const PackedMaterials& packed, const std::map<std::string, std::vector<float>>& attributes,
                              const std::vector<uint32_t>& storedToOriginal, uint64_t labels) {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    auto mix = [&h](const void* data, size_t bytes) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (size_t i = 0; i < bytes; i += 8) {
            uint64_t w = 0;
            std::memcpy(&w, p + i, std::min<size_t>(8, bytes - i));
            h = (h ^ w) * 0x100000001B3ull;
            h ^= h >> 29;
        }
        h = (h ^ bytes) * 0xFF51AFD7ED558CCDull;
    };
    mix(packed.materials.data(), packed.materials.size() * sizeof(GpuMaterial));
    mix(packed.colormapSamples.data(), packed.colormapSamples.size() * sizeof(packed.colormapSamples[0]));
    for (const std::string& name : packed.attributeNames) {
        const std::vector<float>& values = attributes.at(name);
        mix(name.data(), name.size());
        mix(values.data(), values.size() * 4);
    }
    mix(storedToOriginal.data(), storedToOriginal.size() * 4);
    mix(&labels, sizeof labels);
    return h == 0 ? 1 : h; // 0 means "nothing uploaded"
}

} // namespace

uint64_t Renderer::Impl::materialBytes(const PackedMaterials& packed,
                                       const std::map<std::string, std::vector<float>>& attributeArrays,
                                       const std::vector<uint32_t>& storedToOriginal) {
    auto made = [](uint64_t bytes) { return std::max<uint64_t>(bytes, 16); }; // as uploadDeviceLocal allocates
    uint64_t n = made(packed.materials.size() * sizeof(GpuMaterial)) + made(packed.colormapSamples.size() * 16) +
                 made(packed.attributeNames.size() * 8) + made(storedToOriginal.size() * 4);
    for (const std::string& name : packed.attributeNames) n += made(attributeArrays.at(name).size() * 4);
    // The label colours are allocated once (their size is the lookup's): counted when not yet there.
    return n + made(lookup.tableBytes()) + (labelColors.size() == 0 && lookup.colorBytes() > 0 ? made(lookup.colorBytes()) : 0);
}

Status Renderer::Impl::uploadDeviceLocal(Buffer& dst, const void* data, uint64_t bytes) {
    Result<Buffer> b = ctx.createBuffer(std::max<uint64_t>(bytes, 16), MemoryKind::DeviceLocal);
    if (!b) return b.status();
    Status s = ctx.upload(*b, 0, data, bytes);
    if (!s) return s;
    dst = std::move(*b);
    return Status::ok();
}

Status Renderer::Impl::uploadMaterials(const PackedMaterials& packed,
                                       const std::map<std::string, std::vector<float>>& attributeArrays,
                                       const std::vector<uint32_t>& storedToOriginal, uint64_t labels) {
    std::vector<uint64_t> addresses;
    std::vector<Buffer> buffers;
    Status s;
    for (const std::string& name : packed.attributeNames) {
        const std::vector<float>& values = attributeArrays.at(name);
        Buffer b;
        if (!(s = uploadDeviceLocal(b, values.data(), values.size() * 4))) return s.prefix("attribute '" + name + "'");
        addresses.push_back(b.address());
        buffers.push_back(std::move(b));
    }
    const std::vector<GpuMaterial>& mats = packed.materials;
    if (!(s = uploadDeviceLocal(materials, mats.data(), mats.size() * sizeof(GpuMaterial)))) return s;
    if (!(s = uploadDeviceLocal(colormaps, packed.colormapSamples.data(), packed.colormapSamples.size() * 16))) return s;
    if (!(s = uploadDeviceLocal(attributeTable, addresses.data(), addresses.size() * 8))) return s;
    if (!(s = uploadDeviceLocal(labelMap, storedToOriginal.data(), storedToOriginal.size() * 4))) return s;
    attributes = std::move(buffers);
    materialCount = uint32_t(mats.size());
    labelCount = uint32_t(labels);
    hasLabelMap = !storedToOriginal.empty();
    return Status::ok();
}

Status Renderer::Impl::uploadVisibility(const MaterialMatcher& materialOf) {
    // A table label -> material (LabelLookup) replaces the shader's scan of the material list.
    const std::vector<uint32_t> table = lookup.table(materialOf);
    Status s = uploadDeviceLocal(materialTable, table.data(), table.size() * 4);
    if (!s) return s;
    materialTableSize = uint32_t(table.size());
    if (lookup.colorBytes() > 0) { // the labels' colours, computed by the next frame (label_colors.comp)
        if (labelColors.size() == 0) {
            Result<Buffer> colors = ctx.createBuffer(lookup.colorBytes(), MemoryKind::DeviceLocal);
            if (!colors) return colors.status();
            labelColors = std::move(*colors);
        }
        labelColorsPending = true;
    }
    // Which bricks can show anything: their palettes against the materials.
    auto materialOfStored = [&](uint32_t stored) {
        return stored >= table.size() ? materialOf(stored) : lookup.hostMaterial(table, stored);
    };
    // The palettes' labels as the shaders see them (ids where the volume stores them).
    const std::vector<uint32_t>& ids = volume->labelIds();
    auto storedOf = [&](uint32_t label) { return ids.empty() ? label : idOfLabel(ids, label); };
    const CompressedVolume& vol = volume->volume();
    const uint32_t L = vol.levels();
    // The sub-blocks without drawn labels (kSlotHidden) are made anew, where the volume holds two
    // labels or more that no material draws (hiddenLabels; Core's castRaysStable decides alike):
    // with one, such a sub-block holds it alone, a uniform one, and the masks stay 0 (no pass).
    // Materials that draw the same labels (another colour, opacity) keep the masks: the table's
    // entries drawn or not, fingerprinted (without a table: made anew).
    uint64_t drawn = 1469598103934665603ull;
    for (uint32_t m : table) drawn = (drawn ^ (m == kNone ? 0x9Eu : 0x37u)) * 1099511628211ull;
    if (table.empty() || drawn != drawnFingerprint) hiddenAllPending = true;
    drawnFingerprint = table.empty() ? 0 : drawn;
    auto severalUndrawn = [&] {
        const auto undrawn = std::count(table.begin(), table.end(), kNone);
        if (!ids.empty()) return undrawn > 1; // the table holds the palettes' labels alone
        if (!table.empty() && undrawn < 2) return false; // not even among all labels
        uint32_t first = kNone; // the palettes' labels, until a second undrawn one
        for (uint64_t b = 0; b < brickCount; ++b) {
            if (!volume->owns(b)) continue;
            const BrickWords bw = vol.brick(b);
            for (uint32_t k = 0; k < bw.words[L]; ++k)
                if (const uint32_t l = bw.words[bw.size - 1 - k]; materialOfStored(l) == kNone) {
                    if (first != kNone && l != first) return true;
                    first = l;
                }
        }
        return false;
    };
    hiddenLabels = hiddenWanted && severalUndrawn();
    // Per brick its preview label and that label's material (what a view ray shows of the brick
    // while it is not cached: its coarsest level, the root label, else the first palette entry a
    // material draws), kNone twice when no palette entry is drawn (the brick is invisible).
    std::vector<uint32_t> vis(size_t(brickCount) * 2, kNone);
#pragma omp parallel for schedule(dynamic, 64)
    for (int64_t b = 0; b < int64_t(brickCount); ++b) {
        if (!volume->owns(uint64_t(b))) { // another process's brick (MPI): absent here
            vis[2 * size_t(b) + 1] = kBrickAbsent;
            continue;
        }
        const BrickWords bw = vol.brick(uint64_t(b));
        const uint32_t n = bw.words[L];
        for (uint32_t k = 0; k < n && vis[2 * size_t(b)] == kNone; ++k)
            if (const uint32_t l = storedOf(bw.words[bw.size - 1 - k]), m = materialOfStored(l); m != kNone) {
                vis[2 * size_t(b)] = l;
                vis[2 * size_t(b) + 1] = m;
            }
    }
    visibilityChanged = prefetchPending = true;
    visibleBricks = 0;
    for (size_t b = 0; b < brickCount; ++b) visibleBricks += vis[2 * b] != kNone ? 1 : 0;
    if (Status u = ctx.upload(visible, 0, vis.data(), vis.size() * 4); !u) return u;
    const std::vector<uint32_t> groups = emptyGroupLevels(
        vol.brickGrid(), [&](uint64_t b) { return vis[2 * b] == kNone && vis[2 * b + 1] != kBrickAbsent; });
    return ctx.upload(emptyGroups, 0, groups.data(), groups.size() * 4);
}

Status Renderer::setGhostFaces(const std::array<uint32_t, 3>& lo, const std::array<uint32_t, 3>& hi,
                               const std::array<std::vector<uint32_t>, 6>& faces) {
    Impl& im = *m_impl;
    if (im.volume->owned().empty()) return Status::error("ghost faces are for an MPI rank's piece (GpuVolumeOptions::owned)");
    std::vector<uint32_t> words(kGhostHeaderWords, 0u);
    for (int a = 0; a < 3; ++a) {
        if (hi[a] <= lo[a]) return Status::error("the piece's box is empty along axis " + std::to_string(a));
        words[size_t(a)] = lo[a];
        words[size_t(3 + a)] = hi[a];
    }
    for (int side = 0; side < 6; ++side) {
        const int a = side / 2, u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
        const std::vector<uint32_t>& f = faces[size_t(side)];
        if (f.empty()) continue;
        if (f.size() != size_t(hi[u] - lo[u]) * (hi[v] - lo[v]))
            return Status::error("ghost face " + std::to_string(side) + " holds " + std::to_string(f.size()) +
                                 " labels, not the piece's face");
        words[size_t(6 + side)] = uint32_t(words.size());
        words.insert(words.end(), f.begin(), f.end());
    }
    if (words.size() > 0xFFFFFFFFull) return Status::error("the ghost faces are too large");
    Status s = im.uploadDeviceLocal(im.ghost, words.data(), words.size() * 4);
    if (!s) return s.prefix("ghost faces");
    im.resetAccumulation();
    return Status::ok();
}

Status Renderer::setCoarseStandIns(uint32_t first, const std::vector<std::vector<uint32_t>>& levels) {
    Impl& im = *m_impl;
    const CompressedVolume& v = im.volume->volume();
    if (im.volume->owned().empty())
        return Status::error("coarse stand-ins are for an MPI rank's piece (GpuVolumeOptions::owned)");
    if (first >= v.levels() || levels.size() != v.levels() - first)
        return Status::error("coarse stand-ins: levels " + std::to_string(first) + " to the coarsest (" +
                             std::to_string(v.levels() - 1) + ") are needed, " + std::to_string(levels.size()) + " given");
    std::vector<uint32_t> words{first, uint32_t(levels.size())};
    static_assert(kCoarseHeaderWords == 2 && kCoarseLevelWords == 4, "the header written here");
    words.resize(kCoarseHeaderWords + kCoarseLevelWords * levels.size());
    for (size_t i = 0; i < levels.size(); ++i) {
        const std::array<uint32_t, 3> d = lodDimensions(v.dim, first + uint32_t(i));
        if (levels[i].size() != size_t(d[0]) * d[1] * d[2])
            return Status::error("coarse stand-ins: " + std::to_string(levels[i].size()) + " labels do not fill level " +
                                 std::to_string(first + i) + " of the volume");
        if (words.size() + levels[i].size() > 0xFFFFFFFFull) return Status::error("coarse stand-ins: too large");
        uint32_t* e = words.data() + kCoarseHeaderWords + kCoarseLevelWords * i;
        e[0] = uint32_t(words.size());
        std::copy(d.begin(), d.end(), e + 1);
        words.insert(words.end(), levels[i].begin(), levels[i].end());
    }
    Status s = im.uploadDeviceLocal(im.coarse, words.data(), words.size() * 4);
    if (!s) return s.prefix("coarse stand-ins");
    im.resetAccumulation();
    return Status::ok();
}

Status Renderer::setMaterials(const MaterialDocument& doc, const std::map<std::string, std::vector<float>>& attributes,
                              const std::vector<uint32_t>& storedToOriginal) {
    Impl& im = *m_impl;
    std::vector<std::string> names{"label"};
    for (const auto& a : attributes) names.push_back(a.first);
    Status s = checkAttributes(doc, names);
    if (!s) return s;
    Result<uint64_t> given = perLabelCount(attributes, storedToOriginal);
    if (!given) return given.status();
    Result<PackedMaterials> packed = packMaterials(doc);
    if (!packed) return packed.status();
    // What the shaders would read is what they read already (attributes loaded that no material
    // names, a document written anew with the same content): the accumulated image stays. (The
    // volume's ids, below, are the renderer's for good: the same inputs, the same arrays by id.)
    const uint64_t fingerprint = materialsFingerprint(*packed, attributes, storedToOriginal, *given);
    if (fingerprint == im.materialsFingerprint) return Status::ok();
    im.materialsFingerprint = 0;
    // Where the volume stores ids, the shaders index the per-label arrays and the label map by id.
    const PerStored perStored = inStoredLabels(im.volume->labelIds(), attributes, storedToOriginal, *given);
    const auto& attrs = perStored.byId ? perStored.attributes : attributes;
    const std::vector<uint32_t>& map = perStored.byId ? perStored.storedToOriginal : storedToOriginal;
    const uint64_t labels = perStored.byId ? perStored.storedToOriginal.size() : *given;
    resetAccumulation(); // before the uploads: a failure among them must not leave an image called exact
    if (!(s = im.makeRoom(im.materialBytes(*packed, attrs, map), "the materials and attributes"))) return s;
    if (!(s = im.uploadMaterials(*packed, attrs, map, labels))) return s;
    if (!(s = im.uploadVisibility(MaterialMatcher{*packed, attrs, map, labels}))) return s;
    im.materialsFingerprint = fingerprint;
    return Status::ok();
}

void Renderer::setSettings(const RenderSettings& settings) {
    if (settings == m_settings) return; // an unchanged value keeps the accumulated image
    // A pixel's k-th sample is the same whichever frame takes it, so another sample target or
    // pixel stride keeps every sample taken so far: the accumulation goes on from there (after
    // one-sample frames, which keep no sums, frame() takes them again: sumsStale).
    RenderSettings others = settings;
    others.sampleTarget = m_settings.sampleTarget;
    others.subsampling = m_settings.subsampling;
    const bool keep = others == m_settings;
    m_settings = settings;
    if (keep) m_impl->converged = false;
    else resetAccumulation();
}

bool RenderSettings::operator==(const RenderSettings& o) const {
    return shading == o.shading && shadingBlend == o.shadingBlend && maxBounces == o.maxBounces && aoRadius == o.aoRadius &&
           lodBias == o.lodBias && finest == o.finest && subsampling == o.subsampling && denoise == o.denoise &&
           jitter == o.jitter && sampleTarget == o.sampleTarget && lightDirection == o.lightDirection &&
           lightInWorld == o.lightInWorld && lightIntensity == o.lightIntensity && ambient == o.ambient &&
           environment == o.environment && toneMapping == o.toneMapping && brightness == o.brightness &&
           contrast == o.contrast && gamma == o.gamma && clipMin == o.clipMin && clipMax == o.clipMax;
}

void Renderer::resetAccumulation() { m_impl->resetAccumulation(); }

Status Renderer::preparePipelines(bool depthInput) {
    Impl& im = *m_impl;
    if (!im.renderTexels.valid() && !im.resolveTexels.valid()) {
        // Before the first frame there are no image buffers to view: the passes are made as the
        // frame's buffers will most likely be viewed (texel views where wanted and the cache fits
        // the device's limit; an image's buffers are far smaller). Should
        // that frame's views say otherwise (TexelViews::refresh), it drops these and makes its own.
        im.renderTexels.made = im.texelsWanted && TexelViews::fits(im.ctx, im.cache);
        im.resolveTexels.made = im.texelsWanted;
    }
    return im.ensurePipelines(m_settings, depthInput);
}

void Renderer::resetCache() {
    m_impl->cacheResetPending = true;
    m_impl->converged = false; // the next render() submits (and refills the cache)
}

// ---- one frame, in named steps ----

Status Renderer::Impl::validate(const FrameInput& in, const RenderSettings& st, Mat4& clipToWorld) const {
    if (in.width == 0 || in.height == 0 || in.width > 16384 || in.height > 16384)
        return Status::error("image size " + std::to_string(in.width) + "x" + std::to_string(in.height) +
                             " is not between 1x1 and 16384x16384");
    if (!invert(in.worldToClip, clipToWorld)) return Status::error("the camera matrix is singular");
    for (double x : in.worldToClip)
        if (!std::isfinite(x)) return Status::error("the camera matrix holds a non-finite value");
    const uint32_t stride = st.subsampling;
    if (stride != 1 && stride != 2 && stride != 4 && stride != 8)
        return Status::error("pixel subsampling must be 1, 2, 4 or 8, not " + std::to_string(stride));
    return Status::ok();
}

Status Renderer::Impl::detectChanges(const FrameInput& in) {
    if (in.width != width || in.height != height) {
        Status s = allocateImage(in.width, in.height);
        if (!s) return s;
        hadDepth = false;
        resetAccumulation();
    }
    if (in.worldToClip != lastWorldToClip) {
        lastWorldToClip = in.worldToClip;
        resetAccumulation();
    }
    // Opaque geometry that moved (or appeared) changes where rays stop: start anew. The renderer's
    // own copy is the host-visible buffer the shaders read: one comparison, at most one copy.
    const size_t depthBytes = size_t(in.width) * in.height * 4;
    if (bool(in.opaqueDepth) != hadDepth ||
        (in.opaqueDepth && std::memcmp(depthIn.mapped(), in.opaqueDepth, depthBytes) != 0)) {
        if (in.opaqueDepth) std::memcpy(depthIn.mapped(), in.opaqueDepth, depthBytes);
        hadDepth = in.opaqueDepth != nullptr;
        resetAccumulation();
    }
    return Status::ok();
}

Status Renderer::Impl::ensurePipelines(const RenderSettings& st, bool depthInput) {
    const std::vector<PipelineJob> jobs = pipelineJobs(st, depthInput);
    return jobs.empty() ? Status::ok() : makePipelines(ctx, jobs, profileDispatches);
}

std::vector<PipelineJob> Renderer::Impl::pipelineJobs(const RenderSettings& st, bool depthInput) {
    std::vector<PipelineJob> jobs;
    // Every frame asks; only a pipeline not made yet costs anything (its defines are built then).
    auto need = [&](uint64_t& pipeline, const char* name, uint32_t push = 8, const char* define = nullptr,
                    uint32_t value = 0) {
        if (pipeline) return;
        Defines d = defines;
        if (define) d.emplace_back(define, std::to_string(value) + "u");
        jobs.push_back({name, std::move(d), push, &pipeline});
    };
    const uint32_t mode = uint32_t(st.shading) & 3, tc = toneCurves(st), rv = renderVariant(st, depthInput);
    need(pRender[rv][mode], "render.comp", 8, "SHADING", mode);
    if (!jobs.empty() && jobs.back().out == &pRender[rv][mode]) {
        jobs.back().defines.emplace_back("TONE_CURVES", std::to_string(tc));
        jobs.back().defines.emplace_back("ONE_SAMPLE", oneSample(st) ? "1" : "0");
        jobs.back().defines.emplace_back("DEPTH_INPUT", depthInput ? "1" : "0");
        if (renderTexels.made) {
            jobs.back().defines.emplace_back("RENDER_TEXELS", "1");
            jobs.back().texelBindings = kRenderTexelCount;
        }
    }
    for (uint32_t pass = kResolveGather; pass <= kResolveAtrous4; ++pass)
        if (pass == kResolveGather ? !resolvesInRender(st) : denoises(st)) {
            need(pResolve[tc][pass], "resolve.comp", sizeof(ResolvePush), "RESOLVE_PASS", pass);
            if (!jobs.empty() && jobs.back().out == &pResolve[tc][pass]) {
                jobs.back().defines.emplace_back("TONE_CURVES", std::to_string(tc));
                jobs.back().defines.emplace_back("RESOLVE_OUTPUT", std::to_string(resolveTarget(pass)) + "u");
                if (resolveTexels.made) {
                    jobs.back().defines.emplace_back("RESOLVE_TEXELS", "1");
                    jobs.back().texelBindings = kResolveTexelCount;
                }
            }
        }
    need(pRequest, "cache_request.comp");
    need(pProvision, "cache_provision.comp");
    need(pAssign, "cache_assign.comp");
    need(pCommit, "cache_commit.comp");
    if (!hostDecode) need(pUniform, "cache_uniform.comp");
    // cache_hidden.comp reads the cache and the label table as the render pass does (its texel buffers).
    for (const auto& [pipeline, all] : {std::pair<uint64_t*, bool>{&pHidden, false}, {&pHiddenAll, true}}) {
        if (!(all ? hiddenAll() : hiddenLabels)) continue;
        need(*pipeline, "cache_hidden.comp", 8, "HIDDEN_ALL", all ? 1 : 0);
        if (!jobs.empty() && jobs.back().out == pipeline && renderTexels.made) {
            jobs.back().defines.emplace_back("RENDER_TEXELS", "1");
            jobs.back().texelBindings = kRenderTexelCount;
        }
    }
    if (usesPixelList) need(pPixelList, "pixel_list.comp");
    if (labelColorsPending) need(pLabelColors, "label_colors.comp");
    return jobs;
}

void Renderer::warmShadingModes(bool depthInput) {
    Impl& im = *m_impl;
    if (im.warming.valid()) return; // once per renderer
    std::vector<PipelineJob> jobs;
    for (uint32_t mode = 0; mode < kShadingModes; ++mode) {
        RenderSettings st = m_settings;
        st.shading = Shading(mode);
        for (PipelineJob& j : im.pipelineJobs(st, depthInput)) jobs.push_back(std::move(j));
    }
    if (jobs.empty()) return;
    Context* ctx = &im.ctx;
    std::atomic<bool>* stop = &im.stopWarming;
    try {
        im.warming = std::async(std::launch::async, [ctx, stop, jobs = std::move(jobs)] {
            lowerThisThreadsPriority(); // frames and the GUI first
            for (const PipelineJob& j : jobs) {
                if (stop->load()) return;
                // Into the context's pipeline table (by SPIR-V) and the shader cache: the frame
                // that needs it finds it there; an error is met (and reported) by that frame.
                (void)makePipeline(*ctx, j.name, j.defines, j.pushBytes, j.texelBindings, false);
            }
        });
    } catch (const std::system_error&) {
        // No thread to be had: a mode's first frame makes its pipelines, as without this call.
    }
}

void Renderer::waitForWarming() {
    if (m_impl->warming.valid()) m_impl->warming.wait();
}

/// The view: matrices, light, clip box, tone mapping, face normals (then packState).
Status Renderer::Impl::packParams(const FrameInput& in, const RenderSettings& st, const Mat4& clipToWorld) {
    // Index space <-> world <-> clip.
    const Mat4 indexToWorld = indexToWorldMatrix(geometry);
    Mat4 worldToIndex{};
    if (!invert(indexToWorld, worldToIndex)) return Status::error("the volume's spacing or direction is singular");
    const Mat4 indexToClip = multiply(in.worldToClip, indexToWorld);
    const Mat4 clipToIndex = multiply(worldToIndex, clipToWorld);

    FrameParams& p = hostParams();
    std::memset(&p, 0, sizeof(p));
    toFloat(clipToIndex, p.clipToIndex);
    toFloat(indexToClip, p.indexToClip);
    toFloat(indexToWorld, p.indexToWorld);
    toFloat(worldToIndex, p.worldToIndex);
    // View axes from the inverse projection, for a light given in view coordinates.
    const Vec3 c0 = transformPoint(clipToWorld, {0, 0, -1}), cx = transformPoint(clipToWorld, {1, 0, -1}),
               cy = transformPoint(clipToWorld, {0, 1, -1}), cf = transformPoint(clipToWorld, {0, 0, 1});
    const Vec3 right = normalize(sub(cx, c0)), up = normalize(sub(cy, c0)), forward = normalize(sub(cf, c0));
    Vec3 light{st.lightDirection[0], st.lightDirection[1], st.lightDirection[2]};
    if (!st.lightInWorld)
        for (int k = 0; k < 3; ++k) light[k] = st.lightDirection[0] * right[k] + st.lightDirection[1] * up[k] - st.lightDirection[2] * forward[k];
    light = normalize(light);
    const Vec3 lightIndex = transformDir(worldToIndex, light);
    for (int k = 0; k < 3; ++k) {
        p.lightWorld[k] = float(light[k]);
        p.lightIndex[k] = float(lightIndex[k]);
        p.environment[k] = st.environment[k];
    }
    p.lightWorld[3] = st.lightIntensity;
    p.lightIndex[3] = st.ambient;
    p.environment[3] = st.aoRadius;
    const auto& dim = volume->volume().dim;
    for (int k = 0; k < 3; ++k) {
        const bool whole = st.clipMin[k] >= st.clipMax[k];
        p.clipMin[k] = whole ? 0.0f : float(std::clamp<int64_t>(st.clipMin[k], 0, dim[k]));
        p.clipMax[k] = whole ? float(dim[k]) : float(std::clamp<int64_t>(st.clipMax[k], 0, dim[k]));
    }
    rect = footprintRect(indexToClip, p.clipMin, p.clipMax, in.width, in.height);
    // Only where the host lists the pixels, the outline is wanted and every pixel takes its own
    // samples (outlineFrame).
    spans = outlineFrame(st) ? footprintSpans(indexToClip, p.clipMin, p.clipMax, in.width, in.height, rect)
                             : std::vector<uint32_t>{};
    // A denoised frame of the outline whose cells hold or take all of the gathered image (the
    // first of an accumulation lists every cell; later ones keep what the last one gathered) has
    // its render pass write that image: no gather pass over the whole outline.
    gatherInRender = !spans.empty() && denoises(st) && (clearPending || gatheredValid);
    if (!spans.empty() && denoisedShading(st)) {
        // The resolve passes' rows (ResolvePush::spans; kResolveReach): the render pass samples the
        // widest (the frames after denoising ends too, so that they resolve the same pixels).
        uint32_t* words = static_cast<uint32_t*>(outlineRows.mapped());
        std::vector<uint32_t> sampled;
        for (uint32_t pass = 0; pass <= kResolveAtrous4; ++pass) {
            std::vector<uint32_t> reach = widenSpans(spans, rect, kResolveReach[pass]);
            for (size_t r = 0; r < reach.size() / 2; ++r) {
                words[kOutlineRowWords * r + 2 * pass] = reach[2 * r];
                words[kOutlineRowWords * r + 2 * pass + 1] = reach[2 * r + 1];
            }
            if (pass == 0) sampled = std::move(reach);
        }
        spans = std::move(sampled);
    }
    for (int k = 0; k < 4; ++k) p.rect[k] = rect[size_t(k)];
    p.clipMin[3] = st.lodBias;
    p.clipMax[3] = float(std::sqrt(clipToIndex[4] * clipToIndex[4] + clipToIndex[5] * clipToIndex[5] +
                                   clipToIndex[6] * clipToIndex[6]) * 2.0 / in.height);
    p.pixel[0] = 2.0f / float(in.width);
    p.pixel[1] = 2.0f / float(in.height);
    p.pixel[2] = float(std::max(fillBlock, st.subsampling));
    p.pixel[3] = std::clamp(st.shadingBlend, 0.0f, 1.0f);
    p.tone[0] = st.brightness;
    p.tone[1] = st.contrast;
    p.tone[2] = frameGamma(st);
    p.tone[3] = st.toneMapping ? 1.0f : 0.0f;
    // World normals of the index-space faces: the inverse transpose of index-to-world.
    for (int f = 0; f < 6; ++f) {
        Vec3 n{0, 0, 0};
        n[f / 2] = f % 2 == 0 ? -1.0 : 1.0;
        Vec3 w{};
        for (int r = 0; r < 3; ++r) w[r] = worldToIndex[r * 4 + 0] * n[0] + worldToIndex[r * 4 + 1] * n[1] + worldToIndex[r * 4 + 2] * n[2];
        w = normalize(w);
        for (int k = 0; k < 3; ++k) p.faceNormals[f][k] = float(w[k]);
    }
    packState(in, st, p);
    return Status::ok();
}

/// The accumulation and cache state: flags, frame and image words, limits, counts, buffer
/// addresses, and the counter words the GPU adds to this frame.
void Renderer::Impl::packState(const FrameInput& in, const RenderSettings& st, FrameParams& p) {
    uint32_t flags = 0;
    if (st.jitter) flags |= kFlagJitter;
    if (st.finest) flags |= kFlagFinest;
    if (st.denoise) flags |= kFlagDenoise;
    if (limitRequests) flags |= kFlagLimitRequests;
    if (in.opaqueDepth) flags |= kFlagDepthInput;
    if (hasLabelMap) flags |= kFlagLabelMap;
    if (resolvesInRender(st)) flags |= kFlagResolveInRender;
    if (gatherInRender) flags |= kFlagGatherInRender;
    if (visibilityChanged) flags |= kFlagVisibilityChanged;
    if (prefetchPending && prefetches()) flags |= kFlagPrefetch;
    // The next frame lists the pixels below the target (listPixels) only if every pixel is one
    // sample or less short of it then (a frame adds at most one). A cell is the same pixel in the
    // next frame only without subsampling (a stride's cells take another pixel of their block
    // each frame).
    if (usesPixelList && st.subsampling == 1 && st.sampleTarget > 0 &&
        (clearPending ? 0 : prevMinSamples) + 2 >= st.sampleTarget)
        flags |= kFlagListNext;
    visibilityChanged = prefetchPending = false;
    const uint32_t stride = st.subsampling;
    p.frame[0] = frameIndex;
    p.frame[1] = flags;
    if (clearPending) { // a new accumulation: a new epoch, the G-buffer filled whole when they wrap
        gbufferEpoch = imageDirty ? 1 : gbufferEpoch % kGBufferEpochs + 1;
        gbufferFill = gbufferFill || gbufferEpoch == 1; // until a clear fills it
    }
    p.frame[2] = gbufferEpoch;
    p.frame[3] = st.sampleTarget;
    p.image[0] = in.width;
    p.image[1] = in.height;
    p.image[2] = stride;
    p.image[3] = accumulatedFrames % (stride * stride);
    p.limits[0] = maxRequests;
    p.limits[1] = bandRow;
    p.limits[2] = bandRow + bandHeight;
    p.limits[3] = std::min<uint32_t>(st.maxBounces, 32);
    p.counts[0] = materialCount;
    p.counts[1] = brickCount;
    p.counts[2] = labelCount;
    p.counts[3] = materialTableSize;
    const std::pair<uint32_t, const Buffer*> slots[] = {
        {kSlotBricks, &bricks},       {kSlotCache, &cache},         {kSlotAlloc, &alloc},         {kSlotFree, &freeStacks},
        {kSlotRequests, &requests},   {kSlotDecodes, &decodes},     {kSlotAccum, &accum},
        {kSlotGBuffer, &gbuffer},     {kSlotDepthIn, &depthIn},     {kSlotMaterials, &materials}, {kSlotColormaps, &colormaps},
        {kSlotAttributes, &attributeTable}, {kSlotOutput, &colorDepth}, {kSlotLabelMap, &labelMap},
        {kSlotDenoiseA, &denoiseA},   {kSlotDenoiseB, &denoiseB},   {kSlotVisible, &visible},     {kSlotBlueNoise, &blueNoise},
        {kSlotMaterialTable, &materialTable}, {kSlotUniform, &uniformSubs}, {kSlotLabelColors, &labelColors},
        {kSlotPixelList, &pixelList}, {kSlotHidden, &hiddenSubs}, {kSlotEmptyGroups, &emptyGroups}};
    for (const auto& sl : slots) p.addr[sl.first] = sl.second->address();
    p.addr[kSlotArrays] = volume->arraysAddress();
    p.addr[kSlotStarts] = volume->startsAddress();
    p.addr[kSlotDetail] = detail ? detail->tableAddress() : 0;
    p.addr[kSlotDetailRequests] = detailRequests.address();
    p.addr[kSlotGhost] = ghost.size() > 0 ? ghost.address() : 0;
    p.addr[kSlotCoarse] = coarse.size() > 0 ? coarse.address() : 0;

    uint32_t* a = allocWords();
    a[kAllocFull] = 0;
    a[kAllocMinSamples] = kNone;
    a[kAllocHoles] = 0;
    a[kAllocPreviews] = 0;
    a[kAllocNewSamples] = 0;
    a[kAllocMissing] = 0;
    a[kAllocMinRow] = kNone;
    a[kAllocListCount] = 0;
    a[kAllocNextCount] = 0;
    a[kAllocNextKept] = kNone;
    a[kAllocPrevMin] = prevMinSamples;
    a[kAllocEvictAge] = evictAge;
    a[kAllocDetailRequests] = 0;
}

void Renderer::Impl::buildDispatches(const FrameInput& in, const RenderSettings& st, uint64_t renderPipeline) {
    resolvePushes.clear();
    resolvePushes.reserve(8); // the list points into it: no reallocation while building
    dispatches.clear();
    const uint32_t tile = kGroupTile * pixelBlock; // kGroupTile^2 invocations of PIXEL_BLOCK^2 pixels
    if (clearPending) addClear(in);
    const uint32_t perGroup = kGroupBricks * requestBlock;
    addDispatch(pRequest, &frameAddress, 8, (brickCount + perGroup - 1) / perGroup, 1);
    addDispatch(pProvision, &frameAddress, 8, 1, 1);
    addDispatch(pAssign, &frameAddress, 8, (maxRequests + kGroupBricks - 1) / kGroupBricks, 1);
    addDispatch(pCommit, &frameAddress, 8, 1, 1);
    if (usesPixelList) listPixels(st);
    cacheStages = dispatches.size(); // with host decoding, the first submission ends here
    if (!hostDecode) {
        dispatches.insert(dispatches.end(), decodeDispatches.begin(), decodeDispatches.end());
        addDispatch(pUniform, &frameAddress, 8, maxRequests, 1); // a group per decode (host decoding marks them itself)
    }
    // The sub-blocks without drawn labels: after a change of materials none, then (where there are
    // several labels undrawn) those of every cached brick; else those of the bricks decoded now
    // (a group per decode; host decoding sizes it in submit()).
    hiddenDispatch = SIZE_MAX;
    if (hiddenAllPending) {
        Context::Dispatch zero;
        zero.fill = &hiddenSubs;
        zero.fillBytes = uint64_t(brickCount) * 8;
        dispatches.push_back(zero);
    }
    if (hiddenAll()) {
        addDispatch(pHiddenAll, &frameAddress, 8, (brickCount + kHiddenGroupBricks - 1) / kHiddenGroupBricks, 1);
    } else if (hiddenLabels) {
        hiddenDispatch = dispatches.size();
        addDispatch(pHidden, &frameAddress, 8, maxRequests, 1);
    }
    if ((hiddenAll() || hiddenLabels) && renderTexels.valid()) dispatches.back().texels = &renderTexels.sets[0];
    const std::array<uint32_t, 2> cells = cellGrid(st.subsampling);
    const uint32_t rw = cells[0], rh = cells[1];
    if (labelColorsPending) // the materials changed: their colours per label first (frame() made the pipeline)
        addDispatch(pLabelColors, &frameAddress, 8,
                    uint32_t(std::min<uint64_t>((lookup.entries() + kGroupLabels - 1) / kGroupLabels, 4096)), 1);
    renderDispatch = dispatches.size();
    addDispatch(renderPipeline, &frameAddress, 8, (rw + tile - 1) / tile, (rh + tile - 1) / tile); // PIXEL_LIST: sized in submit()
    if (renderTexels.valid()) dispatches.back().texels = &renderTexels.sets[0];
    if (!denoises(st)) {
        gatheredValid = false; // denoiseA is not written
        if (!resolvesInRender(st)) addResolve(kResolveGather, kSlotDenoiseA, kSlotOutput);
        return;
    }
    if (!gatherInRender) addResolve(kResolveGather, kSlotDenoiseA, kSlotDenoiseA);
    // denoiseA keeps this frame's gathered image only until the denoising passes (the step-2
    // pass writes it).
    gatheredValid = deferDenoise;
    denoisePending = deferDenoise;
    if (!deferDenoise) addDenoisePasses();
}

void Renderer::Impl::addDispatch(uint64_t pipeline, const void* push, uint32_t bytes, uint32_t gx, uint32_t gy) {
    Context::Dispatch d;
    d.pipeline = pipeline;
    d.pushConstants = push;
    d.pushConstantBytes = bytes;
    d.groups[0] = std::max(gx, 1u);
    d.groups[1] = std::max(gy, 1u);
    dispatches.push_back(d);
}

void Renderer::Impl::addResolve(uint32_t pass, uint32_t src, uint32_t dst) {
    const uint32_t tile = kGroupTile * pixelBlock;
    // The passes' spans where the frame takes the outline's pixels alone (packParams wrote them).
    const uint64_t outline = spans.empty() ? 0 : outlineRows.address();
    resolvePushes.push_back({frameAddress, src, dst, outline}); // reserved: the list points into it
    addDispatch(pResolve[curves][pass], &resolvePushes.back(), sizeof(ResolvePush), (rect[2] - rect[0] + tile - 1) / tile,
                (rect[3] - rect[1] + tile - 1) / tile);
    if (resolveTexels.valid()) dispatches.back().texels = &resolveTexels.sets[src == kSlotDenoiseB ? 1 : 0];
}

void Renderer::Impl::addDenoisePasses() {
    addResolve(kResolveAtrous1, kSlotDenoiseA, kSlotDenoiseB);
    addResolve(kResolveAtrous2, kSlotDenoiseB, kSlotDenoiseA);
    addResolve(kResolveAtrous4, kSlotDenoiseA, kSlotOutput); // tone-mapped into the output
    static_assert(resolveTarget(kResolveAtrous1) == kResolveToBuffer && resolveTarget(kResolveAtrous2) == kResolveToBuffer &&
                      resolveTarget(kResolveAtrous4) == kResolveToOutput,
                  "resolve.comp is compiled for the targets these passes write");
}

void Renderer::Impl::addClear(const FrameInput& in) {
    // Fills, not a compute pass: pixels outside the footprint keep these values all along, so
    // only the rows drawn since the last clear need them (all of new or resized buffers). The
    // G-buffer's entries of earlier accumulations read as cleared (their epoch is another), so it
    // is filled only when new or when the epochs wrap (whole then: an entry of any row may hold
    // the epoch that comes round again). The accumulation needs none: it is read only where a
    // pixel's sample count (cleared) is not 0.
    uint32_t y0 = 0, y1 = in.height; // new or resized buffers: whole
    if (!imageDirty) {
        const bool drawn = drawnRect[0] < drawnRect[2] && drawnRect[1] < drawnRect[3];
        y0 = drawn ? drawnRect[1] : 0;
        y1 = drawn ? drawnRect[3] : 0;
    }
    const uint64_t pixels = uint64_t(in.width) * in.height;
    const uint64_t first = uint64_t(y0) * in.width, n = uint64_t(y1 - y0) * in.width;
    const std::tuple<const Buffer*, uint64_t, uint64_t, uint64_t> filled[] = {
        {&gbuffer, 16, 0, gbufferFill ? pixels : 0} /* no samples */,
        {&colorDepth, 8, first, n} /* colour 0, depth 1 (kOutputDepthXor) */};
    gbufferFill = false;
    for (const auto& [buffer, bytes, from, count] : filled) {
        if (count == 0) continue;
        Context::Dispatch d;
        d.fill = buffer;
        d.fillOffset = from * bytes;
        d.fillBytes = count * bytes;
        d.fillValue = 0;
        dispatches.push_back(d);
    }
}

bool Renderer::Impl::resolvesInRender(const RenderSettings& st) const {
    // Without denoising or upsampling the gather only divides and tone-maps each pixel: the
    // render pass does that for the pixels it samples, and the others keep their output.
    return !denoises(st) && st.subsampling == 1 && fillBlock <= 1;
}

bool Renderer::Impl::denoises(const RenderSettings& st) const {
    // Denoising is for the noise of the stochastic modes; it fades out as samples accumulate and
    // is skipped once every pixel has 64.
    return denoisedShading(st) && prevMinSamples < 64;
}

Status Renderer::Impl::denoiseOutput() {
    denoisePending = false;
    gatheredValid = false; // the step-2 pass writes denoiseA
    dispatches.clear();
    resolvePushes.clear();
    resolvePushes.reserve(8);
    addDenoisePasses();
    outputParts = 0;
    return run(dispatches);
}

void Renderer::Impl::listPixels(const RenderSettings& st) {
    const uint32_t stride = st.subsampling;
    const std::array<uint32_t, 2> g = cellGrid(stride);
    const uint32_t gx = g[0], gy = g[1];
    const uint64_t cells = uint64_t(gx) * gy;
    // When most pixels have taken their last sample but some have not (the still loop's last
    // frames, or pixels that met missing bricks), pixel_list.comp lists those; otherwise every
    // cell samples and the host lists them all (written once per grid, read back to nothing).
    if (!clearPending && st.sampleTarget > 0 && prevMinSamples + 1 >= st.sampleTarget) {
        const NextList& nl = nextList;
        if (nl.valid && nl.grid == std::array<uint32_t, 4>{gx, gy, stride, st.sampleTarget}) {
            // The last render pass listed them: no pass over the whole grid.
            uint32_t* list = static_cast<uint32_t*>(pixelList.mapped());
            std::memmove(list, list + size_t(width) * height, size_t(nl.count) * 4);
            uint32_t* a = allocWords();
            a[kAllocListCount] = nl.count;
            a[kAllocMinSamples] = a[kAllocNextKept] = nl.kept; // the cells left out keep their samples
            listedGrid = {};
            return;
        }
        const uint64_t perGroup = uint64_t(kGroupList) * kListBlock;
        addDispatch(pPixelList, &frameAddress, 8, uint32_t((cells + perGroup - 1) / perGroup), 1);
        listedGrid = {}; // it writes over the host's list
        return;
    }
    // A frame where every pixel takes its own samples (outlineFrame) takes the pixels within the
    // box's outline alone (RendererOptions::outlineSpans): those outside its rows' spans would
    // sample nothing and keep their cleared output (as pixels outside the rectangle do), their
    // count 0; the resolve passes, if any, skip them too (ResolvePush::spans). The frames
    // that follow list the cells the render pass leaves below the target (kFlagListNext); should
    // pixel_list.comp list by counts instead (a target lowered below the samples taken), it lists
    // those pixels too: they take samples of nothing. The list is written again only when its
    // grid or spans change (the spans are of the rows' cells: columns from the rectangle's edge).
    std::vector<uint32_t> rows;
    if (!spans.empty()) {
        rows = spans;
        for (uint32_t& x : rows) x -= rect[0];
    }
    const std::array<uint32_t, 3> grid{gx, gy, stride};
    if (listedGrid != grid || listedSpans != rows) {
        uint32_t* list = static_cast<uint32_t*>(pixelList.mapped());
        uint32_t n = 0;
        auto span = [&](uint32_t y) {
            return rows.empty() ? std::array<uint32_t, 2>{0, gx} : std::array<uint32_t, 2>{rows[2 * size_t(y)], rows[2 * size_t(y) + 1]};
        };
        // Eight consecutive entries are one SIMD group's lanes on CPU devices: whole tiles of
        // kListTile cells first (rays of a compact tile are more alike than a row's eight: fewer
        // lanes wait at an edge; 2x4 measured fastest), then the cells outside them row by row.
        constexpr uint32_t kTileW = kListTile[0], kTileH = kListTile[1];
        std::vector<std::array<uint32_t, 2>> tiled(gy, std::array<uint32_t, 2>{0, 0}); // per row: the tiles' columns
        for (uint32_t y = 0; y + kTileH <= gy; y += kTileH) {
            uint32_t x0 = 0, x1 = gx;
            for (uint32_t r = 0; r < kTileH; ++r) {
                x0 = std::max(x0, span(y + r)[0]);
                x1 = std::min(x1, span(y + r)[1]);
            }
            if (x1 < x0 + kTileW) continue;
            x1 = x0 + (x1 - x0) / kTileW * kTileW;
            for (uint32_t x = x0; x < x1; x += kTileW)
                for (uint32_t r = 0; r < kTileH; ++r)
                    for (uint32_t c = 0; c < kTileW; ++c) list[n++] = (x + c) | ((y + r) << 16);
            for (uint32_t r = 0; r < kTileH; ++r) tiled[y + r] = {x0, x1};
        }
        for (uint32_t y = 0; y < gy; ++y)
            for (uint32_t x = span(y)[0]; x < span(y)[1]; ++x)
                if (x < tiled[y][0] || x >= tiled[y][1]) list[n++] = x | (y << 16);
        listedGrid = grid;
        listedSpans = std::move(rows);
        listedCount = n;
    }
    allocWords()[kAllocListCount] = listedCount;
}

void Renderer::Impl::sizeRenderDispatch() {
    // The decoded bricks' hidden sub-blocks: a group per decode; nothing decoded, nothing to mark.
    if (hiddenDispatch < dispatches.size()) {
        const uint32_t decoded = std::min(allocWords()[kAllocDecodes], maxRequests);
        if (decoded == 0) {
            dispatches.erase(dispatches.begin() + std::ptrdiff_t(hiddenDispatch));
            if (renderDispatch > hiddenDispatch) --renderDispatch;
            hiddenDispatch = SIZE_MAX;
        } else {
            dispatches[hiddenDispatch].groups[0] = decoded;
        }
    }
    if (!usesPixelList) return;
    const uint64_t perGroup = uint64_t(kGroupTile) * kGroupTile * pixelBlock * pixelBlock;
    Context::Dispatch& d = dispatches[renderDispatch];
    d.groups[0] = uint32_t((allocWords()[kAllocListCount] + perGroup - 1) / perGroup);
    d.groups[1] = 1;
}

Status Renderer::Impl::submit() {
    Status s;
    if (profileDispatches) { // one submission per dispatch, timed (diagnostics)
        auto stage = [&](const Context::Dispatch& d) -> std::string {
            if (d.fill) return "clear";
            const std::pair<uint64_t, const char*> named[] = {
                {pRequest, "request"}, {pProvision, "provision"}, {pAssign, "assign"}, {pCommit, "commit"},
                {pUniform, "uniform sub-blocks"}, {pHidden, "hidden sub-blocks"}, {pHiddenAll, "hidden sub-blocks (all)"},
                {pPixelList, "pixel list"}, {pLabelColors, "label colours"}};
            for (const auto& [p, name] : named)
                if (d.pipeline == p) return name;
            for (const auto& variant : pRender)
                for (const uint64_t p : variant)
                    if (d.pipeline == p) return "render";
            const char* const resolves[] = {"gather", "a-trous 1", "a-trous 2", "a-trous 4"};
            static_assert(std::size(resolves) == kResolveAtrous4 + 1, "a name per resolve pass");
            for (const auto& variant : pResolve)
                for (size_t k = 0; k < std::size(variant); ++k)
                    if (d.pipeline == variant[k]) return resolves[k];
            return "decode";
        };
        const auto t0 = std::chrono::steady_clock::now();
        for (size_t i = 0; i < dispatches.size(); ++i) {
            auto t1 = std::chrono::steady_clock::now();
            if (hostDecode && i == cacheStages) {
                sizeRenderDispatch();
                if (!(s = decodeOnHost())) return s;
                if (!stagedCopies.empty() && !(s = run(withStagedCopies(nullptr, 0)))) return s;
                const auto t2 = std::chrono::steady_clock::now();
                std::fprintf(stderr, "host decode: %.2f ms\n", std::chrono::duration<double, std::milli>(t2 - t1).count());
                t1 = t2; // the next dispatch's line is its own time alone
            }
            if (!(s = run(&dispatches[i], 1))) return s;
            std::fprintf(stderr, "dispatch %zu %s (%u x %u groups): %.2f ms\n", i, stage(dispatches[i]).c_str(),
                         dispatches[i].groups[0], dispatches[i].groups[1],
                         std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count());
        }
        std::fprintf(stderr, "dispatches: %.2f ms in all\n",
                     std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        return Status::ok();
    }
    if (hostDecode) {
        // Two submissions: cache stages; Core decodes the list into the cache; render and resolve.
        if (!(s = run(dispatches.data(), cacheStages))) return s;
        sizeRenderDispatch();
        if (!(s = decodeOnHost())) return s;
        const Context::Dispatch* rest = dispatches.data() + cacheStages;
        const size_t count = dispatches.size() - cacheStages;
        return stagedCopies.empty() ? run(rest, count) : run(withStagedCopies(rest, count));
    }
    return run(dispatches); // one submission: cache stages, decoding, rendering, resolving
}

bool Renderer::Impl::applyCachePolicy(const FrameStats& stats, const FrameInput& in, uint32_t stride) {
    // Cache pressure, decided between frames, gradually (nothing is flushed because the camera
    // moved):
    // - full: evict bricks no ray used for kEvictAgeStart frames, then for half as many each frame
    //   it stays full, down to the previous frame, or at a pixel stride s the previous s^2 (least
    //   recently used first); then let only a band of pixels (row-major, from the first pixel
    //   with the fewest samples) request bricks, halved while full. A full cache whose free stacks hold a large share of it is fragmented
    //   (free regions of other levels than those requested): it is reset (defragmented), at most
    //   once every kDefragInterval frames, or at once when that is the only way on: eviction is at
    //   its youngest age and the frame could place no brick (a render loop would otherwise see
    //   idle frames and stop with pixels unsampled).
    // - not full: the band doubles until it covers the image; kQuietFrames frames later eviction
    //   stops.
    // The band always holds the pixel with the fewest samples, so every pixel converges as long as
    // the cache holds the bricks one pixel's rays need.
    const uint64_t pixels = uint64_t(in.width) * in.height;
    // At a pixel stride s a pixel is rendered every s^2 frames: a brick unused for fewer frames
    // may be needed by the next pixels of its block.
    const uint32_t youngest = stride * stride;
    const uint32_t oldAge = evictAge, oldBand = limitRequests ? bandHeight : 0;
    ++framesSinceDefrag;
    if (stats.cacheFull) {
        quietFrames = 0;
        const bool blocked = evictAge == youngest && stats.decodedBricks == 0;
        if ((framesSinceDefrag >= kDefragInterval || blocked) && fragmented()) {
            cacheResetPending = true;
            framesSinceDefrag = 0;
        } else if (evictAge != youngest) {
            evictAge = evictAge == 0 ? std::max(kEvictAgeStart, 2 * youngest) : std::max(youngest, evictAge / 2);
        } else if (!limitRequests) {
            limitRequests = true;
            bandHeight = uint32_t(std::max<uint64_t>(1, pixels / 2));
        } else {
            bandHeight = std::max<uint32_t>(1, bandHeight / 2);
        }
    } else if (limitRequests) {
        bandHeight = uint32_t(std::min<uint64_t>(uint64_t(bandHeight) * 2, pixels));
        limitRequests = bandHeight < pixels;
    } else if (++quietFrames >= kQuietFrames) {
        evictAge = 0;
    }
    const uint32_t minRow = allocWords()[kAllocMinRow];
    if (limitRequests) bandRow = minRow == kNone ? 0 : minRow;
    prevMinSamples = stats.minSamples;
    return cacheResetPending || evictAge != oldAge || (limitRequests ? bandHeight : 0) != oldBand;
}

bool Renderer::Impl::fragmented() {
    const uint32_t* a = allocWords();
    uint64_t freeWords = 0;
    for (uint32_t l = 0; l < levels; ++l)
        freeWords += uint64_t(std::min(a[kAllocFreeCount + l], brickCount)) * volume->regionWords(l);
    return freeWords * kFragmentedShare >= a[kAllocCapacity];
}

Result<FrameStats> Renderer::Impl::frame(const FrameInput& in, const RenderSettings& st, const Mat4& clipToWorld) {
    Status s = viewBuffers();
    if (!s) return s;
    if (!(s = ensurePipelines(st, in.opaqueDepth != nullptr))) return s;
    FrameStats stats;
    if (st.sampleTarget > 0 && prevMinSamples >= st.sampleTarget && !clearPending && !cacheResetPending) {
        // Every pixel holds its samples: the image is final, nothing to submit.
        stats.frame = accumulatedFrames;
        stats.minSamples = prevMinSamples;
        stats.stride = st.subsampling;
        stats.cacheUsedBytes = uint64_t(allocWords()[kAllocTop]) * 4;
        return stats;
    }
    if (sumsStale && !oneSample(st)) { // the samples so far kept no sums: take them again
        clearPending = true;
        accumulatedFrames = 0;
        prevMinSamples = 0;
    }
    if (cacheResetPending) {
        if (!(s = resetCacheNow())) return s;
        cacheResetPending = false;
        stats.cacheReset = true;
    }
    if (!(s = packParams(in, st, clipToWorld))) return s;
    curves = toneCurves(st);
    buildDispatches(in, st, pRender[renderVariant(st, in.opaqueDepth != nullptr)][uint32_t(st.shading) & 3]);
    // After the clear (addClear reads what was drawn before it): this frame's footprint joins.
    drawnRect = clearPending ? rect : rectUnion(drawnRect, rect);
    const auto t0 = std::chrono::steady_clock::now();
    if (detail && !(s = commitDetail())) return s;
    if (!(s = submit())) return s;
    labelColorsPending = false;
    hiddenAllPending = false;
    cacheEmpty = false;
    if (detail && !(s = requestDetail(stats))) return s;
    stats.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    stats.detailUploads = detailUploads;
    sumsStale = (sumsStale && !clearPending) || oneSample(st);
    clearPending = imageDirty = false;
    outputParts = 0; // the read-back output is stale now
    ++frameIndex;
    ++accumulatedFrames;

    const uint32_t* a = allocWords();
    stats.frame = accumulatedFrames;
    stats.decodedBricks = a[kAllocDecodes];
    stats.newSamples = a[kAllocNewSamples];
    stats.missingPixels = a[kAllocMissing];
    stats.minSamples = a[kAllocMinSamples] == kNone ? 0 : a[kAllocMinSamples];
    stats.holes = a[kAllocHoles];
    stats.previews = a[kAllocPreviews];
    stats.stride = st.subsampling;
    stats.cacheUsedBytes = uint64_t(a[kAllocTop]) * 4;
    stats.cacheFull = a[kAllocFull] != 0;
    stats.requestLimited = limitRequests;
    const std::array<uint32_t, 2> g = cellGrid(st.subsampling);
    nextList.valid = (hostParams().frame[1] & kFlagListNext) != 0;
    nextList.grid = {g[0], g[1], st.subsampling, st.sampleTarget};
    nextList.count = a[kAllocNextCount];
    nextList.kept = a[kAllocNextKept];
    stats.cacheAdapting = applyCachePolicy(stats, in, st.subsampling);
    return stats;
}

Result<FrameStats> Renderer::renderFrame(const FrameInput& in) {
    Impl& im = *m_impl;
    Mat4 clipToWorld{};
    Status s = im.validate(in, m_settings, clipToWorld);
    if (!s) return s;
    if (!(s = im.detectChanges(in))) return s;
    return im.frame(in, m_settings, clipToWorld);
}

Result<RenderResult> Renderer::render(const RenderRequest& request) {
    Impl& im = *m_impl;
    const FrameInput& in = request.frame;
    Mat4 clipToWorld{};
    Status s = im.validate(in, m_settings, clipToWorld);
    if (!s) return s;
    if (!(s = im.detectChanges(in))) return s; // once per call: the frames below see the same input
    RenderResult result;
    if (im.converged) return result; // nothing changed since an exact image: it stays
    const uint32_t target = std::max<uint32_t>(1, m_settings.sampleTarget);
    const uint64_t pixels = uint64_t(in.width) * in.height;
    const uint32_t fine = std::max<uint32_t>(1, m_settings.subsampling);
    if (im.coarseStride == 0)
        im.coarseStride = request.interactive ? fine : im.stillCoarseStride(m_settings, pixels, request.timeBudgetSeconds);
    im.coarseStride = std::max(im.coarseStride, fine);
    im.fillBlock = im.coarseStride;
    RenderSettings settings = m_settings;
    const uint32_t maxFrames = target * im.coarseStride * im.coarseStride + 256;
    const auto t0 = std::chrono::steady_clock::now();
    uint32_t idle = 0;
    double before = 0; // seconds elapsed before this frame
    im.deferDenoise = !request.interactive; // the still loop's frames before its last are never shown
    for (uint32_t f = 0; f < maxFrames; ++f) {
        settings.subsampling = im.shownWhole ? fine : im.coarseStride;
        Result<FrameStats> st = im.frame(in, settings, clipToWorld);
        if (!st) {
            im.deferDenoise = im.denoisePending = im.gatheredValid = false;
            return st.status();
        }
        im.measureFrame(settings, in, *st);
        result.last = *st;
        result.cacheRanFull = result.cacheRanFull || st->cacheFull;
        ++result.frames;
        // Under cache pressure the coarse stride only slows convergence down (a ray finds one
        // missing brick per turn, and its pixel's turn comes every stride^2 frames): go on at the
        // settings' stride.
        const bool whole = st->holes == 0 && st->previews == 0; // every pixel shows a sample (its own or its block's)
        im.shownWhole = im.shownWhole || whole || st->cacheFull;
        if (request.interactive || st->minSamples >= target) break;
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        // The next frame costs this one's time per rendered pixel: stop when it would end past
        // the budget, so the budget holds; but never while a pixel shows nothing or a preview.
        const uint32_t nextStride = im.shownWhole ? fine : im.coarseStride;
        const double next = (elapsed - before) * renderedPixels(in, nextStride) / renderedPixels(in, settings.subsampling);
        before = elapsed;
        if (whole && elapsed + next + im.finishSeconds > request.timeBudgetSeconds) break;
        idle = st->idle() ? idle + 1 : 0;
        if (idle >= st->idleLimit()) break;
    }
    im.deferDenoise = false;
    im.fillBlock = 0;
    const auto t1 = std::chrono::steady_clock::now();
    if (im.denoisePending && !(s = im.denoiseOutput())) return s;
    im.converged = result.last.minSamples >= target;
    (void)output(Color8 | Depth); // what a compositor needs, read while the frame is fresh
    const double finish = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    im.finishSeconds = im.finishSeconds > 0 ? 0.5 * (im.finishSeconds + finish) : finish;
    result.changed = true;
    return result;
}

const FrameOutput& Renderer::output(uint32_t parts) {
    Impl& im = *m_impl;
    uint32_t missing = (parts | Color8 | Depth) & ~im.outputParts;
    if (missing && im.width > 0) {
        if (missing & (Color8 | Depth)) { // read together, always (both are in every call's parts)
            im.readImage();
            im.outputParts |= Color8 | Depth;
            missing &= ~uint32_t(Color8 | Depth);
        }
        if (missing && readOutput(im.output, missing)) im.outputParts |= missing;
    }
    return im.output;
}

void Renderer::Impl::readImage() {
    FrameOutput& out = output;
    const size_t n = size_t(width) * height;
    std::array<uint32_t, 4> r = rectUnion(outputRect, drawnRect);
    if (out.width != width || out.height != height || out.rgba8.size() != n || out.depth.size() != n) {
        out.rgba8.resize(n);
        out.depth.resize(n);
        r = {0, 0, width, height};
    }
    out.width = width;
    out.height = height;
    out.rect = drawnRect;
    outputRect = drawnRect;
    r[2] = std::min(r[2], width);
    r[3] = std::min(r[3], height);
    if (rectEmpty(r)) return;
    const uint32_t* words = static_cast<const uint32_t*>(colorDepth.mapped());
    if (viaCopies) { // the rows drawn, copied into host memory: the rest of readback is not read
        const uint64_t first = uint64_t(r[1]) * width * 8, bytes = uint64_t(r[3] - r[1]) * width * 8;
        if (!ctx.copy(colorDepth, first, readback, first, bytes)) {
            std::fill(out.rgba8.begin(), out.rgba8.end(), 0u); // nothing rather than another frame's pixels
            std::fill(out.depth.begin(), out.depth.end(), 1.0f);
            return;
        }
        words = static_cast<const uint32_t*>(readback.mapped());
    }
    readColorDepth(words, width, r, out.rgba8.data(), out.depth.data());
}

Status Renderer::readOutput(FrameOutput& out, uint32_t parts) const {
    const Impl& im = *m_impl;
    if (im.width == 0) return Status::error("nothing rendered yet");
    const size_t n = size_t(im.width) * im.height;
    out.width = im.width;
    out.height = im.height;
    out.rect = im.drawnRect;
    // The output and the G-buffer as the host sees them: mapped, or copied (Context::download
    // copies through a staging buffer what is not mapped).
    auto hostWords = [&](const Buffer& b, uint64_t words, std::vector<uint32_t>& copy) -> Result<const uint32_t*> {
        if (!im.viaCopies && b.mapped()) return static_cast<const uint32_t*>(b.mapped());
        copy.resize(size_t(words));
        Status s = im.ctx.download(b, 0, copy.data(), words * 4);
        if (!s) return s;
        return static_cast<const uint32_t*>(copy.data());
    };
    std::vector<uint32_t> outputCopy, gbufferCopy;
    Result<const uint32_t*> words = hostWords(im.colorDepth, 2 * n, outputCopy);
    if (!words) return words.status();
    const uint32_t* c = *words;
    if (parts & Color8) out.rgba8.resize(n);
    if (parts & Depth) out.depth.resize(n);
    readColorDepth(c, im.width, {0, 0, im.width, im.height}, parts & Color8 ? out.rgba8.data() : nullptr,
                   parts & Depth ? out.depth.data() : nullptr);
    if (parts & Color) { // colour words at even indices (readColorDepth)
        out.rgba.resize(4 * n);
        for (size_t i = 0; i < n; ++i)
            for (int k = 0; k < 4; ++k) out.rgba[4 * i + k] = float((c[2 * i] >> (8 * k)) & 0xFFu) / 255.0f;
    }
    const uint32_t* g = nullptr;
    if (parts & (GBuffer | Samples)) {
        Result<const uint32_t*> gw = hostWords(im.gbuffer, 4 * n, gbufferCopy);
        if (!gw) return gw.status();
        g = *gw;
    }
    if (parts & GBuffer) {
        out.label.resize(n);
        out.face.resize(n);
        out.hitDepth.resize(n);
        out.distance.resize(n);
        for (size_t i = 0; i < n; ++i) {
            if (!(im.currentWord1(g[4 * i + 1]) & kGBufferSampled)) { // cleared: no sample reached this pixel
                out.label[i] = kNone;
                out.face[i] = Face::None;
                out.hitDepth[i] = 1.0f;
                out.distance[i] = 0.0f;
                continue;
            }
            out.label[i] = g[4 * i];
            out.face[i] = Face(g[4 * i + 1] & 7u);
            std::memcpy(&out.hitDepth[i], &g[4 * i + 2], 4);
            std::memcpy(&out.distance[i], &g[4 * i + 3], 4);
        }
    }
    if (parts & Samples) {
        out.samples.resize(n);
        for (size_t i = 0; i < n; ++i) out.samples[i] = im.currentWord1(g[4 * i + 1]) >> kGBufferCountShift;
    }
    return Status::ok();
}

Result<std::vector<Renderer::CachedBrick>> Renderer::cachedBricks() const {
    const Impl& im = *m_impl;
    std::vector<uint32_t> words(size_t(im.brickCount) * 4);
    std::vector<uint64_t> masks(im.brickCount), hidden(im.brickCount);
    Status s = im.ctx.download(im.bricks, 0, words.data(), words.size() * 4);
    if (s) s = im.ctx.download(im.uniformSubs, 0, masks.data(), masks.size() * 8);
    if (s) s = im.ctx.download(im.hiddenSubs, 0, hidden.data(), hidden.size() * 8);
    if (!s) return s;
    std::vector<CachedBrick> out;
    for (uint32_t b = 0; b < im.brickCount; ++b)
        if (const uint32_t lod = words[4 * b + 1]; lod != kNone) // hidden ones at levels whose nodes fit a sub-block
            out.push_back({b, lod, lod == 0 ? masks[b] : 0, lod + kUniformShift <= log2u(im.volume->volume().brickSize) ? hidden[b] : 0});
    return out;
}

uint64_t Renderer::Impl::usedBytes() const { return memory().total(); }

uint64_t Renderer::deviceMemoryBudget() const { return m_impl->budget; }

bool Renderer::streamsDetail() const { return m_impl->detail != nullptr; }

DetailCounts Renderer::detailCounts() const { return m_impl->detail ? m_impl->detail->counts() : DetailCounts{}; }

MemoryReport Renderer::memory() const { return m_impl->memory(); }

MemoryReport Renderer::Impl::memory() const {
    const Impl& im = *this;
    MemoryReport r;
    r.buffers.push_back({"encoding", im.volume->deviceBytes()});
    if (im.detail) r.buffers.push_back({"detail buffer and table", im.detail->deviceBytes()});
    r.buffers.push_back({"brick cache", im.cache.size()});
    r.buffers.push_back({"brick table and visibility", im.bricks.size() + im.visible.size() + im.uniformSubs.size() + im.hiddenSubs.size() +
                                                         im.emptyGroups.size()});
    r.buffers.push_back({"free stacks", im.freeStacks.size()});
    r.buffers.push_back({"request and decode lists", im.requests.size() + im.decodes.size() + im.decodeStates.size() +
                                                          im.alloc.size() + im.allocHost.size() + im.params.size() + im.paramsHost.size() + im.blueNoise.size() +
                                                          im.detailRequests.size()});
    r.buffers.push_back({"accumulation and denoise", im.accum.size() + im.denoiseA.size() + im.denoiseB.size() +
                                                         im.pixelList.size() + im.outlineRows.size()});
    r.buffers.push_back({"outputs (colour, depth, G-buffer)", im.colorDepth.size() + im.gbuffer.size() +
                                                                   im.depthIn.size() + im.readback.size()});
    uint64_t attr = im.materials.size() + im.colormaps.size() + im.attributeTable.size() + im.labelMap.size() +
                    im.materialTable.size() + im.labelColors.size();
    for (const Buffer& b : im.attributes) attr += b.size();
    r.buffers.push_back({"materials and attributes", attr});
    if (im.ghost.size() > 0) r.buffers.push_back({"ghost faces (MPI piece)", im.ghost.size()});
    if (im.coarse.size() > 0) r.buffers.push_back({"coarse stand-ins (MPI piece)", im.coarse.size()});
    return r;
}

} // namespace csgv::gpu
