// SPDX-License-Identifier: MIT
#pragma once
/// @file Renderer.h
/// @brief The brick-cache ray marcher of the paper: the API that `csgv render` and the ParaView
/// representation both drive. No Vulkan, VTK or Qt type appears here.
///
/// Per frame, in one submission without CPU-GPU synchronisation inside it:
///   request (one thread per brick: free invisible bricks and bricks that need another level,
///   request bricks the previous frame's rays needed, at the level their centre's distance asks
///   for) -> provision (regions from the cache top when free stacks run short) -> assign
///   (regions to requests, decode list) -> decode (GpuVolume's decoder into the cache) -> render
///   (one view ray per pixel, stable multi-level DDA, shading, one sample accumulated; rays that
///   meet a missing brick mark it and add no sample: a pixel without samples shows a preview
///   instead, its ray going on through missing bricks at their coarsest level read from the
///   encoding, never accumulated, so converged images are those of a warm cache; deep
///   path-tracing bounces, which request nothing, see missing bricks at that level too) ->
///   resolve (average, upsampling, A-trous denoising, tone mapping).
/// Between frames the host reads a few counters. Under cache pressure bricks are replaced
/// gradually, least recently used first (those no ray used for 8 frames, then 4, 2, 1); if the
/// cache is still too small, only a band of pixels may request bricks (brick request limitation),
/// starting at the first pixel with the fewest samples, halved while the cache runs full and
/// doubled while it does not, so every pixel converges (as long as the cache holds the bricks one
/// pixel's rays need). A full cache whose free regions belong to other levels is reset
/// (defragmentation), at most once every 64 frames; camera moves keep the cache.
///
/// Conventions (those of Core/RayCast.h and of VTK):
/// - `worldToClip` is column-major (OpenGL layout, VTK's `wcdc` from
///   vtkOpenGLCamera::GetKeyMatrices as it comes); perspective and parallel both work.
/// - Pixel (x, y), row 0 at the bottom, looks through NDC ((x + 0.5) / W * 2 - 1, ...); its ray
///   runs from NDC z = -1 to z = +1.
/// - Voxel (i, j, k) covers [i, i+1] x [j, j+1] x [k, k+1] in index space; world = origin +
///   direction * (index * spacing) (a corner Geometry).
/// - Output colour is premultiplied RGBA (transparent where nothing is hit), depth is window
///   depth ndc_z * 0.5 + 0.5 (what gl_FragDepth expects), 1 where nothing is hit.

#include "csgv/codec/Container.h"
#include "csgv/base/Geometry.h"
#include "csgv/materials/Materials.h"
#include "csgv/reference/RayCast.h"
#include "csgv/gpu/Context.h"
#include "csgv/gpu/DetailStream.h"
#include "csgv/gpu/FramePolicy.h"
#include "csgv/gpu/GpuVolume.h"

#include <algorithm>
#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace csgv::gpu {

/// A mode's name (ShadingMode::name) and its inverse.
const char* shadingName(Shading s);
Result<Shading> parseShading(const std::string& name);

/// @brief Everything that changes the image except camera and materials; a change resets the
/// accumulation.
struct RenderSettings {
    Shading shading = Shading::Local;
    float shadingBlend = 1.0f;        ///< 0: local shading only ... 1: the chosen mode only
    uint32_t maxBounces = 32;         ///< path tracing (Russian roulette from the third bounce)
    float aoRadius = 16.0f;           ///< ambient occlusion ray length in voxels
    float lodBias = 0.0f;             ///< added to log2(pixel footprint / voxel); < 0 finer
    bool finest = false;              ///< level 0 everywhere
    uint32_t subsampling = 1;         ///< 1, 2, 4 or 8: render 1, 1/4, 1/16 or 1/64 of pixels a frame
    bool denoise = true;              ///< A-trous denoising of ao and pt, fading out, off from 64 samples
    bool jitter = true;               ///< sub-pixel jitter after the first sample (anti-aliasing)
    uint32_t sampleTarget = 0;        ///< stop accumulating at this many samples a pixel (0: never)
    /// Direction towards the key light in view coordinates (x right, y up, z towards the viewer),
    /// or in world coordinates when `lightInWorld`.
    std::array<float, 3> lightDirection{{0.35f, 0.6f, 0.72f}};
    bool lightInWorld = false;
    float lightIntensity = 0.8f;
    float ambient = 0.25f;
    std::array<float, 3> environment{{0.55f, 0.55f, 0.6f}}; ///< sky radiance for path tracing
    bool toneMapping = false;
    float brightness = 1.0f, contrast = 1.0f, gamma = 1.0f;
    /// Clip box in voxels [min, max) per axis; empty (min >= max on an axis) means the whole volume.
    std::array<int64_t, 3> clipMin{{0, 0, 0}}, clipMax{{0, 0, 0}};

