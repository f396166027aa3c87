// SPDX-License-Identifier: MIT
// The frame pipeline and ray marcher: the GPU G-buffer at the finest level equals the float CPU
// mirror of the stable DDA exactly (labels, faces) and within 1e-4 (depth, distance); cache
// pressure and subsampling converge to the same image; shading modes match baselines.
#include "GpuTestSupport.h"
#include "RenderTestSupport.h"
#include "TestData.h"
#include "Png.h"

#include "csgv/attributes/Attributes.h"
#include "csgv/base/Checked.h"
#include "csgv/codec/BrickGroups.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/codec/Partition.h"
#include "csgv/codec/UniformLevels.h"
#include "csgv/reference/RayCast.h"
#include "csgv/gpu/DetailStream.h"
#include "csgv/gpu/LabelLookup.h"
#include "csgv/gpu/Renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <map>
#include <set>

using namespace csgv;
using namespace csgv::gpu;
using namespace csgvtest;

namespace {

struct Scene {
    CompressedVolume volume;
    LabelVolume labels;
    std::shared_ptr<GpuVolume> gpu;
};

Scene& fixtureScene(Context& ctx, const std::string& name) {
    static std::map<std::string, std::unique_ptr<Scene>> scenes;
    std::unique_ptr<Scene>& s = scenes[name];
    if (!s) {
        s = std::make_unique<Scene>();
        s->volume = loadFixture(name);
        Result<LabelVolume> l = decodeVolume(s->volume, 0);
        EXPECT_TRUE(l.isOk()) << l.message();
        s->labels = std::move(*l);
        Result<std::unique_ptr<GpuVolume>> g = GpuVolume::create(ctx, s->volume);
        EXPECT_TRUE(g.isOk()) << g.message();
        s->gpu = std::move(*g);
    }
    return *s;
}

/// The scene's GPU volume, or a new one with cache paletting (null after a failure).
std::shared_ptr<GpuVolume> gpuVolume(Context& ctx, Scene& scene, bool paletting) {
    if (!paletting) return scene.gpu;
    GpuVolumeOptions o;
    o.cachePaletting = true;
    Result<std::unique_ptr<GpuVolume>> pg = GpuVolume::create(ctx, scene.volume, o);
    EXPECT_TRUE(pg.isOk()) << pg.message();
    if (!pg) return nullptr;
    EXPECT_LT((*pg)->cacheBits(), 32u) << "cache paletting";
    return std::move(*pg);
}

/// A renderer of the scene's GPU volume with options `o` and settings `st`, or null after a failure.
std::unique_ptr<Renderer> sceneRenderer(Context& ctx, Scene& scene, const RendererOptions& o, const RenderSettings& st) {
    Result<std::unique_ptr<Renderer>> r = Renderer::create(ctx, scene.gpu, o);
    EXPECT_TRUE(r.isOk()) << r.message();
    if (!r) return nullptr;
    (*r)->setSettings(st);
    return std::move(*r);
}

/// A label volume of size `dim` whose voxel (x, y, z) holds label(x, y, z).
template <typename F>
LabelVolume labelVolumeOf(const std::array<uint32_t, 3>& dim, F label) {
    LabelVolume v;
    v.dim = dim;
    v.labels.resize(size_t(v.dim[0]) * v.dim[1] * v.dim[2]);
    for (uint32_t z = 0; z < v.dim[2]; ++z)
        for (uint32_t y = 0; y < v.dim[1]; ++y)
            for (uint32_t x = 0; x < v.dim[0]; ++x) v.labels[size_t(v.index(x, y, z))] = label(x, y, z);
    return v;
}

/// Settings whose images tests compare exactly: the finest level, no jitter, no denoising.
RenderSettings exactSettings() {
    RenderSettings st;
    st.finest = true;
    st.jitter = false;
    st.denoise = false;
    return st;
}

/// Renders until every pixel has `samples` samples (or `maxFrames` frames).
FrameOutput renderConverged(Renderer& r, const FrameInput& in, uint32_t samples, uint32_t maxFrames,
                            uint32_t* framesUsed = nullptr) {
    RenderSettings st = r.settings();
    st.sampleTarget = samples;
    r.setSettings(st);
    uint32_t f = 0;
    for (; f < maxFrames; ++f) {
        Result<FrameStats> s = r.renderFrame(in);
        EXPECT_TRUE(s.isOk()) << s.message();
        if (!s || s->minSamples >= samples) break;
    }
    if (framesUsed) *framesUsed = f + 1;
    FrameOutput out;
    EXPECT_TRUE(r.readOutput(out).isOk());
    return out;
}

void expectGBufferEquals(const FrameOutput& out, const GBuffer& ref, const std::string& what, size_t minHitShare = 10);

/// How Core's castRaysStable must step to mirror a renderer: over the uniform cubes its cache words
/// carry (GpuVolume::uniformLevels), else over uniform sub-blocks.
UniformSteps stepsOf(const Renderer& r) { return r.volume().uniformLevels() ? UniformSteps::Levels : UniformSteps::SubBlocks; }

/// A renderer of `gpu` (the scene's volume) with `options`, at one sample a pixel at the finest
/// level without jitter: its G-buffer equals castRaysStable's, stepping as the renderer does.
void expectGBufferOfVolume(Context& ctx, Scene& scene, const std::shared_ptr<GpuVolume>& gpu, const RendererOptions& options,
                           const FrameInput& in, const Geometry& g, const std::string& what, FrameOutput* image = nullptr) {
    Result<std::unique_ptr<Renderer>> r = Renderer::create(ctx, gpu, options);
    ASSERT_TRUE(r.isOk()) << r.message();
    (*r)->setGeometry(g);
    RenderSettings st;
    st.finest = true;
    st.jitter = false;
    st.denoise = false;
    (*r)->setSettings(st);
    const FrameOutput out = renderConverged(**r, in, 1, 64);
    if (image) *image = out;
    RayCastView view{in.worldToClip, in.width, in.height};
    const GBuffer ref = castRaysStable(scene.labels, g, view, [](uint32_t l) { return l != 0 && l != kInvalidLabel; },
                                       scene.volume.brickSize, stepsOf(**r));
    expectGBufferEquals(out, ref, what);
}

void expectGBufferEqualsReference(Context& ctx, const std::string& fixtureName, const FrameInput& in, const Geometry& g,
                                  const std::string& what, bool paletting = false,
                                  RendererOptions::Decode decode = RendererOptions::Decode::Auto, bool texels = true,
                                  FrameOutput* image = nullptr) {
    Scene& scene = fixtureScene(ctx, fixtureName);
    std::shared_ptr<GpuVolume> gpu = gpuVolume(ctx, scene, paletting);
    ASSERT_TRUE(gpu) << what;
    RendererOptions options;
    options.decode = decode;
    options.renderTexels = texels;
    expectGBufferOfVolume(ctx, scene, gpu, options, in, g, what, image);
}

/// The renderer's G-buffer equals the stable reference's: labels, faces, and depths and
/// distances within float rounding; the view shows the volume (on a 1/minHitShare of its pixels
/// at least) and some background.
void expectGBufferEquals(const FrameOutput& out, const GBuffer& ref, const std::string& what, size_t minHitShare) {
    size_t labelDiff = 0, faceDiff = 0, depthDiff = 0, hits = 0;
    for (size_t i = 0; i < ref.label.size(); ++i) {
        labelDiff += out.label[i] != ref.label[i];
        if (ref.label[i] == kInvalidLabel) continue;
        ++hits;
        faceDiff += out.face[i] != ref.face[i];
        const float dd = std::fabs(out.distance[i] - ref.distance[i]);
        depthDiff += dd > 1e-4f * std::max(ref.distance[i], 1e-3f) || std::fabs(out.hitDepth[i] - ref.depth[i]) > 1e-4f;
    }
    EXPECT_EQ(labelDiff, 0u) << what;
    EXPECT_EQ(faceDiff, 0u) << what;
    EXPECT_EQ(depthDiff, 0u) << what;
    EXPECT_GT(hits, ref.label.size() / minHitShare) << what << ": the view should show the volume";
    EXPECT_LT(hits, ref.label.size()) << what << ": the view should show some background";
}

/// `in` at one sample a pixel at the finest level without jitter (as castRaysStable casts it),
/// its G-buffer compared with `ref`'s (expectGBufferEquals), and each hit pixel's colour with what
/// `rightColour(label, rgba)` expects of its label (the first three others reported).
void expectFinestImage(Renderer& r, const FrameInput& in, const GBuffer& ref, const std::string& what,
                       const std::function<bool(uint32_t, const float*)>& rightColour) {
    RenderSettings st = r.settings();
    st.finest = true;
    st.jitter = false;
    r.setSettings(st);
    const FrameOutput out = renderConverged(r, in, 1, 64);
    expectGBufferEquals(out, ref, what);
    size_t wrong = 0;
    for (size_t i = 0; i < ref.label.size(); ++i) {
        const float* c = &out.rgba[4 * i];
        if (ref.label[i] == kInvalidLabel || rightColour(ref.label[i], c)) continue;
        if (wrong++ < 3)
            ADD_FAILURE() << what << ": pixel " << i << " label " << ref.label[i] << ": " << c[0] << " " << c[1] << " " << c[2] << " " << c[3];
    }
    EXPECT_EQ(wrong, 0u) << what << ": hit pixels in their labels' colours";
}

} // namespace

TEST(Renderer, GBufferEqualsStableReferencePerspective) {
    CSGV_REQUIRE_GPU(ctx);
    const FrameInput in = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    expectGBufferEqualsReference(*ctx, "synthA_b32_rans2.csgv", in, Geometry{}, "perspective");
}

TEST(Renderer, GBufferEqualsStableReferenceParallelAnisotropic) {
    CSGV_REQUIRE_GPU(ctx);
    Geometry g;
    g.spacing = {0.8, 1.0, 1.7};
    g.origin = {-10, 5, 2};
    const FrameInput in = parallelView({150, -60, 120}, {30, 40, 60}, {0, 0.3, 1}, 60, 80, 64);
    expectGBufferEqualsReference(*ctx, "synthA_b16_nibble.csgv", in, g, "parallel");
}

TEST(Renderer, GBufferEqualsStableReferenceParallelAlongAnAxis) {
    CSGV_REQUIRE_GPU(ctx);
    // Every ray runs parallel to two axes (their direction components are +0.0): they must step
    // through empty space like any other ray (they used to hit nothing).
    const FrameInput in = parallelView({30.5, 40.5, 300}, {30.5, 40.5, 0}, {0, 1, 0}, 60, 81, 63);
    expectGBufferEqualsReference(*ctx, "synthA_b16_nibble.csgv", in, Geometry{}, "parallel along z");
}

TEST(Renderer, GBufferEqualsStableReferenceWithCachePaletting) {
    CSGV_REQUIRE_GPU(ctx);
    const FrameInput in = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    // Palette indices packed by the GPU decoder and by the host (Core's decoder, then packing).
    expectGBufferEqualsReference(*ctx, "synthA_b32_rans2.csgv", in, Geometry{}, "paletted, GPU decoding", true,
                                 RendererOptions::Decode::Gpu);
    expectGBufferEqualsReference(*ctx, "synthA_b32_rans2.csgv", in, Geometry{}, "paletted, host decoding", true,
                                 RendererOptions::Decode::Host);
}

// Without uniform levels (GpuVolumeOptions::uniformLevels off, as for labels of 2^29 and more) a
// cache of 32-bit labels steps over uniform sub-blocks alone, and the G-buffer equals Core's
// stepping so, after host and GPU decoding.
TEST(Renderer, GBufferEqualsStableReferenceWithoutUniformLevels) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    ASSERT_TRUE(scene.gpu->uniformLevels());
    GpuVolumeOptions vo;
    vo.uniformLevels = false;
    Result<std::unique_ptr<GpuVolume>> made = GpuVolume::create(*ctx, scene.volume, vo);
    ASSERT_TRUE(made.isOk()) << made.message();
    ASSERT_FALSE((*made)->uniformLevels()); // stepsOf then gives castRaysStable UniformSteps::SubBlocks
    const std::shared_ptr<GpuVolume> gpu(std::move(*made));
    const FrameInput in = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    for (const RendererOptions::Decode decode : {RendererOptions::Decode::Host, RendererOptions::Decode::Gpu}) {
        RendererOptions o;
        o.decode = decode;
        expectGBufferOfVolume(*ctx, scene, gpu, o, in, Geometry{}, decode == RendererOptions::Decode::Gpu ? "sub-blocks, GPU decoding"
                                                                                                          : "sub-blocks, host decoding");
    }
}

// The render pass reads its hottest words through texel buffers where the device allows
// (RendererOptions::renderTexels), else through buffer addresses, as it does for caches larger
// than a texel view: both give the reference's G-buffer and the same image, bit for bit.
TEST(Renderer, GBufferEqualsStableReferenceThroughBufferAddressesAsThroughTexels) {
    CSGV_REQUIRE_GPU(ctx);
    const FrameInput in = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    for (bool paletted : {false, true}) {
        const std::string what = paletted ? "paletted, " : "";
        FrameOutput texels, addresses;
        expectGBufferEqualsReference(*ctx, "synthA_b32_rans2.csgv", in, Geometry{}, what + "texels", paletted,
                                     RendererOptions::Decode::Host, true, &texels);
        expectGBufferEqualsReference(*ctx, "synthA_b32_rans2.csgv", in, Geometry{}, what + "addresses", paletted,
                                     RendererOptions::Decode::Host, false, &addresses);
        ASSERT_EQ(texels.rgba.size(), addresses.rgba.size());
        EXPECT_EQ(texels.rgba, addresses.rgba) << what;
        EXPECT_EQ(texels.label, addresses.label) << what;
    }
}

TEST(Renderer, GBufferEqualsStableReferenceCameraInside) {
    CSGV_REQUIRE_GPU(ctx);
    const FrameInput in = perspectiveView({30.3, 35.7, 20.2}, {80, 70, 60}, {0, 0, 1}, 70, 64, 64);
    expectGBufferEqualsReference(*ctx, "synthA_b8_nibble_delta.csgv", in, Geometry{}, "inside");
}

namespace {

/// Bit j: sub-block j (Morton order, edge brickSize / 4) of `brick` lies inside the volume and
/// its nodes in `level` (the volume decoded at `lod`) hold one label or, given `visible`, no
/// visible label (the renderer's uniform and hidden sub-blocks); computed node by node.
uint64_t expectedSubBlockMask(const CompressedVolume& vol, const LabelVolume& level, uint32_t brick,
                              const std::function<bool(uint32_t)>& visible = nullptr, uint32_t lod = 0) {
    const std::array<uint32_t, 3> grid = vol.brickGrid();
    const uint32_t origin[3] = {brick % grid[0] * vol.brickSize, brick / grid[0] % grid[1] * vol.brickSize,
                                brick / (grid[0] * grid[1]) * vol.brickSize};
    const uint32_t edge = vol.brickSize / 4, nodes = edge >> lod;
    uint64_t mask = 0;
    for (uint32_t j = 0; j < 64; ++j) {
        uint32_t o[3] = {0, 0, 0};
        for (uint32_t bit = 0; bit < 6; ++bit) o[bit % 3] |= ((j >> bit) & 1u) << (bit / 3); // Morton: x in bit 0
        bool inside = true;
        for (int a = 0; a < 3; ++a) {
            inside = inside && origin[a] + (o[a] + 1) * edge <= vol.dim[a];
            o[a] = (origin[a] + o[a] * edge) >> lod;
        }
        if (!inside) continue;
        const uint32_t first = level.at(o[0], o[1], o[2]);
        bool same = !visible, hidden = bool(visible);
        for (uint32_t z = 0; z < nodes; ++z)
            for (uint32_t y = 0; y < nodes; ++y)
                for (uint32_t x = 0; x < nodes; ++x) {
                    const uint32_t l = level.at(o[0] + x, o[1] + y, o[2] + z);
                    same = same && l == first;
                    hidden = hidden && !visible(l);
                }
        if (same || hidden) mask |= uint64_t(1) << j;
    }
    return mask;
}

/// Core's uniform levels of brick `b` (UniformLevels.h), from the volume's labels.
std::vector<uint8_t> expectedUniformLevels(const CompressedVolume& vol, const LabelVolume& labels, uint32_t b) {
    const uint32_t shift = floorLog2(vol.brickSize);
    const std::array<uint32_t, 3> grid = vol.brickGrid();
    const std::array<uint32_t, 3> origin = {b % grid[0] << shift, b / grid[0] % grid[1] << shift, b / (grid[0] * grid[1]) << shift};
    const uint32_t n = 1u << (3 * shift);
    std::vector<uint32_t> morton(n);
    for (uint32_t e = 0; e < n; ++e) {
        const uint32_t x = origin[0] + mortonX(e), y = origin[1] + mortonY(e), z = origin[2] + mortonZ(e);
        morton[e] = x < vol.dim[0] && y < vol.dim[1] && z < vol.dim[2] ? labels.at(x, y, z) : kInvalidLabel;
    }
    std::vector<uint8_t> runs(n / 8), levels(n);
    uniformLevels(morton.data(), shift, origin, {vol.dim[0], vol.dim[1], vol.dim[2]}, runs.data());
    for (uint32_t e = 0; e < n; ++e) levels[e] = runs[e / 8];
    return levels;
}

void expectUniformMasks(Context& ctx, RendererOptions::Decode decode, bool paletting) {
    Scene& scene = fixtureScene(ctx, "synthA_b16_nibble.csgv");
    std::shared_ptr<GpuVolume> gpu = gpuVolume(ctx, scene, paletting);
    ASSERT_TRUE(gpu);
    RendererOptions o;
    o.decode = decode;
    Result<std::unique_ptr<Renderer>> r = Renderer::create(ctx, gpu, o);
    ASSERT_TRUE(r.isOk()) << r.message();
    RenderSettings st;
    st.finest = true;
    (*r)->setSettings(st);
    const FrameInput in = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    renderConverged(**r, in, 1, 64);
    Result<std::vector<Renderer::CachedBrick>> cached = (*r)->cachedBricks();
    ASSERT_TRUE(cached.isOk()) << cached.message();
    size_t finest = 0, uniform = 0, mixed = 0;
    uint32_t deepest = 0;
    for (const Renderer::CachedBrick& b : *cached) {
        ASSERT_EQ(b.lod, 0u);
        ++finest;
        const uint64_t want = expectedSubBlockMask(scene.volume, scene.labels, b.brick);
        EXPECT_EQ(b.uniformSubBlocks, want) << "brick " << b.brick;
        // Uniform levels ride in the cache words where they hold labels (not palette indices).
        ASSERT_EQ(b.uniformLevels.empty(), paletting) << "brick " << b.brick;
        if (!paletting) {
            const std::vector<uint8_t> levels = expectedUniformLevels(scene.volume, scene.labels, b.brick);
            EXPECT_EQ(b.uniformLevels, levels) << "brick " << b.brick;
            for (const uint8_t l : levels) deepest = std::max<uint32_t>(deepest, l);
        }
        // The default materials leave label 0 alone undrawn: its sub-blocks are uniform ones.
        EXPECT_EQ(b.hiddenSubBlocks, 0u) << "brick " << b.brick;
        uniform += want != 0;
        mixed += want != ~uint64_t(0);
    }
    // The view must cache bricks with uniform sub-blocks and bricks with mixed ones.
    EXPECT_GT(finest, 4u);
    EXPECT_GT(uniform, 0u);
    EXPECT_GT(mixed, 0u);
    // ... and cubes larger than a sub-block (levels above it come from several sub-blocks).
    if (!paletting) EXPECT_GT(deepest, floorLog2(scene.volume.brickSize) - kUniformShift);
}

} // namespace

// A view's working set (csgv render's view_working_set_mib): the bricks its rays touched, each at
// the level the view wants (the host's mirror of lodForBrick). Without prefetching, a fresh cache
// large enough holds exactly those bricks after the view converges, each at that level: the same
// count and bytes. The frames of a later view from elsewhere touch others; a mark after the last
// frame holds none.
TEST(Renderer, WorkingSetIsTheViewsBricksAtTheirLevels) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    std::shared_ptr<GpuVolume> gpu = gpuVolume(*ctx, scene, false);
    ASSERT_TRUE(gpu);
    RendererOptions o;
    o.prefetchVoxels = 0;
    Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, gpu, o);
    ASSERT_TRUE(r.isOk()) << r.message();
    // From afar, at 40x30: several levels of detail.
    const FrameInput in = perspectiveView({-120, 160, 200}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 40, 30);
    const uint32_t mark = (*r)->frameMark();
    renderConverged(**r, in, 1, 64);
    Result<Renderer::WorkingSet> ws = (*r)->workingSet(mark);
    ASSERT_TRUE(ws.isOk()) << ws.message();
    Result<std::vector<Renderer::CachedBrick>> cached = (*r)->cachedBricks();
    ASSERT_TRUE(cached.isOk()) << cached.message();
    uint64_t bytes = 0;
    std::set<uint32_t> levels;
    for (const Renderer::CachedBrick& b : *cached) {
        bytes += gpu->regionWords(b.lod) * 4;
        levels.insert(b.lod);
    }
    EXPECT_GT(ws->bricks, 4u);
    EXPECT_EQ(ws->bricks, cached->size());
    EXPECT_EQ(ws->cachedBricks, ws->bricks);
    EXPECT_EQ(ws->bytes, bytes);
    EXPECT_GT(levels.size(), 1u) << "the view should want several levels";
    EXPECT_GT(ws->cacheBytes, ws->bytes);
    const uint32_t second = (*r)->frameMark();
    renderConverged(**r, perspectiveView({300, -200, -150}, {48, 40, 30}, {0, 0, 1}, 40, 96, 72), 1, 64);
    Result<Renderer::WorkingSet> other = (*r)->workingSet(second);
    ASSERT_TRUE(other.isOk());
    EXPECT_GT(other->bricks, 4u);
    Result<Renderer::WorkingSet> none = (*r)->workingSet((*r)->frameMark());
    ASSERT_TRUE(none.isOk());
    EXPECT_EQ(none->bricks, 0u);
    EXPECT_EQ(none->bytes, 0u);
}

