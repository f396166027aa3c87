// SPDX-License-Identifier: MIT
/// @file RendererOutput.cpp
/// @brief The renderer's read-back room: the output image (colour, depth, first-hit labels and
/// their depths) read from the device as the caller asks, the cached bricks' list and a view's
/// working set.
#include "RendererImpl.h"

#include <algorithm>
#include <cmath>

namespace csgv::gpu {

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
        out.translucent.assign(n, 0);
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
            out.translucent[i] = (g[4 * i + 1] & kGBufferTranslucent) != 0 ? 1 : 0;
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
        if (const uint32_t lod = words[4 * b + 1]; lod != kNone) { // hidden ones at levels whose nodes fit a sub-block
            out.push_back({b, lod, lod == 0 ? masks[b] : 0, lod + kUniformShift <= log2u(im.volume->volume().brickSize) ? hidden[b] : 0, {}});
            if (lod != 0 || !im.volume->uniformLevels()) continue;
            std::vector<uint32_t> region(im.volume->regionWords(0));
            if (!(s = im.ctx.download(im.cache, uint64_t(words[4 * b]) * 4, region.data(), region.size() * 4))) return s;
            out.back().uniformLevels.resize(region.size());
            for (size_t e = 0; e < region.size(); ++e)
                out.back().uniformLevels[e] = region[e] == kNone ? 0 : uint8_t(region[e] >> kUniformLevelShift);
        }
    return out;
}

uint32_t Renderer::frameMark() const { return m_impl->frameIndex; }

namespace {

/// The level of detail the last frame's rays want for a brick: render_common.glsl's
/// lodForBrick, on the host (column-major matrices, as the shaders read them).
uint32_t wantedLevel(const FrameParams& p, const CompressedVolume& v, uint64_t brick) {
    if ((p.frame[1] & kFlagFinest) != 0u) return 0u;
    const std::array<uint32_t, 3> grid = v.brickGrid();
    const uint64_t b[3] = {brick % grid[0], (brick / grid[0]) % grid[1], brick / (uint64_t(grid[0]) * grid[1])};
    const float centre[4] = {(float(b[0]) + 0.5f) * float(v.brickSize), (float(b[1]) + 0.5f) * float(v.brickSize),
                             (float(b[2]) + 0.5f) * float(v.brickSize), 1.0f};
    auto apply = [](const float* m, const float* x, float* y) {
        for (int i = 0; i < 4; ++i) y[i] = m[i] * x[0] + m[4 + i] * x[1] + m[8 + i] * x[2] + m[12 + i] * x[3];
    };
    float clip[4], back[4];
    apply(p.indexToClip, centre, clip);
    apply(p.clipToIndex, clip, back);
    const float footprint = p.clipMax[3] * std::fabs(clip[3] / back[3]);
    const float l = std::floor(std::log2(std::max(footprint, 1e-30f)) + p.clipMin[3]);
    return uint32_t(std::clamp(l, 0.0f, float(v.levels() - 1u)));
}

} // namespace

Result<Renderer::WorkingSet> Renderer::workingSet(uint32_t mark) const {
    const Impl& im = *m_impl;
    WorkingSet w;
    w.cacheBytes = im.cache.size();
    // Each brick at the level the view wants (the last frame's camera): a thrashing cache holds
    // some of them at a stand-in's level, or not at all.
    const FrameParams& p = const_cast<Impl&>(im).hostParams();
    const CompressedVolume& v = im.volume->volume();
    std::vector<uint64_t> levelBytes(v.levels());
    for (uint32_t l = 0; l < v.levels(); ++l) levelBytes[l] = im.volume->regionWords(l) * 4;
    // The table in slices (16 bytes a brick, the in-flight words after it aside: 256 MiB at 8192^3,
    // 16 MiB at a time).
    constexpr uint64_t kSlice = uint64_t(1) << 20;
    std::vector<uint32_t> words(size_t(std::min<uint64_t>(im.brickCount, kSlice)) * 4);
    for (uint64_t from = 0; from < im.brickCount; from += kSlice) {
        const uint64_t n = std::min<uint64_t>(kSlice, im.brickCount - from);
        if (Status s = im.ctx.download(im.bricks, from * 16, words.data(), n * 16); !s) return s;
        for (uint64_t i = 0; i < n; ++i) {
            if (words[4 * i + 2] <= mark) continue; // the frame index + 1 of the brick's last use
            ++w.bricks;
            w.cachedBricks += words[4 * i + 1] != kNone;
            w.bytes += levelBytes[wantedLevel(p, v, from + i)];
        }
    }
    return w;
}

} // namespace csgv::gpu
