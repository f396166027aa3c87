// SPDX-License-Identifier: MIT
/// @file Palette.h
/// @brief How the `random` colour mode colours a label, written once for Core's CPU material
/// evaluation (Materials.cpp) and the GPU's (shaders/render_common.glsl): valid C++ and GLSL
/// (csgv/base/GlslShim.h). In namespace csgv::layout because Materials.h declares the public
/// csgv::labelHash, which forwards here.
#ifndef CSGV_MATERIALS_PALETTE_H
#define CSGV_MATERIALS_PALETTE_H

#include "csgv/base/GlslShim.h"

CSGV_NAMESPACE_BEGIN(csgv::layout)

/// Wellons' lowbias32: labels next to each other land far apart.
CSGV_FN uint32_t labelHash(uint32_t x) {
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

/// 16 high-contrast colours (rgb) for `random` without a colormap:
/// colour of label l = kLabelPalette[labelHash(l) % kLabelPaletteSize].
CSGV_CONST(uint32_t, kLabelPaletteSize, 16u)
CSGV_VEC3_ARRAY(kLabelPalette, 16)
    CSGV_VEC3(0.902f, 0.098f, 0.294f), CSGV_VEC3(0.235f, 0.706f, 0.294f), CSGV_VEC3(1.000f, 0.882f, 0.098f), CSGV_VEC3(0.263f, 0.388f, 0.847f),
    CSGV_VEC3(0.961f, 0.510f, 0.192f), CSGV_VEC3(0.569f, 0.118f, 0.706f), CSGV_VEC3(0.275f, 0.941f, 0.941f), CSGV_VEC3(0.941f, 0.196f, 0.902f),
    CSGV_VEC3(0.737f, 0.965f, 0.047f), CSGV_VEC3(0.980f, 0.745f, 0.745f), CSGV_VEC3(0.000f, 0.502f, 0.502f), CSGV_VEC3(0.902f, 0.745f, 1.000f),
    CSGV_VEC3(0.604f, 0.388f, 0.141f), CSGV_VEC3(1.000f, 0.980f, 0.784f), CSGV_VEC3(0.502f, 0.000f, 0.000f), CSGV_VEC3(0.667f, 1.000f, 0.765f)
CSGV_ARRAY_END

CSGV_NAMESPACE_END

#endif // CSGV_MATERIALS_PALETTE_H
