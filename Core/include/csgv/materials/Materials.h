// SPDX-License-Identifier: MIT
#pragma once
/// @file Materials.h
/// @brief The material document of shared/MATERIALS.md: one JSON schema for the backend,
/// `csgv render`, pvpython and the Qt editor. Parsing is strict (unknown keys and wrong types are
/// errors naming the place), missing keys take the documented defaults, and a CPU reference
/// evaluates which material a label takes and its colour, so every layer agrees with the GPU.
///
/// Decisions where MATERIALS.md is silent:
/// - `filter` may be omitted: then the filter is `label` in [1, 4294967294] (every non-zero label).
/// - `color` may be omitted: then it is `{"mode": "random"}`.
/// - Colormap control points need x strictly increasing from 0 to 1 (first 0, last 1); a name
///   must be resolved to points before rendering (built-in names: builtinColormap()).
/// - `random` places a label on the colormap at hash(label) / 2^32 (a fixed 32-bit mix), so a
///   label has the same colour in every view and session; without a colormap it takes one of 16
///   fixed high-contrast colours by the same hash.
/// - `emission` is a float: a value beyond the largest float (about 3.4e38) is an error.
/// - Values a half-finished edit leaves (filter min > max, a colour interval with min == max) are
///   not parse errors: the material stays in the document, materialProblem() says why it cannot
///   be drawn and drawableMaterials() leaves it out, so the rest of the volume keeps drawing.
/// - Two optional top-level keys overlay label visibility on the materials, so that hiding and
///   isolating labels (the pick panel) never rewrites the user's materials: `"hidden": [labels]`
///   (these labels are not drawn) and `"only": [labels]` (when not empty, no other label is
///   drawn). Labels are integers in [0, 4294967294]; both default to empty and are written only
///   when not empty. A label in both is hidden. effectiveMaterials() turns a document with an
///   overlay into the plain one the renderer draws.
/// - The label selection (issue 41) is a third overlay: `"selected": [labels]` (sorted, unique, as
///   the other two), shown in the style `"selectionStyle"`: `"highlight"` (the default: selected
///   labels drawn opaque in `"selectionColor"`, default [1, 0, 1], ParaView's selection magenta)
///   or `"dim"` (selected labels keep their look, every other label's opacity is multiplied by
///   kDimmedOpacity). Only labels the document draws are shown selected: a hidden label stays
///   hidden. The keys are written only when they differ from the defaults.

