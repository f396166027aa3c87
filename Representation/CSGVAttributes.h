// SPDX-License-Identifier: MIT
/**
 * @file CSGVAttributes.h
 * @brief Per-label attributes of the "Segmentation Volume" representation: the table behind
 * materials, picking and the colour export, built from the input's `CSGVAttribute:*` FieldData
 * arrays (the reader's `_csgv.db3` columns), attribute files the user loads (CSV, whitespace
 * tables, SQLite), computed attributes (Core's computeAttributes, once per volume) and derived
 * attributes (SQL expressions), in that order, later sources replacing columns of the same name.
 *
 * The table is keyed by original label (Core's AttributeTable); the renderer gets dense float
 * arrays indexed by the value the volume stores (ids of relabelled volumes).
 *
 * Not a wrapped header: Core types appear here.
 */
#ifndef CSGVAttributes_h
#define CSGVAttributes_h

#include "CSGVVolumeCache.h"

#include "csgv/attributes/Attributes.h"
#include "csgv/materials/Materials.h"

#include <nlohmann/json_fwd.hpp>
#include <vtkType.h>

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

class vtkImageData;

namespace csgvrep
{

/// @brief What the representation's attribute properties say.
struct AttributeConfig
{
  std::vector<std::string> files;                           ///< CSV/TXT/SQLite paths
  std::vector<std::pair<std::string, std::string>> derived; ///< name, SQL expression
  bool computed = false;
  bool operator==(const AttributeConfig& o) const
  {
    return files == o.files && derived == o.derived && computed == o.computed;
  }
  bool operator!=(const AttributeConfig& o) const { return !(*this == o); }
};

/// @brief The attribute table of one input under one configuration, rebuilt only when the
/// volume, its FieldData or the configuration change.
class AttributeCache
{
public:
  /// The table, with `error` saying which sources (a file, computed or derived attributes) were
  /// left out of it; nullptr with `error` set when there is none (no input, unreadable FieldData).
  std::shared_ptr<const csgv::AttributeTable> get(
    vtkImageData* image, const VolumeSource& source, const AttributeConfig& config, std::string& error);

private:
  const SharedVolume* Volume = nullptr;
  const void* Computed = nullptr; ///< the volume's computed table when built (ranks replace it)
  std::string FieldTime; ///< fieldSignature: what the table read of the field data
  AttributeConfig Config;
  std::shared_ptr<const csgv::AttributeTable> Table;
  std::string Error;
  bool Valid = false;
};

/// Dense float arrays, indexed by stored label, of the named attributes (`label` skipped).
/// Returns an error message or "".
std::string denseColumns(const csgv::AttributeTable& table, const SharedVolume& volume,
  const std::vector<std::string>& names, std::map<std::string, std::vector<float>>& out);

/// Distinct stored labels of the volume (from the finest brick palettes, no decoding; an MPI
/// rank's piece: of its own bricks), ascending, at most `cap` (truncated says whether there were
/// more).
std::vector<uint32_t> storedLabels(const SharedVolume& volume, size_t cap, bool& truncated);

/// Exact computed-attribute sums of an MPI rank's own bricks (SharedVolume::owned), with the
/// volume's voxel indices (csgv::computeAttributeSums): what the ranks add up.
csgv::Result<csgv::AttributeSums> ownedAttributeSums(
  const SharedVolume& volume, const csgv::ComputeAttributesOptions& options);

/// The original label of a stored value.
int64_t originalLabel(const SharedVolume& volume, uint32_t stored);

/// Whether the renderer draws a relabelled volume's ids (0, 1, 2, ...) rather than its labels:
/// originals that do not fit 32 bits (negative, 64-bit) cannot be named in a material document,
/// so materials, selections, label images and a pick's "label" name the ids there, and a pick
/// adds the voxel's "original" label (README, "Labels beyond 32 bits").
bool drawsIds(const SharedVolume& volume);

/// The label materials name for a stored value: the id where drawsIds, else the original label.
int64_t drawnLabel(const SharedVolume& volume, uint32_t stored);

/// The original label as JSON: unsigned where the originals were unsigned 64-bit labels.
nlohmann::json originalLabelJson(const SharedVolume& volume, uint32_t stored);

/// The attribute function materials are evaluated with over drawn labels (drawnLabel): where the
/// volume draws ids, an id's row is its original label's.
csgv::MaterialEvaluator::AttributeFn drawnAttributes(const csgv::AttributeTable& table, const SharedVolume& volume);

/// JSON: {"attributes": [{"name", "numeric", "min", "max"}...], "error": "..."}; `label` first,
/// its range from the volume's palettes.
std::string attributeSummary(const csgv::AttributeTable* table, const SharedVolume* volume,
  const std::string& labelArray, const std::string& error);

/// JSON object {name: number|text|null} of one label's attributes.
std::string labelAttributesJson(const csgv::AttributeTable* table, int64_t label);

/// JSON: {"labels": [[label, r, g, b, "text"], ...], "truncated": bool, "text": "name"}: the
/// colour each label present in the volume takes under the materials (labels no material takes,
/// or a fully transparent one, are left out: they are not drawn), with the first text attribute (`name` preferred) as annotation.
std::string labelColorsJson(const csgv::MaterialDocument& doc, const csgv::AttributeTable* table,
  const SharedVolume& volume, size_t cap);
/// `span` query: the range of `attribute` over the labels present whose `filter` attribute lies in
/// [lo, hi] (what a material's filter holds), `{"min", "max", "labels": count}` (null ends when
/// none): the interval a material keeps its labels with when its filter attribute changes.
std::string attributeSpanJson(const csgv::AttributeTable* table, const SharedVolume& volume,
  const std::string& attribute, const std::string& filter, double lo, double hi);

} // namespace csgvrep

#endif