    bool operator==(const RenderSettings& other) const; ///< every field equal
    bool operator!=(const RenderSettings& other) const { return !(*this == other); }
};

struct RendererOptions {
    /// Brick cache budget (0: automaticCacheBytes of the device), clamped to the device's limits
    /// and the budget below.
    uint64_t cacheBytes = 0;
    /// Device-memory budget in bytes for everything the renderer allocates, its volume's encoding
    /// included (0: automaticDeviceMemoryBudget of the device). The brick cache takes what the
    /// encoding, tables and images leave, up to `cacheBytes`; an image or material upload that
    /// would pass the budget shrinks the cache (which then fills anew) rather than fail.
    uint64_t deviceMemoryBytes = 0;
    uint32_t maxRequestsPerFrame = 4096; ///< bricks decoded in one frame at most (more wait a frame)
    /// A small volume has every visible brick decoded at the first frame of a new cache (or of new
    /// visibility) when those bricks hold at most this many voxels, fit one frame's requests and
    /// the cache (a new one whole, else a quarter), and no detail is streamed: a view ray
    /// stops at the first brick it misses, so otherwise a view finds its bricks one layer a frame
    /// (0: never). kPrefetchAuto: kHostPrefetchVoxels where bricks are decoded on the host (a CPU
    /// decodes every brick: a synthetic 256^3, 512 bricks, in 130 ms on two cores, what a view
    /// needs in 22 ms), kGpuPrefetchVoxels where the GPU decodes them (its bricks decode side by
    /// side, so the first frame's decode lasts about as long for 512 bricks as for the view's:
    /// then a moving camera's frames decode nothing; a 32-pose orbit of synth 256^3 with a GPU's
    /// choices on lavapipe, one frame a pose: median 46.5 -> 24.9 ms).
    static constexpr uint64_t kPrefetchAuto = ~uint64_t(0);
    static constexpr uint64_t kHostPrefetchVoxels = uint64_t(1) << 23, kGpuPrefetchVoxels = uint64_t(1) << 24;
    uint64_t prefetchVoxels = kPrefetchAuto;
    /// The render pass reads the brick cache, the brick table, the uniform sub-blocks and the label
    /// table as uniform texel buffers where the device allows views of them whole
    /// (maxTexelBufferElements words; lavapipe: a cache up to 512 MiB): CPU devices then fetch
    /// such a word for all lanes with one gather instruction, where a read through a buffer
    /// address is a loop over the lanes. Off: through their addresses, as larger caches always are
    /// (tests cover both).
    bool renderTexels = true;
    /// Rays step over the sub-blocks of cached bricks that hold no label the materials draw (at
    /// levels whose nodes are no larger than a sub-block; cache_hidden.comp marks them where the
    /// volume holds several undrawn labels). Off: only over uniform ones (tests compare both).
    bool hiddenSubBlocks = true;
    /// Where the host lists the pixels a frame renders (CPU devices), frames where every pixel
    /// takes its own samples (stride 1, no coarse first stride) take only those within the clip
    /// box's outline: the convex hull of its projected corners, 2 pixels wider (the others would
    /// see nothing of the box; they keep their cleared output and no samples, as pixels outside
    /// the footprint rectangle do). Denoised frames (ambient occlusion, path tracing) take 14
    /// pixels more, the misses their A-trous passes read, and each resolve pass the pixels within
    /// its reach. The same image either way. Off: every pixel of the rectangle (tests cover both).
    bool outlineSpans = true;
    /// Where the G-buffer and the output live. GPUs keep them in device memory, which their passes
    /// read and write every frame, and read the output back through a copy into host memory (one
    /// per image read, of the rows drawn); CPU devices map them (no copy: device memory is host
    /// memory there). On: the copy on any device (tests cover both).
    bool readBackThroughCopy = false;
    /// Where GPU decodes carry over frames (decodeStepsPerFrame), previews read a brick still being
    /// decoded at the finest level its decoding has completed (a moving camera shows its coarser
    /// levels instead of one label a brick while its finest level is on its way), and so do path
    /// tracing's deep bounces (as they read detail streaming's stand-ins); exact rays still find
    /// it missing. Off: one label a brick, as before (tests compare both).
    bool inFlightPreviews = true;
    /// Where GPU decodes carry over frames, a frame that spares steps runs its decode beside its
    /// render (no barrier between them): a decode is one long invocation a brick, so the render
    /// no longer waits for the longest brick's steps, and the device runs both at once. A decode
    /// that ends then shows a frame later (published by the next frame's first dispatch, before
    /// its request pass). Off:
    /// the render waits for the decode (tests compare both).
    bool overlapDecodes = true;
    /// Detail streaming (GPU decoding of a separated volume, GpuVolume::separated): bytes of the
    /// detail buffer that receives finest-level streams (0: room for two frames' requests of
    /// average streams, at most all streams and a quarter of what the budget leaves beside the
    /// encoding and tables; at least twice the longest stream).
    uint64_t detailBufferBytes = 0;
    /// Where requested bricks are decoded. Auto: on the GPU, except on CPU devices (lavapipe),
    /// where Core's decoder fills the (host-visible) cache between the frame's cache stages and
    /// its rendering (packing palette indices with cache paletting), in two submissions: the
    /// "GPU" is the CPU there, and Core decodes a brick about 80x faster than the GPU shader does
    /// on lavapipe.
    enum class Decode { Auto, Gpu, Host };
    Decode decode = Decode::Auto;
    /// GPU decoding: decoder steps a frame gives each brick (a step: one node's 8 children; a
    /// 32^3 brick takes 4,686 to its finest level, GpuVolume::decodeSteps). A brick decodes in one
    /// invocation, so a frame that decodes waits for its longest brick (about 5 ms on an H200 for a
    /// finest-level brick, whatever else the frame does): with fewer steps its decoding goes on in
    /// the next frames, the rays finding the brick missing until it ends (previews stand in while
    /// the camera moves, at the levels its decoding completed: inFlightPreviews), and such a frame
    /// renders beside its decode (overlapDecodes). Before the overlap, H200, synth 2048^3 at 1920x1080, one frame a pose of an orbit: median
    /// 6.8 ms a frame with every step, 4.1 with 2048, 3.2 with 1024, 2.7 with 512, the pixels
    /// showing previews 3 %, 12 %, 22 % and 37 % (frame time against detail while moving: on that
    /// GPU every choice is above a display's refresh). Steps are spared in a frame
    /// that begins an accumulation (a new camera, a moving one's every frame) and once every pixel
    /// holds a sample (refining; carrying in every frame, 16 samples over a 6-view orbit of
    /// 2048^3 took 0.69 s against 0.85 with every step in path tracing, 0.30 against 0.38 in
    /// local shading); the frames
    /// between take every step, so the first full image comes as soon as without (sparing them
    /// too took 4x the frames and 1.4x the time for a 16-view orbit at one sample), and so do
    /// frames under cache pressure (evictions or limited requests: a thrashing cache needs each
    /// brick soon; a 1 MiB cache took 257 frames and more instead of 89).
    /// kDecodeStepsAuto: kGpuDecodeStepsPerFrame on GPUs (choosesAsGpu), every step on CPU devices
    /// (one frame); CSGV_DECODE_STEPS=N sets N where the options leave it automatic.
    /// Not with detail streaming (every step: a stream stays in its ring only for its frame).
    static constexpr uint32_t kDecodeStepsAuto = 0, kDecodeStepsAll = 0xFFFFFFFFu;
    static constexpr uint32_t kGpuDecodeStepsPerFrame = 512;
    uint32_t decodeStepsPerFrame = kDecodeStepsAuto;
    /// An MPI rank's piece (GpuVolumeOptions::owned): the largest stored label its rays may meet
    /// beyond its own bricks, in other ranks' coarse stand-ins and ghost faces (setCoarseStandIns,
    /// setGhostFaces, which refuse larger ones); kNone: not known. Known, one dense label table
    /// covers the piece's labels and these (as a whole volume's, where they are small: the colours
    /// are read, not computed); else the piece's own labels take the table and the others the
    /// scan of the materials, which made path tracing at 2 ranks 3-4 times as slow a frame as at
    /// one on lavapipe (CPU devices run every colour mode of a computed colour).
    uint32_t largestOtherLabel = kNone;
};

