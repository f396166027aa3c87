// SPDX-License-Identifier: MIT
// The headless context and the run-time shader compiler.
#include "GpuTestSupport.h"

#include "csgv/gpu/ShaderCompiler.h"
#include "TestData.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <cstdlib>

using namespace csgv;
using namespace csgv::gpu;

TEST(GpuContext, ListsDevicesAndOpensOne) {
    CSGV_REQUIRE_GPU(ctx);
    Result<std::vector<DeviceInfo>> devices = Context::listDevices();
    ASSERT_TRUE(devices.isOk()) << devices.message();
    ASSERT_FALSE(devices->empty());
    EXPECT_FALSE(ctx->device().name.empty());
    EXPECT_TRUE(ctx->device().missing.empty());
    EXPECT_GT(ctx->device().maxAllocation, 0u);
    std::printf("device: %s (%s), subgroup %u\n", ctx->device().name.c_str(), ctx->device().type.c_str(),
                ctx->device().subgroupSize);
}

// The automatic budgets: a CPU device's cache stays at 256 MiB whatever its host memory; a GPU's
// is a quarter of what it reports this process may use, split among the ranks of an MPI job,
// between 256 MiB and 2 GiB.
TEST(GpuContext, AutomaticCacheFollowsTheDevice) {
    DeviceInfo d;
    d.type = "cpu";
    d.memoryBudgetBytes = 100ull << 30;
    EXPECT_EQ(automaticCacheBytes(d), 256ull << 20);
    EXPECT_EQ(automaticCacheBytes(d, 4), 256ull << 20);
    d.type = "discrete";
    EXPECT_EQ(automaticCacheBytes(d), 2048ull << 20);
    EXPECT_EQ(automaticCacheBytes(d, 8), 2048ull << 20);  // 100 GiB / 4 / 8: still the most
    EXPECT_EQ(automaticCacheBytes(d, 40), 640ull << 20);  // ranks that may share the device
    d.memoryBudgetBytes = 4ull << 30;
    EXPECT_EQ(automaticCacheBytes(d), 1024ull << 20);
    EXPECT_EQ(automaticCacheBytes(d, 2), 512ull << 20);
    EXPECT_EQ(automaticCacheBytes(d, 8), 256ull << 20); // never below 256 MiB
    d.type = "integrated";
    d.memoryBudgetBytes = 512ull << 20;
    EXPECT_EQ(automaticCacheBytes(d), 256ull << 20);
    EXPECT_EQ(automaticDeviceMemoryBudget(d), 384ull << 20);
}

TEST(GpuContext, DeviceOverrideThatMatchesNothingIsAClearError) {
    CSGV_REQUIRE_GPU(ctx);
    setenv("CSGV_VULKAN_DEVICE", "no-such-device-xyz", 1);
    Result<std::unique_ptr<Context>> r = Context::create();
    unsetenv("CSGV_VULKAN_DEVICE");
    ASSERT_FALSE(r.isOk());
    EXPECT_NE(r.message().find("no-such-device-xyz"), std::string::npos) << r.message();
    EXPECT_NE(r.message().find(ctx->device().name), std::string::npos) << r.message(); // lists what exists
    setenv("CSGV_VULKAN_DEVICE", std::to_string(ctx->device().index).c_str(), 1);
    Result<std::unique_ptr<Context>> byIndex = Context::create();
    unsetenv("CSGV_VULKAN_DEVICE");
    ASSERT_TRUE(byIndex.isOk()) << byIndex.message();
    EXPECT_EQ((*byIndex)->device().name, ctx->device().name);
}

TEST(GpuContext, BuffersRoundTripThroughBothMemoryKinds) {
    CSGV_REQUIRE_GPU(ctx);
    std::vector<uint32_t> data(100000);
    for (size_t i = 0; i < data.size(); ++i) data[i] = uint32_t(i * 2654435761u);
    for (MemoryKind kind : {MemoryKind::DeviceLocal, MemoryKind::HostVisible}) {
        Result<Buffer> b = ctx->createBuffer(data.size() * 4, kind);
        ASSERT_TRUE(b.isOk()) << b.message();
        EXPECT_NE(b->address(), 0u);
        ASSERT_TRUE(ctx->upload(*b, 0, data.data(), data.size() * 4).isOk());
        std::vector<uint32_t> back(data.size() - 10);
        ASSERT_TRUE(ctx->download(*b, 40, back.data(), back.size() * 4).isOk());
        EXPECT_TRUE(std::equal(back.begin(), back.end(), data.begin() + 10));
        EXPECT_FALSE(ctx->upload(*b, 8, data.data(), data.size() * 4).isOk()); // past the end
    }
    EXPECT_FALSE(ctx->createBuffer(uint64_t(1) << 50, MemoryKind::DeviceLocal).isOk());
}

