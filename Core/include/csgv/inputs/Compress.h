// SPDX-License-Identifier: MIT
#pragma once
/// @file Compress.h
/// @brief From any supported input to `.csgv` + `.csgv.json` (+ `_csgv.db3` when relabelled):
/// the one path that `csgv compress`, benchmarks and the ParaView writer share.
///
/// Inputs: `synth:WxHxD[:seed]` (generated slab by slab) and every form openInput() recognises
/// (Inputs.h), read slab by slab.

#include "csgv/codec/Encoder.h"
#include "csgv/inputs/Inputs.h"
#include "csgv/inputs/Relabel.h"

#include <functional>
#include <memory>
#include <string>

namespace csgv {

/// Called now and then during compression with the fraction done (0..1) and the stage ("reading",
/// "relabelling", "encoding", "writing"). Returning false cancels: nothing is written (or what was
/// written under temporary names is removed) and compressToFile returns an error saying so.
using CompressProgress = std::function<bool(double fraction, const char* stage)>;

struct CompressOptions {
    EncodeOptions encode;
    InputOptions input;
    CompressProgress progress;
    bool relabel = false;                          ///< force dense relabelling
    uint64_t maxInputBytes = uint64_t(16) << 30;   ///< inputs read whole
    uint64_t maxOutputBytes = uint64_t(64) << 30;
};

struct CompressReport {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    uint64_t outputBytes = 0;
    bool relabelled = false;
    uint64_t labelCount = 0;   ///< ids in the database when relabelled
    std::string originalType;
    bool streamed = false;     ///< encoded slab by slab from the source
    double readSeconds = 0, encodeSeconds = 0, writeSeconds = 0;
};

/// Slab source over a `.vraw` file on disk (uint8, uint16 or uint32 labels).
Result<std::unique_ptr<SlabSource>> openVrawSlabs(const std::string& path);

/// Compresses `input` to `output` (and its sidecars). Every file is written under a temporary
/// name and renamed; a stale `_csgv.db3` beside the output is removed when no relabelling happened.
Status compressToFile(const std::string& input, const std::string& output, const CompressOptions& options,
                      CompressReport* report = nullptr);

} // namespace csgv
