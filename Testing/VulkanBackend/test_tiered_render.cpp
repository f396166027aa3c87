// SPDX-License-Identifier: MIT
// Rendering under a host-memory budget (issue 40: TieredVolume): a mapped encoding whose coarse
// levels are resident, or whose every level is read from the file, renders the same first-hit
// labels and converged image as the whole encoding, by GPU decoding (detail streaming from the
// file) and by host decoding; a corrupt brick deep in the file and a file cut short under its
// mapping are named when reached while the rest renders.
#include "GpuTestSupport.h"
#include "RenderTestSupport.h"
#include "TestData.h"

#include "csgv/base/MappedFile.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/TieredVolume.h"
#include "csgv/gpu/GpuVolume.h"
#include "csgv/gpu/Renderer.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <functional>
#include <cstdlib>
#include <unistd.h>

using namespace csgv;
using namespace csgv::gpu;
using namespace csgvtest;

namespace {

constexpr const char* kFixture = "synthA_b32_rans2.csgv";

FrameInput view() { return perspectiveView({300, 260, 380}, {66, 35, 97}, {0, 0, 1}, 35, 64, 48); }

/// A renderer of `volume` (with `tiers` when given) rendered until 2 samples a pixel.
FrameOutput render(Context& ctx, const CompressedVolume& volume, std::shared_ptr<const TieredVolume> tiers,
                   RendererOptions::Decode decode, Renderer** keep = nullptr, std::unique_ptr<Renderer>* owner = nullptr,
                   const std::function<void()>& beforeFrames = {}) {
    GpuVolumeOptions go;
    go.tiers = tiers;
    go.hostDecoding = decode == RendererOptions::Decode::Host;
    Result<std::unique_ptr<GpuVolume>> g = GpuVolume::create(ctx, volume, go);
    EXPECT_TRUE(g.isOk()) << g.message();
    if (!g) return {};
    RendererOptions ro;
    ro.decode = decode;
    ro.cacheBytes = 16ull << 20;
    ro.prefetchVoxels = 0;
    Result<std::unique_ptr<Renderer>> r = Renderer::create(ctx, std::shared_ptr<GpuVolume>(std::move(*g)), ro);
    EXPECT_TRUE(r.isOk()) << r.message();
    if (!r) return {};
    RenderSettings st;
    st.finest = true;
    st.denoise = false;
    st.sampleTarget = 2;
    (*r)->setSettings(st);
    if (beforeFrames) beforeFrames();
    for (int f = 0; f < 200; ++f) {
        Result<FrameStats> s = (*r)->renderFrame(view());
        EXPECT_TRUE(s.isOk()) << s.message();
        if (!s || s->minSamples >= 2) break;
    }
    FrameOutput out;
    EXPECT_TRUE((*r)->readOutput(out).isOk());
    if (keep) *keep = r->get();
    if (owner) *owner = std::move(*r);
    return out;
}

std::shared_ptr<const CompressedVolume> mapped(const std::string& path, const std::vector<uint8_t>& bytes) {
    writeBytes(path, bytes);
    Result<CompressedVolume> v = readCsgvMapped(path);
    EXPECT_TRUE(v.isOk()) << v.message();
    return v ? std::make_shared<const CompressedVolume>(std::move(*v)) : nullptr;
}

std::shared_ptr<const TieredVolume> tiersOf(std::shared_ptr<const CompressedVolume> full, uint64_t budget) {
    TieredVolume::Options o;
    o.budgetBytes = budget;
    Result<std::shared_ptr<const TieredVolume>> t = TieredVolume::create(full, o);
    EXPECT_TRUE(t.isOk()) << t.message();
    return t ? *t : nullptr;
}

/// The byte offset in a `.csgv` of brick b's word w (one encoding array).
size_t wordOffset(const CompressedVolume& v, const std::vector<uint8_t>& file, uint64_t b, uint32_t w) {
    const size_t arrayStart = file.size() - 1 - 4 * v.arrays[0].size(); // the detail byte ends the file
    return arrayStart + 4 * (size_t(v.brickStarts[size_t(b)]) + w);
}

} // namespace

