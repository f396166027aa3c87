// SPDX-License-Identifier: MIT
// The headers shared by C++ and GLSL (GlslShim.h) must mean the same in both languages: a shader
// that includes them writes every constant, a few evaluations of the shared functions and the
// struct members it reads back from host-packed structs; the host compares with its own values.
#include "GpuTestSupport.h"

#include "csgv/base/Morton.h"
#include "csgv/codec/Layout.h"
#include "csgv/gpu/FrameLayout.h"
#include "csgv/gpu/ShaderCompiler.h"
#include "csgv/materials/Palette.h"

#include <cstring>

using namespace csgv;
using namespace csgv::gpu;
using namespace csgv::layout;

namespace {

struct Probe {
    const char* expression; // valid in both languages with the shared headers
    uint32_t host;
};
#define CSGV_PROBE(x) Probe{#x, uint32_t(x)}

const Probe kProbes[] = {
    CSGV_PROBE(kInvalidLabel), CSGV_PROBE(kRansProbBits), CSGV_PROBE(kRansTotal), CSGV_PROBE(kRansLowerBound),
    CSGV_PROBE(kOpParent), CSGV_PROBE(kOpNeighborX), CSGV_PROBE(kOpNeighborY), CSGV_PROBE(kOpNeighborZ),
    CSGV_PROBE(kOpPaletteAdv), CSGV_PROBE(kOpPaletteLast), CSGV_PROBE(kOpPaletteD), CSGV_PROBE(kOpInvalid),
    CSGV_PROBE(kStopBit), CSGV_PROBE(kDecodeOk), CSGV_PROBE(kDecodeStreamEnd), CSGV_PROBE(kDecodeBadRoot),
    CSGV_PROBE(kDecodeBadOperation), CSGV_PROBE(kDecodeStopAtFinest), CSGV_PROBE(kDecodeBadNeighbour),
    CSGV_PROBE(kDecodePaletteOverflow), CSGV_PROBE(kDecodeBadDistance), CSGV_PROBE(kDecodeRansIntegrity),
    CSGV_PROBE(kDecodeRunning),
    CSGV_PROBE(mortonSpread(0x3FFu)), CSGV_PROBE(mortonSpread(0x155u)), CSGV_PROBE(mortonCompact(0x39249249u)),
    CSGV_PROBE(morton3(5u, 1000u, 77u)), CSGV_PROBE(mortonX(0x12345678u)), CSGV_PROBE(mortonY(0x12345678u)),
    CSGV_PROBE(mortonZ(0x12345678u)), CSGV_PROBE(mortonAxisMask(2u)), CSGV_PROBE(mortonIncrement(0x1FFu, 0u)),
    CSGV_PROBE(mortonIncrement(morton3(3u, 7u, 9u), 1u)), CSGV_PROBE(mortonDecrement(morton3(3u, 8u, 9u), 1u)),
    CSGV_PROBE(mortonDecrement(morton3(4u, 1u, 1u), 2u)),
    CSGV_PROBE(labelHash(0u)), CSGV_PROBE(labelHash(1u)), CSGV_PROBE(labelHash(123456789u)),
    CSGV_PROBE(labelHash(0xFFFFFFFEu)), CSGV_PROBE(kLabelPaletteSize),
    CSGV_PROBE(kLookupScan), CSGV_PROBE(kLookupDense),
    CSGV_PROBE(kNone), CSGV_PROBE(kFlagJitter), CSGV_PROBE(kFlagFinest), CSGV_PROBE(kFlagDenoise),
    CSGV_PROBE(kFlagLimitRequests), CSGV_PROBE(kFlagDepthInput), CSGV_PROBE(kFlagLabelMap),
    CSGV_PROBE(kFlagResolveInRender), CSGV_PROBE(kGBufferSampled), CSGV_PROBE(kGBufferPreview), CSGV_PROBE(kGBufferTranslucent),
    CSGV_PROBE(kGBufferCountShift), CSGV_PROBE(kGBufferCountMax), CSGV_PROBE(kGBufferEpochShift),
    CSGV_PROBE(kGBufferEpochMask), CSGV_PROBE(kGBufferEpochs), CSGV_PROBE(kFlagGatherInRender), CSGV_PROBE(kFlagListNext),
    CSGV_PROBE(kShadingLocal), CSGV_PROBE(kShadingShadow), CSGV_PROBE(kShadingAo), CSGV_PROBE(kShadingPt),
    CSGV_PROBE(kColorConstant), CSGV_PROBE(kColorColormap), CSGV_PROBE(kColorRandom),
    CSGV_PROBE(kSlotBricks), CSGV_PROBE(kSlotGBuffer), CSGV_PROBE(kSlotDepthIn), CSGV_PROBE(kSlotOutput),
    CSGV_PROBE(kOutputDepthXor), CSGV_PROBE(kSlotDenoiseB), CSGV_PROBE(kSlotMaterialTable), CSGV_PROBE(kSlotCount),
    CSGV_PROBE(kAllocTop), CSGV_PROBE(kAllocMinSamples), CSGV_PROBE(kAllocPrevMin), CSGV_PROBE(kAllocFreeCount),
    CSGV_PROBE(kAllocEvictAge), CSGV_PROBE(kAllocPreviews),
    CSGV_PROBE(kAllocReqCount), CSGV_PROBE(kAllocPops), CSGV_PROBE(kAllocProvBase), CSGV_PROBE(kAllocProvCount),
    CSGV_PROBE(kAllocWords), CSGV_PROBE(kResolveGather), CSGV_PROBE(kResolveAtrous1), CSGV_PROBE(kResolveAtrous2),
    CSGV_PROBE(kResolveAtrous4), CSGV_PROBE(kTexelCache), CSGV_PROBE(kTexelPixelList),
    CSGV_PROBE(kRenderTexelCount), CSGV_PROBE(kResolveTexelSource), CSGV_PROBE(kResolveTexelSpans),
    CSGV_PROBE(kListLanes), CSGV_PROBE(kOutlineRowWords),
    CSGV_PROBE(kResolveTexelCount),
};
constexpr uint32_t kProbeCount = sizeof(kProbes) / sizeof(kProbes[0]);

uint32_t bitsOf(float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

} // namespace

TEST(SharedLayout, GlslSeesTheSameConstantsFunctionsAndStructLayoutsAsCpp) {
    CSGV_REQUIRE_GPU(ctx);
    // Host-packed structs with a distinct value in every member the shader reads back.
    FrameParams frame{};
    for (int i = 0; i < 16; ++i) frame.worldToIndex[i] = float(100 + i);
    for (int i = 0; i < 4; ++i) {
        frame.tone[i] = float(200 + i);
        frame.faceNormals[5][i] = float(300 + i);
        frame.frame[i] = 400u + i;
        frame.counts[i] = 500u + i;
    }
    for (uint32_t i = 0; i < kSlotCount; ++i) frame.addr[i] = (uint64_t(600 + i) << 32) | (700 + i);
    GpuMaterial mats[2]{};
    for (int i = 0; i < 4; ++i) {
        mats[1].select[i] = 800u + i;
        mats[1].extra[i] = float(900 + i);
    }
    std::vector<uint32_t> expect;
    for (const Probe& p : kProbes) expect.push_back(p.host);
    for (uint32_t i = 0; i < 48; ++i) expect.push_back(bitsOf(kLabelPalette[i / 3][i % 3]));
    expect.push_back(bitsOf(frame.worldToIndex[13])); // column 3, row 1
    expect.push_back(bitsOf(frame.tone[3]));
    expect.push_back(bitsOf(frame.faceNormals[5][2]));
    expect.push_back(frame.frame[1]);
    expect.push_back(frame.counts[3]);
    expect.push_back(uint32_t(frame.addr[kSlotCount - 1]));
    expect.push_back(uint32_t(frame.addr[kSlotCount - 1] >> 32));
    expect.push_back(mats[1].select[2]);
    expect.push_back(bitsOf(mats[1].extra[0]));

    std::string src = "#version 460\n#extension GL_GOOGLE_include_directive : require\n"
                      "#extension GL_EXT_buffer_reference : require\n"
                      "#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require\n"
                      "#include \"csgv/codec/Layout.h\"\n#include \"csgv/base/Morton.h\"\n"
                      "#include \"csgv/materials/Palette.h\"\n#include \"csgv/gpu/FrameLayout.h\"\n"
                      "layout(local_size_x = 1) in;\n"
                      "layout(buffer_reference, std430, buffer_reference_align = 4) buffer Out { uint w[]; };\n"
                      "layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer Frame { CSGV_FRAME_MEMBERS };\n"
                      "layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer Mats { GpuMaterial m[]; };\n"
                      "layout(push_constant) uniform Push { uint64_t out_; uint64_t frame; uint64_t mats; } pc;\n"
                      "void main() {\n  Out o = Out(pc.out_);\n";
    uint32_t n = 0;
    for (const Probe& p : kProbes) src += "  o.w[" + std::to_string(n++) + "] = " + p.expression + ";\n";
    src += "  for (uint i = 0u; i < 48u; ++i) o.w[" + std::to_string(n) + "u + i] = floatBitsToUint(kLabelPalette[i / 3u][i % 3u]);\n";
    n += 48;
    // Whole members first, components after (lavapipe's buffer-reference quirk, render_common.glsl).
    src += "  Frame f = Frame(pc.frame);\n  const mat4 m = f.worldToIndex;\n  const vec4 t = f.tone;\n"
           "  const vec4 fn = f.faceNormals[5];\n  const uvec4 fr = f.frame;\n  const uvec4 c = f.counts;\n"
           "  const uint64_t a = f.addr[kSlotCount - 1u];\n  const GpuMaterial g = Mats(pc.mats).m[1];\n";
    const char* reads[] = {"floatBitsToUint(m[3][1])", "floatBitsToUint(t.w)", "floatBitsToUint(fn.z)", "fr.y", "c.w",
                           "uint(a & 0xFFFFFFFFul)", "uint(a >> 32)", "g.select.z", "floatBitsToUint(g.extra.x)"};
    for (const char* r : reads) src += "  o.w[" + std::to_string(n++) + "] = " + r + ";\n";
    src += "}\n";
    ASSERT_EQ(n, expect.size());

    Result<std::vector<uint32_t>> spirv = compileComputeSource("layout_probe.comp", src, {});
    ASSERT_TRUE(spirv.isOk()) << spirv.message();
    Result<uint64_t> pipeline = ctx->createComputePipeline(*spirv, 24);
    ASSERT_TRUE(pipeline.isOk()) << pipeline.message();
    Result<Buffer> out = ctx->createBuffer(n * 4, MemoryKind::HostVisible);
    Result<Buffer> frameBuf = ctx->createBuffer(sizeof(frame), MemoryKind::DeviceLocal);
    Result<Buffer> matBuf = ctx->createBuffer(sizeof(mats), MemoryKind::DeviceLocal);
    ASSERT_TRUE(out.isOk() && frameBuf.isOk() && matBuf.isOk());
    ASSERT_TRUE(ctx->upload(*frameBuf, 0, &frame, sizeof(frame)).isOk());
    ASSERT_TRUE(ctx->upload(*matBuf, 0, mats, sizeof(mats)).isOk());
    const uint64_t push[3] = {out->address(), frameBuf->address(), matBuf->address()};
    Context::Dispatch d;
    d.pipeline = *pipeline;
    d.pushConstants = push;
    d.pushConstantBytes = sizeof(push);
    ASSERT_TRUE(ctx->run({d}).isOk());
    std::vector<uint32_t> got(n);
    ASSERT_TRUE(ctx->download(*out, 0, got.data(), n * 4).isOk());
    for (uint32_t i = 0; i < n; ++i)
        EXPECT_EQ(got[i], expect[i]) << "value " << i << (i < kProbeCount ? std::string(": ") + kProbes[i].expression : std::string());
}