/// The VmFlags line of /proc/self/smaps for the mapping that holds `address` ("" if none).
static std::string mappingFlags(uintptr_t address) {
    FILE* f = std::fopen("/proc/self/smaps", "r");
    if (!f) return "";
    char line[512];
    bool inside = false;
    std::string flags;
    while (std::fgets(line, sizeof line, f)) {
        unsigned long from = 0, to = 0;
        if (std::sscanf(line, "%lx-%lx ", &from, &to) == 2 && std::strchr(line, '-') < std::strchr(line, ' ')) {
            inside = address >= from && address < to;
        } else if (inside && std::strncmp(line, "VmFlags:", 8) == 0) {
            flags = line + 8;
            break;
        }
    }
    std::fclose(f);
    return flags;
}

// A CPU device's buffers of 1 MiB and more are in 2 MiB pages (their first writes fault 512
// times less often: a new cache's first bricks, a new image size's buffers): lavapipe's are our
// own memory, imported, whole (from their first byte); smaller ones are not, and the contents
// are the same either way.
TEST(GpuContext, CpuDeviceBuffersAskForHugePages) {
    CSGV_REQUIRE_GPU(ctx);
    if (ctx->device().type != "cpu") GTEST_SKIP() << "not a CPU device: its memory is the driver's";
    if (FILE* thp = std::fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r")) std::fclose(thp);
    else GTEST_SKIP() << "this kernel has no transparent huge pages";
    if (const char* env = std::getenv("CSGV_HUGE_PAGES"); env && std::strcmp(env, "0") == 0)
        GTEST_SKIP() << "CSGV_HUGE_PAGES=0";
    const bool imports = ctx->device().name.find("llvmpipe") != std::string::npos; // VK_EXT_external_memory_host
    constexpr uintptr_t kHuge = uintptr_t(2) << 20;
    for (MemoryKind kind : {MemoryKind::DeviceLocal, MemoryKind::HostVisible}) {
        for (uint64_t bytes : {uint64_t(9) << 20, uint64_t(1) << 20, uint64_t(3700) << 10}) {
            SCOPED_TRACE(bytes);
            Result<Buffer> big = ctx->createBuffer(bytes, kind);
            ASSERT_TRUE(big.isOk()) << big.message();
            ASSERT_NE(big->mapped(), nullptr); // a CPU device's memory is the host's
            const uintptr_t at = reinterpret_cast<uintptr_t>(big->mapped());
            const uintptr_t interior = (at + kHuge - 1) & ~(kHuge - 1);
            if (imports) {
                EXPECT_EQ(at % kHuge, 0u);
                EXPECT_NE(mappingFlags(at).find(" hg"), std::string::npos) << mappingFlags(at);
                EXPECT_NE(mappingFlags(at + bytes - 1).find(" hg"), std::string::npos) << mappingFlags(at + bytes - 1);
            } else if (interior + kHuge <= at + bytes) {
                EXPECT_NE(mappingFlags(interior).find(" hg"), std::string::npos) << mappingFlags(interior);
            }
            std::vector<uint32_t> data(big->size() / 4);
            for (size_t i = 0; i < data.size(); ++i) data[i] = uint32_t(i * 2654435761u);
            ASSERT_TRUE(ctx->upload(*big, 0, data.data(), data.size() * 4).isOk());
            std::vector<uint32_t> back(data.size());
            ASSERT_TRUE(ctx->download(*big, 0, back.data(), back.size() * 4).isOk());
            EXPECT_EQ(back, data);
        }
        Result<Buffer> small = ctx->createBuffer(512u << 10, kind);
        ASSERT_TRUE(small.isOk()) << small.message();
        const uintptr_t s = reinterpret_cast<uintptr_t>(small->mapped());
        EXPECT_EQ(mappingFlags(s + small->size() / 2).find(" hg"), std::string::npos) << mappingFlags(s);
    }
}

// A fill writes its range of words alone; one past the end or not word-aligned is refused,
// naming why, and writes nothing.
TEST(GpuContext, FillsWriteTheirRangeAndRefuseOthers) {
    CSGV_REQUIRE_GPU(ctx);
    Result<Buffer> b = ctx->createBuffer(64 * 4, MemoryKind::HostVisible);
    ASSERT_TRUE(b.isOk()) << b.message();
    std::vector<uint32_t> zero(64, 0u);
    ASSERT_TRUE(ctx->upload(*b, 0, zero.data(), zero.size() * 4).isOk());
    Context::Dispatch d;
    d.fill = &*b;
    d.fillOffset = 16 * 4;
    d.fillBytes = 8 * 4;
    d.fillValue = 0x3F800000u;
    ASSERT_TRUE(ctx->run(&d, 1).isOk());
    std::vector<uint32_t> back(64);
    ASSERT_TRUE(ctx->download(*b, 0, back.data(), back.size() * 4).isOk());
    for (uint32_t i = 0; i < 64; ++i) EXPECT_EQ(back[i], i >= 16 && i < 24 ? 0x3F800000u : 0u) << i;
    d.fillValue = 7u;
    d.fillOffset = 60 * 4; // 8 words from word 60 of 64
    Status s = ctx->run(&d, 1);
    EXPECT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("past its buffer's end"), std::string::npos) << s.message();
    d.fillOffset = 2; // not a word
    s = ctx->run(&d, 1);
    EXPECT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("32-bit words"), std::string::npos) << s.message();
    d.fillOffset = ~uint64_t(0) - 3; // offset + bytes would wrap around
    EXPECT_FALSE(ctx->run(&d, 1).isOk());
    ASSERT_TRUE(ctx->download(*b, 0, back.data(), back.size() * 4).isOk());
    for (uint32_t i = 0; i < 64; ++i) EXPECT_NE(back[i], 7u) << i;
}

