// SPDX-License-Identifier: MIT
// GPU brick decoding equals CPU decoding, exactly, for every Volcanite fixture and our own files
// in every encoding and operation mask, at every level of detail; corrupted streams end with an
// error code, never a hang.
#include "GpuTestSupport.h"
#include "TestData.h"

#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/base/Morton.h"
#include "csgv/inputs/Procedural.h"
#include "csgv/gpu/DetailStream.h"
#include "csgv/gpu/GpuVolume.h"
#include "csgv/gpu/Renderer.h"

#include <algorithm>
#include <chrono>
#include <thread>

using namespace csgv;
using namespace csgv::gpu;
using namespace csgvtest;

namespace {

/// Decodes every brick at every level on the GPU and compares in-volume nodes with the CPU.
void expectGpuEqualsCpu(Context& ctx, const CompressedVolume& vol, const std::string& what, bool paletting = false,
                        DetailSeparation separation = DetailSeparation::Auto, uint64_t uploadChunk = 0) {
    GpuVolumeOptions options;
    options.cachePaletting = paletting;
    options.separateDetail = separation;
    if (uploadChunk) options.uploadChunkBytes = uploadChunk;
    Result<std::unique_ptr<GpuVolume>> gpu = GpuVolume::create(ctx, vol, options);
    ASSERT_TRUE(gpu.isOk()) << what << ": " << gpu.message();
    if (separation == DetailSeparation::Always) {
        ASSERT_TRUE((*gpu)->separated()) << what;
        EXPECT_LT((*gpu)->deviceBytes(), GpuVolume::encodingBytes(vol)) << what << ": the finest level stays on the host";
    }
    if (paletting && vol.maxPalette < 1000) {
        EXPECT_LT((*gpu)->cacheBits(), 32u) << what << ": paletting should pack";
    }
    BrickDecoder cpu(vol);
    const auto grid = vol.brickGrid();
    for (uint32_t lod = 0; lod < vol.levels(); ++lod) {
        std::vector<BrickRequest> requests;
        for (uint32_t b = 0; b < vol.brickCount(); ++b) requests.push_back({b, lod, 0});
        Result<std::vector<uint32_t>> got = (*gpu)->decodeToHost(requests);
        ASSERT_TRUE(got.isOk()) << what << " lod " << lod << ": " << got.message();
        const uint32_t edge = vol.brickSize >> lod, n = edge * edge * edge;
        const auto ldim = lodDimensions(vol.dim, lod);
        size_t mismatches = 0;
        for (size_t i = 0; i < requests.size(); ++i) {
            const uint32_t b = requests[i].brick;
            ASSERT_TRUE(cpu.decode(b, lod).isOk());
            const uint32_t o[3] = {(b % grid[0]) * edge, (b / grid[0] % grid[1]) * edge, (b / (grid[0] * grid[1])) * edge};
            for (uint32_t m = 0; m < n; ++m) {
                if (o[0] + mortonX(m) >= ldim[0] || o[1] + mortonY(m) >= ldim[1] || o[2] + mortonZ(m) >= ldim[2]) continue;
                mismatches += (*got)[i * n + m] != cpu.labels()[m];
            }
        }
        EXPECT_EQ(mismatches, 0u) << what << " lod " << lod;
    }
}

} // namespace

TEST(GpuDecode, EveryVolcaniteFixtureAtEveryLevel) {
    CSGV_REQUIRE_GPU(ctx);
    for (const std::string& name : allFixtureNames()) expectGpuEqualsCpu(*ctx, loadFixture(name), name);
}

