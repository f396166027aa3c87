// SPDX-License-Identifier: MIT
#include "csgv/materials/Materials.h"
#include "csgv/materials/Palette.h"
#include "../base/JsonText.h"

#include <algorithm>
#include <set>
#include <charconv>
#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>

namespace csgv {

using nlohmann::json;

namespace {

/// A material as the editor's list numbers it (from 1), with its name.
std::string where(size_t i, const std::string& name) {
    return "material " + std::to_string(i + 1) + (name.empty() ? "" : " ('" + name + "')");
}

/// Refuses keys outside `allowed`, naming the first one.
Status onlyKeys(const json& obj, std::initializer_list<const char*> allowed, const std::string& context) {
    for (auto it = obj.begin(); it != obj.end(); ++it) {
        bool ok = false;
        for (const char* a : allowed) ok = ok || it.key() == a;
        if (!ok) {
            std::string list;
            for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
            return Status::error(context + ": unknown key '" + it.key() + "' (allowed: " + list + ")");
        }
    }
    return Status::ok();
}

Status number(const json& obj, const char* key, double& out, const std::string& context) {
    if (!obj.contains(key)) return Status::ok();
    if (!obj[key].is_number() || !std::isfinite(obj[key].get<double>()))
        return Status::error(context + ": '" + key + "' must be a finite number, not " + jsonText(obj[key]));
    out = obj[key].get<double>();
    return Status::ok();
}

Status text(const json& obj, const char* key, std::string& out, const std::string& context) {
    if (!obj.contains(key)) return Status::ok();
    if (!obj[key].is_string()) return Status::error(context + ": '" + key + "' must be a string, not " + jsonText(obj[key]));
    out = obj[key].get<std::string>();
    return Status::ok();
}

Status parseColormap(const json& v, Colormap& out, const std::string& context) {
    out = Colormap{};
    if (v.is_string()) {
        out.name = v.get<std::string>();
        if (out.name.empty()) return Status::error(context + ": colormap name is empty");
        return Status::ok();
    }
    if (!v.is_array() || v.size() < 2)
        return Status::error(context + ": colormap must be a name or at least two points [x, r, g, b]");
    for (size_t i = 0; i < v.size(); ++i) {
        const json& p = v[i];
        if (!p.is_array() || p.size() != 4)
            return Status::error(context + ": colormap point " + std::to_string(i) + " must be [x, r, g, b]");
        std::array<float, 4> q{};
        for (size_t k = 0; k < 4; ++k) {
            if (!p[k].is_number()) return Status::error(context + ": colormap point " + std::to_string(i) + " holds a non-number");
            const double d = p[k].get<double>();
            if (!(d >= 0 && d <= 1))
                return Status::error(context + ": colormap point " + std::to_string(i) + " has " + jsonText(p[k]) +
                                     " outside [0, 1]");
            q[k] = float(d);
        }
        if (!out.points.empty() && q[0] <= out.points.back()[0])
            return Status::error(context + ": colormap x values must increase (point " + std::to_string(i) + ")");
        out.points.push_back(q);
    }
    if (out.points.front()[0] != 0.0f || out.points.back()[0] != 1.0f)
        return Status::error(context + ": colormap x values must run from 0 to 1");
    return Status::ok();
}

Status parseMaterial(const json& m, size_t index, Material& out) {
    if (!m.is_object()) return Status::error(where(index, "") + " must be an object");
    std::string ctx = where(index, "");
    Status s = text(m, "name", out.name, ctx);
    if (!s) return s;
    ctx = where(index, out.name);
    if (!(s = onlyKeys(m, {"name", "filter", "color", "opacity", "emission"}, ctx))) return s;
    if (m.contains("filter")) {
        const json& f = m["filter"];
        const std::string fc = ctx + ", filter";
        if (!f.is_object()) return Status::error(fc + " must be an object");
        if (!(s = onlyKeys(f, {"attribute", "min", "max"}, fc))) return s;
        if (!(s = text(f, "attribute", out.filterAttribute, fc))) return s;
        if (!(s = number(f, "min", out.filterMin, fc))) return s;
        if (!(s = number(f, "max", out.filterMax, fc))) return s;
        if (out.filterAttribute.empty()) return Status::error(fc + ": 'attribute' is empty");
        // min > max is a value a half-finished edit produces: materialProblem() reports it.
    }
    if (m.contains("color")) {
        const json& c = m["color"];
        const std::string cc = ctx + ", color";
        if (!c.is_object()) return Status::error(cc + " must be an object");
        std::string mode = "random";
        if (!(s = text(c, "mode", mode, cc))) return s;
        if (mode == "constant") {
            out.colorMode = Material::ColorMode::Constant;
            if (!(s = onlyKeys(c, {"mode", "rgb"}, cc + " (constant)"))) return s;
            if (!c.contains("rgb")) return Status::error(cc + ": constant colour needs 'rgb'");
            const json& rgb = c["rgb"];
            if (!rgb.is_array() || rgb.size() != 3) return Status::error(cc + ": 'rgb' must be three numbers in [0, 1]");
            for (size_t k = 0; k < 3; ++k) {
                if (!rgb[k].is_number() || !(rgb[k].get<double>() >= 0 && rgb[k].get<double>() <= 1))
                    return Status::error(cc + ": 'rgb' must be three numbers in [0, 1], not " + jsonText(rgb));
                out.rgb[k] = rgb[k].get<float>();
            }
        } else if (mode == "colormap") {
            out.colorMode = Material::ColorMode::Colormap;
            if (!(s = onlyKeys(c, {"mode", "attribute", "min", "max", "wrap", "colormap"}, cc + " (colormap)"))) return s;
            if (!(s = text(c, "attribute", out.colorAttribute, cc))) return s;
            if (!(s = number(c, "min", out.colorMin, cc))) return s;
            if (!(s = number(c, "max", out.colorMax, cc))) return s;
            // min == max: materialProblem() reports it (the material stays in the document).
            std::string wrap = "clamp";
            if (!(s = text(c, "wrap", wrap, cc))) return s;
            if (wrap == "clamp") out.wrap = Material::Wrap::Clamp;
            else if (wrap == "repeat") out.wrap = Material::Wrap::Repeat;
            else return Status::error(cc + ": 'wrap' is '" + wrap + "', expected clamp or repeat");
            if (!c.contains("colormap")) return Status::error(cc + ": colormap colour needs 'colormap'");
            if (!(s = parseColormap(c["colormap"], out.colormap, cc))) return s;
        } else if (mode == "random") {
            out.colorMode = Material::ColorMode::Random;
            if (!(s = onlyKeys(c, {"mode", "colormap"}, cc + " (random)"))) return s;
            if (c.contains("colormap") && !(s = parseColormap(c["colormap"], out.colormap, cc))) return s;
        } else {
            return Status::error(cc + ": 'mode' is '" + mode + "', expected constant, colormap or random");
        }
    }
    double opacity = 1, emission = 0;
    if (!(s = number(m, "opacity", opacity, ctx))) return s;
    if (!(s = number(m, "emission", emission, ctx))) return s;
    if (opacity < 0 || opacity > 1) return Status::error(ctx + ": 'opacity' must lie in [0, 1]");
    if (emission < 0) return Status::error(ctx + ": 'emission' must not be negative");
    // Kept as a float: a larger value would become infinity, which JSON cannot write back.
    if (emission > double(std::numeric_limits<float>::max()))
        return Status::error(ctx + ": 'emission' " + jsonText(m["emission"]) + " is too large");
    out.opacity = float(opacity);
    out.emission = float(emission);
    return Status::ok();
}

/// A float as the double of its shortest decimal form, so 0.35f is written "0.35", not
/// "0.3499999940395355", and state files stay readable (the value reads back to the same float).
double shortest(float f) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, f);
    double d = f;
    std::from_chars(buf, r.ptr, d);
    return d;
}