TEST(Tiered, EveryBudgetRendersTheWholeEncodingsLabelsAndImage) {
    CSGV_REQUIRE_GPU(ctx);
    const CompressedVolume whole = loadFixture(kFixture);
    std::shared_ptr<const CompressedVolume> full = mapped(tempDir() + "/tiered-render.csgv", fixtureBytes(kFixture));
    ASSERT_TRUE(full);
    for (RendererOptions::Decode decode : {RendererOptions::Decode::Gpu, RendererOptions::Decode::Host}) {
        const char* what = decode == RendererOptions::Decode::Gpu ? "GPU decoding" : "host decoding";
        const FrameOutput want = render(*ctx, whole, nullptr, decode);
        ASSERT_FALSE(want.label.empty());
        size_t hits = 0;
        for (uint32_t l : want.label) hits += l != kNone && l != 0 ? 1 : 0;
        EXPECT_GT(hits, want.label.size() / 8) << "the volume is in view";
        for (uint64_t budget : {uint64_t(0), uint64_t(64)}) { // coarse levels resident; none
            std::shared_ptr<const TieredVolume> tiers = tiersOf(full, budget);
            ASSERT_TRUE(tiers);
            EXPECT_EQ(tiers->hasCoarseTier(), budget == 0);
            const FrameOutput got = render(*ctx, tiers->coarse(), tiers, decode);
            EXPECT_EQ(got.label, want.label) << what << ", budget " << budget;
            EXPECT_EQ(got.rgba, want.rgba) << what << ", budget " << budget;
            EXPECT_GT(tiers->counts().fileBricks, 0u) << what << ": the finest level came from the file";
        }
    }
}

TEST(Tiered, ACorruptBrickDeepInTheFileIsNamedAndTheRestRenders) {
    CSGV_REQUIRE_GPU(ctx);
    const CompressedVolume whole = loadFixture(kFixture);
    const uint32_t L = whole.levels();
    // The bricks of the top layer the camera sees (brick grid 5 x 3 x 7: z 6, x 3 and 4), the
    // deepest in the file: their finest streams overwritten (fails at once), or one word of each
    // in the middle of it flipped (typically decodes to the end, then fails the rANS integrity
    // check: a failed decode must not show what it wrote).
    for (bool flip : {false, true}) {
    std::vector<uint8_t> bytes = fixtureBytes(kFixture);
    for (uint64_t b : {3 + 5 * (0 + 3 * 6), 4 + 5 * (0 + 3 * 6), 3 + 5 * (1 + 3 * 6), 4 + 5 * (1 + 3 * 6), 3 + 5 * (2 + 3 * 6), 4 + 5 * (2 + 3 * 6)}) {
        const BrickWords bw = whole.brick(b);
        const uint32_t from = bw.words[L - 1] / 8, to = bw.size - bw.words[L];
        for (uint32_t w = flip ? (from + to) / 2 : from; w < (flip ? (from + to) / 2 + 1 : to); ++w)
            for (int k = 0; k < 4; ++k) bytes[wordOffset(whole, bytes, b, w) + size_t(k)] ^= flip ? 0x5A : 0xFF;
    }
    std::shared_ptr<const CompressedVolume> full = mapped(tempDir() + "/tiered-corrupt.csgv", bytes);
    ASSERT_TRUE(full);
    // Host decoding names the failed bricks; GPU decoding too (decode_bricks.comp counts them in
    // its dispatches' parameters) and draws them empty, whole or in tiers.
    const std::vector<uint32_t> labels = summarizePalettes(whole, kSummaryLabels).labels;
    std::vector<uint32_t> hostLabels[2]; // by tiered: GPU decoding must draw the same (failed bricks empty)
    for (RendererOptions::Decode decode : {RendererOptions::Decode::Host, RendererOptions::Decode::Gpu}) {
        const bool gpu = decode == RendererOptions::Decode::Gpu;
        const FrameOutput want = render(*ctx, whole, nullptr, decode);
        for (bool tiered : {true, false}) {
            std::shared_ptr<const TieredVolume> tiers = tiered ? tiersOf(full, 64) : nullptr;
            Renderer* r = nullptr;
            std::unique_ptr<Renderer> owner;
            const FrameOutput got = render(*ctx, tiers ? tiers->coarse() : *full, tiers, decode, &r, &owner);
            const std::string what = std::string(flip ? "a word flipped, " : "streams overwritten, ") +
                                     (gpu ? "GPU" : "host") + " decoding, " + (tiered ? "tiers" : "whole");
            ASSERT_TRUE(r) << what;
            EXPECT_GE(r->badBricks(), 1u) << what;
            EXPECT_NE(r->firstBadBrick().find(gpu ? ", GPU decode: " : "brick "), std::string::npos) << what << ": " << r->firstBadBrick();
            ASSERT_EQ(got.label.size(), want.label.size());
            size_t same = 0, differ = 0, foreign = 0;
            for (size_t i = 0; i < got.label.size(); ++i) {
                (got.label[i] == want.label[i] ? same : differ)++;
                foreign += got.label[i] != kNone && !std::binary_search(labels.begin(), labels.end(), got.label[i]) ? 1 : 0;
            }
            EXPECT_GT(differ, 0u) << what << ": the bad brick was in view";
            EXPECT_GT(same, 4 * differ) << what << ": the rest renders";
            EXPECT_EQ(foreign, 0u) << what << ": what shows is the volume's labels";
            if (!gpu) hostLabels[tiered] = got.label;
            else EXPECT_EQ(got.label, hostLabels[tiered]) << what << ": the failed bricks drawn empty, as host decoding draws them";
        }
    }
    }
}