/// Whether the renderer makes a GPU's choices on this device where they change what it does, not
/// only how fast: GPU decoding where Auto, decoder steps spared (decodeStepsPerFrame), per-frame
/// buffers read through copies. GPUs; CPU devices too with CSGV_AS_GPU=1 (the renderer's tests
/// run so on lavapipe; dispatch shapes stay the CPU device's).
bool choosesAsGpu(const DeviceInfo& device);
/// Whether `decode` decodes on the host on this device (Auto: unless choosesAsGpu). The one rule for
/// renderers and for uploads made for them (GpuVolumeOptions::hostDecoding).
bool decodesOnHost(RendererOptions::Decode decode, const DeviceInfo& device);
/// The same for an upload of `volume` under `budget` bytes (0: automatic): Auto also decodes on
/// the host when the encoding GPU decoding needs on the device (without its finest level where
/// the budget separates it) would take more than three quarters of the budget, which then holds
/// no encoding at all.
bool decodesOnHost(RendererOptions::Decode decode, const DeviceInfo& device, const CompressedVolume& volume, uint64_t budget);

/// @brief One frame's inputs.
struct FrameInput {
    std::array<double, 16> worldToClip{}; ///< column-major
    uint32_t width = 0, height = 0;
    /// Optional window depth of opaque geometry per pixel (row 0 at the bottom): rays stop there.
    const float* opaqueDepth = nullptr;
};