json colormapJson(const Colormap& c) {
    if (c.points.empty()) return c.name;
    json pts = json::array();
    for (const auto& p : c.points) pts.push_back({shortest(p[0]), shortest(p[1]), shortest(p[2]), shortest(p[3])});
    return pts;
}

Material labelOnly(Material m, double label) {
    m.filterAttribute = "label";
    m.filterMin = m.filterMax = label;
    return m;
}

/// The value a material filters on for a label: the label itself, the caller's value, or NaN.
double filterValue(const Material& m, uint64_t label, const LabelAttributeFn& attribute) {
    if (m.filterAttribute == "label") return double(label);
    return attribute ? attribute(m.filterAttribute) : std::numeric_limits<double>::quiet_NaN();
}

/// A label list of the visibility overlay ("hidden", "only"): integers in [0, kMaxMaterialLabel],
/// kept sorted and unique (order and repeats mean nothing).
Status labelList(const json& j, const char* key, std::vector<uint32_t>& out) {
    if (!j.contains(key)) return Status::ok();
    const std::string ctx = std::string("material document: '") + key + "'";
    if (!j[key].is_array()) return Status::error(ctx + " must be a list of labels, not " + jsonText(j[key]));
    if (j[key].size() > kMaxOverlayLabels)
        return Status::error(ctx + " lists " + std::to_string(j[key].size()) + " labels, more than " +
                             std::to_string(kMaxOverlayLabels) + " (each run of them is drawn as a material of its own)");
    for (const json& v : j[key]) {
        const bool integral = v.is_number_integer() || (v.is_number_float() && std::floor(v.get<double>()) == v.get<double>());
        if (!integral || !(v.get<double>() >= 0 && v.get<double>() <= kMaxMaterialLabel))
            return Status::error(ctx + " holds " + jsonText(v) + ": labels are integers in [0, 4294967294]");
        out.push_back(uint32_t(v.get<double>()));
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return Status::ok();
}

bool holds(const std::vector<uint32_t>& sorted, uint32_t label) {
    return std::binary_search(sorted.begin(), sorted.end(), label);
}

void insertSorted(std::vector<uint32_t>& sorted, uint32_t label) {
    const auto it = std::lower_bound(sorted.begin(), sorted.end(), label);
    if (it == sorted.end() || *it != label) sorted.insert(it, label);
}

/// "only" applied: each shown label in the material that takes it, narrowed to it; consecutive
/// labels taking the same material share one interval (colours are per label either way).
std::vector<Material> onlyMaterials(const MaterialDocument& doc, const MaterialEvaluator& evaluator) {
    std::vector<Material> out;
    int last = -1;
    for (uint32_t x : doc.only) {
        if (holds(doc.hidden, x)) continue;
        const int m = evaluator.materialOf(x);
        if (m < 0) continue;
        if (m == last && out.back().filterMax == double(x) - 1) {
            out.back().filterMax = double(x);
            continue;
        }
        out.push_back(labelOnly(doc.materials[size_t(m)], double(x)));
        last = m;
    }
    return out;
}

/// What hideLabel() applied to each of `hidden` (sorted) in turn draws, in one pass. Hiding them
/// one by one walked every material per label while the label intervals kept splitting, which was
/// quadratic (12,000 hidden labels splitting one interval took over 10 s), and every material
/// filtering on `label` was split around every hidden label it holds, so that a 11 KB document of
/// 1500 overlapping materials and 1500 hidden labels made 2.25 million materials (1.3 GB). Here a
/// material filtering on `label` that holds no hidden label stays as it is; one that holds some is
/// replaced by the runs of labels it holds that no earlier such material holds (those take an
/// earlier one, which a label's first matching material is), less the hidden labels: so each
/// hidden label splits one run, and there are at most as many runs as materials plus hidden
/// labels. Each hidden label that a material filtering on another attribute may take gets a
/// first material "hidden <label>", the largest label first (as hideLabel inserts each at the
/// front). The labels every material draws, and how, are hideLabel's.
std::vector<Material> hideLabels(const std::vector<Material>& materials, const std::vector<uint32_t>& hidden,
                                 const std::function<double(const std::string&, uint32_t)>& value) {
    if (hidden.empty()) return materials;
    std::vector<Material> out;
    std::map<double, double> taken; // labels [first, second] that earlier `label` materials hold (disjoint)
    const auto firstHidden = [&hidden](double v) {
        return std::lower_bound(hidden.begin(), hidden.end(), v, [](uint32_t h, double x) { return double(h) < x; });
    };
    for (const Material& m : materials) {
        if (m.filterAttribute != "label") {
            out.push_back(m);
            continue;
        }
        const double lo = std::max(0.0, std::ceil(m.filterMin)), hi = std::min(kMaxMaterialLabel, std::floor(m.filterMax));
        if (lo > hi || firstHidden(lo) == hidden.end() || double(*firstHidden(lo)) > hi) {
            out.push_back(m); // holds no hidden label (or no label at all)
        } else {
            // The runs of [lo, hi] that no earlier material holds, each less its hidden labels.
            auto it = taken.upper_bound(lo);
            if (it != taken.begin() && std::prev(it)->second >= lo) --it;
            double from = lo;
            const auto emitRun = [&](double a, double b) {
                for (auto h = firstHidden(a); h != hidden.end() && double(*h) <= b; ++h) {
                    if (a <= double(*h) - 1) {
                        out.push_back(m);
                        out.back().filterMin = a;
                        out.back().filterMax = double(*h) - 1;
                    }
                    a = double(*h) + 1;
                }
                if (a <= b) {
                    out.push_back(m);
                    out.back().filterMin = a;
                    out.back().filterMax = b;
                }
            };
            for (; from <= hi && it != taken.end() && it->first <= hi; ++it) {
                if (it->first > from) emitRun(from, it->first - 1);
                from = std::max(from, it->second + 1);
            }
            if (from <= hi) emitRun(from, hi);
        }
        if (lo > hi) continue;
        // [lo, hi] joins the labels taken, merged with the runs it overlaps or touches.
        double a = lo, b = hi;
        auto j = taken.lower_bound(a);
        if (j != taken.begin() && std::prev(j)->second + 1 >= a) --j;
        while (j != taken.end() && j->first <= b + 1) {
            a = std::min(a, j->first);
            b = std::max(b, j->second);
            j = taken.erase(j);
        }
        taken[a] = b;
    }
    std::vector<Material> first;
    for (auto x = hidden.rbegin(); x != hidden.rend(); ++x) {
        const bool mayTake = std::any_of(materials.begin(), materials.end(), [&](const Material& m) {
            if (m.filterAttribute == "label") return false;
            const double v = value(m.filterAttribute, *x);
            return !(v < m.filterMin || v > m.filterMax); // NaN (unknown) counts as "may"
        });
        if (!mayTake) continue;
        Material h;
        h.name = "hidden " + std::to_string(*x);
        h.colorMode = Material::ColorMode::Constant;
        h.rgb = {{0, 0, 0}};
        h.opacity = 0;
        first.push_back(labelOnly(h, double(*x)));
    }
    out.insert(out.begin(), first.begin(), first.end());
    return out;
}

} // namespace

