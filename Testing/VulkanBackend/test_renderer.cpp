// SPDX-License-Identifier: MIT
// The frame pipeline and ray marcher: the GPU G-buffer at the finest level equals the float CPU
// mirror of the stable DDA exactly (labels, faces) and within 1e-4 (depth, distance); cache
// pressure and subsampling converge to the same image; shading modes match baselines.
#include "GpuTestSupport.h"
#include "RenderTestSupport.h"
#include "TestData.h"

#include "csgv/Decoder.h"
#include "csgv/RayCast.h"
#include "csgv/gpu/Renderer.h"

#include <cmath>

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

void expectGBufferEqualsReference(Context& ctx, const std::string& fixtureName, const FrameInput& in, const Geometry& g,
                                  const std::string& what) {
    Scene& scene = fixtureScene(ctx, fixtureName);
    Result<std::unique_ptr<Renderer>> r = Renderer::create(ctx, scene.gpu);
    ASSERT_TRUE(r.isOk()) << r.message();
    (*r)->setGeometry(g);
    RenderSettings st;
    st.finest = true;
    st.jitter = false;
    st.denoise = false;
    (*r)->setSettings(st);
    const FrameOutput out = renderConverged(**r, in, 1, 64);
    RayCastView view{in.worldToClip, in.width, in.height};
    const GBuffer ref = castRaysStable(scene.labels, g, view, [](uint32_t l) { return l != 0 && l != kInvalidLabel; },
                                       scene.volume.brickSize);
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
    EXPECT_GT(hits, ref.label.size() / 10) << what << ": the view should show the volume";
    EXPECT_LT(hits, ref.label.size()) << what << ": the view should show some background";
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

TEST(Renderer, GBufferEqualsStableReferenceCameraInside) {
    CSGV_REQUIRE_GPU(ctx);
    const FrameInput in = perspectiveView({30.3, 35.7, 20.2}, {80, 70, 60}, {0, 0, 1}, 70, 64, 64);
    expectGBufferEqualsReference(*ctx, "synthA_b8_nibble_delta.csgv", in, Geometry{}, "inside");
}
