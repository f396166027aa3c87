// SPDX-License-Identifier: MIT
#pragma once
/// @file RenderTestSupport.h
/// @brief Cameras as VTK builds them (look-at, perspective with a vertical view angle, parallel
/// with a half-height scale) for renderer tests.

#include "csgv/reference/RayCast.h"
#include "csgv/gpu/Renderer.h"

#include <cmath>

namespace csgvtest {

inline csgv::gpu::FrameInput perspectiveView(std::array<double, 3> eye, std::array<double, 3> centre,
                                             std::array<double, 3> up, double fovY, uint32_t w, uint32_t h) {
    csgv::gpu::FrameInput in;
    in.width = w;
    in.height = h;
    in.worldToClip = csgv::multiply(csgv::perspectiveMatrix(fovY, double(w) / h, 1.0, 1000.0), csgv::lookAtMatrix(eye, centre, up));
    return in;
}

inline csgv::gpu::FrameInput parallelView(std::array<double, 3> eye, std::array<double, 3> centre,
                                          std::array<double, 3> up, double scale, uint32_t w, uint32_t h) {
    csgv::gpu::FrameInput in;
    in.width = w;
    in.height = h;
    const double aspect = double(w) / h;
    in.worldToClip = csgv::multiply(csgv::orthographicMatrix(-scale * aspect, scale * aspect, -scale, scale, 1.0, 1000.0),
                                    csgv::lookAtMatrix(eye, centre, up));
    return in;
}

} // namespace csgvtest