// A copy (Context::copy, a copy dispatch's regions) writes its ranges alone; a region past either
// buffer's end, wrapping around or empty is refused, naming the bytes and offsets, and copies nothing.
TEST(GpuContext, CopiesWriteTheirRegionsAndRefuseOthers) {
    CSGV_REQUIRE_GPU(ctx);
    Result<Buffer> src = ctx->createBuffer(64 * 4, MemoryKind::DeviceLocal);
    Result<Buffer> dst = ctx->createBuffer(32 * 4, MemoryKind::HostVisible);
    ASSERT_TRUE(src.isOk() && dst.isOk());
    std::vector<uint32_t> words(64), zero(32, 0u), back(32);
    for (uint32_t i = 0; i < 64; ++i) words[i] = 1000u + i;
    ASSERT_TRUE(ctx->upload(*src, 0, words.data(), words.size() * 4).isOk());
    ASSERT_TRUE(ctx->upload(*dst, 0, zero.data(), zero.size() * 4).isOk());
    ASSERT_TRUE(ctx->copy(*src, 40 * 4, *dst, 4 * 4, 8 * 4).isOk()); // words 40..47 to 4..11
    const Context::CopyRegion regions[] = {{0, 20 * 4, 4}, {63 * 4, 31 * 4, 4}};
    Context::Dispatch d;
    d.copyFrom = &*src;
    d.copyTo = &*dst;
    d.copyRegions = regions;
    d.copyRegionCount = 2;
    ASSERT_TRUE(ctx->run(&d, 1).isOk());
    ASSERT_TRUE(ctx->download(*dst, 0, back.data(), back.size() * 4).isOk());
    for (uint32_t i = 0; i < 32; ++i)
        EXPECT_EQ(back[i], i >= 4 && i < 12 ? 1036u + i : i == 20 ? 1000u : i == 31 ? 1063u : 0u) << i;
    ASSERT_TRUE(ctx->upload(*dst, 0, zero.data(), zero.size() * 4).isOk());
    Status s = ctx->copy(*src, 0, *dst, 30 * 4, 4 * 4); // two words past the end of dst
    EXPECT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("past the end"), std::string::npos) << s.message();
    EXPECT_FALSE(ctx->copy(*src, ~uint64_t(0) - 3, *dst, 0, 8).isOk()); // wraps around
    const Context::CopyRegion empty{0, 0, 0};
    d.copyRegions = &empty;
    d.copyRegionCount = 1;
    EXPECT_FALSE(ctx->run(&d, 1).isOk());
    ASSERT_TRUE(ctx->download(*dst, 0, back.data(), back.size() * 4).isOk());
    EXPECT_EQ(back, zero);
}