// The encoding goes up in pieces of whole bricks (palette labels replaced by ids on the way):
// pieces of 4 KiB (a brick or a few each, the largest brick alone where it is larger), whole and
// separated, decode as the CPU does.
TEST(GpuDecode, AnUploadInSmallPiecesDecodesTheSame) {
    CSGV_REQUIRE_GPU(ctx);
    for (const std::string& name : {std::string("synthA_b32_rans2.csgv"), std::string("synthA_b16_nibble.csgv")}) {
        const CompressedVolume vol = loadFixture(name);
        expectGpuEqualsCpu(*ctx, vol, name + " (4 KiB pieces)", false, DetailSeparation::Auto, 4096);
        if (vol.encoding == kEncodingRans2)
            expectGpuEqualsCpu(*ctx, vol, name + " (4 KiB pieces, separated)", false, DetailSeparation::Always, 4096);
    }
    // A file of several arrays (a brick that begins an array begins at its word 0) whose labels
    // are stored as ids (all above 3e9).
    SynthSpec spec;
    spec.dim = {45, 38, 29};
    spec.cellSize = 6;
    LabelVolume src = *generateVolume(spec);
    for (uint32_t& l : src.labels) l += 3000000000u;
    EncodeOptions o;
    o.brickSize = 8;
    Result<CompressedVolume> one = encodeVolume(src, o);
    ASSERT_TRUE(one.isOk());
    o.maxArrayWords = uint32_t(one->arrays[0].size() / 5);
    Result<CompressedVolume> split = encodeVolume(src, o);
    ASSERT_TRUE(split.isOk()) << split.message();
    ASSERT_GE(split->arrays.size(), 5u);
    expectGpuEqualsCpu(*ctx, *split, "several arrays, ids (4 KiB pieces)", false, DetailSeparation::Auto, 4096);
    expectGpuEqualsCpu(*ctx, *split, "several arrays, ids (4 KiB pieces, separated)", false, DetailSeparation::Always, 4096);
}

TEST(GpuDecode, EveryVolcaniteFixtureAtEveryLevelWithCachePaletting) {
    CSGV_REQUIRE_GPU(ctx);
    for (const std::string& name : allFixtureNames()) expectGpuEqualsCpu(*ctx, loadFixture(name), name + " (paletted)", true);
}

// Detail separation: the device holds each brick without its finest level (the GPU decodes the
// coarser levels from that); the finest level's streams go through a detail buffer (DetailStream)
// and the GPU decodes them from there; both with and without cache paletting.
TEST(GpuDecode, SeparatedFixturesAtEveryLevel) {
    CSGV_REQUIRE_GPU(ctx);
    size_t separated = 0;
    for (const std::string& name : allFixtureNames()) {
        const CompressedVolume vol = loadFixture(name);
        if (vol.encoding != kEncodingRans2) continue;
        expectGpuEqualsCpu(*ctx, vol, name + " (separated)", false, DetailSeparation::Always);
        if (separated++ == 0) expectGpuEqualsCpu(*ctx, vol, name + " (separated, paletted)", true, DetailSeparation::Always);
    }
    EXPECT_GT(separated, 0u) << "no rANS two-table fixture";
}