/// A pixel rectangle [x0, x1) x [y0, y1) holds no pixel.
inline bool rectEmpty(const std::array<uint32_t, 4>& r) { return r[0] >= r[2] || r[1] >= r[3]; }

/// The smallest pixel rectangle holding both (an empty one adds nothing).
inline std::array<uint32_t, 4> rectUnion(const std::array<uint32_t, 4>& a, const std::array<uint32_t, 4>& b) {
    if (rectEmpty(a)) return b;
    if (rectEmpty(b)) return a;
    return {std::min(a[0], b[0]), std::min(a[1], b[1]), std::max(a[2], b[2]), std::max(a[3], b[3])};
}

/// @brief Per-pixel results, row 0 at the bottom.
struct FrameOutput {
    uint32_t width = 0, height = 0;
    std::vector<float> rgba;       ///< premultiplied, 4 floats a pixel (multiples of 1/255: of rgba8)
    std::vector<uint32_t> rgba8;   ///< the same, as the device writes it: 8 bits a channel, R lowest
    std::vector<float> depth;      ///< window depth of the first surface (1: none)
    /// First opaque label hit (original label), or, where the ray met no opaque surface, its first
    /// semi-transparent one (`translucent` 1); kInvalidLabel: none. This and the next four are the
    /// pixel's first sample's, whose ray is the pixel centre's (later samples are jittered).
    std::vector<uint32_t> label;
    std::vector<Face> face;        ///< its entry face
    std::vector<float> hitDepth;   ///< window depth of the hit
    std::vector<float> distance;   ///< world distance from the near plane to the hit
    std::vector<uint8_t> translucent; ///< 1: the hit is a semi-transparent surface's
    std::vector<uint32_t> samples; ///< valid samples per pixel
    /// Pixels [x0, x1) x [y0, y1) the frames since the accumulation's last reset covered: every
    /// pixel outside is empty (colour 0, depth 1, no label), so a compositor may draw this alone.
    std::array<uint32_t, 4> rect{};
};