TEST(GpuContext, APipelineIsMadeOncePerShaderEvenFromTwoThreads) {
    CSGV_REQUIRE_GPU(ctx);
    const std::string src = "#version 460\n#extension GL_EXT_buffer_reference : require\n"
                            "#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require\n"
                            "layout(local_size_x = 1) in;\n"
                            "layout(buffer_reference, std430) buffer Out { uint w[]; };\n"
                            "layout(push_constant) uniform Push { uint64_t out_; } pc;\n"
                            "void main() { Out(pc.out_).w[0] = VALUE; }\n";
    Result<std::vector<uint32_t>> three = compileComputeSource("memo.comp", src, {{"VALUE", "3u"}});
    Result<std::vector<uint32_t>> four = compileComputeSource("memo.comp", src, {{"VALUE", "4u"}});
    ASSERT_TRUE(three.isOk() && four.isOk()) << three.message() << four.message();
    // Made on two threads at once, then again: one pipeline for the same SPIR-V and push size.
    Result<uint64_t> a = Status::error("not made"), b = Status::error("not made");
    std::thread other([&] { a = ctx->createComputePipeline(*three, 8); });
    b = ctx->createComputePipeline(*three, 8);
    other.join();
    ASSERT_TRUE(a.isOk() && b.isOk()) << a.message() << b.message();
    EXPECT_EQ(*a, *b);
    Result<uint64_t> again = ctx->createComputePipeline(*three, 8);
    ASSERT_TRUE(again.isOk());
    EXPECT_EQ(*again, *a);
    // Other SPIR-V, or another push size, is another pipeline.
    Result<uint64_t> other4 = ctx->createComputePipeline(*four, 8), push16 = ctx->createComputePipeline(*three, 16);
    ASSERT_TRUE(other4.isOk() && push16.isOk());
    EXPECT_NE(*other4, *a);
    EXPECT_NE(*push16, *a);
    // Each does what its SPIR-V says.
    Result<Buffer> out = ctx->createBuffer(4, MemoryKind::HostVisible);
    ASSERT_TRUE(out.isOk());
    const uint64_t push = out->address();
    for (const auto& [pipeline, value] : {std::pair<uint64_t, uint32_t>{*a, 3u}, {*other4, 4u}}) {
        Context::Dispatch d;
        d.pipeline = pipeline;
        d.pushConstants = &push;
        d.pushConstantBytes = 8;
        ASSERT_TRUE(ctx->run({d}).isOk());
        uint32_t got = 0;
        ASSERT_TRUE(ctx->download(*out, 0, &got, 4).isOk());
        EXPECT_EQ(got, value);
    }
}