std::array<float, 3> Colormap::at(double t) const {
    if (points.empty()) return {{1, 1, 1}};
    t = std::isnan(t) ? 0.0 : std::clamp(t, 0.0, 1.0); // clamp keeps a NaN
    size_t i = 1;
    while (i + 1 < points.size() && points[i][0] < t) ++i;
    const auto& a = points[i - 1];
    const auto& b = points[i];
    const double span = b[0] - a[0];
    const double u = span > 0 ? std::clamp((t - a[0]) / span, 0.0, 1.0) : 0.0;
    return {{float(a[1] + (b[1] - a[1]) * u), float(a[2] + (b[2] - a[2]) * u), float(a[3] + (b[3] - a[3]) * u)}};
}

uint32_t labelHash(uint32_t x) { return layout::labelHash(x); } // Palette.h, shared with the GPU

/// "selectionStyle" ("highlight" or "dim") and "selectionColor" ([r, g, b] in [0, 1]).
Status parseSelectionLook(const json& j, MaterialDocument& doc) {
    if (j.contains("selectionStyle")) {
        const json& v = j["selectionStyle"];
        if (v == "highlight") doc.selectionStyle = MaterialDocument::SelectionStyle::Highlight;
        else if (v == "dim") doc.selectionStyle = MaterialDocument::SelectionStyle::Dim;
        else return Status::error("material document: 'selectionStyle' must be \"highlight\" or \"dim\", not " + jsonText(v));
    }
    if (j.contains("selectionColor")) {
        const json& v = j["selectionColor"];
        bool ok = v.is_array() && v.size() == 3;
        for (size_t i = 0; ok && i < 3; ++i) {
            ok = v[i].is_number() && v[i].get<double>() >= 0 && v[i].get<double>() <= 1;
            if (ok) doc.selectionColor[i] = float(v[i].get<double>());
        }
        if (!ok) return Status::error("material document: 'selectionColor' must be [r, g, b] in [0, 1], not " + jsonText(v));
    }
    return Status::ok();
}