TEST(DetailStream, RingEvictsTheOldestNeverThePendingBatchAndNamesOnlyCommittedStreams) {
    CSGV_REQUIRE_GPU(ctx);
    const CompressedVolume vol = loadFixture("synthA_b16_rans2_legacydelta.csgv");
    ASSERT_GE(vol.brickCount(), 8u);
    ASSERT_GT(DetailStream::streamBytes(vol), DetailStream::smallestBytes(vol)) << "the ring must be too small for all";
    // A ring of twice the longest stream: a batch takes at most half of it.
    const uint64_t capacity = DetailStream::smallestBytes(vol);
    Result<std::unique_ptr<DetailStream>> made = DetailStream::create(*ctx, vol, capacity);
    ASSERT_TRUE(made.isOk()) << made.message();
    DetailStream& d = **made;
    EXPECT_EQ(d.capacityBytes(), capacity);
    EXPECT_EQ(d.deviceBytes(), DetailStream::deviceBytes(vol, capacity));
    std::vector<uint32_t> all(size_t(vol.brickCount()));
    for (uint32_t b = 0; b < all.size(); ++b) all[b] = b;
    // Queued streams are not resident before commit (the table names them only afterwards).
    ASSERT_TRUE(d.request(all.data(), all.size()).isOk());
    for (uint32_t b : all) EXPECT_FALSE(d.resident(b)) << b;
    ASSERT_TRUE(d.commit().isOk());
    uint64_t firstBatch = 0, bytes = 0;
    for (uint32_t b : all)
        if (d.resident(b)) {
            ++firstBatch;
            bytes += DetailStream::brickBytes(vol, b);
        }
    EXPECT_GE(firstBatch, 1u);
    EXPECT_LE(bytes, capacity / 2) << "a batch takes at most half the ring";
    EXPECT_EQ(d.counts().uploadedBricks, firstBatch);
    EXPECT_EQ(d.counts().uploadedBytes, bytes);
    // Asking again for resident streams uploads nothing.
    std::vector<uint32_t> resident;
    for (uint32_t b : all)
        if (d.resident(b)) resident.push_back(b);
    ASSERT_TRUE(d.request(resident.data(), resident.size()).isOk());
    ASSERT_TRUE(d.commit().isOk());
    EXPECT_EQ(d.counts().uploadedBricks, firstBatch);
    // Streaming every brick once, in order, through the small ring evicts the oldest first.
    size_t next = resident.size();
    for (int round = 0; round < 10000 && next < all.size(); ++round) {
        ASSERT_TRUE(d.request(all.data() + next, all.size() - next).isOk());
        ASSERT_TRUE(d.commit().isOk());
        const size_t before = next;
        while (next < all.size() && d.resident(all[next])) ++next;
        for (uint32_t b : all) // every stream the table names is intact in the ring
            if (d.resident(b)) {
                const BrickWords bw = vol.brick(b);
                const uint32_t L = vol.levels(), begin = bw.words[L - 1] / 8, end = bw.size - bw.words[L];
                ASSERT_EQ(*d.readStream(b), std::vector<uint32_t>(bw.words + begin, bw.words + end)) << "brick " << b;
            }
        ASSERT_GT(next, before) << "every batch takes at least one stream";
    }
    ASSERT_EQ(next, all.size());
    EXPECT_TRUE(d.resident(all.back()));
    EXPECT_FALSE(d.resident(all.front())) << "the first upload is the oldest";
    EXPECT_GT(d.counts().evictedBricks, 0u);
    uint64_t residentBytes = 0;
    for (uint32_t b : all)
        if (d.resident(b)) residentBytes += DetailStream::brickBytes(vol, b);
    EXPECT_LE(residentBytes, capacity);
    // Too small a ring, and encodings without a stream of their own for the finest level, are refused.
    EXPECT_FALSE(DetailStream::create(*ctx, vol, capacity - 4).isOk());
    EXPECT_FALSE(DetailStream::create(*ctx, loadFixture("synthA_b16_nibble.csgv"), 1 << 20).isOk());
}