// Host decoding (the default on CPU devices), the GPU decoder's pass, and with cache paletting:
// each marks exactly the sub-blocks that hold one label.
TEST(Renderer, UniformSubBlocksAreMarkedExactly) {
    CSGV_REQUIRE_GPU(ctx);
    expectUniformMasks(*ctx, RendererOptions::Decode::Auto, false);
    expectUniformMasks(*ctx, RendererOptions::Decode::Gpu, false);
    expectUniformMasks(*ctx, RendererOptions::Decode::Gpu, true);
    expectUniformMasks(*ctx, RendererOptions::Decode::Host, true);
}

namespace {

/// The scene's labels but 0, sorted, each once.
std::vector<uint32_t> drawableLabels(const Scene& scene) {
    std::vector<uint32_t> labels(scene.labels.labels);
    std::sort(labels.begin(), labels.end());
    labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    if (!labels.empty() && labels.front() == 0) labels.erase(labels.begin());
    return labels;
}

/// One material drawing the labels in [lo, hi] alone.
Result<MaterialDocument> rangeMaterials(uint32_t lo, uint32_t hi) {
    return parseMaterials(R"({"version": 1, "materials": [{"name": "some", "filter": {"attribute": "label", "min": )" +
                          std::to_string(lo) + ", \"max\": " + std::to_string(hi) + "}}]}");
}

/// Materials that draw the labels in [lo, hi] alone, then those in [hi + 1, max], then every
/// label but 0: each time the G-buffer equals the stable reference's for those labels (which
/// steps over the same sub-blocks: one label, or none drawn, in groups of eight where all are)
/// and the cached bricks' hidden sub-blocks are exactly those without drawn labels. Each
/// document keeps the cache: its masks are made anew for every cached brick, or rays would step
/// over sub-blocks that now show labels. The last leaves one label undrawn: no hidden sub-blocks
/// (its sub-blocks are uniform ones).
void expectHiddenSubBlocksFollowTheMaterials(Context& ctx, RendererOptions::Decode decode, bool paletting, bool texels = true) {
    Scene& scene = fixtureScene(ctx, "synthA_b32_rans2.csgv");
    std::shared_ptr<GpuVolume> gpu = gpuVolume(ctx, scene, paletting);
    ASSERT_TRUE(gpu);
    RendererOptions o;
    o.decode = decode;
    o.renderTexels = texels;
    Result<std::unique_ptr<Renderer>> r = Renderer::create(ctx, gpu, o);
    ASSERT_TRUE(r.isOk()) << r.message();
    RenderSettings st;
    st.finest = true;
    st.jitter = false;
    st.denoise = false;
    (*r)->setSettings(st);
    const std::vector<uint32_t> labels = drawableLabels(scene);
    ASSERT_GT(labels.size(), 8u);
    const uint32_t cut = labels[labels.size() / 3];
    const FrameInput in = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    struct Range {
        uint32_t lo, hi;
        bool several; // leaves several labels undrawn
        bool groups;  // leaves aligned 2x2x2 groups of bricks without drawn labels (BrickGroups.h)
    };
    for (const auto& [lo, hi, several, emptyGroups] :
         {Range{labels[0], labels[2], true, true}, Range{labels.front(), cut, true, false}, Range{cut + 1, labels.back(), true, false},
          Range{1, 4294967294u, false, false}}) {
        const std::string what = "labels " + std::to_string(lo) + " to " + std::to_string(hi) +
                                 (paletting ? ", paletted" : "") + (decode == RendererOptions::Decode::Gpu ? ", GPU decoding" : "") +
                                 (texels ? "" : ", through buffer addresses");
        Result<MaterialDocument> doc = rangeMaterials(lo, hi);
        ASSERT_TRUE(doc.isOk()) << doc.message();
        ASSERT_TRUE((*r)->setMaterials(*doc).isOk());
        const FrameOutput out = renderConverged(**r, in, 1, 64);
        const std::function<bool(uint32_t)> visible = [lo = lo, hi = hi](uint32_t l) { return l >= lo && l <= hi; };
        const GBuffer ref = castRaysStable(scene.labels, Geometry{}, RayCastView{in.worldToClip, in.width, in.height}, visible,
                                           scene.volume.brickSize, stepsOf(**r));
        expectGBufferEquals(out, ref, what, emptyGroups ? 100 : 10);
        if (emptyGroups) { // rays step over them whole: the G-buffer above covers that
            const std::array<uint32_t, 3> grid = scene.volume.brickGrid();
            std::vector<uint8_t> drawn(size_t(grid[0]) * grid[1] * grid[2], 0);
            const uint32_t e = scene.volume.brickSize;
            for (uint32_t z = 0; z < scene.labels.dim[2]; ++z)
                for (uint32_t y = 0; y < scene.labels.dim[1]; ++y)
                    for (uint32_t x = 0; x < scene.labels.dim[0]; ++x)
                        if (visible(scene.labels.at(x, y, z))) drawn[x / e + grid[0] * (y / e + size_t(grid[1]) * (z / e))] = 1;
            const std::vector<uint32_t> levels = emptyGroupLevels(grid, [&](uint64_t b) { return !drawn[size_t(b)]; });
            EXPECT_GT(std::count_if(levels.begin(), levels.end(), [](uint32_t g) { return g > 0; }), 0) << what;
        }
        Result<std::vector<Renderer::CachedBrick>> cached = (*r)->cachedBricks();
        ASSERT_TRUE(cached.isOk()) << cached.message();
        size_t mixed = 0, groups = 0;
        for (const Renderer::CachedBrick& b : *cached) {
            if (b.lod != 0) continue;
            const uint64_t want = several ? expectedSubBlockMask(scene.volume, scene.labels, b.brick, visible) : 0;
            EXPECT_EQ(b.hiddenSubBlocks, want) << what << ", brick " << b.brick;
            mixed += (want & ~expectedSubBlockMask(scene.volume, scene.labels, b.brick)) != 0;
            for (uint32_t g = 0; g < 8; ++g) groups += ((want >> (8 * g)) & 0xFF) == 0xFF;
        }
        if (several) {
            EXPECT_GT(mixed, 0u) << what << ": some cached brick must hide sub-blocks of several labels";
            EXPECT_GT(groups, 0u) << what << ": and groups of eight hidden sub-blocks";
        }
    }
}

} // namespace

// Bricks cached at coarser levels (nodes of 2 and 4 voxels, sub-blocks of 8) have hidden
// sub-blocks too, marked from their level's labels; stepping over them changes nothing: the
// G-buffer equals a renderer's that steps over none (there is no CPU mirror of coarser levels).
TEST(Renderer, HiddenSubBlocksAtCoarserLevelsChangeNothing) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    const std::vector<uint32_t> labels = drawableLabels(scene);
    ASSERT_GT(labels.size(), 8u);
    const uint32_t lo = labels.front(), hi = labels[labels.size() / 3];
    Result<MaterialDocument> doc = rangeMaterials(lo, hi);
    ASSERT_TRUE(doc.isOk()) << doc.message();
    const std::function<bool(uint32_t)> visible = [&](uint32_t l) { return l >= lo && l <= hi; };
    const FrameInput in = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    FrameOutput outs[2];
    for (int hidden = 0; hidden < 2; ++hidden) {
        RendererOptions o;
        o.hiddenSubBlocks = hidden == 1;
        RenderSettings st;
        st.lodBias = 1.5f;
        st.jitter = false;
        st.denoise = false;
        std::unique_ptr<Renderer> r = sceneRenderer(*ctx, scene, o, st);
        ASSERT_TRUE(r);
        ASSERT_TRUE(r->setMaterials(*doc).isOk());
        outs[hidden] = renderConverged(*r, in, 1, 64);
        Result<std::vector<Renderer::CachedBrick>> cached = r->cachedBricks();
        ASSERT_TRUE(cached.isOk()) << cached.message();
        size_t coarse = 0;
        for (const Renderer::CachedBrick& b : *cached) {
            if (!hidden || b.lod > 2) {
                if (!hidden) EXPECT_EQ(b.hiddenSubBlocks, 0u) << "brick " << b.brick << ": none marked when off";
                continue;
            }
            Result<LabelVolume> level = decodeVolume(scene.volume, b.lod);
            ASSERT_TRUE(level.isOk()) << level.message();
            const uint64_t want = expectedSubBlockMask(scene.volume, *level, b.brick, visible, b.lod);
            EXPECT_EQ(b.hiddenSubBlocks, want) << "brick " << b.brick << " at level " << b.lod;
            coarse += b.lod > 0 && want != 0;
        }
        if (hidden) EXPECT_GT(coarse, 0u) << "bricks cached at coarser levels with hidden sub-blocks";
    }
    GBuffer without; // the G-buffer of the renderer that steps over no hidden sub-block
    without.label = outs[0].label;
    without.face = outs[0].face;
    without.depth = outs[0].hitDepth;
    without.distance = outs[0].distance;
    expectGBufferEquals(outs[1], without, "coarser levels", 20);
}

TEST(Renderer, HiddenSubBlocksFollowTheMaterialsAndKeepTheGBufferExact) {
    CSGV_REQUIRE_GPU(ctx);
    expectHiddenSubBlocksFollowTheMaterials(*ctx, RendererOptions::Decode::Auto, false);
    expectHiddenSubBlocksFollowTheMaterials(*ctx, RendererOptions::Decode::Gpu, false);
    expectHiddenSubBlocksFollowTheMaterials(*ctx, RendererOptions::Decode::Gpu, true);
    expectHiddenSubBlocksFollowTheMaterials(*ctx, RendererOptions::Decode::Auto, true, false);
}

namespace {

std::unique_ptr<Renderer> makeRenderer(Context& ctx, Scene& scene, uint64_t cacheBytes, const RenderSettings& st,
                                       RendererOptions::Decode decode = RendererOptions::Decode::Auto,
                                       bool outlineSpans = true, bool texels = true) {
    RendererOptions o;
    o.cacheBytes = cacheBytes;
    o.decode = decode;
    o.outlineSpans = outlineSpans;
    o.renderTexels = texels;
    o.prefetchVoxels = 0; // rays find the bricks of a cold cache (the prefetch has a test of its own)
    return sceneRenderer(ctx, scene, o, st);
}

/// A 32^3 volume of label 0 around a 24^3 block [4, 28)^3 whose voxels take `labelAt(x, y, z)`.
LabelVolume blockVolume(const std::function<uint32_t(uint32_t, uint32_t, uint32_t)>& labelAt) {
    LabelVolume v;
    v.dim = {32, 32, 32};
    v.labels.assign(32 * 32 * 32, 0);
    for (uint32_t z = 4; z < 28; ++z)
        for (uint32_t y = 4; y < 28; ++y)
            for (uint32_t x = 4; x < 28; ++x) v.labels[size_t(v.index(x, y, z))] = labelAt(x, y, z);
    return v;
}

/// A renderer of a small hand-made volume (bricks of 16 unless said), or null after a failure.
/// `encoded` receives its encoding, which the renderer's GpuVolume refers to: it must outlive the
/// renderer.
std::unique_ptr<Renderer> volumeRenderer(Context& ctx, const LabelVolume& v, CompressedVolume& encoded,
                                         const RendererOptions& o = {}, uint32_t brickSize = 16) {
    EncodeOptions eo;
    eo.brickSize = brickSize;
    Result<CompressedVolume> vol = encodeVolume(v, eo);
    EXPECT_TRUE(vol.isOk()) << vol.message();
    if (!vol) return nullptr;
    encoded = std::move(*vol);
    Result<std::unique_ptr<GpuVolume>> gpu = GpuVolume::create(ctx, encoded);
    EXPECT_TRUE(gpu.isOk()) << gpu.message();
    if (!gpu) return nullptr;
    Result<std::unique_ptr<Renderer>> r = Renderer::create(ctx, std::shared_ptr<GpuVolume>(std::move(*gpu)), o);
    EXPECT_TRUE(r.isOk()) << r.message();
    if (!r) return nullptr;
    return std::move(*r);
}

} // namespace

// GPU decodes that carry over frames (RendererOptions::decodeStepsPerFrame, as on GPUs): in a frame
// that begins an accumulation (a moving camera's every frame) or refines a full image, a brick
// whose decoding takes more steps than the frame gives is missing to the rays, its decoding going
// on in the next frames; the frames between take every step. The converged G-buffer is the reference's, bit
// for bit, and a still view converges within one frame of decoding whole: with steps that one
// dispatch takes (300; its render runs beside it, RendererOptions::overlapDecodes, and without:
// 301) and that CPU devices split into three (1100: 512, 512, 76; never overlapped), after a moving
// camera whose decodes are still running when it stops (their bricks half decoded, some no longer
// wanted), and under a cache too small for the view (evictions and cache resets).
TEST(Renderer, DecodesCarriedOverFramesGiveTheReferenceGBuffer) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    const FrameInput in = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    RenderSettings st;
    st.finest = true;
    st.jitter = false;
    st.denoise = false;
    const GBuffer ref = castRaysStable(scene.labels, Geometry{}, RayCastView{in.worldToClip, in.width, in.height},
                                       [](uint32_t l) { return l != 0 && l != kInvalidLabel; }, scene.volume.brickSize,
                                       scene.gpu->uniformLevels() ? UniformSteps::Levels : UniformSteps::SubBlocks);
    ASSERT_GT(scene.gpu->decodeSteps(), 1100u);
    uint32_t allFrames = 0;
    for (const uint32_t steps : {RendererOptions::kDecodeStepsAll, 1100u, 300u, 301u}) {
        for (const bool moved : {false, true}) {
            for (const uint64_t cacheBytes : {uint64_t(0), uint64_t(6) << 20}) {
                if (steps == RendererOptions::kDecodeStepsAll && (moved || cacheBytes)) continue;
                // 301: 300 with the render waiting for the decode (overlapDecodes off)
                const std::string what = "steps " + std::to_string(steps) + (moved ? ", after a moving camera" : "") +
                                         (cacheBytes ? ", a small cache" : "");
                RendererOptions o;
                o.decode = RendererOptions::Decode::Gpu;
                o.decodeStepsPerFrame = steps;
                o.overlapDecodes = steps != 301u;
                o.cacheBytes = cacheBytes;
                o.prefetchVoxels = 0; // bricks are asked for as rays find them
                std::unique_ptr<Renderer> r = sceneRenderer(*ctx, scene, o, st);
                ASSERT_TRUE(r) << what;
                uint32_t carried = 0;
                if (moved) { // a camera turning slowly about the volume, a frame a pose: each frame carries decodes on
                    const int poses = int(scene.gpu->decodeSteps() / std::min(steps, 4096u)) + 8;
                    for (int f = 0; f < poses; ++f) {
                        const double a = 0.01 * f;
                        Result<FrameStats> s = r->renderFrame(
                            perspectiveView({48 + 220 * std::cos(a), 40 + 220 * std::sin(a), 120}, {48, 40, 30}, {0, 0, 1}, 30, 48, 36));
                        ASSERT_TRUE(s.isOk()) << what << ": " << s.message();
                        carried = std::max(carried, s->carriedDecodes);
                    }
                    // Decodes went on from frame to frame: bricks of the finest level ended while it moved.
                    Result<std::vector<Renderer::CachedBrick>> cached = r->cachedBricks();
                    ASSERT_TRUE(cached.isOk()) << cached.message();
                    EXPECT_FALSE(cached->empty()) << what << ": no brick ended its decoding while the camera moved";
                }
                if (steps == RendererOptions::kDecodeStepsAll) EXPECT_EQ(carried, 0u) << what;
                else if (moved) EXPECT_GT(carried, 0u) << what << ": finest-level bricks take " << scene.gpu->decodeSteps() << " steps";
                uint32_t frames = 0;
                const FrameOutput out = renderConverged(*r, in, 1, 400, &frames);
                expectGBufferEquals(out, ref, what);
                EXPECT_EQ(r->badBricks(), 0u) << what;
                if (moved || cacheBytes) continue;
                if (steps == RendererOptions::kDecodeStepsAll) allFrames = frames;
                else EXPECT_LE(frames, allFrames + 1) << what << ": the frames after the first take every step";
            }
        }
    }
    // Refining (ambient occlusion, 12 samples): once every pixel holds a sample, frames carry the
    // decodes its secondary rays ask for; the G-buffer stays the reference's.
    RendererOptions o;
    o.decode = RendererOptions::Decode::Gpu;
    o.decodeStepsPerFrame = 300;
    o.prefetchVoxels = 0;
    RenderSettings ao = st;
    ao.shading = Shading::AmbientOcclusion;
    ao.sampleTarget = 12;
    std::unique_ptr<Renderer> r = sceneRenderer(*ctx, scene, o, ao);
    ASSERT_TRUE(r);
    uint32_t carriedRefining = 0, minSamples = 0;
    for (int f = 0; f < 400 && minSamples < ao.sampleTarget; ++f) {
        Result<FrameStats> s = r->renderFrame(in);
        ASSERT_TRUE(s.isOk()) << s.message();
        if (minSamples >= 1) carriedRefining = std::max(carriedRefining, s->carriedDecodes);
        minSamples = s->minSamples;
    }
    EXPECT_GE(minSamples, ao.sampleTarget) << "refining converges";
    EXPECT_GT(carriedRefining, 0u) << "frames after the first full image carry decodes";
    FrameOutput out;
    ASSERT_TRUE(r->readOutput(out).isOk());
    expectGBufferEquals(out, ref, "ambient occlusion, refining with carried decodes");
}

// While a brick's decoding carries over frames, previews read the levels its decoder has
// completed (RendererOptions::inFlightPreviews): a camera moving one frame a pose shows most pixels
// as the converged image has them, where one label a brick showed few; exact rays still find the
// brick missing (the converged image is the reference's). A preview that read stale or wrong words
// (another brick's region, a node's flag word, a level not yet complete) would show other labels.
TEST(Renderer, PreviewsReadBricksStillBeingDecoded) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    const RenderSettings st = exactSettings();
    auto pose = [](int f) {
        const double a = 0.01 * f;
        return perspectiveView({48 + 220 * std::cos(a), 40 + 220 * std::sin(a), 120}, {48, 40, 30}, {0, 0, 1}, 30, 64, 48);
    };
    const int poses = 6; // 300 steps a frame: a finest-level brick takes about 16 frames
    ASSERT_GT(scene.gpu->decodeSteps(), uint64_t(300) * (poses + 2));
    RendererOptions every;
    every.decode = RendererOptions::Decode::Gpu;
    every.decodeStepsPerFrame = RendererOptions::kDecodeStepsAll;
    std::unique_ptr<Renderer> converged = sceneRenderer(*ctx, scene, every, st);
    ASSERT_TRUE(converged);
    const FrameOutput ref = renderConverged(*converged, pose(poses - 1), 1, 400);
    const GBuffer refLabels = castRaysStable(scene.labels, Geometry{}, RayCastView{pose(poses - 1).worldToClip, 64, 48},
                                             [](uint32_t l) { return l != 0 && l != kInvalidLabel; }, scene.volume.brickSize,
                                             scene.gpu->uniformLevels() ? UniformSteps::Levels : UniformSteps::SubBlocks);
    double agreement[2] = {0, 0}, nearby[2] = {0, 0};
    for (const bool inFlight : {false, true}) {
        const std::string what = inFlight ? "in-flight previews" : "one label a brick";
        RendererOptions o;
        o.decode = RendererOptions::Decode::Gpu;
        o.decodeStepsPerFrame = 300;
        o.prefetchVoxels = 0;
        o.inFlightPreviews = inFlight;
        std::unique_ptr<Renderer> r = sceneRenderer(*ctx, scene, o, st);
        ASSERT_TRUE(r) << what;
        uint32_t carried = 0;
        for (int f = 0; f < poses; ++f) {
            Result<FrameStats> s = r->renderFrame(pose(f));
            ASSERT_TRUE(s.isOk()) << what << ": " << s.message();
            carried = s->carriedDecodes;
        }
        EXPECT_GT(carried, 0u) << what << ": decodes in flight at the last pose";
        FrameOutput moving;
        ASSERT_TRUE(r->readOutput(moving).isOk());
        // A preview pixel agrees when the converged image shows its colour there or within two
        // pixels (a coarser level's nodes move edges by a voxel or two).
        size_t previews = 0, same = 0, near = 0;
        const int w = int(moving.width), h = int(moving.height);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const size_t i = size_t(y) * w + x;
                if (moving.samples[i] != 0 || (ref.rgba8[i] >> 24) == 0) continue; // sampled, or nothing there
                ++previews;
                same += moving.rgba8[i] == ref.rgba8[i];
                bool found = false;
                for (int dy = -2; dy <= 2 && !found; ++dy)
                    for (int dx = -2; dx <= 2 && !found; ++dx) {
                        const int u = x + dx, v = y + dy;
                        found = u >= 0 && v >= 0 && u < w && v < h && ref.rgba8[size_t(v) * w + u] == moving.rgba8[i];
                    }
                near += found;
            }
        ASSERT_GT(previews, moving.rgba8.size() / 10) << what << ": much of the view waits for bricks in flight";
        agreement[inFlight] = double(same) / double(previews);
        nearby[inFlight] = double(near) / double(previews);
        // Exact rays never took a preview's words: the image converges to the reference.
        expectGBufferEquals(renderConverged(*r, pose(poses - 1), 1, 400), refLabels, what);
        EXPECT_EQ(r->badBricks(), 0u) << what;
    }
    // Measured: one label a brick 0.27 as converged and 0.44 within two pixels, in-flight previews
    // 0.60 and 0.73 (the bricks asked for last are at their 4-voxel level yet).
    EXPECT_GE(agreement[1], agreement[0] + 0.2) << "in-flight previews against one label a brick";
    EXPECT_GE(nearby[1], 0.6) << "in-flight previews show their pixels nearly as converged";
    EXPECT_LE(nearby[0], 0.55) << "one label a brick shows few pixels as converged";
}