// Texel sets: a pipeline with two texel bindings reads both buffers' words where they are; a
// dispatch without the set its pipeline binds (or with one of another count) is refused.
TEST(GpuContext, TexelSetsFeedTheirBindingsAndMustMatchThePipeline) {
    CSGV_REQUIRE_GPU(ctx);
    EXPECT_GT(ctx->device().maxTexelBufferElements, 65536u);
    const std::string src = "#version 460\n#extension GL_EXT_buffer_reference : require\n"
                            "#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require\n"
                            "layout(local_size_x = 64) in;\n"
                            "layout(set = 0, binding = 0) uniform usamplerBuffer a;\n"
                            "layout(set = 0, binding = 1) uniform usamplerBuffer b;\n"
                            "layout(buffer_reference, std430) buffer Out { uint w[]; };\n"
                            "layout(push_constant) uniform Push { uint64_t out_; } pc;\n"
                            "void main() {\n"
                            "    const uint i = gl_GlobalInvocationID.x;\n"
                            "    Out(pc.out_).w[i] = texelFetch(a, int(i)).x * 1000u + texelFetch(b, int(1023u - i)).x;\n"
                            "}\n";
    Result<std::vector<uint32_t>> spirv = compileComputeSource("texels.comp", src, {});
    ASSERT_TRUE(spirv.isOk()) << spirv.message();
    Result<uint64_t> pipeline = ctx->createComputePipeline(*spirv, 8, 2);
    ASSERT_TRUE(pipeline.isOk()) << pipeline.message();
    std::vector<uint32_t> av(1024), bv(1024);
    for (uint32_t i = 0; i < 1024; ++i) {
        av[i] = i * 7u % 1000u;
        bv[i] = i * 13u % 1000u;
    }
    Result<Buffer> a = ctx->createBuffer(av.size() * 4, MemoryKind::DeviceLocal);
    Result<Buffer> b = ctx->createBuffer(bv.size() * 4, MemoryKind::HostVisible);
    Result<Buffer> out = ctx->createBuffer(1024 * 4, MemoryKind::HostVisible);
    ASSERT_TRUE(a.isOk() && b.isOk() && out.isOk());
    ASSERT_TRUE(ctx->upload(*a, 0, av.data(), av.size() * 4).isOk());
    ASSERT_TRUE(ctx->upload(*b, 0, bv.data(), bv.size() * 4).isOk());
    // Serials tell buffers apart (a new buffer may take a freed one's address) and move with them.
    EXPECT_NE(a->serial(), 0u);
    EXPECT_NE(a->serial(), b->serial());
    Buffer moved = std::move(*out);
    EXPECT_EQ(out->serial(), 0u);
    *out = std::move(moved);
    EXPECT_NE(out->serial(), 0u);
    EXPECT_NE(out->serial(), b->serial());
    Result<TexelSet> set = ctx->createTexelSet({&*a, &*b});
    ASSERT_TRUE(set.isOk()) << set.message();
    EXPECT_EQ(set->bindings(), 2u);
    const uint64_t push = out->address();
    Context::Dispatch d;
    d.pipeline = *pipeline;
    d.pushConstants = &push;
    d.pushConstantBytes = 8;
    d.groups[0] = 1024 / 64;
    d.texels = &*set;
    ASSERT_TRUE(ctx->run({d}).isOk());
    std::vector<uint32_t> got(1024);
    ASSERT_TRUE(ctx->download(*out, 0, got.data(), got.size() * 4).isOk());
    for (uint32_t i = 0; i < 1024; ++i) ASSERT_EQ(got[i], av[i] * 1000u + bv[1023 - i]) << i;
    // Sets must match what a pipeline binds.
    d.texels = nullptr;
    const Status none = ctx->run({d});
    ASSERT_FALSE(none.isOk());
    EXPECT_NE(none.message().find("texel"), std::string::npos) << none.message();
    Result<TexelSet> one = ctx->createTexelSet({&*a});
    ASSERT_TRUE(one.isOk());
    d.texels = &*one;
    EXPECT_FALSE(ctx->run({d}).isOk());
    EXPECT_FALSE(ctx->createTexelSet({}).isOk());
    EXPECT_FALSE(ctx->createTexelSet({nullptr}).isOk());
}

