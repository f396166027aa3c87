// SPDX-License-Identifier: MIT
#pragma once
/// What a volume's palettes hold, from one parallel sweep over its bricks: the summary that the
/// reader computes when it opens a `.csgv` (the label range it reports), the renderer's stored
/// labels (LabelLookup.h) and the label lists of the label table take, so that opening and first
/// drawing a volume read its palettes once.
#include "csgv/codec/Container.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace csgv {

/// The most distinct labels a summary lists (PaletteSummary::labels): as many as the renderer's
/// material table holds (kMaterialTableLabels is this), so that one summary serves the reader,
/// the label table and the renderer.
constexpr uint32_t kSummaryLabels = 1u << 22;

struct PaletteSummary {
    uint64_t entries = 0;   ///< palette entries of the sound bricks
    uint32_t smallest = 0;  ///< the smallest entry (0 without entries)
    uint32_t largest = 0;   ///< the largest entry (0 without entries)
    /// Every entry once, ascending, when there are at most the cap's distinct entries
    /// (labelsComplete); else empty.
    std::vector<uint32_t> labels;
    bool labelsComplete = false;
    /// The bricks whose header words fail checkBrick, ascending: their palettes are not read.
    std::vector<uint64_t> unsound;
    /// Each brick's first palette entry, its root label (0 for an unsound brick): what a renderer
    /// shows of a brick it has not decoded, found without reading the palette again (for a file
    /// larger than memory, again from disk).
    std::vector<uint32_t> first;
};

/// Sweeps every brick once (in parallel, in chunks whose pages a mapped file gives back:
/// sweepBricks), checking each brick's header words (checkBrick) before it reads the palette.
/// `labelCap`: the most distinct entries listed (PaletteSummary::labels).
/// Throws std::bad_alloc when there is no memory for its tables.
PaletteSummary summarizePalettes(const CompressedVolume& vol, size_t labelCap);
/// The same with `progress(fraction)` asked between chunks of bricks (about every 100 MiB of a
/// typical encoding: a sweep of a file larger than memory reads it from disk); false cancels
/// ("cancelled").
Result<PaletteSummary> summarizePalettes(const CompressedVolume& vol, size_t labelCap,
                                         const std::function<bool(double)>& progress);

/// Sorts 32-bit words: linear in their count (two passes of 16 bits) for long lists.
void sortWords(std::vector<uint32_t>& v);

} // namespace csgv