Result<MaterialDocument> parseMaterials(const std::string& text) {
    const std::string deep = jsonTooDeep(text.data(), text.size());
    if (!deep.empty()) return Status::error("material document: " + deep);
    json j;
    // A key given twice in one object is an error, not "the last one wins" (found by an attack
    // pass: "version": 1, "version": 2 said "unsupported version 2").
    std::vector<std::set<std::string>> keys; // of each open object
    std::string twice;
    const json::parser_callback_t seen = [&](int, json::parse_event_t event, json& parsed) {
        if (event == json::parse_event_t::object_start) keys.emplace_back();
        else if (event == json::parse_event_t::object_end && !keys.empty()) keys.pop_back();
        else if (event == json::parse_event_t::key && !keys.empty() && parsed.is_string() &&
                 !keys.back().insert(parsed.get<std::string>()).second && twice.empty())
            twice = parsed.get<std::string>();
        return true;
    };
    try {
        j = json::parse(text, seen);
    } catch (const json::parse_error& e) {
        // Where it went wrong ("parse error at line 3, column 17: syntax error while parsing object
        // key - ..."), without the library's prefix, cut at a line's length.
        std::string why = e.what();
        const size_t at = why.find("] ");
        if (at != std::string::npos) why.erase(0, at + 2);
        if (why.size() > 200) why = why.substr(0, 200) + "...";
        return Status::error("material document: not valid JSON (" + why + ")");
    }
    if (!twice.empty())
        return Status::error("material document: the key " + jsonText(json(twice)) + " appears twice in one object");
    if (!j.is_object()) return Status::error("material document: must be a JSON object");
    Status s = onlyKeys(j, {"version", "materials", "hidden", "only", "selected", "selectionStyle", "selectionColor"},
                        "material document");
    if (!s) return s;
    MaterialDocument doc;
    if (j.contains("version")) {
        if (!j["version"].is_number_integer() || j["version"].get<int64_t>() != 1)
            return Status::error("material document: unsupported version " + jsonText(j["version"]) + " (expected 1)");
    }
    if (!(s = labelList(j, "hidden", doc.hidden))) return s;
    if (!(s = labelList(j, "only", doc.only))) return s;
    if (!(s = labelList(j, "selected", doc.selected))) return s;
    if (!(s = parseSelectionLook(j, doc))) return s;
    if (!j.contains("materials")) {
        doc.materials = defaultMaterials().materials;
        return doc;
    }
    if (!j["materials"].is_array()) return Status::error("material document: 'materials' must be a list");
    for (size_t i = 0; i < j["materials"].size(); ++i) {
        Material m;
        if (!(s = parseMaterial(j["materials"][i], i, m))) return s;
        doc.materials.push_back(std::move(m));
    }
    return doc;
}