// Texels of their own width a binding (1, 2 or 4 words: R32, R32G32, R32G32B32A32): one fetch
// reads a whole record of the same buffer words; other widths and a count that is not one a
// buffer are refused.
TEST(GpuContext, TexelSetsViewEachBufferAtItsOwnWidth) {
    CSGV_REQUIRE_GPU(ctx);
    const std::string src = "#version 460\n#extension GL_EXT_buffer_reference : require\n"
                            "#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require\n"
                            "layout(local_size_x = 64) in;\n"
                            "layout(set = 0, binding = 0) uniform usamplerBuffer one;\n"
                            "layout(set = 0, binding = 1) uniform usamplerBuffer two;\n"
                            "layout(set = 0, binding = 2) uniform usamplerBuffer four;\n"
                            "layout(buffer_reference, std430) buffer Out { uint w[]; };\n"
                            "layout(push_constant) uniform Push { uint64_t out_; } pc;\n"
                            "void main() {\n"
                            "    const uint i = gl_GlobalInvocationID.x;\n"
                            "    const uvec2 t = texelFetch(two, int(i)).xy;\n"
                            "    const uvec4 f = texelFetch(four, int(i)).xyzw;\n"
                            "    Out o = Out(pc.out_);\n"
                            "    o.w[7u * i] = texelFetch(one, int(i)).x;\n"
                            "    o.w[7u * i + 1u] = t.x; o.w[7u * i + 2u] = t.y;\n"
                            "    o.w[7u * i + 3u] = f.x; o.w[7u * i + 4u] = f.y; o.w[7u * i + 5u] = f.z; o.w[7u * i + 6u] = f.w;\n"
                            "}\n";
    Result<std::vector<uint32_t>> spirv = compileComputeSource("texel_widths.comp", src, {});
    ASSERT_TRUE(spirv.isOk()) << spirv.message();
    Result<uint64_t> pipeline = ctx->createComputePipeline(*spirv, 8, 3);
    ASSERT_TRUE(pipeline.isOk()) << pipeline.message();
    constexpr uint32_t n = 256;
    std::vector<uint32_t> words(4 * n);
    for (uint32_t i = 0; i < words.size(); ++i) words[i] = i * 2654435761u;
    Result<Buffer> b = ctx->createBuffer(words.size() * 4, MemoryKind::DeviceLocal);
    Result<Buffer> out = ctx->createBuffer(7 * n * 4, MemoryKind::HostVisible);
    ASSERT_TRUE(b.isOk() && out.isOk());
    ASSERT_TRUE(ctx->upload(*b, 0, words.data(), words.size() * 4).isOk());
    Result<TexelSet> set = ctx->createTexelSet({&*b, &*b, &*b}, std::vector<uint32_t>{1, 2, 4});
    ASSERT_TRUE(set.isOk()) << set.message();
    const uint64_t push = out->address();
    Context::Dispatch d;
    d.pipeline = *pipeline;
    d.pushConstants = &push;
    d.pushConstantBytes = 8;
    d.groups[0] = n / 64;
    d.texels = &*set;
    ASSERT_TRUE(ctx->run({d}).isOk());
    std::vector<uint32_t> got(7 * n);
    ASSERT_TRUE(ctx->download(*out, 0, got.data(), got.size() * 4).isOk());
    for (uint32_t i = 0; i < n; ++i) {
        ASSERT_EQ(got[7 * i], words[i]) << i;
        ASSERT_EQ(got[7 * i + 1], words[2 * i]) << i;
        ASSERT_EQ(got[7 * i + 2], words[2 * i + 1]) << i;
        for (uint32_t k = 0; k < 4; ++k) ASSERT_EQ(got[7 * i + 3 + k], words[4 * i + k]) << i << " " << k;
    }
    const Result<TexelSet> three = ctx->createTexelSet({&*b}, std::vector<uint32_t>{3});
    ASSERT_FALSE(three.isOk());
    EXPECT_NE(three.message().find("3 words"), std::string::npos) << three.message();
    const Result<TexelSet> counts = ctx->createTexelSet({&*b, &*b}, std::vector<uint32_t>{1});
    ASSERT_FALSE(counts.isOk());
    EXPECT_NE(counts.message().find("2 buffers given 1 texel widths"), std::string::npos) << counts.message();
}

TEST(ShaderCompiler, EmbeddedSourcesIncludesAndErrorsWithLines) {
    const auto names = embeddedShaderNames();
    EXPECT_NE(std::find(names.begin(), names.end(), "csgv_decode.glsl"), names.end());
    EXPECT_NE(embeddedShader("decode_bricks.comp"), nullptr);
    EXPECT_EQ(embeddedShader("nope.glsl"), nullptr);
    const std::string ok = "#version 460\nlayout(local_size_x = 1) in;\nvoid main() { uint x = VALUE; }\n";
    Result<std::vector<uint32_t>> spirv = compileComputeSource("ok.comp", ok, {{"VALUE", "3u"}});
    ASSERT_TRUE(spirv.isOk()) << spirv.message();
    EXPECT_EQ((*spirv)[0], 0x07230203u); // SPIR-V magic
    const std::string bad = "#version 460\nlayout(local_size_x = 1) in;\n\nvoid main() { undefined_thing(); }\n";
    Result<std::vector<uint32_t>> err = compileComputeSource("bad.comp", bad, {});
    ASSERT_FALSE(err.isOk());
    EXPECT_NE(err.message().find("bad.comp:4"), std::string::npos) << err.message();
    Result<std::vector<uint32_t>> inc =
        compileComputeSource("inc.comp", "#version 460\n#extension GL_GOOGLE_include_directive : require\n#include \"missing.glsl\"\nvoid main(){}\n", {});
    ASSERT_FALSE(inc.isOk());
    EXPECT_NE(inc.message().find("missing.glsl"), std::string::npos) << inc.message();
    EXPECT_FALSE(compileComputeShader("nope.comp", {}).isOk());
}

