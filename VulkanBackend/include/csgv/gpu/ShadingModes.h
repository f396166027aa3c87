// SPDX-License-Identifier: MIT
/// @file ShadingModes.h
/// @brief The shading modes, one row each: the one table the backend, `csgv render`, the
/// representation and the server-manager XML's enumeration read (Plugin/CSGV/CMakeLists.txt
/// writes the CSGVShading entries, labels and their documentation from the rows, so each row
/// stays on one line in the form below). render.comp compiles one pipeline per mode with
/// SHADING = the row's `define` (FrameLayout.h's kShading* constants, which GLSL reads).
///
/// Adding a mode: a row here, its kShading* constant in FrameLayout.h, its branch of render.comp
/// (a function of its own, selected by SHADING), and a baseline in the gpu tests.
#ifndef CSGV_GPU_SHADING_MODES_H
#define CSGV_GPU_SHADING_MODES_H

#include "csgv/gpu/FrameLayout.h"

#include <cstdint>
#include <iterator>

namespace csgv::gpu {

enum class Shading { Local = 0, Shadow = 1, AmbientOcclusion = 2, PathTracing = 3 };

/// @brief One shading mode.
struct ShadingMode {
    Shading mode;
    const char* name;     ///< what pvpython and `csgv render --shading` take ("pt")
    const char* label;    ///< what the GUI shows ("Path tracing")
    const char* summary;  ///< what the mode draws, for documentation
    uint32_t define;      ///< render.comp's SHADING for this mode
    /// Rays a sample casts, roughly: what the mode costs against another before either is
    /// measured (ModeCosts), and the first frame's time estimate.
    double raysPerSample;
    bool denoised;        ///< RenderSettings::denoise applies (A-trous passes over the noisy modes)
};

// clang-format off
inline constexpr ShadingMode kShadingModeTable[] = {
    {Shading::Local, "local", "Local", "diffuse and ambient light", kShadingLocal, 1, false},
    {Shading::Shadow, "shadow", "Shadow", "plus shadow rays", kShadingShadow, 2, false},
    {Shading::AmbientOcclusion, "ao", "Ambient occlusion", "ambient occlusion", kShadingAo, 2, true},
    {Shading::PathTracing, "pt", "Path tracing", "path tracing", kShadingPt, 4, true},
};
// clang-format on

/// How many shading modes there are (Shading's values are 0 .. kShadingModes - 1).
constexpr uint32_t kShadingModes = uint32_t(std::size(kShadingModeTable));

constexpr bool shadingTableInOrder() {
    for (uint32_t i = 0; i < kShadingModes; ++i)
        if (uint32_t(kShadingModeTable[i].mode) != i || kShadingModeTable[i].define != i) return false;
    return true;
}
static_assert(shadingTableInOrder(), "row i of kShadingModeTable is Shading(i), compiled with SHADING = i");

/// A shading mode as an index 0 .. kShadingModes - 1 (a value out of range counts as Local).
constexpr uint32_t shadingIndex(Shading s) { return uint32_t(s) < kShadingModes ? uint32_t(s) : 0; }
/// The row of a mode (a value out of range: Local's).
constexpr const ShadingMode& shadingMode(Shading s) { return kShadingModeTable[shadingIndex(s)]; }

} // namespace csgv::gpu

#endif