Result<MaterialDocument> parseMaterialsOrDefault(const std::string& text) {
    if (text.find_first_not_of(" \t\r\n") == std::string::npos) return defaultMaterials();
    return parseMaterials(text);
}

std::string serializeMaterials(const MaterialDocument& doc, int indent) {
    json out;
    out["version"] = 1;
    out["materials"] = json::array();
    for (const Material& m : doc.materials) {
        json jm;
        jm["name"] = m.name;
        jm["filter"] = {{"attribute", m.filterAttribute}, {"min", m.filterMin}, {"max", m.filterMax}};
        json c;
        switch (m.colorMode) {
        case Material::ColorMode::Constant:
            c = {{"mode", "constant"}, {"rgb", {shortest(m.rgb[0]), shortest(m.rgb[1]), shortest(m.rgb[2])}}};
            break;
        case Material::ColorMode::Colormap:
            c = {{"mode", "colormap"}, {"attribute", m.colorAttribute}, {"min", m.colorMin}, {"max", m.colorMax},
                 {"wrap", m.wrap == Material::Wrap::Clamp ? "clamp" : "repeat"}, {"colormap", colormapJson(m.colormap)}};
            break;
        case Material::ColorMode::Random:
            c = {{"mode", "random"}};
            if (!m.colormap.points.empty() || !m.colormap.name.empty()) c["colormap"] = colormapJson(m.colormap);
            break;
        }
        jm["color"] = c;
        jm["opacity"] = shortest(m.opacity);
        jm["emission"] = shortest(m.emission);
        out["materials"].push_back(jm);
    }
    // Written only when set, so documents without an overlay read as they always did.
    if (!doc.hidden.empty()) out["hidden"] = doc.hidden;
    if (!doc.only.empty()) out["only"] = doc.only;
    if (!doc.selected.empty()) out["selected"] = doc.selected;
    if (doc.selectionStyle != MaterialDocument::SelectionStyle::Highlight) out["selectionStyle"] = "dim";
    if (doc.selectionColor != MaterialDocument{}.selectionColor)
        out["selectionColor"] = {shortest(doc.selectionColor[0]), shortest(doc.selectionColor[1]), shortest(doc.selectionColor[2])};
    // Names set through an API (not parsed JSON) may hold bytes that are not UTF-8: U+FFFD, not a throw.
    return out.dump(indent, ' ', false, json::error_handler_t::replace);
}

MaterialDocument defaultMaterials() {
    MaterialDocument doc;
    Material m;
    m.name = "all";
    doc.materials.push_back(m);
    return doc;
}

void hideLabel(MaterialDocument& doc, uint64_t label, const LabelAttributeFn& attribute) {
    const double x = double(label);
    std::vector<Material> out;
    bool hiddenFirst = false;
    for (Material& m : doc.materials) {
        const double v = filterValue(m, label, attribute);
        if (m.filterAttribute == "label" && v >= m.filterMin && v <= m.filterMax) {
            // Split the interval around the label; both parts keep the material's place in the order.
            if (m.filterMin <= x - 1) {
                Material below = m;
                below.filterMax = x - 1;
                out.push_back(std::move(below));
            }
            if (x + 1 <= m.filterMax) {
                Material above = m;
                above.filterMin = x + 1;
                out.push_back(std::move(above));
            }
            continue;
        }
        // Another attribute: the label may be taken here (NaN, unknown, counts as "may").
        if (m.filterAttribute != "label" && !(v < m.filterMin || v > m.filterMax)) hiddenFirst = true;
        out.push_back(std::move(m));
    }
    if (hiddenFirst) {
        Material hidden;
        hidden.name = "hidden " + std::to_string(label);
        hidden.colorMode = Material::ColorMode::Constant;
        hidden.rgb = {{0, 0, 0}};
        hidden.opacity = 0;
        out.insert(out.begin(), labelOnly(hidden, x));
    }
    doc.materials = std::move(out);
}