TEST(GpuVolume, WhatEachDecoderKeepsOnTheDeviceAndWhoDecides) {
    CSGV_REQUIRE_GPU(ctx);
    const CompressedVolume vol = loadFixture("synthA_b32_rans2.csgv");
    const uint64_t whole = GpuVolume::encodingBytes(vol);
    // gpuDecodingBytes is what an upload for GPU decoding takes, whole or separated.
    for (uint64_t budget : {4 * whole, 2 * whole - 1}) {
        GpuVolumeOptions o;
        o.deviceMemoryBytes = budget;
        Result<std::unique_ptr<GpuVolume>> g = GpuVolume::create(*ctx, vol, o);
        ASSERT_TRUE(g.isOk()) << g.message();
        EXPECT_EQ((*g)->separated(), budget < 2 * whole);
        EXPECT_EQ((*g)->deviceBytes(), GpuVolume::gpuDecodingBytes(vol, budget)) << budget;
    }
    // An upload for host decoding holds palettes with cache paletting, else nothing, and refuses
    // GPU decoding.
    GpuVolumeOptions host;
    host.hostDecoding = true;
    Result<std::unique_ptr<GpuVolume>> none = GpuVolume::create(*ctx, vol, host);
    ASSERT_TRUE(none.isOk()) << none.message();
    EXPECT_LE((*none)->deviceBytes(), (vol.brickCount() + 1) * 4 + 16);
    EXPECT_FALSE((*none)->decodeToHost({BrickRequest{0, 0, 0}}).isOk());
    host.cachePaletting = true;
    Result<std::unique_ptr<GpuVolume>> palettes = GpuVolume::create(*ctx, vol, host);
    ASSERT_TRUE(palettes.isOk()) << palettes.message();
    EXPECT_GT((*palettes)->deviceBytes(), (*none)->deviceBytes());
    EXPECT_LT((*palettes)->deviceBytes(), whole / 2);
    // Who decodes: Host and Gpu as asked; Auto on the host on CPU devices, or where GPU decoding's
    // encoding would take more than three quarters of the budget.
    DeviceInfo gpuDevice;
    gpuDevice.type = "discrete";
    gpuDevice.memoryBudgetBytes = 8ull << 30;
    using D = RendererOptions::Decode;
    EXPECT_FALSE(decodesOnHost(D::Auto, gpuDevice, vol, 0));
    EXPECT_FALSE(decodesOnHost(D::Auto, gpuDevice, vol, 4 * whole));
    const uint64_t tight = GpuVolume::gpuDecodingBytes(vol, whole) * 4 / 3 - 64; // separated, coarse part > 3/4
    EXPECT_TRUE(decodesOnHost(D::Auto, gpuDevice, vol, tight));
    EXPECT_FALSE(decodesOnHost(D::Gpu, gpuDevice, vol, tight));
    EXPECT_TRUE(decodesOnHost(D::Host, gpuDevice, vol, 4 * whole));
    DeviceInfo cpuDevice = gpuDevice;
    cpuDevice.type = "cpu";
    EXPECT_TRUE(decodesOnHost(D::Auto, cpuDevice, vol, 4 * whole));
}

TEST(GpuDecode, OurFilesInEveryEncodingAndMask) {
    CSGV_REQUIRE_GPU(ctx);
    SynthSpec spec;
    spec.dim = {45, 38, 29}; // no dimension a multiple of any brick size
    spec.cellSize = 6;
    const LabelVolume src = *generateVolume(spec);
    struct Case {
        int32_t encoding;
        uint32_t brick;
        const char* ops;
    };
    // Every encoding, small and large bricks (B = 64 and 128 need many resumed dispatches on
    // CPU devices), PALETTE_D, no stop bits, no neighbours; every other case with cache paletting.
    const Case cases[] = {{0, 8, "all"}, {0, 32, "pnl"}, {1, 16, "default"}, {1, 64, "s"},
                          {2, 8, "pnl"}, {2, 32, "all"}, {2, 64, "default"}, {2, 128, "all"}};
    bool paletting = false;
    for (const Case& c : cases) {
        paletting = !paletting;
        EncodeOptions o;
        o.encoding = c.encoding;
        o.brickSize = c.brick;
        o.opMask = *parseOperationMask(c.ops);
        Result<CompressedVolume> v = encodeVolume(src, o);
        ASSERT_TRUE(v.isOk());
        expectGpuEqualsCpu(*ctx, *v, std::string(encodingName(c.encoding)) + " b" + std::to_string(c.brick) + " " + c.ops +
                                         (paletting ? " paletted" : ""), paletting);
    }
}

