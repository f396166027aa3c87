// SPDX-License-Identifier: MIT
/// @file RendererPipelines.cpp
/// @brief The renderer's pipeline room: which pipelines a frame's settings need (render pass per
/// shading mode and variant, resolve passes, cache passes), making them in parallel, preparing
/// them before the first frame, and warming the other shading modes in the background.
#include "RendererImpl.h"

#include <thread>

namespace csgv::gpu {
namespace renderer_detail {

/// Compiles a shader with defines into a pipeline; with `profile`, says how long it took.
Result<uint64_t> makePipeline(Context& ctx, const char* name, const Defines& defines, uint32_t pushBytes,
                              uint32_t texelBindings, bool profile) {
    const auto t0 = std::chrono::steady_clock::now();
    Result<std::vector<uint32_t>> spirv = compileComputeShader(name, defines);
    if (!spirv) return spirv.status();
    Result<uint64_t> p = ctx.createComputePipeline(*spirv, pushBytes, texelBindings);
    if (!p) return Status(p.status()).prefix(name);
    if (profile)
        std::fprintf(stderr, "pipeline %s (%s): %.1f ms\n", name, defines.back().first.c_str(),
                     std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    return p;
}

/// Lowers the calling thread's scheduling priority (Linux: a thread's own nice value), so that
/// background compilation yields to frames and the GUI on a CPU device. Not the idle policy: on
/// cores busy with other work it would all but stop, and a renderer going away waits for the
/// pipeline its warming is making (kWarmAfterIdle keeps the warming from a moving camera's frames).
void lowerThisThreadsPriority() {
#ifdef __linux__
    (void)setpriority(PRIO_PROCESS, id_t(syscall(SYS_gettid)), 10);
#endif
}


/// Makes the pipelines in parallel, on threads of their own for as long as it takes (a CPU
/// device's compiler takes about 50 ms for the render pipeline, the others a few ms each: the
/// first frame waits for the longest, not for the sum; no pool or decoder is made for it, which a
/// GPU renderer would never use again); the first error is returned.
Status makePipelines(Context& ctx, const std::vector<PipelineJob>& jobs, bool profile) {
    std::vector<Status> results(jobs.size());
    auto make = [&](size_t i) {
        Result<uint64_t> p =
            makePipeline(ctx, jobs[i].name, jobs[i].defines, jobs[i].pushBytes, jobs[i].texelBindings, profile);
        if (p) *jobs[i].out = *p;
        else results[i] = p.status();
    };
    std::atomic<size_t> next{1}; // job 0, the render pipeline (the longest), is this thread's
    auto work = [&] {
        for (size_t i = next++; i < jobs.size(); i = next++) make(i);
    };
    const size_t cores = std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> helpers;
    for (size_t t = 1; t < std::min(cores, jobs.size()); ++t) helpers.emplace_back(work);
    make(0);
    work();
    for (std::thread& t : helpers) t.join();
    for (const Status& r : results)
        if (!r) return r;
    return Status::ok();
}

} // namespace renderer_detail

Status Renderer::preparePipelines(bool depthInput) {
    Impl& im = *m_impl;
    if (!im.renderTexels.valid() && !im.resolveTexels.valid()) {
        // Before the first frame there are no image buffers to view: the passes are made as the
        // frame's buffers will most likely be viewed (texel views where wanted and the cache fits
        // the device's limit; an image's buffers are far smaller). Should
        // that frame's views say otherwise (TexelViews::refresh), it drops these and makes its own.
        im.renderTexels.made = im.resolved.texelsWanted && TexelViews::fits(im.ctx, im.cache);
        im.resolveTexels.made = im.resolved.texelsWanted;
    }
    return im.ensurePipelines(m_settings, depthInput);
}

Status Renderer::Impl::ensurePipelines(const RenderSettings& st, bool depthInput) {
    const std::vector<PipelineJob> jobs = pipelineJobs(st, depthInput);
    return jobs.empty() ? Status::ok() : makePipelines(ctx, jobs, resolved.profileDispatches);
}

std::vector<PipelineJob> Renderer::Impl::pipelineJobs(const RenderSettings& st, bool depthInput) {
    std::vector<PipelineJob> jobs;
    // Every frame asks; only a pipeline not made yet costs anything (its defines are built then).
    auto need = [&](uint64_t& pipeline, const char* name, uint32_t push = 8, const char* define = nullptr,
                    uint32_t value = 0) {
        if (pipeline) return;
        Defines d = defines;
        if (define) d.emplace_back(define, std::to_string(value) + "u");
        jobs.push_back({name, std::move(d), push, &pipeline});
    };
    const uint32_t mode = shadingIndex(st.shading), tc = toneCurves(st), rv = renderVariant(st, depthInput);
    need(pRender[rv][mode], "render.comp", 8, "SHADING", shadingMode(st.shading).define);
    if (!jobs.empty() && jobs.back().out == &pRender[rv][mode]) {
        jobs.back().defines.emplace_back("TONE_CURVES", std::to_string(tc));
        jobs.back().defines.emplace_back("ONE_SAMPLE", oneSample(st) ? "1" : "0");
        jobs.back().defines.emplace_back("DEPTH_INPUT", depthInput ? "1" : "0");
        if (renderTexels.made) {
            jobs.back().defines.emplace_back("RENDER_TEXELS", "1");
            jobs.back().texelBindings = kRenderTexelCount;
        }
    }
    for (uint32_t pass = kResolveGather; pass <= kResolveAtrous4; ++pass)
        if (pass == kResolveGather ? !resolvesInRender(st) : denoises(st)) {
            need(pResolve[tc][pass], "resolve.comp", sizeof(ResolvePush), "RESOLVE_PASS", pass);
            if (!jobs.empty() && jobs.back().out == &pResolve[tc][pass]) {
                jobs.back().defines.emplace_back("TONE_CURVES", std::to_string(tc));
                jobs.back().defines.emplace_back("RESOLVE_OUTPUT", std::to_string(resolveTarget(pass)) + "u");
                if (resolveTexels.made) {
                    jobs.back().defines.emplace_back("RESOLVE_TEXELS", "1");
                    jobs.back().texelBindings = kResolveTexelCount;
                }
            }
        }
    need(pRequest, "cache_request.comp");
    need(pProvision, "cache_provision.comp");
    need(pAssign, "cache_assign.comp");
    need(pCommit, "cache_commit.comp");
    if (!resolved.hostDecode) need(pUniform, "cache_uniform.comp");
    // cache_hidden.comp reads the cache and the label table as the render pass does (its texel buffers).
    for (const auto& [pipeline, all] : {std::pair<uint64_t*, bool>{&pHidden, false}, {&pHiddenAll, true}}) {
        if (!(all ? hiddenAll() : materialState.hiddenLabels)) continue;
        need(*pipeline, "cache_hidden.comp", 8, "HIDDEN_ALL", all ? 1 : 0);
        if (!jobs.empty() && jobs.back().out == pipeline && renderTexels.made) {
            jobs.back().defines.emplace_back("RENDER_TEXELS", "1");
            jobs.back().texelBindings = kRenderTexelCount;
        }
    }
    if (usesPixelList) need(pPixelList, "pixel_list.comp");
    if (materialState.labelColorsPending) need(pLabelColors, "label_colors.comp");
    return jobs;
}

/// How long frames must have paused before a CPU device's warming makes its next pipeline.
constexpr std::chrono::milliseconds kWarmAfterIdle{250};

void Renderer::warmShadingModes(bool depthInput) {
    Impl& im = *m_impl;
    if (im.warming.valid()) return; // once per renderer
    std::vector<PipelineJob> jobs;
    for (uint32_t mode = 0; mode < kShadingModes; ++mode) {
        RenderSettings st = m_settings;
        st.shading = Shading(mode);
        for (PipelineJob& j : im.pipelineJobs(st, depthInput)) jobs.push_back(std::move(j));
    }
    if (jobs.empty()) return;
    Context* ctx = &im.ctx;
    std::atomic<bool>* stop = &im.stopWarming;
    // A CPU device renders on the cores the compiler would take (and shares their caches): each
    // pipeline waits until frames have paused for kWarmAfterIdle (a moving camera keeps its pace;
    // the modes are made while the view rests).
    const auto* lastFrame = ctx->device().type == "cpu" ? &im.lastFrameTicks : nullptr;
    try {
        im.warming = std::async(std::launch::async, [ctx, stop, lastFrame, jobs = std::move(jobs)] {
            lowerThisThreadsPriority(); // frames and the GUI first
            for (const PipelineJob& j : jobs) {
                using Clock = std::chrono::steady_clock;
                while (lastFrame && !stop->load() &&
                       Clock::now() - Clock::time_point(Clock::duration(lastFrame->load())) < kWarmAfterIdle)
                    std::this_thread::sleep_for(std::chrono::milliseconds(20));
                if (stop->load()) return;
                // Into the context's pipeline table (by SPIR-V) and the shader cache: the frame
                // that needs it finds it there; an error is met (and reported) by that frame.
                (void)makePipeline(*ctx, j.name, j.defines, j.pushBytes, j.texelBindings, false);
            }
        });
    } catch (const std::system_error&) {
        // No thread to be had: a mode's first frame makes its pipelines, as without this call.
    }
}

void Renderer::waitForWarming() {
    if (m_impl->warming.valid()) m_impl->warming.wait();
}

} // namespace csgv::gpu