struct FrameStats {
    double milliseconds = 0;      ///< wall time of the frame's submission
    uint32_t frame = 0;           ///< frames since the last reset of the accumulation
    uint32_t decodedBricks = 0;   ///< bricks the frame decoded, those it carried on included
    uint32_t carriedDecodes = 0;  ///< decodes still running after the frame (RendererOptions::decodeStepsPerFrame)
    uint32_t newSamples = 0;      ///< pixels that gained a sample
    uint32_t missingPixels = 0;   ///< pixels whose ray met a brick not yet in the cache
    uint32_t minSamples = 0;      ///< fewest samples of any pixel after the frame
    uint32_t holes = 0;           ///< pixels shown empty: no sample or preview of their own or of their stride block
    /// Pixels showing a preview: no sample of their own or of their stride block yet, but a view
    /// ray that went on through missing bricks at their coarsest level (never accumulated).
    uint32_t previews = 0;
    /// Pixel stride of the frame: the settings', or in a still render coarser while its first image
    /// is incomplete (a slow frame) and then as coarse as a frame within half the budget needs.
    uint32_t stride = 1;
    uint64_t cacheUsedBytes = 0;
    bool cacheFull = false;
    bool cacheReset = false;      ///< the cache was reset before this frame
    bool requestLimited = false;  ///< brick request limitation was on
    /// Cache pressure changed how the next frame treats the cache (eviction age, request band, a
    /// defragmentation reset): a frame without new samples may still lead somewhere.
    bool cacheAdapting = false;
    /// Detail streaming: bricks whose finest-level stream this frame asked for (they show at the
    /// next coarser level meanwhile, as previews), and streams uploaded before this frame.
    uint32_t detailRequests = 0;
    uint32_t detailUploads = 0;
    uint32_t badBricks = 0;       ///< bricks this frame failed to decode (Renderer::firstBadBrick says why)

    /// Nothing happened that later frames build on: no new sample, no decoded brick, no change of
    /// the cache policy, no detail asked for or uploaded (render loops stop after idleLimit() such frames in a row).
    bool idle() const { return newSamples == 0 && decodedBricks == 0 && !cacheAdapting && detailRequests == 0 && detailUploads == 0; }
    /// Three cycles of the pixel stride: at stride s a pixel's turn comes every s^2 frames.
    uint32_t idleLimit() const { return 3 * stride * stride; }
};

/// @brief One render call of a view: camera, size, opaque depth, and how much to render.
struct RenderRequest {
    FrameInput frame;                ///< the opaque depth is compared with the renderer's copy and copied once, here
    bool interactive = false;        ///< one frame
    double timeBudgetSeconds = 3.0;  ///< still renders: stop after this, never before every pixel holds a sample
};

/// @brief What a render call did.
struct RenderResult {
    bool changed = false;   ///< false: the previous output is still exact, nothing rendered
    uint32_t frames = 0;    ///< frames rendered by this call
    bool cacheRanFull = false; ///< a frame of this call found the brick cache full
    FrameStats last;        ///< statistics of the last frame rendered
};

/// Device memory by buffer, for reports.
struct MemoryReport {
    std::vector<std::pair<std::string, uint64_t>> buffers;
    uint64_t total() const;
};

class Renderer {
public:
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    /// The volume stays shared: several renderers (views) may use one GpuVolume.
    static Result<std::unique_ptr<Renderer>> create(Context& context, std::shared_ptr<GpuVolume> volume,
                                                    const RendererOptions& options = {});