// A solid volume (every voxel a drawn label) of sides that are no multiples of the brick size: a
// preview's first surface is where its ray enters the volume, whatever the decoder has completed
// of the bricks there. Nodes at the volume's upper faces whose last child lies outside hold kNone
// in their last word once their children are visited: read as it is, such a node was see-through,
// and previews showed surfaces behind it. Few steps a frame: every level's state is published.
TEST(Renderer, InFlightPreviewsOfASolidVolumeShowItsFaces) {
    CSGV_REQUIRE_GPU(ctx);
    const LabelVolume v = labelVolumeOf({70, 45, 38}, [](uint32_t x, uint32_t y, uint32_t z) { return (x / 5 + y / 7 + z / 3) % 50 + 1; });
    EncodeOptions eo;
    eo.brickSize = 32;
    Result<CompressedVolume> encoded = encodeVolume(v, eo);
    ASSERT_TRUE(encoded.isOk()) << encoded.message();
    const RenderSettings st = exactSettings();
    // Two poses in turn (a new camera every frame: decodes carry), seeing the volume's +x, +y, +z faces.
    const FrameInput poses[2] = {perspectiveView({160, 130, 110}, {35, 22, 19}, {0, 0, 1}, 40, 64, 48),
                                 perspectiveView({150, 140, 115}, {35, 22, 19}, {0, 0, 1}, 40, 64, 48)};
    for (const bool uniformLevels : {true, false}) { // march reads a word with its level, or a label
        const std::string what = uniformLevels ? "uniform levels" : "plain labels";
        GpuVolumeOptions go;
        go.uniformLevels = uniformLevels;
        Result<std::unique_ptr<GpuVolume>> made = GpuVolume::create(*ctx, *encoded, go);
        ASSERT_TRUE(made.isOk()) << made.message();
        const std::shared_ptr<GpuVolume> gpu = std::move(*made);
        std::vector<float> refDepth[2];
        for (int k = 0; k < 2; ++k) {
            RendererOptions every;
            every.decode = RendererOptions::Decode::Gpu;
            every.decodeStepsPerFrame = RendererOptions::kDecodeStepsAll;
            Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, gpu, every);
            ASSERT_TRUE(r.isOk()) << r.message();
            (*r)->setSettings(st);
            refDepth[k] = renderConverged(**r, poses[k], 1, 200).depth;
        }
        RendererOptions o;
        o.decode = RendererOptions::Decode::Gpu;
        o.decodeStepsPerFrame = 24;
        o.prefetchVoxels = 0;
        Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, gpu, o);
        ASSERT_TRUE(r.isOk()) << r.message();
        (*r)->setSettings(st);
        size_t previews = 0, wrong = 0;
        uint32_t carried = 0;
        for (int f = 0; f < 60; ++f) {
            Result<FrameStats> stats = (*r)->renderFrame(poses[f % 2]);
            ASSERT_TRUE(stats.isOk()) << stats.message();
            carried = std::max(carried, stats->carriedDecodes);
            FrameOutput out;
            ASSERT_TRUE((*r)->readOutput(out).isOk());
            for (size_t i = 0; i < out.depth.size(); ++i) {
                if (out.samples[i] != 0 || refDepth[f % 2][i] >= 1.0f) continue; // sampled, or no volume there
                ++previews;
                if (out.depth[i] != refDepth[f % 2][i]) {
                    if (wrong == 0)
                        ADD_FAILURE() << what << ", frame " << f << ", pixel " << i << ": a preview at depth "
                                      << out.depth[i] << ", the volume's face at " << refDepth[f % 2][i];
                    ++wrong;
                }
            }
        }
        EXPECT_GT(carried, 0u) << what << ": decodes in flight";
        EXPECT_GT(previews, size_t(20000)) << what << ": frames that show previews";
        EXPECT_EQ(wrong, 0u) << what << ": previews behind the volume's faces, of " << previews;
    }
}

// A brick whose decoding fails is drawn empty by GPU decoding as by host decoding, whatever its
// size and however its decoding is split into dispatches and frames. Bricks of 64 on a volume of
// odd sizes, the finest streams of some overwritten (fails at once), one word in the middle of
// each flipped (decodes far, then fails), or the first stream's state word zeroed (fails as the
// decoder sets up, before any step: such a brick once stayed missing, its region in use, when
// decodes carried over frames, and unfilled otherwise): GPU decoding once filled a failed region in one
// invocation, which llvmpipe's loop limit cut short (64^3 words), leaving part of what it wrote
// visible, differently for steps of 300 and 512 a dispatch (up to 10 % of a view's pixels off
// host decoding's); cache_uniform.comp fills it now, 64 invocations to a brick.
TEST(Renderer, FailedBricksAreDrawnEmptyByEveryDecoderWhateverTheSteps) {
    CSGV_REQUIRE_GPU(ctx);
    const LabelVolume v = labelVolumeOf({150, 131, 97}, [](uint32_t x, uint32_t y, uint32_t z) {
        return (x * 7 + y * 3 + z * 5) % 89 == 0 ? 9u : (x / 11 + y / 7 + z / 9) % 6 + 1;
    });
    EncodeOptions eo;
    eo.brickSize = 64;
    Result<CompressedVolume> encoded = encodeVolume(v, eo);
    ASSERT_TRUE(encoded.isOk()) << encoded.message();
    const FrameInput in = perspectiveView({-90, 260, 230}, {75, 65, 48}, {0, 0, 1}, 40, 160, 120);
    RenderSettings st;
    st.finest = true;
    st.jitter = false;
    st.denoise = false;
    enum Damage { Overwritten, Flipped, FirstStateZero };
    for (const Damage damage : {Overwritten, Flipped, FirstStateZero}) {
        const bool flip = damage == Flipped;
        CompressedVolume bad = *encoded;
        const uint32_t L = bad.levels();
        std::vector<std::vector<uint32_t>> arrays(bad.arrays.size());
        for (size_t a = 0; a < arrays.size(); ++a) {
            arrays[a].resize(bad.arrays[a].size());
            bad.arrays[a].copyTo(arrays[a].data(), 0, arrays[a].size());
        }
        for (uint64_t b = 0; b < bad.brickCount(); b += 2) { // every other brick
            const BrickWords bw = bad.brick(b);
            const uint32_t start = (b > 0 && b % bad.bricksPerArray == 0) ? 0 : bad.brickStarts[b];
            std::vector<uint32_t>& words = arrays[b / bad.bricksPerArray];
            const uint32_t from = bw.words[L - 1] / 8, to = bw.size - bw.words[L];
            if (to <= from + 2) continue;
            if (damage == FirstStateZero) words[start + L + 1] = 0; // the first stream's rANS state: fails as it starts
            else if (flip) words[start + (from + to) / 2] ^= 0x5A5A5A5Au;
            else for (uint32_t w = from; w < to; ++w) words[start + w] = 0xFFFFFFFFu;
        }
        for (size_t a = 0; a < arrays.size(); ++a) bad.arrays[a] = WordArray(std::move(arrays[a]));
        std::shared_ptr<GpuVolume> gpu;
        {
            Result<std::unique_ptr<GpuVolume>> made = GpuVolume::create(*ctx, bad);
            ASSERT_TRUE(made.isOk()) << made.message();
            gpu = std::move(*made);
        }
        std::vector<uint32_t> hostLabels;
        const std::pair<RendererOptions::Decode, uint32_t> ways[] = {{RendererOptions::Decode::Host, RendererOptions::kDecodeStepsAll},
                                                                     {RendererOptions::Decode::Gpu, RendererOptions::kDecodeStepsAll},
                                                                     {RendererOptions::Decode::Gpu, 300u}};
        for (const auto& [decode, steps] : ways) {
            const std::string what = std::string(damage == FirstStateZero ? "first state zero, " : flip ? "a word flipped, " : "streams overwritten, ") +
                                     (decode == RendererOptions::Decode::Gpu ? "GPU decoding, steps " + std::to_string(steps) : "host decoding");
            RendererOptions o;
            o.decode = decode;
            o.decodeStepsPerFrame = steps;
            Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, gpu, o);
            ASSERT_TRUE(r.isOk()) << r.message();
            (*r)->setSettings(st);
            if (steps != RendererOptions::kDecodeStepsAll) // a moving camera first: decodes carried, some fail on the way
                for (int f = 0; f < 8; ++f)
                    ASSERT_TRUE((*r)->renderFrame(perspectiveView({-90.0 + 3 * f, 260, 230}, {75, 65, 48}, {0, 0, 1}, 40, 80, 60)).isOk());
            const FrameOutput out = renderConverged(**r, in, 1, 200);
            EXPECT_GE((*r)->badBricks(), 1u) << what;
            if (decode == RendererOptions::Decode::Host) {
                hostLabels = out.label;
                size_t hits = 0;
                for (uint32_t l : out.label) hits += l != kInvalidLabel ? 1 : 0;
                EXPECT_GT(hits, out.label.size() / 8) << what << ": the volume is in view";
                continue;
            }
            size_t differ = 0;
            for (size_t i = 0; i < out.label.size(); ++i) differ += out.label[i] != hostLabels[i];
            EXPECT_EQ(differ, 0u) << what << ": pixels whose labels differ from host decoding's";
        }
    }
}

// Uniform levels at the smallest and a large brick size (sub-blocks of 2 and 16 voxels, levels up
// to 3 and 6), on a volume of odd sizes whose bricks reach beyond it: the cached words' levels equal
// Core's after host and GPU decoding, and the G-buffer equals castRaysStable's stepping by them.
TEST(Renderer, UniformLevelsOfEveryBrickSizeStepExactly) {
    CSGV_REQUIRE_GPU(ctx);
    LabelVolume v;
    v.dim = {70, 61, 53};
    v.labels.resize(size_t(v.dim[0]) * v.dim[1] * v.dim[2]);
    for (uint32_t z = 0; z < v.dim[2]; ++z) // slabs of one label (a fifth of them label 0), a few voxels off
        for (uint32_t y = 0; y < v.dim[1]; ++y)
            for (uint32_t x = 0; x < v.dim[0]; ++x)
                v.labels[size_t(v.index(x, y, z))] = (x * 7 + y * 3 + z * 5) % 97 == 0 ? 9 : (x / 12 + y / 9 + z / 7) % 5;
    const FrameInput in = perspectiveView({-60, 140, 120}, {35, 30, 26}, {0.1, 0.2, 1}, 40, 96, 72);
    for (const uint32_t brickSize : {8u, 64u})
        for (const RendererOptions::Decode decode : {RendererOptions::Decode::Host, RendererOptions::Decode::Gpu}) {
            const std::string what = "bricks of " + std::to_string(brickSize) +
                                     (decode == RendererOptions::Decode::Gpu ? ", GPU decoding" : ", host decoding");
            CompressedVolume encoded;
            RendererOptions o;
            o.decode = decode;
            std::unique_ptr<Renderer> r = volumeRenderer(*ctx, v, encoded, o, brickSize);
            ASSERT_TRUE(r) << what;
            ASSERT_TRUE(r->volume().uniformLevels()) << what;
            RenderSettings st;
            st.finest = true;
            st.jitter = false;
            st.denoise = false;
            r->setSettings(st);
            const FrameOutput out = renderConverged(*r, in, 1, 64);
            const GBuffer ref = castRaysStable(v, Geometry{}, RayCastView{in.worldToClip, in.width, in.height},
                                               [](uint32_t l) { return l != 0 && l != kInvalidLabel; }, brickSize, UniformSteps::Levels);
            expectGBufferEquals(out, ref, what);
            Result<std::vector<Renderer::CachedBrick>> cached = r->cachedBricks();
            ASSERT_TRUE(cached.isOk()) << cached.message();
            size_t checked = 0;
            for (const Renderer::CachedBrick& b : *cached) {
                if (b.lod != 0) continue;
                EXPECT_EQ(b.uniformLevels, expectedUniformLevels(encoded, v, b.brick)) << what << ", brick " << b.brick;
                ++checked;
            }
            EXPECT_GT(checked, 1u) << what;
        }
}

namespace {

size_t differingValues(const std::vector<float>& a, const std::vector<float>& b) {
    size_t n = 0;
    for (size_t i = 0; i < a.size(); ++i) n += std::fabs(a[i] - b[i]) > 1e-6f;
    return n;
}

void expectSmallCacheConverges(Context& ctx, Shading shading,
                               RendererOptions::Decode decode = RendererOptions::Decode::Auto) {
    Scene& scene = fixtureScene(ctx, "synthA_b32_rans2.csgv");
    const FrameInput in = perspectiveView({-60, 130, 160}, {66, 35, 97}, {0, 0, 1}, 35, 64, 48);
    RenderSettings st;
    st.shading = shading;
    st.finest = true;
    st.denoise = false;
    std::unique_ptr<Renderer> big = makeRenderer(ctx, scene, 64ull << 20, st);
    ASSERT_TRUE(big);
    uint32_t bigFrames = 0, smallFrames = 0;
    const FrameOutput ref = renderConverged(*big, in, 2, 100, &bigFrames);
    // Twelve finest bricks (32^3 words each): far fewer than the view needs.
    std::unique_ptr<Renderer> small = makeRenderer(ctx, scene, 12ull * 32 * 32 * 32 * 4, st, decode);
    ASSERT_TRUE(small);
    const FrameOutput got = renderConverged(*small, in, 2, 1500, &smallFrames);
    // Every pixel the large cache sampled has its samples (with host decoding, those outside the
    // box's outline take none: RendererOptions::outlineSpans).
    uint32_t minSamples = ~0u;
    for (size_t i = 0; i < got.samples.size(); ++i)
        if (ref.samples[i] > 0) minSamples = std::min(minSamples, got.samples[i]);
    EXPECT_EQ(minSamples, 2u) << "the small cache did not converge in " << smallFrames << " frames";
    EXPECT_EQ(differingValues(got.rgba, ref.rgba), 0u) << shadingName(shading);
    EXPECT_EQ(got.label, ref.label);
    EXPECT_GT(smallFrames, bigFrames) << "the small cache should have needed more frames";
}

} // namespace

TEST(Renderer, SmallCacheConvergesLikeLargeCacheLocal) {
    CSGV_REQUIRE_GPU(ctx);
    expectSmallCacheConverges(*ctx, Shading::Local);
}

// The same through the GPU decoder in the frame pipeline (CPU devices decode on the host by default).
TEST(Renderer, SmallCacheConvergesLikeLargeCacheLocalWithGpuDecoding) {
    CSGV_REQUIRE_GPU(ctx);
    expectSmallCacheConverges(*ctx, Shading::Local, RendererOptions::Decode::Gpu);
}

TEST(Renderer, SmallCacheConvergesLikeLargeCacheShadow) {
    CSGV_REQUIRE_GPU(ctx);
    expectSmallCacheConverges(*ctx, Shading::Shadow);
}

namespace {

uint64_t cacheBytesOf(const Renderer& r) {
    for (const auto& b : r.memory().buffers)
        if (b.first == "brick cache") return b.second;
    return 0;
}

/// Renders frames until every pixel holds `samples` samples, checking after each frame that the
/// renderer's device memory stays within its budget.
FrameOutput renderWithinBudget(Renderer& r, const FrameInput& in, uint32_t samples, const std::string& what) {
    RenderSettings st = r.settings();
    st.sampleTarget = samples;
    r.setSettings(st);
    uint32_t f = 0, minSamples = 0;
    for (; f < 1500 && minSamples < samples; ++f) {
        Result<FrameStats> s = r.renderFrame(in);
        EXPECT_TRUE(s.isOk()) << what << ": " << s.message();
        if (!s) break;
        minSamples = s->minSamples;
        EXPECT_LE(r.memory().total(), r.deviceMemoryBudget()) << what << ", frame " << f;
    }
    EXPECT_EQ(minSamples, samples) << what << ": no convergence in " << f << " frames";
    FrameOutput out;
    EXPECT_TRUE(r.readOutput(out).isOk());
    return out;
}

} // namespace

// Options without a cache size take the device's automatic one (within the budget).
TEST(Renderer, DefaultCacheIsTheDevicesAutomaticOne) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, scene.gpu, RendererOptions{});
    ASSERT_TRUE(r.isOk()) << r.message();
    const uint64_t wanted = automaticCacheBytes(ctx->device());
    if (wanted * 2 < (*r)->deviceMemoryBudget()) EXPECT_EQ(cacheBytesOf(**r), wanted);
    EXPECT_LE((*r)->memory().total(), (*r)->deviceMemoryBudget());
}

// A device-memory budget bounds everything the renderer allocates, the encoding included: the
// cache takes what the rest leaves, shrinks when a larger image needs room, and the converged
// first-hit labels equal those of an unconstrained renderer. Budgets too small are refused with
// the sizes, before anything is uploaded.
TEST(Renderer, DeviceMemoryBudgetBoundsEveryAllocation) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    const FrameInput small = perspectiveView({-60, 130, 160}, {66, 35, 97}, {0, 0, 1}, 35, 64, 48);
    const FrameInput large = perspectiveView({-60, 130, 160}, {66, 35, 97}, {0, 0, 1}, 35, 128, 96);
    RenderSettings st;
    st.finest = true;
    st.denoise = false;
    st.jitter = false;
    std::unique_ptr<Renderer> free = makeRenderer(*ctx, scene, 64ull << 20, st);
    ASSERT_TRUE(free);
    const FrameOutput refSmall = renderConverged(*free, small, 1, 100);
    const FrameOutput refLarge = renderConverged(*free, large, 1, 100);
    // Everything but the cache at the large size, and twelve finest bricks (32^3 words each).
    const uint64_t budget = free->memory().total() - cacheBytesOf(*free) + 12ull * 32 * 32 * 32 * 4;
    RendererOptions o;
    o.cacheBytes = 64ull << 20;
    o.deviceMemoryBytes = budget;
    Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, scene.gpu, o);
    ASSERT_TRUE(r.isOk()) << r.message();
    Renderer& bounded = **r;
    bounded.setSettings(st);
    EXPECT_EQ(bounded.deviceMemoryBudget(), budget);
    EXPECT_LE(bounded.memory().total(), budget);
    EXPECT_EQ(renderWithinBudget(bounded, small, 1, "64x48").label, refSmall.label);
    const uint64_t cacheBefore = cacheBytesOf(bounded);
    EXPECT_EQ(renderWithinBudget(bounded, large, 1, "128x96").label, refLarge.label);
    EXPECT_LT(cacheBytesOf(bounded), cacheBefore) << "the larger image should have taken room from the cache";

    // Too small for the encoding (held whole; or even without its finest level): refused before
    // uploading, with both sizes.
    GpuVolumeOptions tight;
    tight.deviceMemoryBytes = GpuVolume::encodingBytes(scene.volume) - 1;
    tight.separateDetail = DetailSeparation::Never;
    Result<std::unique_ptr<GpuVolume>> refused = GpuVolume::create(*ctx, scene.volume, tight);
    ASSERT_FALSE(refused.isOk());
    EXPECT_NE(refused.message().find("budget"), std::string::npos) << refused.message();
    tight.separateDetail = DetailSeparation::Auto;
    tight.deviceMemoryBytes = 4096;
    refused = GpuVolume::create(*ctx, scene.volume, tight);
    ASSERT_FALSE(refused.isOk());
    EXPECT_NE(refused.message().find("without its finest level"), std::string::npos) << refused.message();
    EXPECT_EQ(GpuVolume::encodingBytes(scene.volume), scene.gpu->deviceBytes());
    // Room for the encoding but not for tables and one brick.
    o.deviceMemoryBytes = scene.gpu->deviceBytes() + 4096;
    Result<std::unique_ptr<Renderer>> tooSmall = Renderer::create(*ctx, scene.gpu, o);
    ASSERT_FALSE(tooSmall.isOk());
    EXPECT_NE(tooSmall.message().find("too small"), std::string::npos) << tooSmall.message();
    // An image that cannot fit even with the smallest cache is an error, and the renderer stays usable.
    o.deviceMemoryBytes = budget;
    Result<std::unique_ptr<Renderer>> again = Renderer::create(*ctx, scene.gpu, o);
    ASSERT_TRUE(again.isOk()) << again.message();
    (*again)->setSettings(st);
    const FrameInput huge = perspectiveView({-60, 130, 160}, {66, 35, 97}, {0, 0, 1}, 35, 1024, 768);
    EXPECT_EQ(renderWithinBudget(**again, small, 1, "64x48 before the failure").label, refSmall.label);
    Result<FrameStats> failed = (*again)->renderFrame(huge);
    ASSERT_FALSE(failed.isOk());
    EXPECT_NE(failed.message().find("1024x768 image"), std::string::npos) << failed.message();
    EXPECT_LE((*again)->memory().total(), budget);
    // The same size as before the failure: its image was given up for the attempt, and comes back.
    EXPECT_EQ(renderWithinBudget(**again, small, 1, "64x48 after the failure").label, refSmall.label);
}