void showOnlyLabel(MaterialDocument& doc, uint64_t label, const LabelAttributeFn& attribute) {
    const double x = double(label);
    for (const Material& m : doc.materials) {
        const double v = filterValue(m, label, attribute);
        if (v >= m.filterMin && v <= m.filterMax) {
            doc.materials = {labelOnly(m, x)};
            return;
        }
    }
    Material m;
    m.name = "label " + std::to_string(label);
    doc.materials = {labelOnly(m, x)};
}

void hideLabelOver(MaterialDocument& doc, uint32_t label) { insertSorted(doc.hidden, label); }

void showOnlyLabelOver(MaterialDocument& doc, uint32_t label) {
    doc.only = {label};
    doc.hidden.erase(std::remove(doc.hidden.begin(), doc.hidden.end(), label), doc.hidden.end());
}

void showAllLabels(MaterialDocument& doc) {
    doc.hidden.clear();
    doc.only.clear();
}

void editSelection(MaterialDocument& doc, const std::vector<uint32_t>& labels, SelectionEdit edit) {
    std::vector<uint32_t> sorted = labels;
    std::sort(sorted.begin(), sorted.end());
    sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
    std::vector<uint32_t> out;
    switch (edit) {
    case SelectionEdit::Replace: out = std::move(sorted); break;
    case SelectionEdit::Add:
        std::set_union(doc.selected.begin(), doc.selected.end(), sorted.begin(), sorted.end(), std::back_inserter(out));
        break;
    case SelectionEdit::Remove:
        std::set_difference(doc.selected.begin(), doc.selected.end(), sorted.begin(), sorted.end(), std::back_inserter(out));
        break;
    }
    doc.selected = std::move(out);
}

MaterialDocument effectiveMaterials(const MaterialDocument& doc,
                                    const std::function<double(const std::string&, uint32_t)>& attribute) {
    const auto value = [&attribute](const std::string& name, uint32_t label) {
        return attribute ? attribute(name, label) : std::numeric_limits<double>::quiet_NaN();
    };
    MaterialDocument out;
    out.version = doc.version;
    if (!doc.only.empty()) {
        // Hidden labels are skipped here, so nothing is left to hide.
        out.materials = onlyMaterials(doc, MaterialEvaluator(doc, value));
    } else {
        out.materials = hideLabels(doc.materials, doc.hidden, value);
    }
    if (doc.selected.empty()) return out;
    // The selection over what the overlay leaves drawn.
    const MaterialEvaluator drawn(out, value);
    std::vector<Material> front;
    int last = -1;
    for (uint32_t x : doc.selected) {
        const int m = drawn.materialOf(x);
        if (m < 0 || out.materials[size_t(m)].opacity <= 0) continue; // not drawn: not shown selected
        const bool highlight = doc.selectionStyle == MaterialDocument::SelectionStyle::Highlight;
        if ((highlight || m == last) && !front.empty() && front.back().filterMax == double(x) - 1) {
            front.back().filterMax = double(x);
            continue;
        }
        if (highlight) {
            Material h;
            h.name = "selected";
            h.colorMode = Material::ColorMode::Constant;
            h.rgb = doc.selectionColor;
            front.push_back(labelOnly(h, double(x)));
        } else {
            front.push_back(labelOnly(out.materials[size_t(m)], double(x)));
        }
        last = m;
    }
    if (doc.selectionStyle == MaterialDocument::SelectionStyle::Dim)
        for (Material& m : out.materials) m.opacity *= kDimmedOpacity;
    front.insert(front.end(), std::make_move_iterator(out.materials.begin()), std::make_move_iterator(out.materials.end()));
    out.materials = std::move(front);
    return out;
}

std::vector<std::string> attributesUsed(const MaterialDocument& doc) {
    std::vector<std::string> out;
    auto add = [&](const std::string& a) {
        if (std::find(out.begin(), out.end(), a) == out.end()) out.push_back(a);
    };
    for (const Material& m : doc.materials) {
        add(m.filterAttribute);
        if (m.colorMode == Material::ColorMode::Colormap) add(m.colorAttribute);
    }
    return out;
}