    /// Corner geometry (Metadata.h): origin of voxel (0,0,0)'s corner, spacing, direction. A
    /// different geometry resets the accumulation; the same one keeps it.
    void setGeometry(const Geometry& cornerGeometry);
    /// An MPI rank's piece of the volume (GpuVolumeOptions::owned), voxels [lo, hi): `faces` are the
    /// stored labels just outside each side (csgv::ghostFaces: -x, +x, -y, +y, -z, +z; empty on
    /// the volume's boundary). A ray entering the piece from outside then starts with the label it
    /// leaves, so a label continuing across the boundary is not a new surface (translucent
    /// materials composite over the ranks as over one). Restarts the accumulation. An error for a
    /// volume that is not a piece.
    Status setGhostFaces(const std::array<uint32_t, 3>& lo, const std::array<uint32_t, 3>& hi,
                         const std::array<std::vector<uint32_t>, 6>& faces);
    /// An MPI rank's piece: the whole volume's stored labels at levels `first`, first + 1, ..., the
    /// coarsest (`levels[i]` at level first + i: lodDimensions(volume dims, first + i), x
    /// fastest), so that shadow, ambient-occlusion and path-tracing rays meet other ranks' bricks
    /// at their level of detail (as one rank's rays meet them), or at `first` where that is
    /// coarser, instead of passing through them (view rays still pass: the owner draws them).
    /// Restarts the accumulation. An error for a volume that is not a piece.
    Status setCoarseStandIns(uint32_t first, const std::vector<std::vector<uint32_t>>& levels);
    /// Materials with colormaps resolved to control points. `attributes` are per stored label
    /// (index = the label value in the volume); `label` is built in. `storedToOriginal` maps
    /// stored labels to original labels (relabelled files); empty when they are the same.
    /// Recomputes which bricks are visible (their palettes against the materials). Materials and
    /// arrays that pack to what the shaders read already keep the accumulated image.
    Status setMaterials(const MaterialDocument& materials,
                        const std::map<std::string, std::vector<float>>& attributes = {},
                        const std::vector<uint32_t>& storedToOriginal = {});
    /// Different settings reset the accumulation; the same ones keep it, and so does another
    /// sample target or subsampling alone (the samples taken stay valid), except after frames at
    /// a target of one sample, which keep no sums (CPU-cheap): those samples are taken again.
    void setSettings(const RenderSettings& settings);
    const RenderSettings& settings() const { return m_settings; }
    /// Makes the pipelines a frame with these settings will use (with or without an opaque depth
    /// input) now, not at that frame: a caller may overlap their compilation (about 70 ms for the
    /// render pipeline on a CPU device) with other work. render() makes whatever is still missing.
    Status preparePipelines(bool depthInput);
    /// Starts making, on a thread of its own at a low priority, the pipelines the other shading
    /// modes need with these settings (once per renderer; it touches the shared context only), so
    /// that switching the mode shows its first frame without waiting for the compiler (about a
    /// second per mode on a CPU device). Frames do not wait for it. waitForWarming: for tests.
    void warmShadingModes(bool depthInput);
    void waitForWarming();

    /// Renders what the request calls for: one frame when interactive, else frames until every
    /// pixel holds max(1, settings().sampleTarget) samples, the next frame (as long as the last)
    /// would end past the time budget (never before every pixel holds one sample), nothing changes (three frames without new samples or decoded
    /// bricks), or target * subsampling^2 + 256 frames. A new camera, size or opaque depth (or
    /// settings, geometry, materials since the last call) resets the accumulation; when nothing
    /// changed since a call that reached the target, nothing is rendered (`changed` false). Reads
    /// colour and depth back (output()). This is a view's render call (the ParaView representation).
    Result<RenderResult> render(const RenderRequest& request);
    /// Renders one frame and accumulates it (`csgv render`'s per-frame loop and the tests). A new
    /// camera, size or opaque depth resets the accumulation; once every pixel holds `sampleTarget`
    /// samples nothing is submitted. Reads nothing back.
    Result<FrameStats> renderFrame(const FrameInput& input);
    /// Parts of the output to read back (a compositor needs only colour and depth).
    enum OutputParts : uint32_t { Color = 1, Depth = 2, GBuffer = 4, Samples = 8, Color8 = 16, All = 31 };
    /// The output of the last render/renderFrame: 8-bit colour and depth always, plus `parts`; each part
    /// is read from the device once per frame, on first use (picking and the label image need the
    /// G-buffer, compositing does not). Empty before the first frame.
    const FrameOutput& output(uint32_t parts = Color8 | Depth);
    /// Reads the current resolved image and G-buffer into `out` (the parts asked for; others stay
    /// as they are).
    Status readOutput(FrameOutput& out, uint32_t parts = All) const;
    /// The time model's view of a caller's whole draw: the last render() ended a draw of `frames`
    /// frames of `pixels` each, in the settings' shading mode, that took `seconds` (render,
    /// read-back and compositing; FramePolicy.h).
    void recordDraw(double seconds, uint32_t frames, double pixels);
    /// The reduction factor per axis (1..8) of an interactive frame of `pixels` in the settings'
    /// shading mode, so that a draw takes at most half of 1 / `desiredRate` seconds: from the draws
    /// recorded, else from this renderer's own frames (FramePolicy.h's interactiveReduction).
    int interactiveReduction(double pixels, double desiredRate) const;
    /// Starts accumulating anew (the cache stays).
    void resetAccumulation();
    /// Empties the brick cache.
    void resetCache();

