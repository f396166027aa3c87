// SPDX-License-Identifier: MIT
#pragma once
/// @file Extract.h
/// @brief Extracting a selection of labels from a compressed volume as a label image or a binary
/// mask, cropped to the selection's bounding box, decoding only the bricks whose palettes hold a
/// selected label (issue 41).
///
/// How it works, in named steps:
/// 1. **Select.** The caller names original labels (as users know them). A relabelled file maps
///    them to stored ids through its attribute database (CsgvFile::attributes); a label it lacks
///    is unknown. A file without one stores labels: a label no brick's palette holds is unknown.
///    Unknown labels are an error listing the first few; more than ExtractOptions::maxLabels
///    distinct labels are refused before anything is decoded.
/// 2. **Scan palettes.** Every brick's palette (the words at the end of its encoding,
///    CSGV-FORMAT.md section 3) is read without decoding; the bricks that intersect the box and
///    hold a selected id are the candidates. Every label a brick decodes to, at any level, comes
///    from its palette (each operation copies a palette entry or a label already decoded in the
///    same brick), so no other brick can hold a selected node.
/// 3. **Decode candidates** (in parallel, one brick per thread at a time) to the wanted level;
///    each keeps only the part of the brick inside the tight box of its own selected voxels
///    (others set to 0), so everything kept lies inside the final bounding box and, bricks being
///    disjoint, adds up to at most the output's size.
/// 4. **Assemble.** The union of those boxes is the output's box; its size is checked against
///    ExtractOptions::maxOutputBytes before it is allocated, then the kept parts are copied in.
///
/// Working memory: the output plus at most as much again for the kept parts (step 3), one decoded
/// brick per thread, the palette scan's candidate list (8 bytes per candidate brick) and the
/// selection (about 40 bytes per selected label). Never the volume.
///
/// Coordinates: `box` is given in full-resolution voxels, half-open; at level `lod` the output
/// holds the level's nodes that overlap it (a node at lod covers 2^lod voxels per axis). Results
/// are in the level's node grid: node (i,j,k) of the output is node `offset + (i,j,k)` of the
/// level image, the same node decodeRegion() gives there.

#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace csgv {

/// Default limit on the distinct labels of one selection (issue 41: "a selection that meets a
/// million labels is refused unless the user raises a limit").
constexpr uint64_t kDefaultMaxExtractLabels = 1000000;

/// @brief What to extract.
struct ExtractOptions {
    /// Original labels as int64 bits (uint64 labels of a file with labelsUnsigned64: their bits);
    /// repeats are allowed and count once.
    std::vector<int64_t> labels;
    bool mask = false;      ///< true: uint8 mask (1 selected, 0 not); false: label image
    uint32_t lod = 0;       ///< 0 full resolution, 1 half, ...
    bool hasBox = false;    ///< restrict to `box` (full-resolution voxels, half-open)
    Box box;
    uint64_t maxLabels = kDefaultMaxExtractLabels;
    uint64_t maxOutputBytes = uint64_t(4) << 30; ///< the output image's bytes
    int threads = 0;        ///< 0: OpenMP's default
    /// Only the selection's checks (labels unknown to the database, or held by no brick), nothing
    /// decoded: a caller that extracts a selection in parts checks it whole first, so that its
    /// error counts and names the selection's unknown labels, not a part's.
    bool checkOnly = false;
    /// Called now and then from one thread with the fraction of candidate bricks decoded; false
    /// stops the extraction (an error saying it was cancelled). May be empty.
    std::function<bool(double)> progress;
};