// Graceful cache pressure along a camera path with a cache far smaller than what each view
// needs: every stop converges to the unconstrained renderer's image, a camera move flushes
// nothing (no cache reset in the frames after it), the request band grows back once a view
// fits, and the path holds at most one defragmentation reset per 64 frames.
TEST(Renderer, CameraPathUnderCachePressureConvergesAtEveryStopWithoutFlushing) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    RenderSettings st;
    st.finest = true;
    st.denoise = false;
    st.jitter = false;
    std::unique_ptr<Renderer> free = makeRenderer(*ctx, scene, 64ull << 20, st);
    std::unique_ptr<Renderer> tight = makeRenderer(*ctx, scene, 12ull * 32 * 32 * 32 * 4, st);
    ASSERT_TRUE(free && tight);
    uint32_t frames = 0, resets = 0;
    bool limited = false;
    for (int stop = 0; stop < 5; ++stop) {
        const double a = 0.5 * stop;
        const FrameInput in = perspectiveView({66 + 190 * std::cos(a), 35 + 190 * std::sin(a), 150}, {66, 35, 97}, {0, 0, 1},
                                              35, 64, 48);
        const FrameOutput ref = renderConverged(*free, in, 1, 100);
        RenderSettings target = tight->settings();
        target.sampleTarget = 1;
        tight->setSettings(target);
        uint32_t minSamples = 0, f = 0;
        for (; f < 1500 && minSamples < 1; ++f, ++frames) {
            Result<FrameStats> r = tight->renderFrame(in);
            ASSERT_TRUE(r.isOk()) << r.message();
            minSamples = r->minSamples;
            resets += r->cacheReset;
            limited = limited || r->requestLimited;
            // The old policy reset the cache at the first "full" after every move (its third frame).
            if (stop > 0 && f < 16) EXPECT_FALSE(r->cacheReset) << "stop " << stop << ": the camera move flushed the cache";
        }
        EXPECT_EQ(minSamples, 1u) << "stop " << stop << " did not converge in " << f << " frames";
        FrameOutput got;
        ASSERT_TRUE(tight->readOutput(got).isOk());
        EXPECT_EQ(got.label, ref.label) << "stop " << stop;
        EXPECT_EQ(differingValues(got.rgba, ref.rgba), 0u) << "stop " << stop;
    }
    EXPECT_TRUE(limited) << "the path should have needed request limitation";
    EXPECT_LE(resets, 1 + frames / 64) << "defragmentation resets in " << frames << " frames";
    // A view that needs few bricks (a corner, from close by): the request band grows back.
    const FrameInput corner = perspectiveView({-20, -20, -20}, {0, 0, 0}, {0, 0, 1}, 20, 64, 48);
    bool unlimited = false;
    for (int f = 0; f < 64 && !unlimited; ++f) {
        Result<FrameStats> r = tight->renderFrame(corner);
        ASSERT_TRUE(r.isOk()) << r.message();
        unlimited = !r->requestLimited && !r->cacheFull;
    }
    EXPECT_TRUE(unlimited) << "request limitation should end once the view fits the cache";
}

namespace {

/// A path whose stops want other levels of detail (near, far, near, ...) fragments a tight
/// cache (the free regions are of the levels the last stop used). A render loop that gives up
/// after FrameStats::idleLimit() idle frames, as `csgv render` and the representation do, must
/// converge at every stop: a cache blocked by fragmentation may not wait for the defragmentation
/// interval (seen on an NVIDIA H200: AO at 1080p on 1024^3 stopped with 475885 pixels unsampled).
void expectLevelChangesConvergeInAnIdleBoundedLoop(Context& ctx, RendererOptions::Decode decode) {
    Scene& scene = fixtureScene(ctx, "synthA_b32_rans2.csgv");
    RenderSettings st;
    st.shading = Shading::AmbientOcclusion;
    st.denoise = false;
    st.sampleTarget = 2;
    std::unique_ptr<Renderer> tight = makeRenderer(ctx, scene, 12ull * 32 * 32 * 32 * 4, st, decode);
    ASSERT_TRUE(tight);
    for (int stop = 0; stop < 6; ++stop) {
        const double a = 0.7 * stop, dist = stop % 2 ? 900 : 120;
        const FrameInput in = perspectiveView({66 + dist * std::cos(a), 35 + dist * std::sin(a), 97 + 0.3 * dist},
                                              {66, 35, 97}, {0, 0, 1}, stop % 2 ? 12 : 50, 64, 48);
        uint32_t idle = 0, minSamples = 0, f = 0;
        for (; f < 2000; ++f) {
            Result<FrameStats> r = tight->renderFrame(in);
            ASSERT_TRUE(r.isOk()) << r.message();
            minSamples = r->minSamples;
            if (minSamples >= 2) break;
            idle = r->idle() ? idle + 1 : 0;
            if (idle >= r->idleLimit()) break;
        }
        EXPECT_EQ(minSamples, 2u) << "stop " << stop << " gave up after " << f << " frames";
    }
}

} // namespace

TEST(Renderer, LevelChangesUnderCachePressureConvergeInAnIdleBoundedLoop) {
    CSGV_REQUIRE_GPU(ctx);
    expectLevelChangesConvergeInAnIdleBoundedLoop(*ctx, RendererOptions::Decode::Auto);
}

TEST(Renderer, LevelChangesUnderCachePressureConvergeInAnIdleBoundedLoopWithGpuDecoding) {
    CSGV_REQUIRE_GPU(ctx);
    expectLevelChangesConvergeInAnIdleBoundedLoop(*ctx, RendererOptions::Decode::Gpu);
}

/// An MPI rank's piece (GpuVolumeOptions::owned): view rays pass the other ranks' bricks, shadow
/// rays meet them at their level of detail from the whole volume's coarse levels
/// (setCoarseStandIns) instead of passing through: with every level there, the piece's own
/// surfaces are shaded exactly as in the whole volume (finest, and with levels of detail); with
/// the levels from 3 (4^3 nodes a brick), nearly. `variants`: finest, levels of detail, and
/// finest with one dense table over the other ranks' labels (RendererOptions::largestOtherLabel).
void expectPieceShadowsWithStandIns(Context& context, const char* fixture, int variants) {
    Context* ctx = &context;
    Scene& scene = fixtureScene(*ctx, fixture);
    GpuVolumeOptions o;
    o.owned = brickPartition(scene.volume.brickGrid(), 2, 0); // the lower half in z: the other piece lies above
    ASSERT_EQ(o.owned.hi[2], 3u);
    // As a rank holds it: its bricks in the volume's index space, the others label 0 (so its
    // largest label is its own; the stand-ins hold larger ones).
    Result<CompressedVolume> own = extractPiece(scene.volume, o.owned);
    ASSERT_TRUE(own.isOk()) << own.message();
    Result<CompressedVolume> embedded = embedPiece(*own, o.owned, scene.volume.dim);
    ASSERT_TRUE(embedded.isOk()) << embedded.message();
    Result<std::unique_ptr<GpuVolume>> pg = GpuVolume::create(*ctx, *embedded, o);
    ASSERT_TRUE(pg.isOk()) << pg.message();
    std::shared_ptr<GpuVolume> piece = std::move(*pg);
    RenderSettings st;
    st.shading = Shading::Shadow;
    st.jitter = false;
    st.denoise = false;
    st.lightInWorld = true;
    st.lightDirection = {0.2f, -0.5f, 0.85f}; // from above, on the camera's side
    const FrameInput in = perspectiveView({66, -260, 70}, {66, 35, 70}, {0, 0, 1}, 40, 96, 72);
    constexpr uint32_t kNoStandIns = ~0u;
    uint32_t largestOther = kNone; // RendererOptions::largestOtherLabel: not known (the scan), or known (one dense table)
    auto render = [&](std::shared_ptr<GpuVolume> v, uint32_t coarseFrom) {
        RendererOptions ro;
        ro.cacheBytes = 64ull << 20;
        ro.largestOtherLabel = largestOther;
        Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, v, ro);
        EXPECT_TRUE(r.isOk()) << r.message();
        if (!r) return FrameOutput{};
        (*r)->setSettings(st);
        if (v == scene.gpu) EXPECT_FALSE((*r)->setCoarseStandIns(0, {}).isOk()) << "stand-ins for a whole volume";
        if (coarseFrom != kNoStandIns) {
            std::vector<std::vector<uint32_t>> levels;
            for (uint32_t l = coarseFrom; l < scene.volume.levels(); ++l) {
                Result<LabelVolume> grid = decodeVolume(scene.volume, l);
                EXPECT_TRUE(grid.isOk()) << grid.message();
                if (!grid) return FrameOutput{};
                levels.push_back(std::move(grid->labels));
            }
            EXPECT_FALSE((*r)->setCoarseStandIns(coarseFrom + 1, levels).isOk()) << "too many levels";
            levels.back().push_back(0);
            EXPECT_FALSE((*r)->setCoarseStandIns(coarseFrom, levels).isOk()) << "a level of the wrong size";
            levels.back().pop_back();
            if (largestOther != kNone) { // a label beyond the table it was made for is refused
                const uint32_t kept = levels.back().back();
                levels.back().back() = largestOther + 1;
                const Status beyond = (*r)->setCoarseStandIns(coarseFrom, levels);
                EXPECT_NE(beyond.message().find("beyond the largest the renderer was made for"), std::string::npos)
                    << beyond.message();
                levels.back().back() = kept;
            }
            Status s = (*r)->setCoarseStandIns(coarseFrom, levels);
            EXPECT_TRUE(s.isOk()) << s.message();
        }
        return renderConverged(**r, in, 1, 200);
    };
    for (int variant = 0; variant < variants; ++variant) {
        const bool finest = variant != 1;
        st.finest = finest;
        largestOther = variant == 2 ? scene.gpu->largestStoredLabel() : kNone; // the whole volume's labels, as the ranks share them
        const FrameOutput whole = render(scene.gpu, kNoStandIns);
        const FrameOutput passing = render(piece, kNoStandIns);
        const FrameOutput exact = render(piece, 0);
        const FrameOutput coarse = render(piece, 3);
        ASSERT_EQ(passing.label.size(), whole.label.size());
        // View rays are the same with or without stand-ins: the piece draws only its own voxels.
        EXPECT_EQ(exact.label, passing.label);
        EXPECT_EQ(coarse.label, passing.label);
        // On the piece's surfaces that the whole volume shows too, the shaded pixels that differ.
        size_t shared = 0, passingDiffers = 0, exactDiffers = 0, coarseDiffers = 0;
        auto differs = [&](const FrameOutput& o, size_t i) {
            for (int c = 0; c < 3; ++c)
                if (std::fabs(o.rgba[4 * i + c] - whole.rgba[4 * i + c]) > 2.0f / 255) return true;
            return false;
        };
        for (size_t i = 0; i < whole.label.size(); ++i) {
            if (passing.label[i] == kNone || passing.label[i] != whole.label[i] || whole.depth[i] != passing.depth[i])
                continue;
            ++shared;
            passingDiffers += differs(passing, i);
            exactDiffers += differs(exact, i);
            coarseDiffers += differs(coarse, i);
        }
        const std::string what = std::string(finest ? "finest" : "levels of detail") +
                                 (largestOther == kNone ? ", the scan for other ranks' labels: " : ", one dense table: ");
        EXPECT_GT(shared, whole.label.size() / 8) << what;
        EXPECT_GT(passingDiffers, shared / 50) << what << "the other piece should shadow this one (" << shared << " pixels)";
        EXPECT_EQ(exactDiffers, 0u) << what << "every level stands in";
        EXPECT_LT(coarseDiffers * 2, passingDiffers) << what << "levels from 3";
        std::printf("%spixels of the piece: %zu; shaded unlike the whole volume: %zu passing through the other piece, "
                    "%zu with its levels from 3, %zu with every level\n",
                    what.c_str(), shared, passingDiffers, coarseDiffers, exactDiffers);
    }
}

TEST(Renderer, APieceShadowsItsSurfacesWithTheOtherPiecesStandIns) {
    CSGV_REQUIRE_GPU(ctx);
    // Relabelled: dense ids, a label -> material table; the stand-ins' words carry uniform levels.
    expectPieceShadowsWithStandIns(*ctx, "synthA_b32_rans2_attr.csgv", 3);
}

/// The same with labels beyond the uniform levels' bits (above 2^29, as the file stores them: a
/// piece keeps its labels), whose stand-ins carry none and are stepped node by node.
TEST(Renderer, APieceOfLabelsBeyondTheUniformLevelsBitsShadowsAlike) {
    CSGV_REQUIRE_GPU(ctx);
    expectPieceShadowsWithStandIns(*ctx, "synthA_b32_rans2.csgv", 1);
}

/// An MPI rank's far piece, seen across the boundary with the piece in front: where a view ray
/// enters it in the label it leaves (ghost faces), opaque, the rank in front met that label's
/// surface first and the compositing keeps that one, so the far piece lights its entry locally
/// (no secondary rays, which from its entry face would start inside the label); its other
/// surfaces are shaded as before, and what the rays hit is the same.
TEST(Renderer, AFarPieceLightsLocallyTheSurfacesTheRankInFrontCovers) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2_attr.csgv");
    std::vector<PieceLayers> layers;
    std::array<std::array<uint32_t, 3>, 2> lo{}, hi{};
    for (uint32_t p = 0; p < 2; ++p) {
        const BrickBox b = brickPartition(scene.volume.brickGrid(), 2, p); // split in z
        for (int a = 0; a < 3; ++a) {
            lo[p][a] = b.lo[a] * scene.volume.brickSize;
            hi[p][a] = std::min(b.hi[a] * scene.volume.brickSize, scene.volume.dim[a]);
        }
        Result<PieceLayers> l = pieceLayers(scene.volume, lo[p], hi[p]);
        ASSERT_TRUE(l.isOk()) << l.message();
        layers.push_back(std::move(*l));
    }
    GpuVolumeOptions o;
    o.owned = brickPartition(scene.volume.brickGrid(), 2, 0); // the lower half: the far one from above
    Result<CompressedVolume> embedded = embedPiece(*extractPiece(scene.volume, o.owned), o.owned, scene.volume.dim);
    ASSERT_TRUE(embedded.isOk()) << embedded.message();
    Result<std::unique_ptr<GpuVolume>> pg = GpuVolume::create(*ctx, *embedded, o);
    ASSERT_TRUE(pg.isOk()) << pg.message();
    std::shared_ptr<GpuVolume> piece = std::move(*pg);
    std::vector<std::vector<uint32_t>> levels;
    for (uint32_t l = 0; l < scene.volume.levels(); ++l) levels.push_back(decodeVolume(scene.volume, l)->labels);
    const FrameInput in = perspectiveView({80, 45, 420}, {66, 35, 97}, {0, 1, 0}, 40, 96, 72); // from above
    auto render = [&](Shading shading, bool ghosts) {
        RendererOptions ro;
        ro.cacheBytes = 64ull << 20;
        ro.largestOtherLabel = scene.gpu->largestStoredLabel();
        Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, piece, ro);
        EXPECT_TRUE(r.isOk()) << r.message();
        if (!r) return FrameOutput{};
        RenderSettings st;
        st.shading = shading;
        st.jitter = false;
        st.denoise = false;
        st.lightInWorld = true;
        st.lightDirection = {0.2f, -0.3f, 0.93f}; // from above
        (*r)->setSettings(st);
        EXPECT_TRUE((*r)->setCoarseStandIns(0, levels).isOk());
        if (ghosts) {
            const Status s = (*r)->setGhostFaces(lo[0], hi[0], ghostFaces(lo[0], hi[0], scene.volume.dim, layers));
            EXPECT_TRUE(s.isOk()) << s.message();
        }
        return renderConverged(**r, in, 1, 200);
    };
    const FrameOutput local = render(Shading::Local, true);
    const FrameOutput before = render(Shading::Shadow, false); // no ghost faces: every surface its shadow ray
    const FrameOutput after = render(Shading::Shadow, true);
    ASSERT_EQ(after.label.size(), local.label.size());
    EXPECT_EQ(after.label, before.label);
    EXPECT_EQ(after.depth, before.depth);
    auto same = [](const FrameOutput& a, const FrameOutput& b, size_t i) {
        for (int c = 0; c < 4; ++c)
            if (std::fabs(a.rgba[4 * i + c] - b.rgba[4 * i + c]) > 2.0f / 255) return false;
        return true;
    };
    size_t covered = 0, litLocally = 0, changed = 0;
    for (size_t i = 0; i < after.label.size(); ++i) {
        if (after.label[i] == kNone) continue;
        ++covered;
        if (same(after, before, i)) continue;
        ++changed;
        EXPECT_TRUE(same(after, local, i)) << "pixel " << i << ": a covered surface is lit locally, nothing else changes";
        litLocally += same(after, local, i);
    }
    std::printf("pixels of the far piece: %zu; lit locally as covered by the piece in front: %zu\n", covered, litLocally);
    EXPECT_GT(changed, covered / 8) << "the piece's face towards the other: labels continuing across it";
    EXPECT_LT(changed, covered) << "the other surfaces keep their shadows";
}

namespace {

size_t coveredPixels(const FrameOutput& out) {
    size_t n = 0;
    for (size_t i = 0; i < out.rgba.size() / 4; ++i) n += out.rgba[4 * i + 3] > 0.5f;
    return n;
}

/// The first frame of an empty cache shows a preview everywhere (no holes), none of it counted as
/// a sample, and the image converges to exactly what a renderer whose cache was warm gives.
void expectPreviewThenExactImage(Context& ctx, Shading shading, uint32_t subsampling) {
    Scene& scene = fixtureScene(ctx, "synthA_b32_rans2.csgv");
    const FrameInput in = perspectiveView({-60, 130, 160}, {66, 35, 97}, {0, 0, 1}, 35, 96, 72);
    RenderSettings st;
    st.shading = shading;
    st.subsampling = subsampling;
    st.denoise = false;
    st.jitter = false;
    std::unique_ptr<Renderer> warm = makeRenderer(ctx, scene, 64ull << 20, st);
    ASSERT_TRUE(warm);
    renderConverged(*warm, in, 1, 200);
    warm->resetAccumulation(); // the cache stays: every sample below finds its bricks
    const FrameOutput ref = renderConverged(*warm, in, 1, 200);
    std::unique_ptr<Renderer> cold = makeRenderer(ctx, scene, 64ull << 20, st);
    ASSERT_TRUE(cold);
    RenderSettings target = st;
    target.sampleTarget = 1;
    cold->setSettings(target);
    Result<FrameStats> first = cold->renderFrame(in);
    ASSERT_TRUE(first.isOk()) << first.message();
    const std::string what = std::string(shadingName(shading)) + ", stride " + std::to_string(subsampling);
    EXPECT_GT(first->missingPixels, 0u) << what;
    EXPECT_EQ(first->holes, 0u) << what << ": every pixel shows a preview";
    EXPECT_GT(first->previews, 0u) << what;
    FrameOutput preview;
    ASSERT_TRUE(cold->readOutput(preview).isOk());
    // Nothing is cached before the first frame: its only samples are of rays that met no visible
    // brick (transparent); every other pixel shows an uncounted preview.
    size_t sampled = 0;
    for (size_t i = 0; i < preview.samples.size(); ++i)
        if (preview.samples[i] > 0) {
            ++sampled;
            ASSERT_EQ(preview.rgba[4 * i + 3], 0.0f) << what << ": a preview counted as a sample at pixel " << i;
        }
    EXPECT_EQ(sampled, first->newSamples) << what;
    EXPECT_GT(coveredPixels(preview), coveredPixels(ref) / 2) << what << ": the preview should show the volume";
    const FrameOutput got = renderConverged(*cold, in, 1, 200);
    EXPECT_EQ(got.label, ref.label) << what;
    EXPECT_EQ(differingValues(got.rgba, ref.rgba), 0u) << what;
}

} // namespace

