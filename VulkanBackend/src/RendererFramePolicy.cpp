// SPDX-License-Identifier: MIT
/// @file RendererFramePolicy.cpp
/// @brief The renderer's frame policy: the still render's loop (a coarse first stride until
/// every pixel shows something, then the settings' own, until the sample target, the time
/// budget or idleness), the strides chosen from the time model (FramePolicy.h), and what the
/// time model learns from frames and from a caller's draws.
#include "RendererImpl.h"

namespace csgv::gpu {

uint32_t Renderer::Impl::strideFor(const RenderSettings& st, uint64_t pixels, double frameSeconds) const {
    double seconds = costs.secondsPerPixel(st.shading);
    if (seconds <= 0)
        seconds = kPriorSecondsPerRay[ctx.device().type == "cpu" ? 0 : 1] * shadingMode(st.shading).raysPerSample;
    return csgv::gpu::strideFor(seconds, double(pixels), frameSeconds, st.subsampling);
}

uint32_t Renderer::Impl::stillCoarseStride(const RenderSettings& st, uint64_t pixels, double budgetSeconds) const {
    return std::max(std::max<uint32_t>(1, st.subsampling), strideFor(st, pixels, std::max(budgetSeconds, 0.1) / 8));
}

void Renderer::Impl::measureFrame(const RenderSettings& st, const FrameInput& in, const FrameStats& stats) {
    if (stats.milliseconds <= 0) return; // nothing was submitted
    costs.record(st.shading, stats.milliseconds / 1000, renderedPixels(in, st.subsampling));
}

void Renderer::recordDraw(double seconds, uint32_t frames, double pixels) {
    if (frames > 0) m_impl->drawCosts.record(m_settings.shading, seconds / frames, pixels);
}

int Renderer::interactiveReduction(double pixels, double desiredRate) const {
    double seconds = m_impl->drawCosts.secondsPerPixel(m_settings.shading);
    if (seconds <= 0) seconds = m_impl->costs.secondsPerPixel(m_settings.shading);
    return csgv::gpu::interactiveReduction(seconds, pixels, desiredRate);
}

Result<RenderResult> Renderer::render(const RenderRequest& request) {
    Impl& im = *m_impl;
    const FrameInput& in = request.frame;
    Mat4 clipToWorld{};
    Status s = im.validate(in, m_settings, clipToWorld);
    if (!s) return s;
    if (!(s = im.detectChanges(in))) return s; // once per call: the frames below see the same input
    RenderResult result;
    if (im.accumulation.converged) return result; // nothing changed since an exact image: it stays
    const uint32_t target = std::max<uint32_t>(1, m_settings.sampleTarget);
    const uint64_t pixels = uint64_t(in.width) * in.height;
    const uint32_t fine = std::max<uint32_t>(1, m_settings.subsampling);
    if (im.accumulation.coarseStride == 0)
        im.accumulation.coarseStride = request.interactive ? fine : im.stillCoarseStride(m_settings, pixels, request.timeBudgetSeconds);
    im.accumulation.coarseStride = std::max(im.accumulation.coarseStride, fine);
    im.fillBlock = im.accumulation.coarseStride;
    RenderSettings settings = m_settings;
    const uint32_t maxFrames = target * im.accumulation.coarseStride * im.accumulation.coarseStride + 256;
    const auto t0 = std::chrono::steady_clock::now();
    uint32_t idle = 0;
    double before = 0; // seconds elapsed before this frame
    im.denoising.deferDenoise = !request.interactive; // the still loop's frames before its last are never shown
    for (uint32_t f = 0; f < maxFrames; ++f) {
        settings.subsampling = im.accumulation.shownWhole ? fine : im.accumulation.coarseStride;
        Result<FrameStats> st = im.frame(in, settings, clipToWorld);
        if (!st) {
            im.denoising.deferDenoise = im.denoising.denoisePending = im.denoising.gatheredValid = false;
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
        im.accumulation.shownWhole = im.accumulation.shownWhole || whole || st->cacheFull;
        if (request.interactive || st->minSamples >= target) break;
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        // The next frame costs this one's time per rendered pixel: stop when it would end past
        // the budget, so the budget holds; but never while a pixel shows nothing or a preview.
        const uint32_t nextStride = im.accumulation.shownWhole ? fine : im.accumulation.coarseStride;
        const double next = (elapsed - before) * renderedPixels(in, nextStride) / renderedPixels(in, settings.subsampling);
        before = elapsed;
        if (whole && elapsed + next + im.finishSeconds > request.timeBudgetSeconds) break;
        idle = st->idle() ? idle + 1 : 0;
        if (idle >= st->idleLimit()) break;
    }
    im.denoising.deferDenoise = false;
    im.fillBlock = 0;
    const auto t1 = std::chrono::steady_clock::now();
    if (im.denoising.denoisePending && !(s = im.denoiseOutput())) return s;
    im.accumulation.converged = result.last.minSamples >= target;
    (void)output(Color8 | Depth); // what a compositor needs, read while the frame is fresh
    const double finish = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    im.finishSeconds = im.finishSeconds > 0 ? 0.5 * (im.finishSeconds + finish) : finish;
    result.changed = true;
    return result;
}

} // namespace csgv::gpu