// Functions are inlined into the entry point (lavapipe's own inlining of render.comp's cost most
// of a first frame's 250-280 ms of making its pipeline); CSGV_SPIRV_OPT=0 keeps glslang's module.
TEST(ShaderCompiler, FunctionsAreInlinedIntoTheEntryPoint) {
    auto functions = [](const std::vector<uint32_t>& spirv) {
        int n = 0;
        for (size_t i = 5; i < spirv.size(); i += std::max<uint32_t>(1u, spirv[i] >> 16))
            n += (spirv[i] & 0xFFFFu) == 54u; // OpFunction
        return n;
    };
    // pick() has early returns, one inside a loop; choose() returns a buffer reference (the inliner
    // keeps it in a variable that must be decorated, else the module is not valid and is not used).
    const std::string src = "#version 460\n#extension GL_EXT_buffer_reference : require\n"
                            "layout(local_size_x = 1) in;\n"
                            "layout(buffer_reference, std430) buffer Ref { uint v[]; };\n"
                            "layout(push_constant) uniform P { Ref a; Ref b; } pc;\n"
                            "Ref choose(uint x) { if (x > 3u) return pc.a; return pc.b; }\n"
                            "uint pick(Ref r, uint x) { if (x > 3u) return x * 2u; for (uint i = 0u; i < x; ++i) if (r.v[i] == 7u) return i; return 0u; }\n"
                            "void main() { Ref r = choose(pc.a.v[1]); r.v[0] = pick(r, pc.a.v[1]) + pick(pc.b, pc.b.v[2]); }\n";
    // The runner's settings are put back afterwards (CSGV_SPIRV_OPT=0 exported would keep the modules as written).
    auto saved = [](const char* name) { const char* v = std::getenv(name); return v ? std::optional<std::string>(v) : std::nullopt; };
    const std::optional<std::string> cacheDir = saved("CSGV_SHADER_CACHE_DIR"), opt = saved("CSGV_SPIRV_OPT");
    ::setenv("CSGV_SHADER_CACHE_DIR", "", 1);
    ::unsetenv("CSGV_SPIRV_OPT");
    auto inlined = csgv::gpu::compileComputeSource("inline_test.comp", src, {});
    ::setenv("CSGV_SPIRV_OPT", "0", 1);
    auto asWritten = csgv::gpu::compileComputeSource("inline_test.comp", src, {});
    for (const auto& [name, value] : {std::pair{"CSGV_SHADER_CACHE_DIR", cacheDir}, std::pair{"CSGV_SPIRV_OPT", opt}})
        if (value) ::setenv(name, value->c_str(), 1);
        else ::unsetenv(name);
    ASSERT_TRUE(inlined.isOk()) << inlined.message();
    ASSERT_TRUE(asWritten.isOk()) << asWritten.message();
    EXPECT_EQ(functions(*inlined), 1) << "choose() and pick() inlined into main(), and the module valid";
    EXPECT_EQ(functions(*asWritten), 3) << "glslang's module as written";
}

// Callers of one key at once (a frame asking for the pipeline the warming is making) get the same
// inlined module; those that come while it is being inlined wait for it (nothing hangs).
TEST(ShaderCompiler, OneKeyCompiledFromManyThreadsAtOnce) {
    const std::string src = "#version 460\nlayout(local_size_x = 1) in;\n"
                            "layout(std430, binding = 0) buffer B { uint v[]; };\n"
                            "uint twice(uint x) { return x + x; }\n"
                            "void main() { v[0] = twice(v[1]); /* many threads */ }\n";
    const char* dir = std::getenv("CSGV_SHADER_CACHE_DIR");
    const std::optional<std::string> cacheDir = dir ? std::optional<std::string>(dir) : std::nullopt;
    ::setenv("CSGV_SHADER_CACHE_DIR", "", 1);
    std::vector<Result<std::vector<uint32_t>>> results(4, Status::error("not run"));
    std::vector<std::thread> threads;
    for (size_t t = 0; t < results.size(); ++t)
        threads.emplace_back([&, t] { results[t] = csgv::gpu::compileComputeSource("many_threads.comp", src, {}); });
    for (std::thread& t : threads) t.join();
    if (cacheDir) ::setenv("CSGV_SHADER_CACHE_DIR", cacheDir->c_str(), 1);
    else ::unsetenv("CSGV_SHADER_CACHE_DIR");
    for (const auto& r : results) {
        ASSERT_TRUE(r.isOk()) << r.message();
        EXPECT_EQ(*r, *results[0]);
    }
}