TEST(GpuDecode, CorruptStreamsEndWithAnErrorCode) {
    CSGV_REQUIRE_GPU(ctx);
    // Nibble fixture: replace the first level-1 symbol of brick 0 (after the root) with 7.
    CompressedVolume vol = loadFixture("synthA_b16_nibble.csgv");
    const uint32_t L = vol.levels();
    uint32_t* w = vol.arrays[0].owned().data() + vol.brickStarts[0];
    const uint32_t pos = w[1]; // level 1 start (the root did not stop in this brick)
    ASSERT_GT(w[2], w[1]) << "fixture brick 0 must visit level 1";
    w[pos >> 3] = (w[pos >> 3] & ~(0xFu << (28 - 4 * (pos & 7)))) | (7u << (28 - 4 * (pos & 7)));
    Result<std::unique_ptr<GpuVolume>> gpu = GpuVolume::create(*ctx, vol);
    ASSERT_TRUE(gpu.isOk()) << gpu.message();
    Result<std::vector<uint32_t>> r = (*gpu)->decodeToHost({{0, 0, 0}, {1, 0, 0}});
    ASSERT_FALSE(r.isOk());
    EXPECT_NE(r.message().find("brick 0"), std::string::npos) << r.message();
    EXPECT_NE(r.message().find("operation symbol 7"), std::string::npos) << r.message();
    (void)L;
    // rANS: shorten stream A of brick 3 by a word; the integrity check or the stream end catches it.
    CompressedVolume rans = loadFixture("synthA_b32_rans2.csgv");
    uint32_t* rb = rans.arrays[0].owned().data() + rans.brickStarts[3];
    rb[rans.levels() - 1] -= 8;
    if (checkContainer(rans).isOk()) {
        Result<std::unique_ptr<GpuVolume>> g2 = GpuVolume::create(*ctx, rans);
        ASSERT_TRUE(g2.isOk());
        Result<std::vector<uint32_t>> r2 = (*g2)->decodeToHost({{3, 0, 0}});
        ASSERT_FALSE(r2.isOk());
        EXPECT_NE(r2.message().find("brick 3"), std::string::npos) << r2.message();
    }
    // Requests outside the volume or the cache are refused on the host.
    EXPECT_FALSE((*gpu)->decodeToHost({{uint32_t(vol.brickCount()), 0, 0}}).isOk());
    EXPECT_FALSE((*gpu)->decodeToHost({{0, L, 0}}).isOk());
}

TEST(GpuDecode, ATimeoutLeavesAClearErrorAndNoCrash) {
    CSGV_REQUIRE_GPU(shared);
    Result<std::unique_ptr<Context>> ctx = Context::create();
    ASSERT_TRUE(ctx.isOk()) << ctx.message();
    const CompressedVolume vol = loadFixture("synthA_b32_rans2.csgv");
    Result<std::unique_ptr<GpuVolume>> gpu = GpuVolume::create(**ctx, vol);
    ASSERT_TRUE(gpu.isOk()) << gpu.message();
    std::vector<BrickRequest> all;
    for (uint32_t b = 0; b < vol.brickCount(); ++b) all.push_back({b, 0, 0});
    (*ctx)->setSubmitTimeout(1e-6); // far less than the decode takes
    Result<std::vector<uint32_t>> r = (*gpu)->decodeToHost(all);
    if (r.isOk()) GTEST_SKIP() << "the device finished within a microsecond";
    EXPECT_NE(r.message().find("did not finish"), std::string::npos) << r.message();
    EXPECT_TRUE((*ctx)->lost());
    Result<Buffer> b = (*ctx)->createBuffer(64, MemoryKind::HostVisible);
    ASSERT_FALSE(b.isOk());
    EXPECT_NE(b.message().find("stopped responding"), std::string::npos) << b.message();
    EXPECT_FALSE((*gpu)->decodeToHost({{0, 5, 0}}).isOk());
    // Destroying everything now must not crash; give the device time to finish its queue first,
    // as nothing it might use is freed.
    gpu->reset();
    ctx->reset();
    std::this_thread::sleep_for(std::chrono::seconds(3));
}