    MemoryReport memory() const;
    /// The device-memory budget in force (RendererOptions::deviceMemoryBytes or the automatic one):
    /// memory().total() never exceeds it.
    uint64_t deviceMemoryBudget() const;
    /// How the shaders find a stored label's material: kLookupDense (one table covers every
    /// label the rays meet, with the labels' colours) or kLookupScan (LabelLookup.h).
    uint32_t labelLookup() const;
    /// Detail streaming (GPU decoding of a separated volume): finest-level streams uploaded into the
    /// detail buffer and evicted from it, since creation (zeros without streaming).
    bool streamsDetail() const;
    DetailCounts detailCounts() const;
    /// Bricks whose encoding failed to decode on the host since the renderer was made (a corrupt
    /// or truncated brick: it is drawn as empty, the rest renders), and the first one's error.
    uint64_t badBricks() const;
    std::string firstBadBrick() const;
    const GpuVolume& volume() const { return *m_volume; }

    /// A brick in the cache (diagnostics and tests): its level of detail and, at the finest
    /// level, its uniform levels and its uniform sub-blocks (bit j: Morton sub-block j of csgv/codec/Layout.h lies inside
    /// the volume and holds one label) and its hidden ones (inside the volume, no label the
    /// materials draw; marked where the volume holds several undrawn labels, else 0: then they are
    /// uniform). Rays step over both whole, over a Morton-aligned 2x2x2 group of hidden ones at once.
    struct CachedBrick {
        uint32_t brick = 0;
        uint32_t lod = 0;
        uint64_t uniformSubBlocks = 0;
        uint64_t hiddenSubBlocks = 0;
        /// With GpuVolume::uniformLevels, at the finest level: each entry's uniform level (Morton
        /// order, csgv/codec/UniformLevels.h) as its cache word holds it; else empty.
        std::vector<uint8_t> uniformLevels;
    };
    /// Reads the brick table back: the bricks the cache holds now.
    Result<std::vector<CachedBrick>> cachedBricks() const;

    /// The bricks a view's rays touched (its working set) and the brick cache that has to hold
    /// them: whether a budget lets a view converge without decoding its own bricks again.
    struct WorkingSet {
        uint64_t bricks = 0;       ///< drawn bricks some ray touched since the mark, cached or not
        uint64_t cachedBricks = 0; ///< of those, the ones in the cache now
        /// Cache bytes they take, each at the level the last frame's camera wants for it.
        uint64_t bytes = 0;
        uint64_t cacheBytes = 0;   ///< the brick cache's size
    };
    /// A mark before a view's first frame (the frame counter, never reset).
    uint32_t frameMark() const;
    /// Reads the brick table back: the bricks touched by the frames since `mark`.
    Result<WorkingSet> workingSet(uint32_t mark) const;

    struct Impl;

private:
    Renderer() = default;
    std::unique_ptr<Impl> m_impl;
    std::shared_ptr<GpuVolume> m_volume;
    RenderSettings m_settings;
};

} // namespace csgv::gpu