TEST(Renderer, FirstFrameShowsAPreviewAndConvergesToTheExactImage) {
    CSGV_REQUIRE_GPU(ctx);
    expectPreviewThenExactImage(*ctx, Shading::Local, 1);  // resolved in the render pass
    expectPreviewThenExactImage(*ctx, Shading::Shadow, 1); // gathered; shadow rays lose the sample
    expectPreviewThenExactImage(*ctx, Shading::Local, 2);  // gathered with upsampling
}

// The resolve passes (gather with upsampling, A-trous denoising, final) read through texel buffers
// or buffer addresses alike: denoised ambient occlusion at a pixel stride of 2, both ways, bit for bit.
TEST(Renderer, ResolvePassesGiveTheSameImageThroughTexelsAndBufferAddresses) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    const FrameInput in = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    FrameOutput images[2];
    for (int texels = 0; texels < 2; ++texels) {
        RendererOptions o;
        o.renderTexels = texels == 1;
        RenderSettings st;
        st.shading = Shading::AmbientOcclusion;
        st.subsampling = 2;
        st.denoise = true;
        std::unique_ptr<Renderer> r = sceneRenderer(*ctx, scene, o, st);
        ASSERT_TRUE(r);
        images[texels] = renderConverged(*r, in, 3, 64);
        ASSERT_GT(coveredPixels(images[texels]), images[texels].rgba.size() / 16);
    }
    EXPECT_EQ(images[0].rgba, images[1].rgba);
    EXPECT_EQ(images[0].label, images[1].label);
}

// GPUs keep the G-buffer, the output, the counters and the frame parameters in device memory and
// the host works on copies (RendererOptions::readBackThroughCopy forces that here): the same
// images, frame after frame, as the host reading them mapped, and the copy's rows counted in the
// renderer's memory.
TEST(Renderer, OutputsReadBackThroughACopyEqualMappedOnes) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    RenderRequest req;
    req.frame = perspectiveView({-140, 350, 370}, {48, 40, 30}, {0.1, 0.2, 1}, 40, 96, 72);
    req.timeBudgetSeconds = 1e9;
    std::unique_ptr<Renderer> r[2];
    for (int copied = 0; copied < 2; ++copied) {
        RendererOptions o;
        o.readBackThroughCopy = copied == 1;
        RenderSettings st;
        st.shading = Shading::AmbientOcclusion;
        st.sampleTarget = 2;
        r[copied] = sceneRenderer(*ctx, scene, o, st);
        ASSERT_TRUE(r[copied]);
    }
    for (int view = 0; view < 3; ++view) {
        SCOPED_TRACE("view " + std::to_string(view));
        for (auto& renderer : r) {
            Result<RenderResult> done = renderer->render(req);
            ASSERT_TRUE(done.isOk()) << done.message();
        }
        const FrameOutput& a = r[0]->output();
        const FrameOutput& b = r[1]->output();
        ASSERT_GT(coveredPixels(r[0]->output(Renderer::Color)), a.rgba8.size() / 16);
        EXPECT_EQ(a.rect, b.rect);
        EXPECT_EQ(a.rgba8, b.rgba8);
        EXPECT_EQ(a.depth, b.depth);
        FrameOutput all[2];
        for (int k = 0; k < 2; ++k) ASSERT_TRUE(r[k]->readOutput(all[k], Renderer::All).isOk());
        EXPECT_EQ(all[0].rgba, all[1].rgba);
        EXPECT_EQ(all[0].rgba8, all[1].rgba8);
        EXPECT_EQ(all[0].label, all[1].label);
        EXPECT_EQ(all[0].hitDepth, all[1].hitDepth);
        EXPECT_EQ(all[0].samples, all[1].samples);
        // The next view moves the volume across the image (NDC x + 0.3, y - 0.3): other rows
        // drawn, others cleared.
        for (int c = 0; c < 4; ++c) {
            req.frame.worldToClip[4 * c] += 0.3 * req.frame.worldToClip[4 * c + 3];
            req.frame.worldToClip[4 * c + 1] -= 0.3 * req.frame.worldToClip[4 * c + 3];
        }
    }
    auto outputs = [](const Renderer& x) {
        for (const auto& [name, bytes] : x.memory().buffers)
            if (name == "outputs (colour, depth, G-buffer)") return bytes;
        return uint64_t(0);
    };
    // G-buffer 16 bytes a pixel, output 8, opaque depth input 4, and the copy's 8 (the renderer
    // without it on CPU devices has a 16-byte stand-in; on GPUs both copy).
    EXPECT_EQ(outputs(*r[1]), uint64_t(96 * 72) * (16 + 8 + 4 + 8));
    EXPECT_GE(outputs(*r[1]), outputs(*r[0]));
}

// A preview goes on through missing bricks of a semi-transparent label to what lies behind them:
// two bricks of label 1 (half opaque) in front of one of label 2 (opaque), none cached. Before,
// the preview stopped in the first brick (the same label again: no new surface), half
// transparent where the converged image is opaque.
TEST(Renderer, PreviewsSeeThroughMissingBricksOfASemiTransparentLabel) {
    CSGV_REQUIRE_GPU(ctx);
    LabelVolume v;
    v.dim = {48, 16, 16};
    v.labels.assign(48 * 16 * 16, 1);
    for (uint32_t z = 0; z < 16; ++z)
        for (uint32_t y = 0; y < 16; ++y)
            for (uint32_t x = 32; x < 48; ++x) v.labels[v.index(x, y, z)] = 2;
    RendererOptions o;
    o.prefetchVoxels = 0; // a cold first frame: every brick missing
    CompressedVolume encoded;
    std::unique_ptr<Renderer> r = volumeRenderer(*ctx, v, encoded, o);
    ASSERT_TRUE(r);
    Result<MaterialDocument> doc = parseMaterials(R"({"version": 1, "materials": [
        {"filter": {"attribute": "label", "min": 1, "max": 1}, "color": {"mode": "constant", "rgb": [0, 1, 0]}, "opacity": 0.5},
        {"filter": {"attribute": "label", "min": 2, "max": 2}, "color": {"mode": "constant", "rgb": [1, 0, 0]}}]})");
    ASSERT_TRUE(doc.isOk()) << doc.message();
    ASSERT_TRUE(r->setMaterials(*doc).isOk());
    RenderSettings st;
    st.jitter = false;
    st.denoise = false;
    st.sampleTarget = 1;
    r->setSettings(st);
    // Down the x axis through the middle of the end face: every ray crosses all three bricks.
    const FrameInput in = perspectiveView({-40, 8, 8}, {24, 8, 8}, {0, 0, 1}, 10, 16, 16);
    Result<FrameStats> first = r->renderFrame(in);
    ASSERT_TRUE(first.isOk()) << first.message();
    EXPECT_EQ(first->previews, 16u * 16u) << "nothing is cached: every pixel shows a preview";
    FrameOutput preview;
    ASSERT_TRUE(r->readOutput(preview).isOk());
    const FrameOutput converged = renderConverged(*r, in, 1, 16);
    for (size_t i = 0; i < converged.label.size(); ++i) {
        ASSERT_EQ(converged.label[i], 2u) << "pixel " << i;
        ASSERT_FLOAT_EQ(converged.rgba[4 * i + 3], 1.0f) << "pixel " << i;
        ASSERT_FLOAT_EQ(preview.rgba[4 * i + 3], 1.0f) << "the preview of pixel " << i << " should reach label 2";
        EXPECT_GT(preview.rgba[4 * i], 0.1f) << "red of label 2 behind the green, pixel " << i;
    }
}

// Levels of detail follow the camera: a renderer whose cache holds bricks at the levels of an
// earlier, farther view converges to exactly the image of a renderer that only saw this view (a
// brick cached at another level than the view wants is never sampled, used or not).
TEST(Renderer, ConvergedImageDoesNotDependOnTheCacheHistory) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    RenderSettings st;
    st.denoise = false;
    std::unique_ptr<Renderer> travelled = makeRenderer(*ctx, scene, 64ull << 20, st);
    std::unique_ptr<Renderer> fresh = makeRenderer(*ctx, scene, 64ull << 20, st);
    ASSERT_TRUE(travelled && fresh);
    const FrameInput near = perspectiveView({150, -40, 130}, {66, 35, 97}, {0, 0, 1}, 30, 96, 72);
    for (double distance : {900.0, 600.0, 400.0}) { // farther views first: coarser levels cached
        const double k = distance / 160.0;
        renderConverged(*travelled, perspectiveView({66 + 84 * k, 35 - 75 * k, 97 + 33 * k}, {66, 35, 97}, {0, 0, 1}, 30, 96, 72),
                        2, 200);
    }
    const FrameOutput got = renderConverged(*travelled, near, 4, 400);
    const FrameOutput ref = renderConverged(*fresh, near, 4, 400);
    EXPECT_EQ(got.label, ref.label);
    EXPECT_EQ(differingValues(got.rgba, ref.rgba), 0u);
}

// Detail separation: a budget that the whole encoding would take more than half of keeps the
// finest level in host memory; the renderer streams it (GPU decoding: through the detail buffer;
// host decoding: Core reads it from host memory) and the converged image is exactly the one of a
// volume held whole, within the budget.
TEST(Renderer, SeparatedDetailRendersTheSameImageWithinTheBudget) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    const uint64_t whole = GpuVolume::encodingBytes(scene.volume);
    GpuVolumeOptions o;
    o.deviceMemoryBytes = 2 * whole - 1; // more than half: separated
    Result<std::unique_ptr<GpuVolume>> separated = GpuVolume::create(*ctx, scene.volume, o);
    ASSERT_TRUE(separated.isOk()) << separated.message();
    ASSERT_TRUE((*separated)->separated());
    EXPECT_LT((*separated)->deviceBytes(), whole);
    o.deviceMemoryBytes = 2 * whole;
    Result<std::unique_ptr<GpuVolume>> kept = GpuVolume::create(*ctx, scene.volume, o);
    ASSERT_TRUE(kept.isOk()) << kept.message();
    EXPECT_FALSE((*kept)->separated());
    std::shared_ptr<GpuVolume> gpu(std::move(*separated));

    const FrameInput in = perspectiveView({-60, 130, 160}, {66, 35, 97}, {0, 0, 1}, 35, 64, 48);
    RenderSettings st;
    st.finest = true;
    st.denoise = false;
    std::unique_ptr<Renderer> ref = makeRenderer(*ctx, scene, 64ull << 20, st);
    ASSERT_TRUE(ref);
    const FrameOutput want = renderConverged(*ref, in, 2, 100);
    for (RendererOptions::Decode decode : {RendererOptions::Decode::Gpu, RendererOptions::Decode::Host}) {
        RendererOptions ro;
        ro.decode = decode;
        ro.cacheBytes = 16ull << 20;
        Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, gpu, ro);
        ASSERT_TRUE(r.isOk()) << r.message();
        (*r)->setSettings(st);
        const FrameOutput got = renderConverged(**r, in, 2, 100);
        const char* what = decode == RendererOptions::Decode::Gpu ? "GPU decoding" : "host decoding";
        EXPECT_EQ(got.label, want.label) << what;
        EXPECT_EQ(differingValues(got.rgba, want.rgba), 0u) << what;
        EXPECT_EQ((*r)->memory().buffers.front().second, gpu->deviceBytes()) << what;
    }
}

TEST(Renderer, DetailStreamingShowsTheCoarserLevelUntilStreamsArriveAndConvergesExactly) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_rans2_legacydelta.csgv");
    GpuVolumeOptions o;
    o.separateDetail = DetailSeparation::Always;
    Result<std::unique_ptr<GpuVolume>> made = GpuVolume::create(*ctx, scene.volume, o);
    ASSERT_TRUE(made.isOk()) << made.message();
    std::shared_ptr<GpuVolume> gpu(std::move(*made));
    const FrameInput in = perspectiveView({-60, 130, 160}, {66, 35, 97}, {0, 0, 1}, 35, 64, 48);
    RenderSettings st;
    st.finest = true; // every brick wants its finest level, so every brick streams
    st.denoise = false;
    std::unique_ptr<Renderer> ref = makeRenderer(*ctx, scene, 64ull << 20, st);
    ASSERT_TRUE(ref);
    const FrameOutput want = renderConverged(*ref, in, 2, 100);
    st.sampleTarget = 2;
    auto streamingRenderer = [&](uint64_t ringBytes) -> std::unique_ptr<Renderer> {
        RendererOptions ro;
        ro.decode = RendererOptions::Decode::Gpu;
        ro.detailBufferBytes = ringBytes;
        Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, gpu, ro);
        EXPECT_TRUE(r.isOk()) << r.message();
        if (!r) return nullptr;
        EXPECT_TRUE((*r)->streamsDetail());
        (*r)->setSettings(st);
        return std::move(*r);
    };
    auto converge = [&](Renderer& r, const char* what) {
        uint32_t frames = 0;
        for (; frames < 400; ++frames) {
            Result<FrameStats> f = r.renderFrame(in);
            ASSERT_TRUE(f.isOk()) << f.message();
            EXPECT_LE(r.memory().total(), r.deviceMemoryBudget()) << what;
            if (f->minSamples >= 2) break;
        }
        EXPECT_LT(frames, 400u) << what << ": not converged";
        FrameOutput got;
        ASSERT_TRUE(r.readOutput(got).isOk());
        EXPECT_EQ(got.label, want.label) << what;
        EXPECT_EQ(differingValues(got.rgba, want.rgba), 0u) << what;
    };

    // The automatic ring holds every stream the view asks for.
    std::unique_ptr<Renderer> r = streamingRenderer(0);
    ASSERT_TRUE(r);
    // Frame 1: nothing cached, previews of brick blocks; its rays mark the bricks they need.
    Result<FrameStats> f1 = r->renderFrame(in);
    ASSERT_TRUE(f1.isOk()) << f1.message();
    EXPECT_EQ(f1->detailRequests, 0u);
    EXPECT_GT(f1->previews, 0u);
    FrameOutput o1;
    ASSERT_TRUE(r->readOutput(o1).isOk());
    // Frame 2: the bricks stand in at the next coarser level while their streams are asked for;
    // previews go on through them there (no holes, no sample from a stand-in).
    Result<FrameStats> f2 = r->renderFrame(in);
    ASSERT_TRUE(f2.isOk()) << f2.message();
    EXPECT_GT(f2->detailRequests, 0u);
    EXPECT_EQ(f2->detailUploads, 0u);
    EXPECT_EQ(f2->decodedBricks, f2->detailRequests);
    EXPECT_EQ(f2->holes, 0u);
    EXPECT_GT(f2->previews, 0u);
    const std::vector<Renderer::CachedBrick> cached = *r->cachedBricks();
    ASSERT_FALSE(cached.empty());
    for (const Renderer::CachedBrick& c : cached) EXPECT_EQ(c.lod, 1u) << "brick " << c.brick << " stands in at level 1";
    FrameOutput o2;
    ASSERT_TRUE(r->readOutput(o2).isOk());
    size_t changed = 0;
    for (size_t i = 0; i < o1.rgba.size(); ++i) changed += std::fabs(o1.rgba[i] - o2.rgba[i]) > 1e-3f;
    EXPECT_GT(changed, o1.rgba.size() / 20) << "the stand-ins' level 1 replaces the brick blocks";
    // Frame 3: the streams were uploaded between the frames: the bricks decode at level 0 and
    // give exact samples.
    Result<FrameStats> f3 = r->renderFrame(in);
    ASSERT_TRUE(f3.isOk()) << f3.message();
    EXPECT_EQ(f3->detailUploads, f2->detailRequests);
    EXPECT_GT(f3->newSamples, f2->newSamples);
    converge(*r, "automatic ring");
    EXPECT_EQ(r->detailCounts().evictedBricks, 0u);

    // A ring far smaller than the streams the view needs: batches of half the ring, the oldest
    // streams evicted; bricks decoded at level 0 keep their labels without their streams.
    const uint64_t tiny = DetailStream::smallestBytes(scene.volume);
    std::unique_ptr<Renderer> small = streamingRenderer(tiny);
    ASSERT_TRUE(small);
    converge(*small, "tiny ring");
    uint64_t viewStreams = 0;
    const std::vector<Renderer::CachedBrick> smallCached = *small->cachedBricks();
    for (const Renderer::CachedBrick& c : smallCached)
        if (c.lod == 0) viewStreams += DetailStream::brickBytes(scene.volume, c.brick);
    EXPECT_GT(viewStreams, 2 * tiny) << "the view must need more streams than the ring holds";
    const DetailCounts counts = small->detailCounts();
    EXPECT_GT(counts.evictedBricks, 0u);
    EXPECT_GE(counts.uploadedBytes, viewStreams);
}

TEST(Renderer, SubsamplingConvergesToFullResolution) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    const FrameInput in = perspectiveView({200, -80, 150}, {66, 35, 97}, {0, 0, 1}, 30, 72, 56);
    RenderSettings st;
    st.denoise = false;
    std::unique_ptr<Renderer> full = makeRenderer(*ctx, scene, 64ull << 20, st);
    const FrameOutput ref = renderConverged(*full, in, 3, 100);
    st.subsampling = 4;
    std::unique_ptr<Renderer> sub = makeRenderer(*ctx, scene, 64ull << 20, st);
    uint32_t frames = 0;
    const FrameOutput got = renderConverged(*sub, in, 3, 400, &frames);
    EXPECT_GE(frames, 3u * 16u) << "each pixel is rendered every 16th frame";
    EXPECT_EQ(differingValues(got.rgba, ref.rgba), 0u);
    // Early frames are upsampled: after one frame of 1/16 of the pixels, no hit pixel is empty.
    std::unique_ptr<Renderer> early = makeRenderer(*ctx, scene, 64ull << 20, st);
    for (int f = 0; f < 4; ++f) ASSERT_TRUE(early->renderFrame(in).isOk());
    FrameOutput e;
    ASSERT_TRUE(early->readOutput(e).isOk());
    size_t covered = 0, hit = 0;
    for (size_t i = 0; i < ref.label.size(); ++i)
        if (ref.rgba[4 * i + 3] > 0.99f) {
            ++hit;
            covered += e.rgba[4 * i + 3] > 0.5f;
        }
    EXPECT_GT(covered, hit * 9 / 10) << "upsampling should fill the pixels not rendered yet";
}

namespace {

/// Compares with (or, with CSGV_UPDATE_BASELINES=1, writes) a baseline PNG. Tolerance: mean
/// absolute difference <= 2/255 per channel, and at most 2% of pixels off by more than 24/255
/// (lavapipe and real GPUs round transcendental functions differently).
void expectMatchesBaseline(const FrameOutput& out, const std::string& name) {
    std::vector<uint8_t> px(size_t(out.width) * out.height * 3);
    for (uint32_t y = 0; y < out.height; ++y)
        for (uint32_t x = 0; x < out.width; ++x)
            for (int k = 0; k < 3; ++k) {
                const float* c = &out.rgba[4 * (size_t(out.height - 1 - y) * out.width + x)];
                px[(size_t(y) * out.width + x) * 3 + k] = uint8_t(std::lround(std::clamp(c[k] + (1 - c[3]), 0.0f, 1.0f) * 255));
            }
    const std::string path = std::string(CSGV_BASELINE_DIR) + "/" + name + ".png";
    const char* update = std::getenv("CSGV_UPDATE_BASELINES");
    if (update && std::string(update) == "1") {
        ASSERT_TRUE(writePng(path, out.width, out.height, 3, px).isOk());
        return;
    }
    uint32_t w = 0, h = 0, c = 0;
    std::vector<uint8_t> base;
    const Status s = readPng(path, w, h, c, base);
    ASSERT_TRUE(s.isOk()) << s.message();
    ASSERT_EQ(w, out.width);
    ASSERT_EQ(h, out.height);
    ASSERT_EQ(c, 3u);
    double sum = 0;
    size_t bad = 0;
    for (size_t i = 0; i < px.size(); i += 3) {
        int worst = 0;
        for (int k = 0; k < 3; ++k) {
            const int d = std::abs(int(px[i + k]) - int(base[i + k]));
            sum += d;
            worst = std::max(worst, d);
        }
        bad += worst > 24;
    }
    EXPECT_LE(sum / px.size(), 2.0) << name << ": mean difference";
    EXPECT_LE(bad, px.size() / 3 / 50) << name << ": pixels off by more than 24/255";
}

} // namespace