TEST(Tiered, BricksWithWrongHeadersOpenAreNamedAndDrawnEmpty) {
    // Opening checks the layout only (O(header + brick starts)): bricks whose header words are
    // wrong (here their palette sizes) are found when the volume is uploaded, never decoded (the
    // GPU decoder trusts a brick's header), counted as bad bricks and drawn empty, whole or in
    // tiers, by GPU and by host decoding, while every other brick renders.
    CSGV_REQUIRE_GPU(ctx);
    const CompressedVolume whole = loadFixture(kFixture);
    std::vector<uint8_t> bytes = fixtureBytes(kFixture);
    const uint32_t L = whole.levels();
    const std::vector<uint64_t> bad = {3 + 5 * (0 + 3 * 6), 4 + 5 * (1 + 3 * 6), 3 + 5 * (2 + 3 * 6)};
    for (uint64_t b : bad) {
        const uint32_t wrong = whole.maxPalette + 7;
        std::memcpy(&bytes[wordOffset(whole, bytes, b, L)], &wrong, 4);
    }
    std::shared_ptr<const CompressedVolume> full = mapped(tempDir() + "/tiered-bad-headers.csgv", bytes);
    ASSERT_TRUE(full) << "a bad brick header does not stop the file opening";
    EXPECT_EQ(summarizePalettes(*full, 0).unsound, bad);
    for (RendererOptions::Decode decode : {RendererOptions::Decode::Gpu, RendererOptions::Decode::Host}) {
        const char* what = decode == RendererOptions::Decode::Gpu ? "GPU decoding" : "host decoding";
        const FrameOutput want = render(*ctx, whole, nullptr, decode);
        for (int budget : {-1, 0, 64}) { // whole; coarse levels resident; every level from the file
            std::shared_ptr<const TieredVolume> tiers = budget < 0 ? nullptr : tiersOf(full, uint64_t(budget));
            Renderer* r = nullptr;
            std::unique_ptr<Renderer> owner;
            const FrameOutput got = render(*ctx, tiers ? tiers->coarse() : *full, tiers, decode, &r, &owner);
            ASSERT_TRUE(r) << what << ", budget " << budget;
            EXPECT_EQ(r->badBricks(), bad.size()) << what << ", budget " << budget;
            EXPECT_NE(r->firstBadBrick().find("brick " + std::to_string(bad[0]) + ": palette size"), std::string::npos)
                << r->firstBadBrick();
            ASSERT_EQ(got.label.size(), want.label.size());
            size_t same = 0, differ = 0;
            for (size_t i = 0; i < got.label.size(); ++i) (got.label[i] == want.label[i] ? same : differ)++;
            EXPECT_GT(differ, 0u) << what << ", budget " << budget << ": the bad bricks were in view";
            EXPECT_GT(same, 4 * differ) << what << ", budget " << budget << ": the rest renders";
        }
    }
}

TEST(Tiered, AFileCutShortUnderItsMappingIsNamedNotACrash) {
    CSGV_REQUIRE_GPU(ctx);
    const std::string path = tempDir() + "/tiered-cut.csgv";
    const std::vector<uint8_t> bytes = fixtureBytes(kFixture);
    std::shared_ptr<const CompressedVolume> full = mapped(path, bytes);
    ASSERT_TRUE(full);
    std::shared_ptr<const TieredVolume> tiers = tiersOf(full, 64); // every level from the file
    Renderer* r = nullptr;
    std::unique_ptr<Renderer> owner;
    // Cut short once the renderer holds the palettes, before any brick is decoded.
    render(*ctx, tiers->coarse(), tiers, RendererOptions::Decode::Host, &r, &owner,
           [&] { ASSERT_EQ(::truncate(path.c_str(), off_t(bytes.size() / 3)), 0); });
    ASSERT_TRUE(r);
    EXPECT_GE(r->badBricks(), 1u);
    EXPECT_NE(r->firstBadBrick().find("the file changed on disk while it was open"), std::string::npos) << r->firstBadBrick();
}

TEST(Tiered, AFileCutShortBeforeItsUploadIsRefusedClearly) {
    CSGV_REQUIRE_GPU(ctx);
    const std::string path = tempDir() + "/tiered-cut-early.csgv";
    const std::vector<uint8_t> bytes = fixtureBytes(kFixture);
    std::shared_ptr<const CompressedVolume> full = mapped(path, bytes);
    ASSERT_TRUE(full);
    std::shared_ptr<const TieredVolume> tiers = tiersOf(full, 64);
    ASSERT_EQ(::truncate(path.c_str(), off_t(bytes.size() / 3)), 0);
    GpuVolumeOptions go;
    go.tiers = tiers;
    go.hostDecoding = true;
    Result<std::unique_ptr<GpuVolume>> g = GpuVolume::create(*ctx, tiers->coarse(), go);
    ASSERT_FALSE(g.isOk());
    EXPECT_NE(g.message().find("changed on disk"), std::string::npos) << g.message();
}