Status checkAttributes(const MaterialDocument& doc, const std::vector<std::string>& available) {
    for (const std::string& a : attributesUsed(doc)) {
        if (a == "label" || std::find(available.begin(), available.end(), a) != available.end()) continue;
        std::string list = "label";
        for (const std::string& b : available) list += ", " + b;
        return Status::error("material document names attribute '" + a + "', which the volume lacks (it has: " + list + ")");
    }
    return Status::ok();
}

namespace {

/// A double in its shortest decimal form, as the editor shows it.
std::string numberText(double v) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

/// Why an attribute a material names cannot be read: "" when it is `label` or available (or when
/// the caller knows no list).
std::string missingAttribute(const std::string& role, const std::string& attribute,
                             const std::vector<std::string>* available) {
    if (!available || attribute == "label") return {};
    if (std::find(available->begin(), available->end(), attribute) != available->end()) return {};
    return role + " attribute '" + attribute + "' is not available";
}

} // namespace

std::string materialProblem(const Material& m, const std::vector<std::string>* availableAttributes) {
    if (m.filterMin > m.filterMax)
        return "filter min " + numberText(m.filterMin) + " is greater than max " + numberText(m.filterMax);
    std::string missing = missingAttribute("filter", m.filterAttribute, availableAttributes);
    if (!missing.empty()) return missing;
    if (m.colorMode != Material::ColorMode::Colormap) return {};
    if (m.colorMin == m.colorMax) return "colour min equals max (" + numberText(m.colorMin) + ")";
    return missingAttribute("colour", m.colorAttribute, availableAttributes);
}

MaterialDocument drawableMaterials(const MaterialDocument& doc, const std::vector<std::string>* availableAttributes,
                                   std::vector<std::string>* skippedReasons) {
    MaterialDocument out = doc; // every other key of the document as it is
    out.materials.clear();
    for (size_t i = 0; i < doc.materials.size(); ++i) {
        const Material& m = doc.materials[i];
        const std::string problem = materialProblem(m, availableAttributes);
        if (problem.empty()) {
            out.materials.push_back(m);
        } else if (skippedReasons) {
            skippedReasons->push_back(where(i, m.name) + ": " + problem + "; not drawn");
        }
    }
    return out;
}

std::vector<std::string> builtinColormapNames() { return {"Viridis (matplotlib)", "Turbo", "Cool to Warm", "Grayscale"}; }

Result<Colormap> builtinColormap(const std::string& name) {
    Colormap c;
    c.name = name;
    if (name == "Viridis (matplotlib)") {
        c.points = {{0.0f, 0.267004f, 0.004874f, 0.329415f},   {0.125f, 0.282623f, 0.140926f, 0.457517f},
                    {0.25f, 0.229739f, 0.322361f, 0.545706f},  {0.375f, 0.172719f, 0.448791f, 0.557885f},
                    {0.5f, 0.127568f, 0.566949f, 0.550556f},   {0.625f, 0.157851f, 0.683765f, 0.501686f},
                    {0.75f, 0.369214f, 0.788888f, 0.382914f},  {0.875f, 0.678489f, 0.863742f, 0.189503f},
                    {1.0f, 0.993248f, 0.906157f, 0.143936f}};
    } else if (name == "Turbo") {
        // Google's polynomial approximation of Turbo, sampled at 17 points.
        for (int i = 0; i <= 16; ++i) {
            const double x = i / 16.0;
            auto poly = [x](double a, double b, double cc, double d, double e, double f) {
                return std::clamp(a + x * (b + x * (cc + x * (d + x * (e + x * f)))), 0.0, 1.0);
            };
            c.points.push_back({float(x), float(poly(0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943)),
                                float(poly(0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604)),
                                float(poly(0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973))});
        }
    } else if (name == "Cool to Warm") {
        c.points = {{0.0f, 0.231373f, 0.298039f, 0.752941f}, {0.5f, 0.865003f, 0.865003f, 0.865003f},
                    {1.0f, 0.705882f, 0.015686f, 0.149020f}};
    } else if (name == "Grayscale") {
        c.points = {{0.0f, 0.0f, 0.0f, 0.0f}, {1.0f, 1.0f, 1.0f, 1.0f}};
    } else {
        std::string list;
        for (const std::string& n : builtinColormapNames()) list += (list.empty() ? "" : ", ") + n;
        return Status::error("colormap '" + name + "' is not built in (built in: " + list +
                             "; in ParaView every preset name works)");
    }
    return c;
}

