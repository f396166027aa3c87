// SPDX-License-Identifier: MIT
/// @file Vraw.cpp
/// @brief Volcanite's `.vraw` / `.vraw.gz` as an input volume: the codec's reader (readVraw,
/// which reads through InputStream) widened to full-width values.
#include "InputCommon.h"

#include "csgv/codec/LabelVolume.h"

namespace csgv {
namespace inputs {

Result<InputVolume> readVrawInput(const std::string& path, uint64_t maxBytes) {
    Result<LabelVolume> raw = readVraw(path, maxBytes);
    if (!raw) return raw.status();
    const std::array<uint64_t, 3> d3 = {{raw->dim[0], raw->dim[1], raw->dim[2]}};
    if (Status s = checkBudget(path, d3, maxBytes); !s) return s;
    InputVolume vol;
    vol.dim = raw->dim;
    vol.type = LabelType::U32; // readVraw widens uint8/uint16 labels to uint32
    vol.values.assign(raw->labels.begin(), raw->labels.end());
    return vol;
}

} // namespace inputs
} // namespace csgv