TEST(Renderer, ShadingModesMatchBaselines) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    const FrameInput in = perspectiveView({260, -120, 240}, {66, 35, 97}, {0, 0, 1}, 30, 96, 96);
    for (Shading mode : {Shading::Local, Shading::Shadow, Shading::AmbientOcclusion, Shading::PathTracing}) {
        RenderSettings st;
        st.shading = mode;
        std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
        ASSERT_TRUE(r);
        const FrameOutput out = renderConverged(*r, in, mode == Shading::Local || mode == Shading::Shadow ? 2 : 8, 100);
        expectMatchesBaseline(out, std::string("synthA_") + shadingName(mode));
    }
}

TEST(Renderer, MaterialsWithAttributesSelectTheSameLabelsAsTheReference) {
    CSGV_REQUIRE_GPU(ctx);
    // The relabelled fixture: stored labels are dense ids, its database maps them to originals.
    Result<CsgvFile> file = openCsgv(fixture("synthA_b32_rans2_attr.csgv"));
    ASSERT_TRUE(file.isOk()) << file.message();
    ASSERT_TRUE(file->hasAttributes && !file->wideLabels);
    Result<LabelVolume> ids = decodeVolume(file->volume, 0);
    ASSERT_TRUE(ids.isOk()) << ids.message();
    Result<std::unique_ptr<GpuVolume>> gpu = GpuVolume::create(*ctx, file->volume);
    ASSERT_TRUE(gpu.isOk()) << gpu.message();
    const std::vector<uint32_t>& idToLabel = file->idToLabel;
    // An attribute per id: the parity of its original label. Odd labels are opaque red; the
    // second material would take every label but is never reached for odd ones (first match
    // wins) and is fully transparent, so even labels stay invisible.
    std::vector<float> parity(idToLabel.size());
    for (size_t i = 0; i < idToLabel.size(); ++i) parity[i] = float(idToLabel[i] % 2);
    Result<MaterialDocument> doc = parseMaterials(R"({"version": 1, "materials": [
        {"name": "odd", "filter": {"attribute": "parity", "min": 1, "max": 1},
         "color": {"mode": "constant", "rgb": [1, 0, 0]}},
        {"name": "the rest", "filter": {"attribute": "label", "min": 1, "max": 4294967294},
         "color": {"mode": "constant", "rgb": [0, 1, 0]}, "opacity": 0}]})");
    ASSERT_TRUE(doc.isOk()) << doc.message();
    Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, std::shared_ptr<GpuVolume>(std::move(*gpu)));
    ASSERT_TRUE(r.isOk()) << r.message();
    // A document naming a missing attribute is refused with its name.
    const Status missing = (*r)->setMaterials(*doc);
    EXPECT_FALSE(missing.isOk());
    EXPECT_NE(missing.message().find("parity"), std::string::npos) << missing.message();
    ASSERT_TRUE((*r)->setMaterials(*doc, {{"parity", parity}}, idToLabel).isOk());
    const FrameInput in = perspectiveView({-50, 160, 150}, {66, 35, 97}, {0.1, 0, 1}, 35, 80, 60);
    GBuffer ref = castRaysStable(
        *ids, Geometry{}, RayCastView{in.worldToClip, in.width, in.height},
        [&](uint32_t id) { return id < idToLabel.size() && idToLabel[id] % 2 == 1; }, file->volume.brickSize, stepsOf(**r));
    for (uint32_t& l : ref.label) l = l == kInvalidLabel ? l : idToLabel[l]; // the G-buffer holds original labels
    // The odd-labelled voxels hit first, opaque red.
    expectFinestImage(**r, in, ref, "parity", [](uint32_t, const float* c) { return c[0] > 0.0f && c[1] == 0.0f && c[3] == 1.0f; });
}

// Where a ray meets no opaque surface, its G-buffer hit is the first semi-transparent one, flagged
// as such (a pick names what the pixel shows, also in a volume of translucent materials); an
// opaque surface behind a semi-transparent one is the hit; opacity 0 is never a hit. The labels,
// faces and depths equal the reference's, also with several jittered samples a pixel (the flag
// rides the first sample's entry).
TEST(Renderer, TranslucentFirstSurfacesAreTheHitWhereNoOpaqueOneIs) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    std::vector<uint32_t> present;
    for (uint32_t l : scene.labels.labels)
        if (l != 0) present.push_back(l);
    std::nth_element(present.begin(), present.begin() + present.size() / 2, present.end());
    const uint32_t middle = present[present.size() / 2];
    const uint32_t clearFrom = middle + (std::numeric_limits<uint32_t>::max() - middle) / 2;
    Result<MaterialDocument> doc = parseMaterials(R"({"version": 1, "materials": [
        {"name": "glass", "filter": {"attribute": "label", "min": 1, "max": )" + std::to_string(middle) + R"(},
         "opacity": 0.3},
        {"name": "clear", "filter": {"attribute": "label", "min": )" + std::to_string(clearFrom) + R"(,
         "max": 4294967294}, "opacity": 0},
        {"name": "solid", "filter": {"attribute": "label", "min": 1, "max": 4294967294}}]})");
    ASSERT_TRUE(doc.isOk()) << doc.message();
    const FrameInput in = perspectiveView({-50, 160, 150}, {66, 35, 97}, {0.1, 0, 1}, 35, 80, 60);
    const RayCastView view{in.worldToClip, in.width, in.height};
    const auto solid = [&](uint32_t l) { return l > middle && l < clearFrom && l != kInvalidLabel; };
    const auto shown = [&](uint32_t l) { return l != 0 && l < clearFrom && l != kInvalidLabel; };
    for (const uint32_t samples : {1u, 4u}) {
        SCOPED_TRACE(samples);
        RenderSettings st;
        st.finest = true;
        st.jitter = samples > 1;
        st.denoise = false;
        std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
        ASSERT_TRUE(r);
        ASSERT_TRUE(r->setMaterials(*doc).isOk());
        const FrameOutput out = renderConverged(*r, in, samples, 100);
        const GBuffer opaque = castRaysStable(scene.labels, Geometry{}, view, solid, scene.volume.brickSize, stepsOf(*r));
        GBuffer ref = castRaysStable(scene.labels, Geometry{}, view, shown, scene.volume.brickSize, stepsOf(*r));
        size_t glass = 0, behind = 0, flagWrong = 0;
        for (size_t i = 0; i < ref.label.size(); ++i) {
            const bool first = ref.label[i] != kInvalidLabel && !solid(ref.label[i]); // a semi-transparent first surface
            if (opaque.label[i] != kInvalidLabel) { // the opaque surface is the hit, behind glass or not
                behind += first;
                ref.label[i] = opaque.label[i];
                ref.face[i] = opaque.face[i];
                ref.depth[i] = opaque.depth[i];
                ref.distance[i] = opaque.distance[i];
            }
            const bool translucent = ref.label[i] != kInvalidLabel && !solid(ref.label[i]);
            glass += translucent;
            flagWrong += out.translucent[i] != (translucent ? 1 : 0);
        }
        EXPECT_GT(glass, 100u);
        EXPECT_GT(behind, 20u);
        EXPECT_EQ(flagWrong, 0u);
        expectGBufferEquals(out, ref, "translucent first surfaces");
    }
}

// Ray steps take a label change within the interval of drawn labels as a candidate and look its
// material up once out of the steps' loop (render_common.glsl's entersCandidate). Drawn labels
// with undrawn ones between them, one interval of labels whose ends the view shows (an interval
// a label too short at either end misses them), and none at all hit what the reference hits.
TEST(Renderer, DrawnLabelsWithUndrawnOnesBetweenThemHitAsTheReference) {
    CSGV_REQUIRE_GPU(ctx);
    const FrameInput in = perspectiveView({-50, 160, 150}, {66, 35, 97}, {0.1, 0, 1}, 35, 80, 60);
    for (const char* name : {"synthA_b32_rans2_attr.csgv", "synthA_b32_rans2.csgv"}) {
        SCOPED_TRACE(name);
        Result<CsgvFile> file = openCsgv(fixture(name));
        ASSERT_TRUE(file.isOk()) << file.message();
        Result<LabelVolume> stored = decodeVolume(file->volume, 0);
        ASSERT_TRUE(stored.isOk()) << stored.message();
        Result<std::unique_ptr<GpuVolume>> gpu = GpuVolume::create(*ctx, file->volume);
        ASSERT_TRUE(gpu.isOk()) << gpu.message();
        // Original labels of the stored ones (the first fixture stores ids, not in label order).
        const std::vector<uint32_t>& ids = file->idToLabel;
        auto original = [&](uint32_t s) { return ids.empty() ? s : (s < ids.size() ? ids[s] : kInvalidLabel); };
        std::vector<float> parity(ids.size()); // an attribute of the ids (the labels' parity)
        for (size_t i = 0; i < ids.size(); ++i) parity[i] = float(ids[i] % 2);
        Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, std::shared_ptr<GpuVolume>(std::move(*gpu)));
        ASSERT_TRUE(r.isOk()) << r.message();
        auto reference = [&](const std::function<bool(uint32_t)>& drawn) {
            GBuffer ref = castRaysStable(*stored, Geometry{}, RayCastView{in.worldToClip, in.width, in.height},
                                         [&](uint32_t s) { return original(s) != kInvalidLabel && drawn(original(s)); },
                                         file->volume.brickSize, stepsOf(**r));
            for (uint32_t& l : ref.label) l = l == kInvalidLabel ? l : original(l);
            return ref;
        };
        const GBuffer all = reference([](uint32_t l) { return l != 0; });
        std::vector<uint32_t> shown;
        for (uint32_t l : all.label)
            if (l != kInvalidLabel) shown.push_back(l);
        std::sort(shown.begin(), shown.end());
        shown.erase(std::unique(shown.begin(), shown.end()), shown.end());
        ASSERT_GT(shown.size(), 8u);
        const uint32_t lo = shown[shown.size() / 4], hi = shown[3 * shown.size() / 4];
        const uint32_t gapLo = shown[shown.size() / 2 - 1], gapHi = shown[shown.size() / 2 + 1];
        auto range = [](uint32_t a, uint32_t b) {
            return "{\"name\": \"[" + std::to_string(a) + ", " + std::to_string(b) +
                   "]\", \"filter\": {\"attribute\": \"label\", \"min\": " + std::to_string(a) + ", \"max\": " + std::to_string(b) + "}}";
        };
        struct Case {
            std::string what, materials;
            std::function<bool(uint32_t)> drawn; // of an original label
        } cases[] = {
            {"odd labels alone", ids.empty() ? "" : R"({"version": 1, "materials": [{"name": "odd", "filter": {"attribute": "parity", "min": 1, "max": 1}}]})",
             [](uint32_t l) { return l % 2 == 1; }},
            {"two intervals", "{\"version\": 1, \"materials\": [" + range(lo, gapLo) + ", " + range(gapHi, hi) + "]}",
             [&](uint32_t l) { return (l >= lo && l <= gapLo) || (l >= gapHi && l <= hi); }},
            {"one interval", "{\"version\": 1, \"materials\": [" + range(lo, hi) + "]}", [&](uint32_t l) { return l >= lo && l <= hi; }},
            {"none", R"({"version": 1, "materials": [{"name": "none", "filter": {"attribute": "label", "min": 4294967290, "max": 4294967294}}]})",
             [](uint32_t) { return false; }},
        };
        for (const Case& c : cases) {
            if (c.materials.empty()) continue; // the parity of ids only
            Result<MaterialDocument> doc = parseMaterials(c.materials);
            ASSERT_TRUE(doc.isOk()) << doc.message();
            const Status set = ids.empty() ? (*r)->setMaterials(*doc) : (*r)->setMaterials(*doc, {{"parity", parity}}, ids);
            ASSERT_TRUE(set.isOk()) << c.what << ": " << set.message();
            const GBuffer ref = reference(c.drawn);
            const ptrdiff_t hits = std::count_if(ref.label.begin(), ref.label.end(), [](uint32_t l) { return l != kInvalidLabel; });
            if (c.what == "none") { // an empty interval: nothing is hit
                ASSERT_EQ(hits, 0);
                const FrameOutput out = renderConverged(**r, in, 1, 64);
                EXPECT_EQ(std::count(out.label.begin(), out.label.end(), kNone), ptrdiff_t(out.label.size()));
                continue;
            }
            EXPECT_GT(hits, 100) << c.what;
            if (c.what == "one interval") { // both ends are hit
                EXPECT_NE(std::find(ref.label.begin(), ref.label.end(), lo), ref.label.end());
                EXPECT_NE(std::find(ref.label.begin(), ref.label.end(), hi), ref.label.end());
            }
            expectFinestImage(**r, in, ref, c.what, [](uint32_t, const float*) { return true; });
        }
    }
}

namespace {

/// Labels whose attribute "low" is 5 red, labels from 1000 up green (first match wins).
MaterialDocument fiveRedLargeGreen() {
    Result<MaterialDocument> doc = parseMaterials(R"({"version": 1, "materials": [
        {"name": "five", "filter": {"attribute": "low", "min": 5, "max": 5},
         "color": {"mode": "constant", "rgb": [1, 0, 0]}},
        {"name": "large", "filter": {"attribute": "label", "min": 1000, "max": 4294967294},
         "color": {"mode": "constant", "rgb": [0, 1, 0]}}]})");
    EXPECT_TRUE(doc.isOk()) << doc.message();
    return doc ? *doc : MaterialDocument{};
}

} // namespace

TEST(Renderer, LargeLabelsStoredAsIdsKeepTheirLabelsAttributesAndColours) {
    CSGV_REQUIRE_GPU(ctx);
    // Labels up to 4282514378: the device stores them as ids (their index among the palettes'
    // labels); a piece (an MPI rank's) keeps them as they are.
    Result<CsgvFile> file = openCsgv(fixture("synthA_b32_rans2.csgv"));
    ASSERT_TRUE(file.isOk()) << file.message();
    Result<LabelVolume> labels = decodeVolume(file->volume, 0);
    ASSERT_TRUE(labels.isOk()) << labels.message();
    GpuVolumeOptions pieceOptions;
    pieceOptions.owned = BrickBox{{0, 0, 0}, {1, 1, 1}};
    Result<std::unique_ptr<GpuVolume>> piece = GpuVolume::create(*ctx, file->volume, pieceOptions);
    ASSERT_TRUE(piece.isOk()) << piece.message();
    EXPECT_TRUE((*piece)->labelIds().empty());
    for (const bool paletting : {false, true}) {
        SCOPED_TRACE(paletting ? "cache paletting" : "labels in the cache");
        GpuVolumeOptions o;
        o.cachePaletting = paletting;
        Result<std::unique_ptr<GpuVolume>> gpu = GpuVolume::create(*ctx, file->volume, o);
        ASSERT_TRUE(gpu.isOk()) << gpu.message();
        ASSERT_EQ((*gpu)->labelIds(), storedLabels(file->volume, false).ids);
        ASSERT_FALSE((*gpu)->labelIds().empty());
        ASSERT_EQ((*gpu)->labelIds()[0], 0u) << "the fixture holds label 0";
        Result<std::unique_ptr<Renderer>> r = Renderer::create(*ctx, std::shared_ptr<GpuVolume>(std::move(*gpu)));
        ASSERT_TRUE(r.isOk()) << r.message();
        // An attribute per label value covering labels 0 and 1 alone: label 0 (its id too) holds
        // 5 and is drawn red by it; larger labels read NaN, match no attribute interval, and take
        // the second material (green) by their label.
        ASSERT_TRUE((*r)->setMaterials(fiveRedLargeGreen(), {{"low", {5.0f, 7.0f}}}).isOk());
        const FrameInput in = perspectiveView({-50, 160, 150}, {66, 35, 97}, {0.1, 0, 1}, 35, 80, 60);
        const GBuffer ref = castRaysStable(*labels, Geometry{}, RayCastView{in.worldToClip, in.width, in.height},
                                           [](uint32_t l) { return l == 0 || (l >= 1000 && l != kInvalidLabel); },
                                           file->volume.brickSize, stepsOf(**r));
        size_t zeros = 0;
        expectFinestImage(**r, in, ref, "labels, not ids", [&](uint32_t l, const float* c) {
            zeros += l == 0;
            return l == 0 ? c[0] > 0.0f && c[1] == 0.0f : c[0] == 0.0f && c[1] > 0.0f; // 0 red by its attribute, the rest green
        });
        EXPECT_GT(zeros, 0u);
    }
}

TEST(Renderer, AttributesOfLabelsStoredAsIdsAreTheirLabelsValues) {
    CSGV_REQUIRE_GPU(ctx);
    // Labels 0, 3, 9 and 2^23 + 5 (stored as ids 0 to 3); an attribute per label value up to 9:
    // label 3 holds 5 and is drawn red by it, label 9 holds 7 (not drawn), the large label is
    // drawn green by its label. Ids read the values of their labels, not of their own index.
    const uint32_t large = (1u << 23) + 5;
    const LabelVolume v = blockVolume([&](uint32_t x, uint32_t y, uint32_t) { return x < 12 ? 3 : (y < 16 ? 9 : large); });
    CompressedVolume encoded;
    std::unique_ptr<Renderer> r = volumeRenderer(*ctx, v, encoded);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->volume().labelIds(), (std::vector<uint32_t>{0, 3, 9, large}));
    std::vector<float> low(10, 0.0f);
    low[3] = 5.0f;
    low[9] = 7.0f;
    ASSERT_TRUE(r->setMaterials(fiveRedLargeGreen(), {{"low", low}}).isOk());
    const FrameInput in = perspectiveView({-30, 70, 60}, {16, 16, 16}, {0, 0, 1}, 35, 80, 60);
    const GBuffer ref = castRaysStable(v, Geometry{}, RayCastView{in.worldToClip, in.width, in.height},
                                       [&](uint32_t l) { return l == 3 || l == large; }, 16, stepsOf(*r));
    size_t threes = 0;
    expectFinestImage(*r, in, ref, "labels 3 and 2^23 + 5", [&](uint32_t l, const float* c) {
        threes += l == 3;
        return l == 3 ? c[0] > 0.0f && c[1] == 0.0f : c[0] == 0.0f && c[1] > 0.0f;
    });
    EXPECT_GT(threes, 0u);
}

TEST(Renderer, LocalShadingFollowsTheLightAnalytically) {
    CSGV_REQUIRE_GPU(ctx);
    // A solid 24^3 block of label 7 in a 32^3 volume, white, lit from +z in world space.
    const LabelVolume v = blockVolume([](uint32_t, uint32_t, uint32_t) { return 7u; });
    CompressedVolume encoded;
    std::unique_ptr<Renderer> r = volumeRenderer(*ctx, v, encoded);
    ASSERT_TRUE(r);
    Result<MaterialDocument> doc = parseMaterials(
        R"({"version": 1, "materials": [{"filter": {"attribute": "label", "min": 7, "max": 7},
            "color": {"mode": "constant", "rgb": [0.5, 0.5, 0.5]}}]})");
    ASSERT_TRUE(doc.isOk());
    ASSERT_TRUE(r->setMaterials(*doc).isOk());
    RenderSettings st;
    st.lightInWorld = true;
    st.lightDirection = {0, 0, 1};
    st.lightIntensity = 0.6f;
    st.ambient = 0.2f;
    st.jitter = false;
    r->setSettings(st);
    // Seen from above and from -x, -y: the top face (+z) and the -x, -y faces are visible.
    for (const auto& eye : {std::array<double, 3>{-40, -50, 70}, std::array<double, 3>{-60, 20, 50}}) {
        const FrameInput in = perspectiveView(eye, {16, 16, 16}, {0, 0, 1}, 40, 64, 64);
        const FrameOutput out = renderConverged(*r, in, 1, 32);
        size_t top = 0, side = 0;
        const float step = 0.5f / 255 + 1e-5f; // the output has 8 bits a channel, rounded
        for (size_t i = 0; i < out.face.size(); ++i) {
            if (out.label[i] != 7) continue;
            const float red = out.rgba[4 * i];
            if (out.face[i] == Face::PlusZ) { // cos = 1: 0.5 * (0.2 + 0.6)
                EXPECT_NEAR(red, 0.4f, step) << "top face, pixel " << i;
                ++top;
            } else { // the side faces are perpendicular to the light: ambient only
                EXPECT_NEAR(red, 0.1f, step) << "side face " << int(out.face[i]) << ", pixel " << i;
                ++side;
            }
        }
        EXPECT_GT(top, 100u);
        EXPECT_GT(side, 100u);
    }
}