Status resolveColormapNames(MaterialDocument& doc) {
    for (size_t i = 0; i < doc.materials.size(); ++i) {
        Colormap& c = doc.materials[i].colormap;
        if (!c.points.empty() || c.name.empty()) continue;
        Result<Colormap> r = builtinColormap(c.name);
        if (!r) return Status(r.status()).prefix(where(i, doc.materials[i].name));
        c = std::move(*r);
    }
    return Status::ok();
}

std::pair<uint64_t, uint64_t> labelInterval(const Material& m) {
    const double lo = std::ceil(std::max(m.filterMin, 0.0)), hi = std::floor(std::min(m.filterMax, 4294967295.0));
    if (!(lo <= hi) || std::isnan(m.filterMin) || std::isnan(m.filterMax)) return {1, 0}; // std::max/min pass a NaN on
    return {uint64_t(lo), uint64_t(hi)};
}

FirstInterval::FirstInterval(const std::vector<std::pair<uint64_t, uint64_t>>& intervals)
    : m_intervals(intervals.size()) {
    // The union so far as disjoint, non-adjacent components: each interval adds the gaps it
    // leaves between them and merges them, so the work is O(n log n) whatever the overlaps.
    std::map<uint64_t, uint64_t> covered;
    for (size_t i = 0; i < intervals.size(); ++i) {
        const uint64_t a = intervals[i].first, b = std::min<uint64_t>(intervals[i].second, uint64_t(1) << 62); // no b + 1 overflow
        if (a > b) continue;
        auto it = covered.upper_bound(a);
        if (it != covered.begin() && std::prev(it)->second + 1 >= a) --it;
        uint64_t from = a, lo = a, hi = b;
        while (it != covered.end() && it->first <= b + 1) {
            if (it->first > from) m_pieces.push_back({from, std::min(it->first - 1, b), uint32_t(i)});
            from = std::max(from, it->second + 1);
            lo = std::min(lo, it->first);
            hi = std::max(hi, it->second);
            it = covered.erase(it);
        }
        if (from <= b) m_pieces.push_back({from, b, uint32_t(i)});
        covered[lo] = hi;
    }
    std::sort(m_pieces.begin(), m_pieces.end(), [](const Piece& x, const Piece& y) { return x.lo < y.lo; });
}

int64_t FirstInterval::find(uint64_t v) const {
    auto it = std::upper_bound(m_pieces.begin(), m_pieces.end(), v, [](uint64_t x, const Piece& p) { return x < p.lo; });
    if (it == m_pieces.begin()) return -1;
    --it;
    return v <= it->hi ? int64_t(it->index) : -1;
}

MaterialEvaluator::MaterialEvaluator(const MaterialDocument& doc, AttributeFn attribute)
    : m_doc(doc), m_attribute(std::move(attribute)) {
    std::vector<std::pair<uint64_t, uint64_t>> leading;
    for (const Material& m : doc.materials) {
        if (m.filterAttribute != "label") break;
        leading.push_back(labelInterval(m));
    }
    m_leading = FirstInterval(leading);
}

int MaterialEvaluator::materialOf(uint32_t label) const {
    if (const int64_t i = m_leading.find(label); i >= 0) return int(i);
    for (size_t i = m_leading.size(); i < m_doc.materials.size(); ++i) {
        const Material& m = m_doc.materials[i];
        const double v = m.filterAttribute == "label" ? double(label) : m_attribute(m.filterAttribute, label);
        if (v >= m.filterMin && v <= m.filterMax) return int(i); // closed interval; NaN never matches
    }
    return -1;
}

std::array<float, 3> MaterialEvaluator::colorOf(uint32_t label, int index) const {
    if (index < 0 || size_t(index) >= m_doc.materials.size()) return {{0, 0, 0}};
    const Material& m = m_doc.materials[size_t(index)];
    switch (m.colorMode) {
    case Material::ColorMode::Constant: return m.rgb;
    case Material::ColorMode::Colormap: {
        const double v = m.colorAttribute == "label" ? double(label) : m_attribute(m.colorAttribute, label);
        double t = (v - m.colorMin) / (m.colorMax - m.colorMin);
        if (std::isnan(t)) t = 0;
        // min == max (not drawable, but the evaluator may still be asked) or a huge value gives an
        // infinite t: clamped by at(), never wrapped (inf - floor(inf) is NaN).
        if (m.wrap == Material::Wrap::Repeat && std::isfinite(t)) t -= std::floor(t);
        return m.colormap.at(t);
    }
    case Material::ColorMode::Random:
    default: {
        const uint32_t h = labelHash(label);
        if (m.colormap.points.empty()) {
            const float* c = layout::kLabelPalette[h % layout::kLabelPaletteSize];
            return {{c[0], c[1], c[2]}};
        }
        return m.colormap.at(double(h) / 4294967295.0);
    }
    }
}

} // namespace csgv