#include "csgv/base/Status.h"

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace csgv {

/// The largest label a document can name: 0xFFFFFFFF is the format's reserved "no label".
constexpr double kMaxMaterialLabel = 4294967294.0;

/// @brief Control points [x, r, g, b], x strictly increasing over [0, 1].
struct Colormap {
    std::string name; ///< the preset name it came from ("" for explicit points)
    std::vector<std::array<float, 4>> points;
    bool empty() const { return points.empty(); }
    /// Linear interpolation at t (clamped to [0, 1]).
    std::array<float, 3> at(double t) const;
};

struct Material {
    enum class ColorMode { Constant, Colormap, Random };
    enum class Wrap { Clamp, Repeat };

    std::string name;
    std::string filterAttribute = "label";
    double filterMin = 1, filterMax = kMaxMaterialLabel;
    ColorMode colorMode = ColorMode::Random;
    std::array<float, 3> rgb{{1, 1, 1}};    ///< constant
    std::string colorAttribute = "label";  ///< colormap
    double colorMin = 0, colorMax = 1;     ///< colormap
    Wrap wrap = Wrap::Clamp;               ///< colormap
    Colormap colormap;                     ///< colormap (required) and random (optional)
    float opacity = 1;
    float emission = 0;
};

/// The most labels one overlay list ("hidden", "only", "selected") may hold: each run of
/// scattered labels becomes a material of its own on the device.
constexpr size_t kMaxOverlayLabels = 1000000;
/// The opacity factor of the labels that are not selected in the selection style "dim".
constexpr float kDimmedOpacity = 0.15f;

struct MaterialDocument {
    enum class SelectionStyle { Highlight, Dim };

    int version = 1;
    std::vector<Material> materials;
    std::vector<uint32_t> hidden; ///< labels not drawn whatever material takes them (sorted, unique)
    std::vector<uint32_t> only;   ///< when not empty, the only labels drawn (sorted, unique)
    std::vector<uint32_t> selected; ///< the label selection, shown in selectionStyle (sorted, unique)
    SelectionStyle selectionStyle = SelectionStyle::Highlight;
    std::array<float, 3> selectionColor{{1, 0, 1}}; ///< "highlight": the selected labels' colour
};

/// Parses a document; errors name the material (its number in the list, from 1, and its name) and
/// the key. Structure is checked here; drawability is materialProblem()'s.
Result<MaterialDocument> parseMaterials(const std::string& json);
/// The text of a material property: blank text is the default document, anything else must parse.
Result<MaterialDocument> parseMaterialsOrDefault(const std::string& json);
/// Writes a document that parseMaterials() reads back unchanged: every key written, numbers in
/// their shortest form; `indent` < 0 writes one compact line (the editor's property text).
std::string serializeMaterials(const MaterialDocument& doc, int indent = 2);
/// One material named "all": every non-zero label, random colours, opaque.
MaterialDocument defaultMaterials();

/// A label's value of a non-`label` attribute for hideLabel() and showOnlyLabel(); NaN (or no
/// function at all) when unknown.
using LabelAttributeFn = std::function<double(const std::string& attribute)>;
/// Hides `label` (the pick panel's "Hide this label"). Materials filtering on `label` whose
/// interval holds it are split around it in place, so the volume stays in the opaque pass; when a
/// material filtering on another attribute holds it, or may (its value is unknown), a first
/// material "hidden <label>" takes it with opacity 0. Other materials are kept as they are.
void hideLabel(MaterialDocument& doc, uint64_t label, const LabelAttributeFn& attribute = {});
/// Leaves only `label` visible ("Show only this label"): the first material whose filter holds it
/// now, its filter narrowed to `label` in [label, label], is the only material; when none holds it,
/// one material "label <label>" with the default (random, opaque) look.
void showOnlyLabel(MaterialDocument& doc, uint64_t label, const LabelAttributeFn& attribute = {});
/// Label visibility over the materials (the keys "hidden" and "only"); the materials list is
/// never touched, so "Show all" gives back exactly the user's materials.
/// Hides `label`: adds it to "hidden".
void hideLabelOver(MaterialDocument& doc, uint32_t label);
/// Shows only `label`: "only" becomes [label] and the label leaves "hidden".
void showOnlyLabelOver(MaterialDocument& doc, uint32_t label);
/// Shows every label the materials take: clears "hidden" and "only".
void showAllLabels(MaterialDocument& doc);
/// The label selection: `labels` (any order, repeats) replace it, are added to it or are removed
/// from it; the style and colour stay.
enum class SelectionEdit { Replace, Add, Remove };
void editSelection(MaterialDocument& doc, const std::vector<uint32_t>& labels, SelectionEdit edit);
/// The plain document (no overlay) that draws what `doc` means: with "only", one material per run
/// of consecutive shown labels taking the same material, narrowed to them (the materials each
/// label takes under `attribute`, as MaterialEvaluator decides); then each hidden label removed
/// as hideLabel() does, its attribute values from `attribute` (an empty function: unknown).
/// Then the selection: in front, one material per run of consecutive selected labels that this
/// document draws (a material of non-zero opacity takes them) and that take the same material:
/// "highlight" gives them selectionColor, opaque; "dim" keeps their material, narrowed to them,
/// and every material after them has its opacity multiplied by kDimmedOpacity.
/// Without an overlay, the materials as they are. This is the document the renderer and the
/// label-colour query use.
MaterialDocument effectiveMaterials(const MaterialDocument& doc,
                                    const std::function<double(const std::string&, uint32_t)>& attribute);
/// Every attribute a document names, once each, in order of first use.
std::vector<std::string> attributesUsed(const MaterialDocument& doc);
/// An error naming the first attribute that `available` lacks.
Status checkAttributes(const MaterialDocument& doc, const std::vector<std::string>& available);
/// Why a material cannot be drawn as it stands, "" when it can: values a half-finished edit leaves
/// (filter min > max, a colormap's colour min == max), which parseMaterials() accepts so the
/// material stays in the document, and, when `availableAttributes` is given, an attribute other
/// than `label` that the list lacks.
std::string materialProblem(const Material& m, const std::vector<std::string>* availableAttributes = nullptr);
/// The document without the materials materialProblem() refuses, so the rest of the volume keeps
/// drawing; each skipped one adds a reason to `skippedReasons` (when given), naming it as the
/// editor's list does ("material 2 ('vessels'): filter min 5 is greater than max 3; not drawn").
MaterialDocument drawableMaterials(const MaterialDocument& doc, const std::vector<std::string>* availableAttributes,
                                   std::vector<std::string>* skippedReasons);
/// Replaces colormap names by control points (built-in names; others are an error naming them).
Status resolveColormapNames(MaterialDocument& doc);
/// "Viridis (matplotlib)", "Turbo", "Cool to Warm", "Grayscale".
Result<Colormap> builtinColormap(const std::string& name);
std::vector<std::string> builtinColormapNames();

/// The labels a material filtering on `label` holds, as integers: [ceil(max(min, 0)),
/// floor(min(max, 2^32 - 1))], or {1, 0} (none) when that is empty or a bound is NaN. The CPU
/// evaluator and the renderer's packed materials compare labels against this one interval.
std::pair<uint64_t, uint64_t> labelInterval(const Material& m);

/// @brief The first of a list of closed intervals that holds a value, in O(log n): the leading
/// materials that filter on `label` (the overlays put one per run of labels there: a selection or
/// "only" of 100,000 scattered labels makes as many) would otherwise be scanned per label.
class FirstInterval {
public:
    FirstInterval() = default;
    /// `intervals` [lo, hi] in order (lo > hi: empty; hi is taken as at most 2^62); the first that
    /// holds a value is its answer.
    explicit FirstInterval(const std::vector<std::pair<uint64_t, uint64_t>>& intervals);
    /// The index of the first interval holding `v`, or -1.
    int64_t find(uint64_t v) const;
    size_t size() const { return m_intervals; }

private:
    struct Piece {
        uint64_t lo, hi;
        uint32_t index;
    };
    std::vector<Piece> m_pieces; ///< disjoint, ascending: where each interval is the first
    size_t m_intervals = 0;
};

/// @brief CPU reference of material evaluation. `attribute(name, label)` gives a label's value of
/// an attribute ("label" is the label itself).
class MaterialEvaluator {
public:
    using AttributeFn = std::function<double(const std::string& attribute, uint32_t label)>;
    MaterialEvaluator(const MaterialDocument& doc, AttributeFn attribute);
    /// Index of the first material whose closed filter interval holds the label, or -1 (invisible).
    int materialOf(uint32_t label) const;
    /// Colour of a label under material m.
    std::array<float, 3> colorOf(uint32_t label, int m) const;

private:
    const MaterialDocument& m_doc;
    AttributeFn m_attribute;
    FirstInterval m_leading; ///< the leading materials that filter on `label`
};

/// The stable 32-bit hash that places labels for `random` colouring.
uint32_t labelHash(uint32_t label);

} // namespace csgv
