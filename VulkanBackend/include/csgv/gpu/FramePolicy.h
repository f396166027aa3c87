// SPDX-License-Identifier: MIT
/// @file FramePolicy.h
/// @brief The backend's one time model: what a pixel costs in each shading mode, measured frame
/// by frame, and the two decisions made from it: the pixel stride of a still render's first
/// frames (Renderer::render) and the reduced resolution of an interactive frame
/// (Renderer::interactiveReduction, which ParaView's level of detail asks for).
#ifndef CSGV_GPU_FRAME_POLICY_H
#define CSGV_GPU_FRAME_POLICY_H

#include "csgv/gpu/ShadingModes.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace csgv::gpu {

/// @brief The cost of a pixel in each shading mode, measured frame by frame (a running average).
/// A mode not measured yet is estimated from the dearest measured one, scaled by the rays each
/// casts (ShadingMode::raysPerSample); 0 when nothing was measured.
class ModeCosts {
public:
    /// A frame of `pixels` in mode `s` took `seconds`.
    void record(Shading s, double seconds, double pixels) {
        if (seconds <= 0) return;
        const double perPixel = seconds / (pixels > 1 ? pixels : 1);
        double& avg = m_perPixel[shadingIndex(s)];
        avg = avg > 0 ? 0.5 * (avg + perPixel) : perPixel;
    }
    double secondsPerPixel(Shading s) const {
        const double rays = shadingMode(s).raysPerSample;
        double seconds = m_perPixel[shadingIndex(s)];
        for (uint32_t k = 0; seconds <= 0 && k < kShadingModes; ++k) // none measured: from the others
            for (uint32_t m = 0; m < kShadingModes; ++m)
                if (m_perPixel[m] > 0 && m_perPixel[m] / kShadingModeTable[m].raysPerSample * rays > seconds)
                    seconds = m_perPixel[m] / kShadingModeTable[m].raysPerSample * rays;
        return seconds;
    }

private:
    double m_perPixel[kShadingModes] = {};
};

/// The finest pixel stride, `least` or coarser (powers of two up to 8), at which a frame of
/// `pixels` costing `secondsPerPixel` each takes at most `frameSeconds`.
inline uint32_t strideFor(double secondsPerPixel, double pixels, double frameSeconds, uint32_t least) {
    uint32_t stride = std::max<uint32_t>(1, least);
    while (stride < 8 && pixels * secondsPerPixel / (double(stride) * stride) > frameSeconds) stride *= 2;
    return stride;
}

/// ParaView's level of detail: while the mouse moves, frames are drawn at 1/f of the view's
/// resolution per axis and stretched over it, f (1..8) chosen so that a frame of `pixels` at
/// `secondsPerPixel` takes at most half the time `desiredRate` (frames a second) allows (the
/// other half is ParaView's own work). 1 when nothing is known.
inline int interactiveReduction(double secondsPerPixel, double pixels, double desiredRate) {
    if (secondsPerPixel <= 0 || desiredRate <= 0) return 1;
    const double frameSeconds = 0.5 / desiredRate;
    const double f = std::ceil(std::sqrt(pixels * secondsPerPixel / frameSeconds) - 0.05);
    return int(std::min(8.0, std::max(1.0, f)));
}

} // namespace csgv::gpu

#endif
