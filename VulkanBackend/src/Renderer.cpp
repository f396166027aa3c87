// SPDX-License-Identifier: MIT
#include "RendererImpl.h"

#include <cstdlib>
#include <string>
#include <utility>

namespace csgv::gpu {


const char* shadingName(Shading s) { return shadingMode(s).name; }

Result<Shading> parseShading(const std::string& name) {
    std::string names;
    for (const ShadingMode& m : kShadingModeTable) {
        if (name == m.name) return m.mode;
        names += (names.empty() ? "" : ", ") + std::string(m.name);
    }
    return Status::error("unknown shading mode '" + name + "' (" + names + ")");
}

uint64_t MemoryReport::total() const {
    uint64_t n = 0;
    for (const auto& b : buffers) n += b.second;
    return n;
}


Renderer::~Renderer() = default;

bool choosesAsGpu(const DeviceInfo& device) {
    if (device.type != "cpu") return true;
    const char* env = std::getenv("CSGV_AS_GPU");
    return env && std::string(env) == "1";
}

bool decodesOnHost(RendererOptions::Decode decode, const DeviceInfo& device) {
    return decode == RendererOptions::Decode::Host || (decode == RendererOptions::Decode::Auto && !choosesAsGpu(device));
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
    // Bricks whose header words are wrong are drawn empty: bad bricks from the start.
    if (!volume->unsound().empty()) {
        im.badBricks = volume->unsound().size();
        im.firstBadBrick = checkBrick(v, volume->unsound().front()).message();
    }

    Defines d;
    d.emplace_back("BRICK_SIZE", std::to_string(v.brickSize) + "u");
    d.emplace_back("BRICK_SHIFT", std::to_string(log2u(v.brickSize)) + "u");
    d.emplace_back("LEVELS", std::to_string(v.levels()) + "u");
    d.emplace_back("VOLUME_DIM", uvec3Of(v.dim));
    d.emplace_back("BRICK_GRID", uvec3Of(v.brickGrid()));
    d.emplace_back("BRICKS_PER_ARRAY", std::to_string(v.bricksPerArray) + "u");
    d.emplace_back("CACHE_BITS", std::to_string(volume->cacheBits()));
    d.emplace_back("UNIFORM_LEVELS", volume->uniformLevels() ? "1" : "0");
    // Pixels per render and resolve invocation along each axis: CPU devices pay per invocation
    // (16 pixels against 4: 10-15 % less time a frame on lavapipe, local shading; 64 against 16:
    // about 4 % less at 1280x720).
    constexpr uint32_t kCpuPixelBlock = 8;
    static_assert(kCpuPixelBlock * kCpuPixelBlock <= 64, "render.comp's listNext keeps a bit per pixel of an invocation (two words)");
    im.pixelBlock = context.device().type == "cpu" ? kCpuPixelBlock : 1;
    d.emplace_back("PIXEL_BLOCK", std::to_string(im.pixelBlock) + "u");
    im.requestBlock = context.device().type == "cpu" ? 64 : 1;
    d.emplace_back("REQUEST_BLOCK", std::to_string(im.requestBlock) + "u");
    if (volume->hostDecoding() && options.decode == RendererOptions::Decode::Gpu)
        return Status::error("GPU decoding was asked for, but the volume was uploaded for host decoding");
    im.resolved.hostDecode = volume->hostDecoding() || decodesOnHost(options.decode, context.device());
    // With host decoding a frame is two submissions: the render pass can be sized between them to
    // the pixels that take samples (CPU devices run every branch for all lanes: a pass over the
    // whole footprint would cost a few pixels' frame as much as a full one).
    im.usesPixelList = im.resolved.hostDecode;
    d.emplace_back("PIXEL_LIST", im.usesPixelList ? "1" : "0");
    const bool streaming = volume->separated() && !im.resolved.hostDecode; // host decoding reads every level from host memory
    d.emplace_back("DETAIL_STREAMING", streaming ? "1" : "0");
    // GPU decodes that carry over frames: fewer steps a frame than a brick's finest level needs.
    // CSGV_DECODE_STEPS=N: N steps where the options leave it automatic, on any device.
    uint32_t steps = options.decodeStepsPerFrame;
    if (steps == RendererOptions::kDecodeStepsAuto) {
        const char* env = std::getenv("CSGV_DECODE_STEPS");
        const unsigned long long n = env ? std::strtoull(env, nullptr, 10) : 0; // "-3" wraps to huge: every step
        steps = n > 0                               ? uint32_t(std::min<unsigned long long>(n, RendererOptions::kDecodeStepsAll))
                : choosesAsGpu(context.device()) ? RendererOptions::kGpuDecodeStepsPerFrame
                                                 : RendererOptions::kDecodeStepsAll;
    }
    im.resolved.carrySteps = !im.resolved.hostDecode && !streaming && steps < volume->decodeSteps() ? steps : 0;
    im.resolved.overlapDecodes = im.resolved.carrySteps && options.overlapDecodes;
    d.emplace_back("CARRY_DECODES", im.resolved.carrySteps ? "1" : "0");
    d.emplace_back("IN_FLIGHT_PREVIEWS", im.resolved.carrySteps && options.inFlightPreviews && volume->cacheBits() == 32 ? "1" : "0");
    d.emplace_back("ABSENT_BRICKS", volume->owned().empty() ? "0" : "1"); // an MPI rank's piece
    im.budget = options.deviceMemoryBytes ? options.deviceMemoryBytes : automaticDeviceMemoryBudget(context.device());
    im.lookup = planLabelLookup(volume->largestStoredLabel(), !volume->owned().empty(), im.budget, options.largestOtherLabel);
    d.emplace_back("LABEL_LOOKUP", std::to_string(im.lookup.kind)); // tested by #if: no suffix
    im.defines = d;
    im.resolved.profileDispatches = std::getenv("CSGV_PROFILE_DISPATCHES") != nullptr;
    // CSGV_READ_THROUGH_COPIES=1: copies on any device, its other choices kept (ParaView's tests).
    const char* copies = std::getenv("CSGV_READ_THROUGH_COPIES");
    im.viaCopies = options.readBackThroughCopy || choosesAsGpu(context.device()) || (copies && std::string(copies) == "1");

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
    im.resolved.prefetchVoxels = options.prefetchVoxels != RendererOptions::kPrefetchAuto ? options.prefetchVoxels
                                 : im.resolved.hostDecode ? RendererOptions::kHostPrefetchVoxels
                                                          : RendererOptions::kGpuPrefetchVoxels;
    const MemoryKind hostOrDevice = im.resolved.hostDecode ? MemoryKind::HostVisible : MemoryKind::DeviceLocal;
    // Host decoding writes the cache and the masks itself, unless they live in device memory
    // (viaCopies: GPUs), where the render pass reads them at every step: then through copies.
    im.stagedDecode = im.resolved.hostDecode && im.viaCopies;
    const MemoryKind cacheKind = im.stagedDecode ? MemoryKind::DeviceLocal : hostOrDevice;
    im.cacheKind = cacheKind;
    // Everything but the cache and the images, sized once: summed for the budget, then allocated.
    struct Table {
        Buffer* buffer;
        uint64_t bytes;
        MemoryKind kind;
        const char* what;
    };
    const uint64_t bricks = im.brickCount, requests = im.maxRequests, lists = im.resolved.carrySteps ? 2 : 1;
    const Table tables[] = {{&im.params, sizeof(FrameParams), im.viaCopies ? MemoryKind::DeviceLocal : MemoryKind::HostVisible, "frame parameters"},
                            {&im.paramsHost, im.viaCopies ? sizeof(FrameParams) : 0, MemoryKind::HostVisible, "frame parameters' host copy"},
                            {&im.bricks, inFlightWordsOffset(im.brickCount) + (im.resolved.carrySteps ? bricks * 4 : 0), MemoryKind::DeviceLocal,
                             "brick table"}, // and the in-flight words (kInFlightValid) with carried decodes
                            {&im.visible, bricks * 8, MemoryKind::DeviceLocal, "brick visibility"},
                            {&im.emptyGroups, bricks * 4, MemoryKind::DeviceLocal, "empty brick groups"},
                            {&im.uniformSubs, bricks * 8, cacheKind, "uniform sub-block masks"},
                            {&im.hiddenSubs, bricks * 8, MemoryKind::DeviceLocal, "hidden sub-block masks"},
                            {&im.alloc, kAllocWords * 4, im.viaCopies ? MemoryKind::DeviceLocal : MemoryKind::HostVisible, "cache counters"},
                            {&im.allocHost, im.viaCopies ? kAllocWords * 4 : 0, MemoryKind::HostVisible, "cache counters' host copy"},
                            {&im.freeStacks, bricks * im.levels * 4, MemoryKind::DeviceLocal, "free stacks"},
                            {&im.requests, requests * 8, MemoryKind::DeviceLocal, "request list"},
                            {&im.decodes, lists * requests * kDecodeEntryWords * 4, hostOrDevice, "decode list"},
                            {&im.decodeStates, lists * requests * kDecodeStateWords * 4, MemoryKind::DeviceLocal, "decoder states"},
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
        Result<std::unique_ptr<DetailStream>> ds = DetailStream::create(context, v, ringBytes, &volume->detailSizes(), volume->tiers());
        if (!ds) return ds.status();
        im.detail = std::move(*ds);
    }
    const uint64_t wantedCache = options.cacheBytes ? options.cacheBytes : automaticCacheBytes(context.device());
    const uint64_t imageRoom = std::min<uint64_t>(kImageReserveBytes, (im.budget - fixed - smallestCache) / 4);
    const uint64_t cacheBytes =
        std::max(smallestCache, std::min({std::max<uint64_t>(wantedCache, 4096), maxBytes, im.budget - fixed - imageRoom})) &
        ~uint64_t(3);
    if (!(s = make(im.cache, cacheBytes, cacheKind, "brick cache"))) return s;
    im.resolved.texelsWanted = options.renderTexels;
    im.resolved.hiddenWanted = options.hiddenSubBlocks;
    im.resolved.outlineWanted = options.outlineSpans;
    for (const Table& t : tables)
        if (!(s = make(*t.buffer, t.bytes, t.kind, t.what))) return s;
    if (!(s = context.upload(im.blueNoise, 0, kBlueNoise64, sizeof(kBlueNoise64)))) return s;
    im.frameAddress = im.params.address();
    // The GPU decoding passes read the request list the frame wrote: the same dispatches every frame.
    if (!(s = im.makeFrameDecodes())) return s;
    std::vector<uint32_t> brickWords(size_t(im.bricks.size() / 4), 0u); // and no decodes in flight
    for (size_t b = 0; b < im.brickCount; ++b) brickWords[kBrickEntryWords * b] = brickWords[kBrickEntryWords * b + 1] = kNone;
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
    if (g == im.geometry) return;
    im.geometry = g;
    resetAccumulation();
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
    if (keep) m_impl->accumulation.converged = false;
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

void Renderer::resetCache() {
    m_impl->cacheState.cacheResetPending = true;
    m_impl->accumulation.converged = false; // the next render() submits (and refills the cache)
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
        accumulation.hadDepth = false;
        resetAccumulation();
    }
    if (in.worldToClip != accumulation.lastWorldToClip) {
        accumulation.lastWorldToClip = in.worldToClip;
        resetAccumulation();
    }
    // Opaque geometry that moved (or appeared) changes where rays stop: start anew. The renderer's
    // own copy is the host-visible buffer the shaders read: one comparison, at most one copy.
    const size_t depthBytes = size_t(in.width) * in.height * 4;
    if (bool(in.opaqueDepth) != accumulation.hadDepth ||
        (in.opaqueDepth && std::memcmp(depthIn.mapped(), in.opaqueDepth, depthBytes) != 0)) {
        if (in.opaqueDepth) std::memcpy(depthIn.mapped(), in.opaqueDepth, depthBytes);
        accumulation.hadDepth = in.opaqueDepth != nullptr;
        resetAccumulation();
    }
    return Status::ok();
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
    denoising.gatherInRender = !spans.empty() && denoises(st) && (accumulation.clearPending || denoising.gatheredValid);
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
    if (cacheState.limitRequests) flags |= kFlagLimitRequests;
    if (in.opaqueDepth) flags |= kFlagDepthInput;
    if (hasLabelMap) flags |= kFlagLabelMap;
    if (resolvesInRender(st)) flags |= kFlagResolveInRender;
    if (denoising.gatherInRender) flags |= kFlagGatherInRender;
    if (cacheState.visibilityChanged) flags |= kFlagVisibilityChanged;
    if (cacheState.prefetchPending && prefetches()) flags |= kFlagPrefetch;
    // The next frame lists the pixels below the target (listPixels) only if every pixel is one
    // sample or less short of it then (a frame adds at most one). A cell is the same pixel in the
    // next frame only without subsampling (a stride's cells take another pixel of their block
    // each frame).
    if (usesPixelList && st.subsampling == 1 && st.sampleTarget > 0 &&
        (accumulation.clearPending ? 0 : accumulation.prevMinSamples) + 2 >= st.sampleTarget)
        flags |= kFlagListNext;
    cacheState.visibilityChanged = cacheState.prefetchPending = false;
    const uint32_t stride = st.subsampling;
    p.frame[0] = frameIndex;
    p.frame[1] = flags;
    if (accumulation.clearPending) { // a new accumulation: a new epoch, the G-buffer filled whole when they wrap
        imageState.gbufferEpoch = imageState.imageDirty ? 1 : imageState.gbufferEpoch % kGBufferEpochs + 1;
        imageState.gbufferFill = imageState.gbufferFill || imageState.gbufferEpoch == 1; // until a clear fills it
    }
    p.frame[2] = imageState.gbufferEpoch;
    p.frame[3] = st.sampleTarget;
    p.image[0] = in.width;
    p.image[1] = in.height;
    p.image[2] = stride;
    p.image[3] = accumulation.accumulatedFrames % (stride * stride);
    p.limits[0] = maxRequests;
    p.limits[1] = cacheState.bandRow;
    p.limits[2] = cacheState.bandRow + cacheState.bandHeight;
    p.limits[3] = std::min<uint32_t>(st.maxBounces, 32);
    p.counts[0] = materialCount;
    p.counts[1] = brickCount;
    p.counts[2] = labelCount;
    p.counts[3] = materialTableSize;
    p.drawn[0] = drawnFirst;
    p.drawn[1] = drawnLast;
    p.drawn[2] = p.drawn[3] = 0;
    const std::pair<uint32_t, const Buffer*> slots[] = {
        {kSlotBricks, &bricks},       {kSlotCache, &cache},         {kSlotAlloc, &alloc},         {kSlotFree, &freeStacks},
        {kSlotRequests, &requests},   {kSlotAccum, &accum},
        {kSlotGBuffer, &gbuffer},     {kSlotDepthIn, &depthIn},     {kSlotMaterials, &materials}, {kSlotColormaps, &colormaps},
        {kSlotAttributes, &attributeTable}, {kSlotOutput, &colorDepth}, {kSlotLabelMap, &labelMap},
        {kSlotDenoiseA, &denoiseA},   {kSlotDenoiseB, &denoiseB},   {kSlotVisible, &visible},     {kSlotBlueNoise, &blueNoise},
        {kSlotMaterialTable, &materialTable}, {kSlotUniform, &uniformSubs}, {kSlotLabelColors, &labelColors},
        {kSlotPixelList, &pixelList}, {kSlotHidden, &hiddenSubs}, {kSlotEmptyGroups, &emptyGroups}};
    for (const auto& sl : slots) p.addr[sl.first] = sl.second->address();
    p.addr[kSlotDecodes] = decodeList(decodeParity);
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
    a[kAllocPrevMin] = accumulation.prevMinSamples;
    a[kAllocEvictAge] = cacheState.evictAge;
    a[kAllocDetailRequests] = 0;
}

void Renderer::Impl::buildDispatches(const FrameInput& in, const RenderSettings& st, uint64_t renderPipeline) {
    resolvePushes.clear();
    resolvePushes.reserve(8); // the list points into it: no reallocation while building
    dispatches.clear();
    const uint32_t tile = kGroupTile * pixelBlock; // kGroupTile^2 invocations of PIXEL_BLOCK^2 pixels
    if (accumulation.clearPending) addClear(in);
    const uint32_t perGroup = kGroupBricks * requestBlock;
    // Overlapped decodes (RendererOptions::overlapDecodes): the decodes that ended beside the last
    // frame's render are published first, so the request pass sees them (a level the view no
    // longer wants is evicted before a ray samples it).
    if (!resolved.hostDecode && frameDecode[decodeParity][0].overlapped)
        dispatches.push_back(decodeDispatches[decodeParity][0].front());
    std::pair<const Context::Dispatch*, const Context::Dispatch*> beside{nullptr, nullptr}; // an overlapped decode
    addDispatch(pRequest, &frameAddress, 8, (brickCount + perGroup - 1) / perGroup, 1);
    addDispatch(pProvision, &frameAddress, 8, 1, 1);
    addDispatch(pAssign, &frameAddress, 8, (maxRequests + kGroupBricks - 1) / kGroupBricks, 1);
    addDispatch(pCommit, &frameAddress, 8, 1, 1);
    if (usesPixelList) listPixels(st);
    cacheStages = dispatches.size(); // with host decoding, the first submission ends here
    if (!resolved.hostDecode) {
        // Steps are spared in a frame that begins an accumulation (a moving camera renders nothing
        // else) and once every pixel holds a sample (refining: shorter frames, fewer samples
        // lost to bricks on their way); the frames between take every step, so the first full
        // image comes as soon as without carrying, as do frames under cache pressure (a
        // thrashing cache needs each brick soon), and a frame that asks for every visible brick
        // (a small volume's first frame is complete: RendererOptions::prefetchVoxels).
        const bool incomplete = !accumulation.clearPending && accumulation.prevMinSamples == 0;
        const bool prefetching = (hostParams().frame[1] & kFlagPrefetch) != 0; // packState ran
        decodeWhole = resolved.carrySteps && (incomplete || prefetching || cacheState.evictAge != 0 || cacheState.limitRequests);
        const auto& passes = decodeDispatches[decodeParity][decodeWhole];
        // Overlapped (RendererOptions::overlapDecodes): the decode right before the render, beside
        // it (its set's first dispatch, the publishing one, came before the request pass).
        if (frameDecode[decodeParity][decodeWhole].overlapped)
            beside = {passes.data() + 1, passes.data() + passes.size()};
        else
            dispatches.insert(dispatches.end(), passes.begin(), passes.end());
        addDispatch(pUniform, &frameAddress, 8, maxRequests, 1); // a group per decode (host decoding marks them itself)
    }
    // The sub-blocks without drawn labels: after a change of materials none, then (where there are
    // several labels undrawn) those of every cached brick; else those of the bricks decoded now
    // (a group per decode; host decoding sizes it in submit()).
    hiddenDispatch = SIZE_MAX;
    if (materialState.hiddenAllPending) {
        Context::Dispatch zero;
        zero.fill = &hiddenSubs;
        zero.fillBytes = uint64_t(brickCount) * 8;
        dispatches.push_back(zero);
    }
    if (hiddenAll()) {
        addDispatch(pHiddenAll, &frameAddress, 8, (brickCount + kHiddenGroupBricks - 1) / kHiddenGroupBricks, 1);
    } else if (materialState.hiddenLabels) {
        hiddenDispatch = dispatches.size();
        addDispatch(pHidden, &frameAddress, 8, maxRequests, 1);
    }
    if ((hiddenAll() || materialState.hiddenLabels) && renderTexels.valid()) dispatches.back().texels = &renderTexels.sets[0];
    const std::array<uint32_t, 2> cells = cellGrid(st.subsampling);
    const uint32_t rw = cells[0], rh = cells[1];
    if (materialState.labelColorsPending) // the materials changed: their colours per label first (frame() made the pipeline)
        addDispatch(pLabelColors, &frameAddress, 8,
                    uint32_t(std::min<uint64_t>((lookup.entries() + kGroupLabels - 1) / kGroupLabels, 4096)), 1);
    dispatches.insert(dispatches.end(), beside.first, beside.second); // its last overlaps the render
    renderDispatch = dispatches.size();
    addDispatch(renderPipeline, &frameAddress, 8, (rw + tile - 1) / tile, (rh + tile - 1) / tile); // PIXEL_LIST: sized in submit()
    if (renderTexels.valid()) dispatches.back().texels = &renderTexels.sets[0];
    if (!denoises(st)) {
        denoising.gatheredValid = false; // denoiseA is not written
        if (!resolvesInRender(st)) addResolve(kResolveGather, kSlotDenoiseA, kSlotOutput);
        return;
    }
    if (!denoising.gatherInRender) addResolve(kResolveGather, kSlotDenoiseA, kSlotDenoiseA);
    // denoiseA keeps this frame's gathered image only until the denoising passes (the step-2
    // pass writes it).
    denoising.gatheredValid = denoising.deferDenoise;
    denoising.denoisePending = denoising.deferDenoise;
    if (!denoising.deferDenoise) addDenoisePasses();
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
    if (!imageState.imageDirty) {
        const bool drawn = drawnRect[0] < drawnRect[2] && drawnRect[1] < drawnRect[3];
        y0 = drawn ? drawnRect[1] : 0;
        y1 = drawn ? drawnRect[3] : 0;
    }
    const uint64_t pixels = uint64_t(in.width) * in.height;
    const uint64_t first = uint64_t(y0) * in.width, n = uint64_t(y1 - y0) * in.width;
    const std::tuple<const Buffer*, uint64_t, uint64_t, uint64_t> filled[] = {
        {&gbuffer, 16, 0, imageState.gbufferFill ? pixels : 0} /* no samples */,
        {&colorDepth, 8, first, n} /* colour 0, depth 1 (kOutputDepthXor) */};
    imageState.gbufferFill = false;
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
    return denoisedShading(st) && accumulation.prevMinSamples < 64;
}

Status Renderer::Impl::denoiseOutput() {
    denoising.denoisePending = false;
    denoising.gatheredValid = false; // the step-2 pass writes denoiseA
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
    if (!accumulation.clearPending && st.sampleTarget > 0 && accumulation.prevMinSamples + 1 >= st.sampleTarget) {
        const Accumulation::NextList& nl = accumulation.nextList;
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
    if (resolved.profileDispatches) { // one submission per dispatch, timed (diagnostics)
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
            if (resolved.hostDecode && i == cacheStages) {
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
    if (resolved.hostDecode) {
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
    const uint32_t oldAge = cacheState.evictAge, oldBand = cacheState.limitRequests ? cacheState.bandHeight : 0;
    ++cacheState.framesSinceDefrag;
    if (stats.cacheFull) {
        cacheState.quietFrames = 0;
        const bool blocked = cacheState.evictAge == youngest && stats.decodedBricks == 0;
        if ((cacheState.framesSinceDefrag >= kDefragInterval || blocked) && fragmented()) {
            cacheState.cacheResetPending = true;
            cacheState.framesSinceDefrag = 0;
        } else if (cacheState.evictAge != youngest) {
            cacheState.evictAge = cacheState.evictAge == 0 ? std::max(kEvictAgeStart, 2 * youngest) : std::max(youngest, cacheState.evictAge / 2);
        } else if (!cacheState.limitRequests) {
            cacheState.limitRequests = true;
            cacheState.bandHeight = uint32_t(std::max<uint64_t>(1, pixels / 2));
        } else {
            cacheState.bandHeight = std::max<uint32_t>(1, cacheState.bandHeight / 2);
        }
    } else if (cacheState.limitRequests) {
        cacheState.bandHeight = uint32_t(std::min<uint64_t>(uint64_t(cacheState.bandHeight) * 2, pixels));
        cacheState.limitRequests = cacheState.bandHeight < pixels;
    } else if (++cacheState.quietFrames >= kQuietFrames) {
        cacheState.evictAge = 0;
    }
    const uint32_t minRow = allocWords()[kAllocMinRow];
    if (cacheState.limitRequests) cacheState.bandRow = minRow == kNone ? 0 : minRow;
    accumulation.prevMinSamples = stats.minSamples;
    return cacheState.cacheResetPending || cacheState.evictAge != oldAge || (cacheState.limitRequests ? cacheState.bandHeight : 0) != oldBand;
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
    if (st.sampleTarget > 0 && accumulation.prevMinSamples >= st.sampleTarget && !accumulation.clearPending && !cacheState.cacheResetPending) {
        // Every pixel holds its samples: the image is final, nothing to submit.
        stats.frame = accumulation.accumulatedFrames;
        stats.minSamples = accumulation.prevMinSamples;
        stats.stride = st.subsampling;
        stats.cacheUsedBytes = uint64_t(allocWords()[kAllocTop]) * 4;
        return stats;
    }
    if (accumulation.sumsStale && !oneSample(st)) { // the samples so far kept no sums: take them again
        accumulation.clearPending = true;
        accumulation.accumulatedFrames = 0;
        accumulation.prevMinSamples = 0;
    }
    if (cacheState.cacheResetPending) {
        if (!(s = resetCacheNow())) return s;
        cacheState.cacheResetPending = false;
        stats.cacheReset = true;
    }
    if (!(s = packParams(in, st, clipToWorld))) return s;
    curves = toneCurves(st);
    buildDispatches(in, st, pRender[renderVariant(st, in.opaqueDepth != nullptr)][shadingIndex(st.shading)]);
    // After the clear (addClear reads what was drawn before it): this frame's footprint joins.
    drawnRect = accumulation.clearPending ? rect : rectUnion(drawnRect, rect);
    const auto t0 = std::chrono::steady_clock::now();
    lastFrameTicks = t0.time_since_epoch().count(); // the device's work begins (the warming waits)
    if (detail && !(s = commitDetail())) return s;
    if (!(s = submit())) return s;
    if (!resolved.hostDecode) noteGpuDecodeFailures();
    if (resolved.carrySteps) decodeParity ^= 1; // the next frame decodes from the list this one carried into
    materialState.labelColorsPending = false;
    materialState.hiddenAllPending = false;
    cacheState.cacheEmpty = cacheState.newCache = false;
    if (detail && !(s = requestDetail(stats))) return s;
    const auto t1 = std::chrono::steady_clock::now();
    lastFrameTicks = t1.time_since_epoch().count();
    stats.milliseconds = std::chrono::duration<double, std::milli>(t1 - t0).count();
    stats.detailUploads = detailUploads;
    stats.badBricks = std::exchange(frameBadBricks, 0u);
    accumulation.sumsStale = (accumulation.sumsStale && !accumulation.clearPending) || oneSample(st);
    accumulation.clearPending = imageState.imageDirty = false;
    outputParts = 0; // the read-back output is stale now
    ++frameIndex;
    ++accumulation.accumulatedFrames;

    const uint32_t* a = allocWords();
    stats.frame = accumulation.accumulatedFrames;
    stats.decodedBricks = a[kAllocDecodes] - std::min(a[kAllocDecodes], a[kAllocCarriedEnded]);
    // 0 unless decodes carry (cache_provision.comp); overlapped decodes that ended are carried to be
    // published, not decoded: they count in neither.
    stats.carriedDecodes = a[kAllocCarry] - std::min(a[kAllocCarry], a[kAllocCarryEnded]);
    stats.newSamples = a[kAllocNewSamples];
    stats.missingPixels = a[kAllocMissing];
    stats.minSamples = a[kAllocMinSamples] == kNone ? 0 : a[kAllocMinSamples];
    stats.holes = a[kAllocHoles];
    stats.previews = a[kAllocPreviews];
    stats.stride = st.subsampling;
    stats.cacheUsedBytes = uint64_t(a[kAllocTop]) * 4;
    stats.cacheFull = a[kAllocFull] != 0;
    stats.requestLimited = cacheState.limitRequests;
    const std::array<uint32_t, 2> g = cellGrid(st.subsampling);
    accumulation.nextList.valid = (hostParams().frame[1] & kFlagListNext) != 0;
    accumulation.nextList.grid = {g[0], g[1], st.subsampling, st.sampleTarget};
    accumulation.nextList.count = a[kAllocNextCount];
    accumulation.nextList.kept = a[kAllocNextKept];
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

uint64_t Renderer::Impl::usedBytes() const { return memory().total(); }

uint64_t Renderer::deviceMemoryBudget() const { return m_impl->budget; }

uint32_t Renderer::labelLookup() const { return m_impl->lookup.kind; }

bool Renderer::streamsDetail() const { return m_impl->detail != nullptr; }

DetailCounts Renderer::detailCounts() const { return m_impl->detail ? m_impl->detail->counts() : DetailCounts{}; }

uint64_t Renderer::badBricks() const {
    std::lock_guard<std::mutex> lock(m_impl->badMutex);
    return m_impl->badBricks;
}

std::string Renderer::firstBadBrick() const {
    std::lock_guard<std::mutex> lock(m_impl->badMutex);
    return m_impl->firstBadBrick;
}

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