TEST(Renderer, OpaqueDepthStopsRaysAndItsChangeRestartsAccumulation) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    FrameInput in = perspectiveView({200, -80, 150}, {66, 35, 97}, {0, 0, 1}, 30, 48, 40);
    RenderSettings st;
    st.finest = true;
    st.jitter = false;
    std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
    const FrameOutput free = renderConverged(*r, in, 1, 64);
    // Opaque geometry just in front of every hit in the left half: nothing there any more.
    std::vector<float> depth(size_t(in.width) * in.height, 1.0f);
    for (uint32_t y = 0; y < in.height; ++y)
        for (uint32_t x = 0; x < in.width / 2; ++x) {
            const size_t i = size_t(y) * in.width + x;
            if (free.label[i] != kInvalidLabel) depth[i] = free.hitDepth[i] * 0.999f;
        }
    in.opaqueDepth = depth.data();
    const FrameOutput blocked = renderConverged(*r, in, 1, 64);
    size_t leftHits = 0, rightSame = 0, right = 0;
    for (uint32_t y = 0; y < in.height; ++y)
        for (uint32_t x = 0; x < in.width; ++x) {
            const size_t i = size_t(y) * in.width + x;
            if (x < in.width / 2) leftHits += blocked.label[i] != kInvalidLabel && free.label[i] != kInvalidLabel;
            else {
                ++right;
                rightSame += blocked.label[i] == free.label[i];
            }
        }
    EXPECT_EQ(leftHits, 0u) << "rays stop at the opaque depth";
    EXPECT_EQ(rightSame, right) << "where the depth is 1 nothing changes";
    // The same camera and settings, a different depth: the image follows (no stale image, although
    // every pixel already held its one sample).
    std::fill(depth.begin(), depth.end(), 1.0f);
    for (int f = 0; f < 8; ++f) ASSERT_TRUE(r->renderFrame(in).isOk());
    FrameOutput again;
    ASSERT_TRUE(r->readOutput(again).isOk());
    EXPECT_EQ(again.label, free.label);
}

TEST(Renderer, ClipBoxShowsExactlyTheCroppedVolume) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    const std::array<uint32_t, 3> lo{20, 10, 50}, hi{100, 60, 150};
    // The reference: the cropped volume placed where the box is (origin shifted by lo).
    LabelVolume crop;
    crop.dim = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    crop.labels.resize(size_t(crop.dim[0]) * crop.dim[1] * crop.dim[2]);
    for (uint32_t z = 0; z < crop.dim[2]; ++z)
        for (uint32_t y = 0; y < crop.dim[1]; ++y)
            for (uint32_t x = 0; x < crop.dim[0]; ++x)
                crop.labels[crop.index(x, y, z)] = scene.labels.at(x + lo[0], y + lo[1], z + lo[2]);
    Geometry shifted;
    shifted.origin = {double(lo[0]), double(lo[1]), double(lo[2])};
    const FrameInput in = perspectiveView({-60, -90, 230}, {60, 35, 100}, {0, 0, 1}, 40, 64, 56);
    RenderSettings st;
    st.finest = true;
    st.jitter = false;
    st.clipMin = {lo[0], lo[1], lo[2]};
    st.clipMax = {hi[0], hi[1], hi[2]};
    std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
    const FrameOutput out = renderConverged(*r, in, 1, 64);
    RayCastView view{in.worldToClip, in.width, in.height};
    // A double-precision reference: the two float pipelines differ in the last bits of the ray,
    // so a few grazing rays may pick the neighbouring voxel.
    const GBuffer ref = castRays(crop, shifted, view, [](uint32_t l) { return l != 0 && l != kInvalidLabel; });
    size_t diff = 0, hits = 0;
    for (size_t i = 0; i < ref.label.size(); ++i) {
        diff += out.label[i] != ref.label[i];
        hits += ref.label[i] != kInvalidLabel;
    }
    EXPECT_GT(hits, ref.label.size() / 10);
    EXPECT_LE(diff, ref.label.size() / 200) << "at most 0.5% of pixels on voxel edges may differ";
    std::printf("clip box: %zu of %zu pixels differ, %zu hits\n", diff, ref.label.size(), hits);
}

bool inRect(const std::array<uint32_t, 4>& r, uint32_t x, uint32_t y) { return x >= r[0] && x < r[2] && y >= r[1] && y < r[3]; }

/// Every pixel outside FrameOutput::rect is empty (compositors draw the rectangle alone), and
/// the rectangle follows the footprint: the volume's part of the image, wider after a move.
void expectEmptyOutsideRect(const FrameOutput& out) {
    ASSERT_LE(out.rect[2], out.width);
    ASSERT_LE(out.rect[3], out.height);
    size_t inside = 0;
    for (uint32_t y = 0; y < out.height; ++y)
        for (uint32_t x = 0; x < out.width; ++x) {
            const size_t i = size_t(y) * out.width + x;
            if (inRect(out.rect, x, y)) {
                inside += out.rgba8[i] != 0;
                continue;
            }
            ASSERT_EQ(out.rgba8[i], 0u) << x << "," << y;
            ASSERT_EQ(out.depth[i], 1.0f) << x << "," << y;
        }
    EXPECT_GT(inside, 100u);
}

/// output()'s colour and depth, which it reads from the device where the last frames drew and
/// where it read last (Renderer::Impl::readImage), are the whole image's read-back.
void expectOutputIsWhole(Renderer& r, const FrameOutput& whole) {
    const FrameOutput& o = r.output();
    EXPECT_EQ(o.rect, whole.rect);
    ASSERT_EQ(o.rgba8.size(), whole.rgba8.size());
    for (size_t i = 0; i < o.rgba8.size(); ++i) {
        ASSERT_EQ(o.rgba8[i], whole.rgba8[i]) << "pixel " << i;
        ASSERT_EQ(o.depth[i], whole.depth[i]) << "pixel " << i;
    }
}

TEST(Renderer, OutputIsEmptyOutsideItsRectangle) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    RenderSettings st;
    st.jitter = false;
    st.clipMin = {20, 10, 50}; // a small box: a small footprint
    st.clipMax = {60, 40, 90};
    std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
    const FrameInput a = perspectiveView({-60, -90, 230}, {40, 25, 70}, {0, 0, 1}, 40, 96, 80);
    const FrameOutput first = renderConverged(*r, a, 1, 64);
    expectEmptyOutsideRect(first);
    expectOutputIsWhole(*r, first);
    EXPECT_LT(uint64_t(first.rect[2] - first.rect[0]) * (first.rect[3] - first.rect[1]), uint64_t(first.width) * first.height / 2);
    // The box elsewhere in the image: what the first view drew there was cleared (only the rows
    // drawn are), the new footprint drawn.
    const FrameInput b = perspectiveView({-60, -90, 230}, {75, -10, 70}, {0, 0, 1}, 40, 96, 80);
    const FrameOutput out = renderConverged(*r, b, 1, 64);
    expectEmptyOutsideRect(out);
    expectOutputIsWhole(*r, out); // the first view's pixels outside this rectangle are gone there too
    size_t moved = 0; // pixels the first view drew outside the second's rectangle
    for (uint32_t y = 0; y < out.height; ++y)
        for (uint32_t x = 0; x < out.width; ++x)
            moved += first.rgba8[size_t(y) * out.width + x] != 0 && !inRect(out.rect, x, y);
    EXPECT_GT(moved, 100u);
}

/// Every opaque pixel's channel of `curved` is `curve` of the same channel of `plain` (both 8-bit:
/// the bounds of the curve over plain's rounding interval, rounded), and the curve changed some.
void expectCurveOfOpaquePixels(const FrameOutput& plain, const FrameOutput& curved, double (*curve)(double),
                               const char* what) {
    ASSERT_EQ(plain.rgba8.size(), curved.rgba8.size());
    size_t opaque = 0, changed = 0;
    for (size_t i = 0; i < plain.rgba8.size(); ++i) {
        if ((plain.rgba8[i] >> 24) != 255u) continue;
        ++opaque;
        ASSERT_EQ(curved.rgba8[i] >> 24, 255u) << what << " at pixel " << i;
        for (int k = 0; k < 3; ++k) {
            const double v0 = double((plain.rgba8[i] >> (8 * k)) & 0xFFu);
            const uint32_t v1 = (curved.rgba8[i] >> (8 * k)) & 0xFFu;
            const double lo = std::round(curve(std::max(v0 - 0.5, 0.0) / 255.0) * 255.0);
            const double hi = std::round(curve(std::min(v0 + 0.5, 255.0) / 255.0) * 255.0);
            ASSERT_GE(double(v1), lo) << what << " at pixel " << i << " channel " << k << " (was " << v0 << ")";
            ASSERT_LE(double(v1), hi) << what << " at pixel " << i << " channel " << k << " (was " << v0 << ")";
            changed += double(v1) != v0;
        }
    }
    EXPECT_GT(opaque, 500u) << what;
    EXPECT_GT(changed, opaque / 2) << what;
}

// Gamma and ACES tone mapping (their own pipelines, TONE_CURVES 1; the default passes are compiled
// without them) apply to the output, locally resolved and through the gather, and switching back
// gives the plain image bit for bit.
TEST(Renderer, ToneCurvesApplyToTheOutputAndSwitchBack) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    const FrameInput in = perspectiveView({-60, -90, 230}, {66, 35, 97}, {0, 0, 1}, 40, 96, 80);
    for (const uint32_t stride : {1u, 2u}) { // the render pass resolves, or the gather does
        RenderSettings st;
        st.jitter = false;
        st.subsampling = stride;
        std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
        const FrameOutput plain = renderConverged(*r, in, 1, 64);
        RenderSettings gamma = st;
        gamma.gamma = 2.2f;
        r->setSettings(gamma);
        expectCurveOfOpaquePixels(plain, renderConverged(*r, in, 1, 64), [](double x) { return std::pow(x, 1.0 / 2.2); },
                                  stride == 1 ? "gamma" : "gamma, gathered");
        RenderSettings aces = st;
        aces.toneMapping = true;
        r->setSettings(aces);
        expectCurveOfOpaquePixels(plain, renderConverged(*r, in, 1, 64), [](double x) {
            return std::clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
        }, stride == 1 ? "aces" : "aces, gathered");
        r->setSettings(st);
        EXPECT_EQ(renderConverged(*r, in, 1, 64).rgba8, plain.rgba8) << "stride " << stride;
    }
}

// Frames at a target of one sample keep no sums (ONE_SAMPLE): a higher target, or a stride whose
// gather reads them, takes the samples again and ends with the image a fresh renderer gives.
TEST(Renderer, OneSampleFramesGoOnToMoreSamplesExactly) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    const FrameInput in = perspectiveView({200, -80, 150}, {66, 35, 97}, {0, 0, 1}, 30, 64, 48);
    for (const uint32_t stride : {1u, 2u}) {
        RenderSettings st;
        st.denoise = false;
        std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
        renderConverged(*r, in, 1, 64);
        st.subsampling = stride;
        r->setSettings(st); // the samples are kept (the same image)
        const FrameOutput more = renderConverged(*r, in, 3, 64);
        std::unique_ptr<Renderer> fresh = makeRenderer(*ctx, scene, 64ull << 20, st);
        const FrameOutput want = renderConverged(*fresh, in, 3, 64);
        EXPECT_EQ(more.rgba8, want.rgba8) << "stride " << stride;
        EXPECT_EQ(more.samples, want.samples) << "stride " << stride;
    }
}

// Frames where every pixel takes its own samples list only the pixels within the box's outline
// (RendererOptions::outlineSpans, Renderer.cpp footprintSpans), and their resolve passes, if any,
// take those alone (ResolvePush::spans): the pixels they leave out see nothing of the box.
// Renderers with and without the outline (reading through texels and through addresses) give the
// same image, depth and G-buffer, one sample and four jittered ones, and four of ambient occlusion
// and of path tracing denoised (the misses the A-trous passes read are sampled, the passes take
// the pixels within their reach; a still render's frames gather in their render pass), from
// views at many angles, close up, and with a clip box.
TEST(Renderer, OutlineFramesLeaveOutOnlyPixelsOutsideTheBox) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    struct View {
        std::array<double, 3> eye, centre;
        bool clip;
    };
    const View views[] = {
        {{200, -80, 150}, {66, 35, 97}, false}, {{-60, -90, 230}, {40, 25, 70}, false},
        {{66, 0, 320}, {66, 35, 97}, false},    {{300, 35, 97}, {66, 35, 97}, false},
        {{140, 110, 170}, {66, 35, 97}, false}, {{-40, 200, 20}, {66, 35, 97}, true},
        {{90, 60, 120}, {30, 10, 60}, false},   {{-60, -90, 230}, {75, -10, 70}, true}};
    struct Mode {
        uint32_t target;
        Shading shading;
    };
    size_t leftOut = 0;
    for (const Mode mode : {Mode{1, Shading::Local}, Mode{4, Shading::Local}, Mode{4, Shading::AmbientOcclusion},
                            Mode{4, Shading::PathTracing}}) {
        const uint32_t target = mode.target;
        for (const View& v : views) {
            RenderSettings st;
            st.jitter = target > 1;
            st.shading = mode.shading;
            st.denoise = mode.shading != Shading::Local;
            if (v.clip) {
                st.clipMin = {20, 10, 50};
                st.clipMax = {60, 40, 90};
            }
            const FrameInput in = perspectiveView(v.eye, v.centre, {0, 0, 1}, 40, 96, 80);
            std::unique_ptr<Renderer> outline = makeRenderer(*ctx, scene, 64ull << 20, st);
            std::unique_ptr<Renderer> whole = makeRenderer(*ctx, scene, 64ull << 20, st, RendererOptions::Decode::Auto, false);
            std::unique_ptr<Renderer> addressed =
                makeRenderer(*ctx, scene, 64ull << 20, st, RendererOptions::Decode::Auto, true, false);
            const FrameOutput a = renderConverged(*outline, in, target, 64);
            const FrameOutput b = renderConverged(*whole, in, target, 64);
            const FrameOutput c = renderConverged(*addressed, in, target, 64);
            const std::string at = "target " + std::to_string(target) + ", shading " + std::to_string(int(mode.shading)) +
                                   ", eye " + std::to_string(v.eye[0]) + "," +
                                   std::to_string(v.eye[1]) + "," + std::to_string(v.eye[2]);
            ASSERT_EQ(a.rgba8.size(), b.rgba8.size());
            EXPECT_EQ(a.rgba8, c.rgba8) << "through addresses, " << at;
            EXPECT_EQ(a.samples, c.samples) << "through addresses, " << at;
            if (mode.shading != Shading::Local) {
                // A still render's loop (render()): its frames after the first write the gathered
                // image in their render pass (kFlagGatherInRender), denoised once at the end.
                // One sample (ParaView's CSGVFramesPerStillRender 1) and the mode's target.
                RenderRequest req;
                req.frame = in;
                req.timeBudgetSeconds = 1e9; // the target ends the loop; every frame at stride 1
                for (const uint32_t stillTarget : {1u, target}) {
                    RenderSettings still = st;
                    still.sampleTarget = stillTarget;
                    std::unique_ptr<Renderer> loopOutline = makeRenderer(*ctx, scene, 64ull << 20, still);
                    std::unique_ptr<Renderer> loopWhole =
                        makeRenderer(*ctx, scene, 64ull << 20, still, RendererOptions::Decode::Auto, false);
                    Result<RenderResult> ro = loopOutline->render(req), rw = loopWhole->render(req);
                    ASSERT_TRUE(ro.isOk() && rw.isOk()) << at;
                    EXPECT_GE(ro->frames, stillTarget) << at;
                    FrameOutput lo, lw;
                    ASSERT_TRUE(loopOutline->readOutput(lo).isOk() && loopWhole->readOutput(lw).isOk());
                    EXPECT_EQ(lo.rgba8, lw.rgba8) << "still loop, target " << stillTarget << ", " << at;
                    EXPECT_EQ(lo.label, lw.label) << "still loop, target " << stillTarget << ", " << at;
                }
            }
            for (size_t i = 0; i < a.rgba8.size(); ++i) {
                ASSERT_EQ(a.rgba8[i], b.rgba8[i]) << "pixel " << i << ", " << at;
                ASSERT_EQ(a.depth[i], b.depth[i]) << "pixel " << i << ", " << at;
                ASSERT_EQ(a.label[i], b.label[i]) << "pixel " << i << ", " << at;
                ASSERT_EQ(a.face[i], b.face[i]) << "pixel " << i << ", " << at;
                ASSERT_EQ(a.hitDepth[i], b.hitDepth[i]) << "pixel " << i << ", " << at;
                ASSERT_EQ(a.distance[i], b.distance[i]) << "pixel " << i << ", " << at;
                ASSERT_TRUE(a.samples[i] == b.samples[i] || a.samples[i] == 0) << "pixel " << i << ", " << at;
                leftOut += a.samples[i] == 0 && b.samples[i] > 0;
            }
        }
    }
    if (decodesOnHost(RendererOptions::Decode::Auto, ctx->device())) { // the host lists the pixels then
        EXPECT_GT(leftOut, 1000u);
    }
}

// A new accumulation fills the G-buffer only when its epochs wrap (kGBufferEpochShift): entries
// of earlier ones read as cleared. One renderer with a close view first, then alternating between
// two others for more than twice kGBufferEpochs accumulations, gives each view's image, G-buffer
// and sample counts as a fresh renderer does (it fails with no fill at the wrap: the first view's
// entries outside the others' footprints would come back; or with no epochs).
TEST(Renderer, AccumulationsReadTheGBufferOfTheirOwnEpochAlone) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    RenderSettings st;
    st.jitter = false;
    st.denoise = false;
    const FrameInput views[3] = {perspectiveView({600, -300, 350}, {66, 35, 97}, {0, 0, 1}, 30, 96, 80),
                                 perspectiveView({700, 35, 97}, {66, 35, 97}, {0, 0, 1}, 30, 96, 80),
                                 perspectiveView({90, 60, 120}, {30, 10, 60}, {0, 0, 1}, 60, 96, 80)};
    FrameOutput fresh[3];
    for (int v = 0; v < 3; ++v) {
        std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
        fresh[v] = renderConverged(*r, views[v], 1, 64);
    }
    std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
    for (uint32_t i = 0; i < 2 * kGBufferEpochs + 6; ++i) {
        const int v = i == 0 ? 2 : int(i % 2);
        const FrameOutput out = renderConverged(*r, views[v], 1, 64);
        ASSERT_EQ(out.samples, fresh[v].samples) << "accumulation " << i;
        ASSERT_EQ(out.label, fresh[v].label) << "accumulation " << i;
        ASSERT_EQ(out.rgba8, fresh[v].rgba8) << "accumulation " << i;
    }
}

TEST(Renderer, RenderRunsTheStillLoopOnceAndSkipsUnchangedViews) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    RenderRequest req;
    req.frame = perspectiveView({200, -80, 150}, {66, 35, 97}, {0, 0, 1}, 30, 48, 40);
    req.timeBudgetSeconds = 1e9; // the sample target ends the loop, not the clock
    RenderSettings st;
    st.finest = true;
    st.jitter = false;
    st.denoise = false;
    st.sampleTarget = 2;
    std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
    Result<RenderResult> first = r->render(req);
    ASSERT_TRUE(first.isOk()) << first.message();
    EXPECT_TRUE(first->changed);
    EXPECT_GE(first->frames, 2u);
    EXPECT_GE(first->last.minSamples, 2u);
    // The same view again: the image is exact, nothing is rendered.
    Result<RenderResult> again = r->render(req);
    ASSERT_TRUE(again.isOk());
    EXPECT_FALSE(again->changed);
    EXPECT_EQ(again->frames, 0u);
    // Equal settings keep the image; different ones start anew.
    r->setSettings(st);
    EXPECT_FALSE(r->render(req)->changed);
    st.ambient = 0.5f;
    r->setSettings(st);
    Result<RenderResult> relit = r->render(req);
    ASSERT_TRUE(relit.isOk());
    EXPECT_TRUE(relit->changed);
    EXPECT_GE(relit->frames, 2u);
    // The output: colour and depth as read back, the G-buffer on request, all equal to readOutput.
    FrameOutput direct;
    ASSERT_TRUE(r->readOutput(direct, Renderer::Color | Renderer::Color8 | Renderer::Depth | Renderer::GBuffer).isOk());
    const FrameOutput& out = r->output(Renderer::Color | Renderer::GBuffer);
    EXPECT_EQ(out.rgba, direct.rgba);
    EXPECT_EQ(out.rgba8, direct.rgba8);
    ASSERT_EQ(out.rgba.size(), 4 * out.rgba8.size());
    for (size_t i = 0; i < out.rgba8.size(); ++i) // the float colour is the 8-bit one's
        for (int k = 0; k < 4; ++k) ASSERT_EQ(out.rgba[4 * i + k], float((out.rgba8[i] >> (8 * k)) & 0xFFu) / 255.0f) << i;
    EXPECT_EQ(out.depth, direct.depth);
    EXPECT_EQ(out.label, direct.label);
    // An opaque depth that appears, then changes, restarts the accumulation; the same one does not.
    std::vector<float> depth(size_t(req.frame.width) * req.frame.height, 0.5f);
    req.frame.opaqueDepth = depth.data();
    EXPECT_TRUE(r->render(req)->changed);
    EXPECT_FALSE(r->render(req)->changed);
    depth[7] = 0.25f;
    EXPECT_TRUE(r->render(req)->changed);
    // Interactive: one frame.
    req.interactive = true;
    req.frame.worldToClip[12] += 0.01;
    Result<RenderResult> one = r->render(req);
    ASSERT_TRUE(one.isOk());
    EXPECT_TRUE(one->changed);
    EXPECT_EQ(one->frames, 1u);
}