/// @brief The extracted image and what it took.
struct ExtractResult {
    uint32_t lod = 0;
    std::array<uint32_t, 3> offset{{0, 0, 0}}; ///< the output's node (0,0,0) in the level image
    std::array<uint32_t, 3> dim{{0, 0, 0}};    ///< all 0 when no voxel was selected
    /// Label image (when !mask), x fastest: selected voxels keep their original label, others 0.
    /// When the file's labels are wider than 32 bits, selected voxels hold the stored id
    /// (CsgvFile::originalLabel maps it) and others kInvalidLabel (an id may be 0).
    std::vector<uint32_t> labels;
    std::vector<uint8_t> mask; ///< when mask: 1 where a selected label is, else 0
    uint64_t voxels = 0;           ///< selected voxels (nodes) in the output
    uint64_t labelsSelected = 0;   ///< distinct labels asked for
    uint64_t labelsFound = 0;      ///< of those, held by a palette of a brick in the box
    uint64_t bricksTotal = 0;      ///< bricks of the volume
    uint64_t bricksInBox = 0;      ///< bricks intersecting the box (all without a box)
    uint64_t bricksDecoded = 0;    ///< bricks whose palettes hold a selected label: decoded
    uint64_t bricksWithVoxels = 0; ///< of those, bricks with a selected voxel at this level
    bool empty() const { return voxels == 0; }
    uint64_t outputBytes() const { return uint64_t(dim[0]) * dim[1] * dim[2] * (mask.empty() ? 4 : 1); }
};

/// A label image's values as original labels where the file's labels are wider than 32 bits
/// (ExtractResult::labels holds stored ids there): file.originalLabel of each, 0 where no selected
/// label is (kInvalidLabel).
std::vector<int64_t> originalLabels(const ExtractResult& result, const CsgvFile& file);
/// Extracts the selected labels of an opened file (see the file comment). Errors: unknown or too
/// many labels, a box outside the volume, a level out of range, an output over the limit, a
/// stream error in a decoded brick, cancellation. An empty result is not an error.
Result<ExtractResult> extractLabels(const CsgvFile& file, const ExtractOptions& options);

/// Where the selection lies, as boxes to extract one at a time (full-resolution voxels,
/// half-open, within options.box): the bricks whose palettes hold a selected label, in groups of
/// 26-connected bricks, merged until no two groups' boxes overlap, each the box of its bricks.
/// No selected voxel of one box touches another box's, so meshes or images extracted box by box
/// are those of the whole selection, while a selection scattered over the volume never makes
/// one box of it (a label in two corners: two small boxes). More than `maxBoxes` groups: runs
/// of neighbours in Morton order joined into at most `maxBoxes` boxes (then merged where they
/// overlap). Empty: no brick holds a selected label. Errors as extractLabels' selection.
Result<std::vector<Box>> selectionBoxes(const CsgvFile& file, const ExtractOptions& options, size_t maxBoxes = 256);

/// Extracts the selection box by box (selectionBoxes within options.box; when no brick holds it,
/// one extraction of options.box, which says why or finds nothing): `take(result)` for each box's
/// non-empty result, in turn, so that one box's output can be dropped before the next is made.
/// options.progress spans all the boxes; `bricksDecoded` adds up what each decoded. The first
/// error (of an extraction or of `take`) ends it.
Status extractByBoxes(const CsgvFile& file, const ExtractOptions& options,
                      const std::function<Status(ExtractResult&)>& take, uint64_t* bricksDecoded = nullptr);

/// The corner geometry (CsgvFile::metadata's convention: origin at the minimum corner of node 0)
/// of an extracted image, so it overlays the volume: spacing times 2^lod, origin moved to the
/// output's first node.
Geometry extractGeometry(const Geometry& volumeCorner, uint32_t lod, const std::array<uint32_t, 3>& offset);

/// The labels of a relabelled file's attribute database for which the SQL condition `query` is
/// true (nonzero), e.g. `voxels > 1000 and kind = 'a'`: SQLite evaluates it over one row per
/// label with the database's columns, `label` and `csgv_id` (addDerivedAttribute's rules and
/// budget). An error when the file has no database or the condition is not valid SQL.
Result<std::vector<int64_t>> labelsMatchingQuery(const CsgvFile& file, const std::string& query);

} // namespace csgv