TEST(ShaderCompiler, DiskCacheIsUsedAndSurvivesGarbage) {
    const std::string dir = csgvtest::tempDir() + "/shader-cache";
    ASSERT_EQ(::system(("mkdir -p '" + dir + "'").c_str()), 0);
    ::setenv("CSGV_SHADER_CACHE_DIR", dir.c_str(), 1);
    const csgv::gpu::Defines d = {{"CSGV_TEST_DISK_CACHE", "1"}};
    const std::string src = "#version 460\nlayout(local_size_x = 1) in;\nvoid main() {}\n";
    auto first = csgv::gpu::compileComputeSource("disk_cache_test.comp", src, d);
    ::unsetenv("CSGV_SHADER_CACHE_DIR");
    ASSERT_TRUE(first.isOk()) << first.message();
    // One file, holding exactly the SPIR-V.
    FILE* list = ::popen(("ls '" + dir + "'").c_str(), "r");
    char name[256] = {0};
    ASSERT_TRUE(list && std::fgets(name, sizeof(name), list));
    ::pclose(list);
    std::string path = dir + "/" + std::string(name).substr(0, std::strlen(name) - 1);
    FILE* f = std::fopen(path.c_str(), "rb");
    ASSERT_TRUE(f);
    std::vector<uint32_t> disk(first->size());
    EXPECT_EQ(std::fread(disk.data(), 4, disk.size(), f), disk.size());
    std::fclose(f);
    EXPECT_EQ(disk, *first);
    // A garbage file in its place is ignored (compiled again), never loaded.
    f = std::fopen(path.c_str(), "wb");
    std::fputs("not SPIR-V at all, not at all", f);
    std::fclose(f);
    csgv::gpu::clearShaderMemoryCache();
    ::setenv("CSGV_SHADER_CACHE_DIR", dir.c_str(), 1);
    auto again = csgv::gpu::compileComputeSource("disk_cache_test.comp", src, d);
    ::unsetenv("CSGV_SHADER_CACHE_DIR");
    ASSERT_TRUE(again.isOk()) << again.message();
    EXPECT_EQ(*again, *first) << "garbage in the cache file is compiled over, never loaded";
    f = std::fopen(path.c_str(), "rb");
    ASSERT_TRUE(f);
    std::vector<uint32_t> rewritten(first->size());
    EXPECT_EQ(std::fread(rewritten.data(), 4, rewritten.size(), f), rewritten.size());
    std::fclose(f);
    EXPECT_EQ(rewritten, *first) << "and the file is rewritten";
}

// Without CSGV_SHADER_CACHE_DIR the cache lives under $XDG_CACHE_HOME (its folders made on the
// way); CSGV_SHADER_CACHE_DIR set but empty turns it off.
TEST(ShaderCompiler, DiskCacheDefaultsToTheUserCacheFolder) {
    const std::string xdg = csgvtest::tempDir() + "/xdg-cache";
    const std::string folder = xdg + "/csgv/shaders";
    auto files = [&] {
        FILE* list = ::popen(("ls '" + folder + "' 2>/dev/null | wc -l").c_str(), "r");
        int n = -1;
        if (list && std::fscanf(list, "%d", &n) != 1) n = -1;
        if (list) ::pclose(list);
        return n;
    };
    const std::string src = "#version 460\nlayout(local_size_x = 1) in;\nvoid main() { /* default cache */ }\n";
    ::setenv("XDG_CACHE_HOME", xdg.c_str(), 1);
    ::setenv("CSGV_SHADER_CACHE_DIR", "", 1);
    ASSERT_TRUE(csgv::gpu::compileComputeSource("default_cache_test.comp", src, {}).isOk());
    EXPECT_EQ(files(), 0) << "an empty CSGV_SHADER_CACHE_DIR writes nothing";
    csgv::gpu::clearShaderMemoryCache();
    ::unsetenv("CSGV_SHADER_CACHE_DIR");
    ASSERT_TRUE(csgv::gpu::compileComputeSource("default_cache_test.comp", src, {}).isOk());
    ::unsetenv("XDG_CACHE_HOME");
    EXPECT_EQ(files(), 1) << "one file in " << folder;
}