namespace {
/// A context of the test's own (the pipelines it holds are that test's alone) with the nibble
/// fixture uploaded, and a still request of a perspective view of it; false on failure (reported).
/// Filled in place: the GPU volume keeps the address of `volume`.
struct OwnContext {
    CompressedVolume volume; // the GPU volume reads it
    std::unique_ptr<Context> ctx;
    std::shared_ptr<GpuVolume> gpu;
    RenderRequest req;
};
bool makeOwnContext(OwnContext& o) {
    Result<std::unique_ptr<Context>> own = Context::create();
    EXPECT_TRUE(own.isOk()) << own.message();
    if (!own) return false;
    o.volume = loadFixture("synthA_b16_nibble.csgv");
    Result<std::unique_ptr<GpuVolume>> made = GpuVolume::create(**own, o.volume);
    EXPECT_TRUE(made.isOk()) << made.message();
    if (!made) return false;
    o.ctx = std::move(*own);
    o.gpu = std::move(*made);
    o.req.frame = perspectiveView({200, -80, 150}, {66, 35, 97}, {0, 0, 1}, 30, 48, 40);
    o.req.timeBudgetSeconds = 1e9;
    return true;
}
} // namespace

TEST(Renderer, PreparedPipelinesServeTheFirstFrameAndAnUnforeseenOneIsMadeThen) {
    CSGV_REQUIRE_GPU(shared);
    OwnContext own;
    ASSERT_TRUE(makeOwnContext(own));
    Context& ctx = *own.ctx;
    const std::shared_ptr<GpuVolume> gpu = own.gpu;
    RenderRequest req = own.req;
    RenderSettings st;
    st.sampleTarget = 1;
    std::vector<float> depth(size_t(req.frame.width) * req.frame.height, 0.5f);
    for (const bool texels : {true, false}) {
        SCOPED_TRACE(texels ? "texel views" : "buffer addresses");
        RendererOptions o;
        o.cacheBytes = 64ull << 20;
        o.renderTexels = texels;
        auto renderer = [&]() {
            Result<std::unique_ptr<Renderer>> r = Renderer::create(ctx, gpu, o);
            EXPECT_TRUE(r.isOk()) << r.message();
            if (r) (*r)->setSettings(st);
            return r ? std::move(*r) : nullptr;
        };
        std::unique_ptr<Renderer> prepared = renderer();
        ASSERT_TRUE(prepared);
        ASSERT_TRUE(prepared->preparePipelines(false).isOk());
        const size_t before = ctx.pipelineCount();
        EXPECT_GT(before, 0u);
        req.frame.opaqueDepth = nullptr;
        Result<RenderResult> first = prepared->render(req);
        ASSERT_TRUE(first.isOk()) << first.message();
        EXPECT_GE(first->last.minSamples, 1u);
        EXPECT_EQ(ctx.pipelineCount(), before) << "the first frame made a pipeline the preparation did not";
        // The same image as a renderer that made its pipelines at its first frame.
        std::unique_ptr<Renderer> plain = renderer();
        ASSERT_TRUE(plain && plain->render(req).isOk());
        EXPECT_EQ(prepared->output().rgba8, plain->output().rgba8);
        EXPECT_EQ(prepared->output().depth, plain->output().depth);
        // An opaque depth the preparation did not foresee: that frame makes its pipeline.
        req.frame.opaqueDepth = depth.data();
        Result<RenderResult> stopped = prepared->render(req);
        ASSERT_TRUE(stopped.isOk()) << stopped.message();
        EXPECT_GT(ctx.pipelineCount(), before);
        ASSERT_TRUE(plain->render(req).isOk());
        EXPECT_EQ(prepared->output().rgba8, plain->output().rgba8);
    }
}

TEST(Renderer, WarmedShadingModesSwitchWithoutMakingPipelines) {
    // Issue 38, item 4: after a frame, warmShadingModes makes the other modes' pipelines in the
    // background, so switching the mode makes none at its first frame (on a CPU device a new
    // mode's render pipeline took about a second); the images equal those of a renderer that made
    // its pipelines at the switch.
    CSGV_REQUIRE_GPU(shared);
    OwnContext own;
    ASSERT_TRUE(makeOwnContext(own));
    Context& ctx = *own.ctx;
    const std::shared_ptr<GpuVolume> gpu = own.gpu;
    const RenderRequest req = own.req;
    RenderSettings st;
    st.sampleTarget = 2;
    RendererOptions o;
    o.cacheBytes = 64ull << 20;
    // Every decoder step in each frame: path tracing's deep bounces read what the cache holds
    // (bricks still being decoded at the levels completed), so where decodes carry over frames
    // (GPUs) the images of renderers with other histories differ there (H200: mode 3 did).
    o.decodeStepsPerFrame = RendererOptions::kDecodeStepsAll;
    Result<std::unique_ptr<Renderer>> warmed = Renderer::create(ctx, gpu, o);
    ASSERT_TRUE(warmed.isOk()) << warmed.message();
    (*warmed)->setSettings(st);
    ASSERT_TRUE((*warmed)->render(req).isOk());
    (*warmed)->warmShadingModes(false);
    (*warmed)->waitForWarming();
    const size_t before = ctx.pipelineCount();
    for (uint32_t mode = 0; mode < kShadingModes; ++mode) {
        SCOPED_TRACE("shading mode " + std::to_string(mode));
        st.shading = Shading(mode);
        (*warmed)->setSettings(st);
        Result<RenderResult> r = (*warmed)->render(req);
        ASSERT_TRUE(r.isOk()) << r.message();
        EXPECT_EQ(ctx.pipelineCount(), before) << "switching the mode made a pipeline the warming did not";
        Result<std::unique_ptr<Renderer>> plain = Renderer::create(ctx, gpu, o);
        ASSERT_TRUE(plain.isOk()) << plain.message();
        (*plain)->setSettings(st);
        ASSERT_TRUE((*plain)->render(req).isOk());
        EXPECT_EQ((*warmed)->output().rgba8, (*plain)->output().rgba8);
    }
}

TEST(Renderer, MaterialsThatShowHiddenBricksDrawThemAfterFramesWithoutThem) {
    // The request stage skips bricks that are neither cached nor needed, except in the frame after
    // the materials changed which bricks are visible: bricks no ray could see before must appear.
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    const FrameInput in = perspectiveView({200, -80, 150}, {66, 35, 97}, {0, 0, 1}, 30, 48, 40);
    RenderSettings st;
    st.finest = true;
    st.denoise = false;
    std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
    Result<MaterialDocument> none = parseMaterials(R"({"version": 1, "materials": [
        {"name": "nothing", "filter": {"attribute": "label", "min": 1, "max": 1}}]})");
    ASSERT_TRUE(none.isOk()) << none.message();
    ASSERT_TRUE(r->setMaterials(*none).isOk());
    const FrameOutput empty = renderConverged(*r, in, 2, 50);
    EXPECT_TRUE(std::all_of(empty.label.begin(), empty.label.end(), [](uint32_t l) { return l == kInvalidLabel; }));
    ASSERT_TRUE(r->setMaterials(defaultMaterials()).isOk());
    const FrameOutput shown = renderConverged(*r, in, 2, 50);
    std::unique_ptr<Renderer> fresh = makeRenderer(*ctx, scene, 64ull << 20, st);
    const FrameOutput want = renderConverged(*fresh, in, 2, 50);
    EXPECT_GT(std::count_if(want.label.begin(), want.label.end(), [](uint32_t l) { return l != kInvalidLabel; }), 100);
    EXPECT_EQ(shown.label, want.label);
    EXPECT_EQ(differingValues(shown.rgba, want.rgba), 0u);
}

TEST(Renderer, ChangesThatKeepTheImageKeepTheAccumulation) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    RenderRequest req;
    req.frame = perspectiveView({200, -80, 150}, {66, 35, 97}, {0, 0, 1}, 30, 48, 40);
    req.timeBudgetSeconds = 1e9;
    RenderSettings st;
    st.finest = true;
    st.denoise = false;
    st.sampleTarget = 2;
    std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
    MaterialDocument doc = defaultMaterials();
    const std::vector<float> unused(256, 1.0f);
    ASSERT_TRUE(r->setMaterials(doc, {{"unused", unused}}).isOk());
    Result<RenderResult> two = r->render(req);
    ASSERT_TRUE(two.isOk());
    const uint32_t taken = two->last.frame; // frames accumulated
    // The same document again, with another attribute array no material names: nothing to render.
    ASSERT_TRUE(r->setMaterials(doc, {{"unused", unused}}).isOk());
    ASSERT_TRUE(r->setMaterials(doc, {{"unused", unused}, {"also unused", unused}}).isOk());
    EXPECT_FALSE(r->render(req)->changed);
    // A higher sample target goes on from the samples taken (the accumulation is not reset, and
    // it takes fewer frames than a renderer that starts anew; a jittered ray that meets a brick
    // no ray met before waits for it, longer where decodes carry over frames, as on GPUs), and
    // the image equals one rendered to four samples from the start.
    st.sampleTarget = 4;
    r->setSettings(st);
    Result<RenderResult> more = r->render(req);
    ASSERT_TRUE(more.isOk());
    EXPECT_TRUE(more->changed);
    EXPECT_EQ(more->last.frame, taken + more->frames) << "the accumulation was reset";
    EXPECT_EQ(more->last.minSamples, 4u);
    std::unique_ptr<Renderer> fresh = makeRenderer(*ctx, scene, 64ull << 20, st);
    Result<RenderResult> anew = fresh->render(req);
    ASSERT_TRUE(anew.isOk());
    EXPECT_LT(more->frames, anew->frames);
    EXPECT_EQ(r->output().rgba8, fresh->output().rgba8);
    // Another subsampling keeps the samples too: nothing is left to render.
    st.subsampling = 2;
    r->setSettings(st);
    Result<RenderResult> strided = r->render(req);
    ASSERT_TRUE(strided.isOk());
    EXPECT_EQ(strided->last.minSamples, 4u);
    EXPECT_LE(strided->frames, 1u);
    // A document that draws differently starts anew.
    st.subsampling = 1;
    r->setSettings(st);
    doc.materials[0].opacity = 0.5f;
    ASSERT_TRUE(r->setMaterials(doc).isOk());
    Result<RenderResult> changed = r->render(req);
    ASSERT_TRUE(changed.isOk());
    EXPECT_TRUE(changed->changed);
    EXPECT_GE(changed->frames, 4u);
    const std::vector<uint32_t> translucent = r->output().rgba8;
    // A smaller image and back: the buffers are reused, the image is rendered anew at each size.
    RenderRequest small = req;
    small.frame.width = 24;
    small.frame.height = 20;
    const uint64_t device = r->memory().total();
    ASSERT_TRUE(r->render(small).isOk());
    EXPECT_EQ(r->output().width, 24u);
    EXPECT_EQ(r->memory().total(), device);
    ASSERT_TRUE(r->render(req).isOk());
    EXPECT_EQ(r->output().width, req.frame.width);
    EXPECT_EQ(r->output().rgba8, translucent);
}

// Overlapped decodes (RendererOptions::overlapDecodes) publish a decode that ended beside a
// render in the next frame, before its request pass: a brick decoded at a level a far camera
// wanted is evicted before the next view, nearer, samples it (found by a review: published after
// that pass, the near view's first frame sampled the far level, and with one sample a pixel those
// samples were its final image).
TEST(Renderer, OverlappedDecodesNeverShowALevelTheNextViewDoesNotWant) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b32_rans2.csgv");
    RenderSettings st;
    st.jitter = false;
    st.denoise = false;
    st.sampleTarget = 1;
    RendererOptions o;
    o.decode = RendererOptions::Decode::Gpu;
    o.decodeStepsPerFrame = 300;
    o.prefetchVoxels = 0;
    const FrameInput nearView = perspectiveView({-40, 150, 170}, {48, 40, 30}, {0, 0, 1}, 40, 96, 72);
    std::unique_ptr<Renderer> fresh = sceneRenderer(*ctx, scene, o, st);
    ASSERT_TRUE(fresh);
    const FrameOutput want = renderConverged(*fresh, nearView, 1, 400);
    for (const double far : {4.0, 8.0}) {
        std::unique_ptr<Renderer> r = sceneRenderer(*ctx, scene, o, st);
        ASSERT_TRUE(r);
        // A camera far away, moving (every frame begins an accumulation: overlapped), then near:
        // the second far frame decodes what the first one's rays found missing (at far levels).
        for (int f = 0; f < 2; ++f) {
            const double a = 0.02 * f;
            Result<FrameStats> s = r->renderFrame(perspectiveView(
                {48 + far * (-88 * std::cos(a) + 110 * std::sin(a)), 40 + far * 110 * std::cos(a), 30 + far * 140}, {48, 40, 30},
                {0, 0, 1}, 40, 96, 72));
            ASSERT_TRUE(s.isOk()) << s.message();
        }
        const FrameOutput got = renderConverged(*r, nearView, 1, 400);
        EXPECT_EQ(got.label, want.label) << "from " << far << " times as far";
        EXPECT_EQ(got.depth, want.depth) << "from " << far << " times as far";
        EXPECT_EQ(differingValues(got.rgba, want.rgba), 0u) << "from " << far << " times as far";
    }
}

TEST(Renderer, SmallVolumesHaveEveryVisibleBrickDecodedAtTheFirstFrame) {
    CSGV_REQUIRE_GPU(ctx);
    // denseB: 60 bricks of 16^3, far below RendererOptions::prefetchVoxels.
    Scene& scene = fixtureScene(*ctx, "denseB_b16_rans2_delta.csgv");
    const FrameInput in = perspectiveView({-50, 140, 110}, {38, 30, 22}, {0, 0, 1}, 35, 96, 72);
    RenderSettings st;
    st.shading = Shading::Shadow;
    st.jitter = false;
    st.denoise = false;
    st.sampleTarget = 1;
    for (RendererOptions::Decode decode : {RendererOptions::Decode::Auto, RendererOptions::Decode::Gpu}) {
        SCOPED_TRACE(decode == RendererOptions::Decode::Gpu ? "GPU decoding" : "the device's decoding");
        auto cold = [&](uint64_t prefetchVoxels) {
            RendererOptions o;
            o.decode = decode;
            o.cacheBytes = 16ull << 20;
            o.prefetchVoxels = prefetchVoxels;
            return sceneRenderer(*ctx, scene, o, st);
        };
        std::unique_ptr<Renderer> fetched = cold(RendererOptions{}.prefetchVoxels), found = cold(0);
        ASSERT_TRUE(fetched && found);
        // Every view ray finds its bricks at once: the first frame is complete (shadow rays too).
        Result<FrameStats> first = fetched->renderFrame(in);
        ASSERT_TRUE(first.isOk()) << first.message();
        EXPECT_EQ(first->missingPixels, 0u);
        EXPECT_EQ(first->previews, 0u);
        EXPECT_EQ(first->minSamples, 1u);
        // Without it the rays find them a layer a frame; the converged images are the same.
        Result<FrameStats> firstFound = found->renderFrame(in);
        ASSERT_TRUE(firstFound.isOk()) << firstFound.message();
        EXPECT_GT(firstFound->missingPixels, 0u);
        FrameOutput a, b;
        ASSERT_TRUE(fetched->readOutput(a).isOk());
        b = renderConverged(*found, in, 1, 64);
        EXPECT_EQ(a.rgba, b.rgba);
        EXPECT_EQ(a.depth, b.depth);
        EXPECT_EQ(a.label, b.label);
    }
}

TEST(Renderer, StillRenderUnderATinyBudgetEndsWithoutHoles) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    RenderSettings st;
    st.sampleTarget = 64;
    st.shading = Shading::PathTracing;
    std::unique_ptr<Renderer> r = makeRenderer(*ctx, scene, 64ull << 20, st);
    // The first frame of a cold cache shows previews where bricks are missing, never holes.
    FrameInput in = perspectiveView({200, -80, 150}, {66, 35, 97}, {0, 0, 1}, 30, 96, 80);
    Result<FrameStats> first = r->renderFrame(in);
    ASSERT_TRUE(first.isOk()) << first.message();
    EXPECT_EQ(first->holes, 0u);
    EXPECT_EQ(first->previews, first->missingPixels);
    EXPECT_GT(first->previews, 0u);
    // A still render with no time to spare stops as soon as every pixel shows a sample (its own
    // or, at a coarser stride, its block's; a preview is not enough), far short of the target;
    // later renders go on.
    RenderRequest req;
    req.frame = perspectiveView({210, -70, 150}, {66, 35, 97}, {0, 0, 1}, 30, 96, 80);
    req.timeBudgetSeconds = 0;
    Result<RenderResult> still = r->render(req);
    ASSERT_TRUE(still.isOk()) << still.message();
    EXPECT_EQ(still->last.holes, 0u);
    EXPECT_EQ(still->last.previews, 0u);
    EXPECT_LT(still->last.minSamples, 64u);
    const uint32_t stride = still->last.stride;
    EXPECT_TRUE(stride == 1 || stride == 2 || stride == 4 || stride == 8) << stride;
    const FrameOutput& out = r->output();
    size_t shown = 0;
    for (size_t i = 0; i < out.depth.size(); ++i) shown += out.depth[i] < 1.0f;
    EXPECT_GT(shown, out.depth.size() / 4); // the volume fills the view's middle
    Result<RenderResult> more = r->render(req);
    ASSERT_TRUE(more.isOk());
    EXPECT_GE(more->last.minSamples, still->last.minSamples);
    EXPECT_LE(more->last.stride, stride); // once the image is whole, frames go on as fine or finer
}

TEST(Renderer, StillRenderDenoisesOnlyItsLastFrameAndGivesTheSameImage) {
    CSGV_REQUIRE_GPU(ctx);
    Scene& scene = fixtureScene(*ctx, "synthA_b16_nibble.csgv");
    RenderSettings st;
    st.shading = Shading::AmbientOcclusion;
    st.sampleTarget = 3;
    RenderRequest req;
    req.frame = perspectiveView({200, -80, 150}, {66, 35, 97}, {0, 0, 1}, 30, 48, 40);
    req.timeBudgetSeconds = 1e9;
    std::unique_ptr<Renderer> still = makeRenderer(*ctx, scene, 64ull << 20, st);
    Result<RenderResult> r = still->render(req);
    ASSERT_TRUE(r.isOk()) << r.message();
    ASSERT_EQ(r->last.stride, 1u);
    // Frame by frame, every frame denoised: the same last image.
    std::unique_ptr<Renderer> frames = makeRenderer(*ctx, scene, 64ull << 20, st);
    const FrameOutput byFrame = renderConverged(*frames, req.frame, 3, 64);
    EXPECT_EQ(still->output(Renderer::Color).rgba, byFrame.rgba);
}

TEST(ModeCosts, MeasuredModesAreTheirOwnAndOthersScaleByTheirRays) {
    // The one time model of the backend's strides and the representation's interactive
    // resolution (issue 39: it existed twice, each with its own fallback).
    ModeCosts costs;
    EXPECT_EQ(costs.secondsPerPixel(Shading::PathTracing), 0.0); // nothing measured
    costs.record(Shading::Local, 2.0, 1e8);                      // 2e-8 s a pixel
    EXPECT_DOUBLE_EQ(costs.secondsPerPixel(Shading::Local), 2e-8);
    EXPECT_DOUBLE_EQ(costs.secondsPerPixel(Shading::Shadow), 4e-8);      // two rays a sample
    EXPECT_DOUBLE_EQ(costs.secondsPerPixel(Shading::PathTracing), 8e-8); // about four
    costs.record(Shading::PathTracing, 1.0, 1e8);
    EXPECT_DOUBLE_EQ(costs.secondsPerPixel(Shading::PathTracing), 1e-8); // measured wins
    costs.record(Shading::PathTracing, 3.0, 1e8);
    EXPECT_DOUBLE_EQ(costs.secondsPerPixel(Shading::PathTracing), 2e-8); // a running average
    // Unmeasured modes take the dearest estimate: local's 2e-8 x 2 over path tracing's 2e-8 / 4 x 2.
    EXPECT_DOUBLE_EQ(costs.secondsPerPixel(Shading::AmbientOcclusion), 4e-8);
    EXPECT_EQ(shadingIndex(Shading(7)), 0u);
}
