// SPDX-License-Identifier: MIT
/**
 * @file CSGVPresets.h
 * @brief Material documents with ParaView's colour presets: preset names in a document's
 * colormaps become control points sampled from ParaView's preset (vtkSMTransferFunctionPresets),
 * then Core resolves its own built-in names.
 *
 * Not a wrapped header: Core types may appear here.
 */
#ifndef CSGVPresets_h
#define CSGVPresets_h

#include "csgv/materials/Materials.h"

#include <string>

namespace csgvrep
{

/// Parses a material document (MATERIALS.md; empty text: the default document), replacing
/// ParaView preset names by control points (1024 samples) and then Core's built-in names.
/// Returns an error message or "".
std::string resolveMaterials(const std::string& json, csgv::MaterialDocument& out);

} // namespace csgvrep

#endif
