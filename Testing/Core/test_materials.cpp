// SPDX-License-Identifier: MIT
// The material document (shared/MATERIALS.md): parsing, defaults, strict errors, and the CPU
// reference of material selection and colouring that the GPU must match.
#include "csgv/materials/Materials.h"

#include <cmath>
#include <fstream>
#include <gtest/gtest.h>
#include <map>
#include <random>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

using namespace csgv;

namespace {

// The example of MATERIALS.md, verbatim.
const char* kExample = R"j({
  "version": 1,
  "materials": [
    {
      "name": "tumour cells",
      "filter": {"attribute": "kind", "min": 1, "max": 1},
      "color": {
        "mode": "colormap",
        "attribute": "nutrient",
        "min": 0.0, "max": 2.5,
        "wrap": "clamp",
        "colormap": "Viridis (matplotlib)"
      },
      "opacity": 1.0,
      "emission": 0.0
    },
    {
      "name": "vessels",
      "filter": {"attribute": "kind", "min": 2, "max": 2},
      "color": {"mode": "constant", "rgb": [0.8, 0.1, 0.1]},
      "opacity": 0.35
    },
    {
      "name": "everything else",
      "filter": {"attribute": "label", "min": 1, "max": 4294967294},
      "color": {"mode": "random", "colormap": [[0, 0.2, 0.3, 0.9], [1, 0.95, 0.85, 0.2]]}
    }
  ]
})j";

std::string errorOf(const std::string& json) {
    Result<MaterialDocument> r = parseMaterials(json);
    EXPECT_FALSE(r.isOk()) << json;
    return r.message();
}

} // namespace

TEST(Materials, TheDocumentedExampleParses) {
    Result<MaterialDocument> doc = parseMaterials(kExample);
    ASSERT_TRUE(doc.isOk()) << doc.message();
    ASSERT_EQ(doc->materials.size(), 3u);
    const Material& a = doc->materials[0];
    EXPECT_EQ(a.name, "tumour cells");
    EXPECT_EQ(a.filterAttribute, "kind");
    EXPECT_EQ(a.colorMode, Material::ColorMode::Colormap);
    EXPECT_EQ(a.colorAttribute, "nutrient");
    EXPECT_EQ(a.colorMax, 2.5);
    EXPECT_EQ(a.colormap.name, "Viridis (matplotlib)");
    EXPECT_TRUE(a.colormap.points.empty());
    const Material& b = doc->materials[1];
    EXPECT_EQ(b.colorMode, Material::ColorMode::Constant);
    EXPECT_FLOAT_EQ(b.opacity, 0.35f);
    EXPECT_FLOAT_EQ(b.emission, 0.0f); // default
    EXPECT_FLOAT_EQ(b.rgb[0], 0.8f);
    const Material& c = doc->materials[2];
    EXPECT_EQ(c.colorMode, Material::ColorMode::Random);
    EXPECT_EQ(c.colormap.points.size(), 2u);
    EXPECT_FLOAT_EQ(c.opacity, 1.0f);
    EXPECT_EQ(attributesUsed(*doc), (std::vector<std::string>{"kind", "nutrient", "label"}));
    // Serialising gives a document that parses to the same thing.
    Result<MaterialDocument> again = parseMaterials(serializeMaterials(*doc));
    ASSERT_TRUE(again.isOk()) << again.message();
    EXPECT_EQ(serializeMaterials(*again), serializeMaterials(*doc));
}

TEST(Materials, DefaultsAndTheDefaultDocument) {
    const MaterialDocument d = defaultMaterials();
    ASSERT_EQ(d.materials.size(), 1u);
    EXPECT_EQ(d.materials[0].filterAttribute, "label");
    EXPECT_EQ(d.materials[0].filterMin, 1);
    EXPECT_EQ(d.materials[0].filterMax, 4294967294.0);
    EXPECT_EQ(d.materials[0].colorMode, Material::ColorMode::Random);
    EXPECT_EQ(d.materials[0].opacity, 1.0f);
    Result<MaterialDocument> empty = parseMaterials("{}");
    ASSERT_TRUE(empty.isOk());
    EXPECT_EQ(serializeMaterials(*empty), serializeMaterials(d));
    Result<MaterialDocument> minimal = parseMaterials(R"j({"materials": [{}]})j");
    ASSERT_TRUE(minimal.isOk()) << minimal.message();
    EXPECT_EQ(minimal->materials[0].filterMin, 1);
    MaterialEvaluator e(d, [](const std::string&, uint32_t) { return 0.0; });
    EXPECT_EQ(e.materialOf(0), -1); // label 0 is empty space
    EXPECT_EQ(e.materialOf(1), 0);
    EXPECT_EQ(e.materialOf(4294967294u), 0);
}

TEST(Materials, DeeplyNestedDocumentsAreRefusedNotAStackOverflow) {
    const std::string deep = "{\"version\": 1, \"materials\": [{\"name\": " + std::string(200000, '[') +
                             std::string(200000, ']') + "}]}";
    Result<MaterialDocument> doc = parseMaterials(deep);
    ASSERT_FALSE(doc.isOk());
    EXPECT_EQ(doc.message(), "material document: nests arrays or objects more than 64 levels deep");
    // A scalar of the wrong type is quoted; a container is described, never dumped.
    doc = parseMaterials("{\"version\": [1, 2]}");
    ASSERT_FALSE(doc.isOk());
    EXPECT_NE(doc.message().find("an array of 2 elements"), std::string::npos) << doc.message();
}

TEST(Materials, StrictErrorsNameThePlace) {
    EXPECT_NE(errorOf("not json").find("not valid JSON"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"version": 1, "version": 2})j").find("the key \"version\" appears twice"), std::string::npos)
        << errorOf(R"j({"version": 1, "version": 2})j");
    EXPECT_NE(errorOf(R"j({"materials": [{"name": "a", "opacity": 1, "opacity": 0.5}]})j").find("\"opacity\" appears twice"),
              std::string::npos);
    EXPECT_TRUE(parseMaterials(R"j({"materials": [{"name": "a"}, {"name": "b"}]})j").isOk()); // the same key in two objects
    // Where it breaks, by line and column (found by an attack pass: "not valid JSON" alone).
    EXPECT_NE(errorOf("{\n  \"materials\": [\n    {\"name\": \"a\",}\n  ]\n}").find("line 3, column"), std::string::npos)
        << errorOf("{\n  \"materials\": [\n    {\"name\": \"a\",}\n  ]\n}");
    EXPECT_NE(errorOf("[1]").find("object"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"version": 2})j").find("version"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [], "colour": 1})j").find("unknown key 'colour'"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"name": "a", "opacty": 1}]})j").find("material 1 ('a'): unknown key 'opacty'"),
              std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{}, {"opacity": 1.5}]})j").find("material 2: 'opacity'"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"emission": -1}]})j").find("emission"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"filter": {"attribute": 3}}]})j").find("string"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"color": {"mode": "rainbow"}}]})j").find("'rainbow'"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"color": {"mode": "constant"}}]})j").find("needs 'rgb'"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"color": {"mode": "constant", "rgb": [1, 2, 0]}}]})j").find("rgb"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"color": {"mode": "random", "rgb": [1, 1, 0]}}]})j").find("unknown key 'rgb'"),
              std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"color": {"mode": "colormap"}}]})j").find("needs 'colormap'"), std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"color": {"mode": "colormap", "colormap": "Turbo", "wrap": "mirror"}}]})j").find("mirror"),
              std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"color": {"mode": "colormap", "colormap": [[0, 0, 0, 0], [0.5, 1, 1, 1]]}}]})j").find("0 to 1"),
              std::string::npos);
    EXPECT_NE(errorOf(R"j({"materials": [{"color": {"mode": "colormap", "colormap": [[0, 0, 0, 0], [0, 1, 1, 1], [1, 1, 1, 1]]}}]})j").find("increase"),
              std::string::npos);
    // Attributes the volume lacks are named.
    Result<MaterialDocument> doc = parseMaterials(kExample);
    Status s = checkAttributes(*doc, {"kind"});
    ASSERT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("'nutrient'"), std::string::npos) << s.message();
    EXPECT_TRUE(checkAttributes(*doc, {"kind", "nutrient"}).isOk());
}

TEST(Materials, FirstMatchWinsOnClosedIntervals) {
    MaterialDocument doc = *parseMaterials(kExample);
    ASSERT_TRUE(resolveColormapNames(doc).isOk());
    std::map<uint32_t, double> kind = {{5, 1}, {6, 2}, {7, 0}, {8, 1.5}};
    MaterialEvaluator e(doc, [&](const std::string& a, uint32_t l) {
        if (a == "kind") return kind.count(l) ? kind[l] : 0.0;
        if (a == "nutrient") return double(l) / 4.0;
        return std::nan("");
    });
    EXPECT_EQ(e.materialOf(5), 0); // kind 1: first material, although the third also matches
    EXPECT_EQ(e.materialOf(6), 1);
    EXPECT_EQ(e.materialOf(7), 2);
    EXPECT_EQ(e.materialOf(8), 2); // kind 1.5 is in no [1,1] or [2,2] interval
    EXPECT_EQ(e.materialOf(0), -1);
    // Interval edges are inclusive on both sides.
    MaterialDocument edges = *parseMaterials(R"j({"materials": [{"filter": {"min": 10, "max": 20}}]})j");
    MaterialEvaluator ee(edges, [](const std::string&, uint32_t) { return 0.0; });
    EXPECT_EQ(ee.materialOf(9), -1);
    EXPECT_EQ(ee.materialOf(10), 0);
    EXPECT_EQ(ee.materialOf(20), 0);
    EXPECT_EQ(ee.materialOf(21), -1);
}

TEST(Materials, ColourModesAndWrap) {
    MaterialDocument doc = *parseMaterials(R"j({"materials": [
        {"color": {"mode": "colormap", "attribute": "v", "min": 0, "max": 10, "wrap": "clamp", "colormap": "Grayscale"}},
        {"color": {"mode": "colormap", "attribute": "v", "min": 0, "max": 10, "wrap": "repeat", "colormap": "Grayscale"}},
        {"color": {"mode": "constant", "rgb": [0.25, 0.5, 0.75]}}]})j");
    ASSERT_TRUE(resolveColormapNames(doc).isOk());
    MaterialEvaluator e(doc, [](const std::string&, uint32_t l) { return double(l); });
    EXPECT_FLOAT_EQ(e.colorOf(5, 0)[0], 0.5f);
    EXPECT_FLOAT_EQ(e.colorOf(15, 0)[0], 1.0f);  // clamped
    EXPECT_FLOAT_EQ(e.colorOf(15, 1)[0], 0.5f);  // repeated
    EXPECT_FLOAT_EQ(e.colorOf(0, 0)[1], 0.0f);
    EXPECT_FLOAT_EQ(e.colorOf(99, 2)[2], 0.75f);
    // Random colours: stable, and neighbouring labels differ.
    MaterialDocument rnd = defaultMaterials();
    MaterialEvaluator r(rnd, [](const std::string&, uint32_t) { return 0.0; });
    EXPECT_EQ(r.colorOf(1234, 0), r.colorOf(1234, 0));
    int same = 0;
    for (uint32_t l = 1; l < 1000; ++l) same += r.colorOf(l, 0) == r.colorOf(l + 1, 0);
    EXPECT_LT(same, 1000 / 8);
    std::set<uint32_t> hashes;
    for (uint32_t l = 0; l < 100000; ++l) hashes.insert(labelHash(l));
    EXPECT_EQ(hashes.size(), 100000u); // a bijection on 32 bits
}

TEST(Materials, BuiltinColormaps) {
    for (const std::string& n : builtinColormapNames()) {
        Result<Colormap> c = builtinColormap(n);
        ASSERT_TRUE(c.isOk()) << n;
        EXPECT_EQ(c->points.front()[0], 0.0f);
        EXPECT_EQ(c->points.back()[0], 1.0f);
        for (size_t i = 1; i < c->points.size(); ++i) EXPECT_LT(c->points[i - 1][0], c->points[i][0]) << n;
    }
    EXPECT_NEAR(builtinColormap("Viridis (matplotlib)")->at(0)[2], 0.329, 1e-3);
    EXPECT_NEAR(builtinColormap("Turbo")->at(0.5)[1], 0.98, 0.05); // green in the middle
    Result<Colormap> nope = builtinColormap("Jet-ish");
    ASSERT_FALSE(nope.isOk());
    EXPECT_NE(nope.message().find("Viridis"), std::string::npos);
    MaterialDocument doc = *parseMaterials(R"j({"materials": [{"color": {"mode": "random", "colormap": "Nope"}}]})j");
    Status s = resolveColormapNames(doc);
    ASSERT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("material 1"), std::string::npos) << s.message();
}

namespace {

MaterialDocument docOf(const std::string& json) {
    Result<MaterialDocument> r = parseMaterialsOrDefault(json);
    EXPECT_TRUE(r.isOk()) << r.message() << "\n" << json;
    return r.isOk() ? *r : MaterialDocument{};
}

std::string canonical(const std::string& json) { return serializeMaterials(docOf(json)); }

} // namespace

TEST(Materials, ParseOrDefaultAndCompactText) {
    EXPECT_EQ(serializeMaterials(docOf("")), serializeMaterials(defaultMaterials()));
    EXPECT_EQ(serializeMaterials(docOf(" \n\t")), serializeMaterials(defaultMaterials()));
    EXPECT_EQ(defaultMaterials().materials[0].name, "all");
    EXPECT_FALSE(parseMaterialsOrDefault("not json").isOk()); // blank is the default, garbage is not
    // One compact line for property text, and floats in their shortest form.
    MaterialDocument d = docOf(R"j({"materials": [{"opacity": 0.35, "color": {"mode": "constant", "rgb": [0.1, 0.2, 0.3]}}]})j");
    const std::string compact = serializeMaterials(d, -1);
    EXPECT_EQ(compact.find('\n'), std::string::npos);
    EXPECT_NE(compact.find("\"opacity\":0.35"), std::string::npos) << compact;
    EXPECT_NE(compact.find("[0.1,0.2,0.3]"), std::string::npos) << compact;
    EXPECT_EQ(serializeMaterials(docOf(compact)), serializeMaterials(d));
}

TEST(Materials, HideLabelSplitsLabelIntervals) {
    MaterialDocument d = defaultMaterials();
    hideLabel(d, 7);
    ASSERT_EQ(d.materials.size(), 2u);
    EXPECT_EQ(d.materials[0].filterMin, 1);
    EXPECT_EQ(d.materials[0].filterMax, 6);
    EXPECT_EQ(d.materials[1].filterMin, 8);
    EXPECT_EQ(d.materials[1].filterMax, kMaxMaterialLabel);
    for (const Material& m : d.materials) EXPECT_EQ(m.opacity, 1.0f); // still opaque: no translucent pass
    MaterialEvaluator e(d, [](const std::string&, uint32_t) { return 0.0; });
    EXPECT_EQ(e.materialOf(7), -1);
    EXPECT_EQ(e.materialOf(6), 0);
    EXPECT_EQ(e.materialOf(8), 1);
    // The last label: nothing above it.
    MaterialDocument top = defaultMaterials();
    hideLabel(top, uint64_t(kMaxMaterialLabel));
    ASSERT_EQ(top.materials.size(), 1u);
    EXPECT_EQ(top.materials[0].filterMax, kMaxMaterialLabel - 1);
}

TEST(Materials, HideLabelOnOtherAttributes) {
    const std::string byKind = R"j({"materials": [{"name": "k", "filter": {"attribute": "kind", "min": 2, "max": 2}}]})j";
    MaterialDocument d = docOf(byKind);
    hideLabel(d, 7, [](const std::string& a) { return a == "kind" ? 2.0 : std::nan(""); });
    ASSERT_EQ(d.materials.size(), 2u);
    EXPECT_EQ(d.materials[0].name, "hidden 7");
    EXPECT_EQ(d.materials[0].opacity, 0.0f);
    EXPECT_EQ(d.materials[0].filterAttribute, "label");
    EXPECT_EQ(d.materials[0].filterMin, 7);
    EXPECT_EQ(d.materials[0].filterMax, 7);
    EXPECT_EQ(d.materials[1].name, "k");
    MaterialDocument outside = docOf(byKind);
    hideLabel(outside, 7, [](const std::string&) { return 1.0; });
    EXPECT_EQ(serializeMaterials(outside), canonical(byKind));
    MaterialDocument unknown = docOf(byKind);
    hideLabel(unknown, 7); // no values known: the material may take it
    EXPECT_EQ(unknown.materials.size(), 2u);
}

TEST(Materials, ShowOnlyLabel) {
    MaterialDocument d = docOf(R"j({"materials": [{"name": "a", "filter": {"min": 10, "max": 20}},
        {"name": "b", "color": {"mode": "constant", "rgb": [1, 0, 0]}, "opacity": 0.5}]})j");
    showOnlyLabel(d, 7);
    ASSERT_EQ(d.materials.size(), 1u);
    EXPECT_EQ(d.materials[0].name, "b");
    EXPECT_EQ(d.materials[0].colorMode, Material::ColorMode::Constant);
    EXPECT_EQ(d.materials[0].opacity, 0.5f);
    EXPECT_EQ(d.materials[0].filterMin, 7);
    EXPECT_EQ(d.materials[0].filterMax, 7);
    MaterialDocument none = docOf(R"j({"materials": [{"filter": {"attribute": "kind", "min": 2, "max": 2}}]})j");
    showOnlyLabel(none, 7, [](const std::string&) { return std::nan(""); });
    ASSERT_EQ(none.materials.size(), 1u);
    EXPECT_EQ(none.materials[0].name, "label 7");
    EXPECT_EQ(none.materials[0].colorMode, Material::ColorMode::Random);
    EXPECT_EQ(none.materials[0].filterAttribute, "label");
}

// The cases Examples/csgv_tools.py must also pass (Testing/ParaView/test_material_label_edits.py):
// pvpython cannot call Core, so one file of cases holds both implementations to one behaviour.
TEST(Materials, LabelEditsMatchTheSharedCases) {
    std::string here = __FILE__;
    const std::string path = here.substr(0, here.find_last_of('/')) + "/../ParaView/material_label_edits.json";
    std::ifstream in(path);
    ASSERT_TRUE(in.good()) << "cannot read " << path;
    std::stringstream text;
    text << in.rdbuf();
    const nlohmann::json cases = nlohmann::json::parse(text.str())["cases"];
    ASSERT_GE(cases.size(), 10u);
    for (const nlohmann::json& c : cases) {
        SCOPED_TRACE(c["what"].get<std::string>());
        const std::string input = c["input"].is_string() ? c["input"].get<std::string>() : c["input"].dump();
        const nlohmann::json attrs = c.value("attributes", nlohmann::json::object());
        LabelAttributeFn attribute = [&attrs](const std::string& a) {
            return attrs.contains(a) ? attrs[a].get<double>() : std::nan("");
        };
        MaterialDocument d = docOf(input);
        if (c["op"] == "select") {
            const std::string edit = c["edit"].get<std::string>();
            editSelection(d, c["labels"].get<std::vector<uint32_t>>(),
                          edit == "add" ? SelectionEdit::Add : edit == "remove" ? SelectionEdit::Remove : SelectionEdit::Replace);
            if (c.contains("style"))
                d.selectionStyle = c["style"] == "dim" ? MaterialDocument::SelectionStyle::Dim : MaterialDocument::SelectionStyle::Highlight;
        } else {
            const uint64_t label = c["label"].get<uint64_t>();
            if (c["op"] == "hide") hideLabel(d, label, attribute);
            else if (c["op"] == "showOnly") showOnlyLabel(d, label, attribute);
            else FAIL() << "unknown op " << c["op"].dump();
        }
        EXPECT_EQ(serializeMaterials(d), canonical(c["expected"].dump()));
    }
}

// Half-finished edits (issue 15): value problems keep the material in the document, and Core says
// why it cannot be drawn; the rest of the document still draws.
namespace {

const char* kHalfEdited = R"j({"materials": [
  {"name": "cortex", "filter": {"attribute": "label", "min": 1, "max": 10},
   "color": {"mode": "constant", "rgb": [1, 0, 0]}},
  {"name": "typing", "filter": {"attribute": "label", "min": 50, "max": 5}},
  {"name": "flat", "color": {"mode": "colormap", "colormap": "Turbo", "min": 3, "max": 3}},
  {"name": "by kind", "filter": {"attribute": "kind", "min": 0, "max": 9}},
  {"name": "rest"}
]})j";

} // namespace

TEST(MaterialProblems, HalfFinishedValuesParseAndRoundTrip) {
    Result<MaterialDocument> doc = parseMaterials(kHalfEdited);
    ASSERT_TRUE(doc.isOk()) << doc.message();
    ASSERT_EQ(doc->materials.size(), 5u);
    EXPECT_EQ(doc->materials[1].filterMin, 50);
    EXPECT_EQ(doc->materials[1].filterMax, 5);
    EXPECT_EQ(doc->materials[2].colorMin, 3);
    Result<MaterialDocument> again = parseMaterials(serializeMaterials(*doc));
    ASSERT_TRUE(again.isOk()) << again.message();
    EXPECT_EQ(serializeMaterials(*again), serializeMaterials(*doc));
    // Structure stays strict.
    EXPECT_NE(errorOf(R"j({"materials": [{"filter": {"min": "5"}}]})j").find("finite number"), std::string::npos);
}

TEST(MaterialProblems, MaterialProblemNamesTheValue) {
    const MaterialDocument doc = *parseMaterials(kHalfEdited);
    EXPECT_EQ(materialProblem(doc.materials[0]), "");
    EXPECT_EQ(materialProblem(doc.materials[1]), "filter min 50 is greater than max 5");
    EXPECT_EQ(materialProblem(doc.materials[2]), "colour min equals max (3)");
    EXPECT_EQ(materialProblem(doc.materials[3]), ""); // no attribute list: not checked
    const std::vector<std::string> none;
    EXPECT_EQ(materialProblem(doc.materials[3], &none), "filter attribute 'kind' is not available");
    const std::vector<std::string> kind{"kind"};
    EXPECT_EQ(materialProblem(doc.materials[3], &kind), "");
    EXPECT_EQ(materialProblem(doc.materials[4], &none), ""); // `label` always exists
    // A random material's unused colour interval is no problem.
    Material random;
    random.colorMin = random.colorMax = 2;
    EXPECT_EQ(materialProblem(random), "");
}

TEST(MaterialProblems, DrawableMaterialsSkipsOnlyTheProblemsAndNumbersFromOne) {
    const MaterialDocument doc = *parseMaterials(kHalfEdited);
    const std::vector<std::string> available{"voxels"};
    std::vector<std::string> reasons;
    const MaterialDocument drawn = drawableMaterials(doc, &available, &reasons);
    ASSERT_EQ(drawn.materials.size(), 2u);
    EXPECT_EQ(drawn.materials[0].name, "cortex");
    EXPECT_EQ(drawn.materials[1].name, "rest");
    EXPECT_EQ(reasons, (std::vector<std::string>{
                           "material 2 ('typing'): filter min 50 is greater than max 5; not drawn",
                           "material 3 ('flat'): colour min equals max (3); not drawn",
                           "material 4 ('by kind'): filter attribute 'kind' is not available; not drawn"}));
    // Without a list, attributes are not checked; without a reason list, nothing is written.
    EXPECT_EQ(drawableMaterials(doc, nullptr, nullptr).materials.size(), 3u);
    // The labels the skipped materials would have taken fall to the next drawable one.
    MaterialEvaluator e(drawn, [](const std::string&, uint32_t) { return 0.0; });
    EXPECT_EQ(e.materialOf(5), 0);
    EXPECT_EQ(e.materialOf(20), 1);
}

namespace {

/// Which material each of labels 0..n-1 takes (-1: none) under the document the renderer draws.
std::vector<int> takenBy(const MaterialDocument& drawn, uint32_t n, const MaterialEvaluator::AttributeFn& attribute) {
    MaterialEvaluator e(drawn, attribute);
    std::vector<int> out;
    for (uint32_t l = 0; l < n; ++l) out.push_back(e.materialOf(l));
    return out;
}

// Two materials: labels 1..4 red, the rest ("kind" 2 or label >= 5) random; "kind" is label % 3.
const char* kTwoMaterials = R"j({"materials": [
    {"name": "red", "filter": {"min": 1, "max": 4}, "color": {"mode": "constant", "rgb": [1, 0, 0]}},
    {"name": "kind 2", "filter": {"attribute": "kind", "min": 2, "max": 2}},
    {"name": "rest", "filter": {"min": 5, "max": 9}, "opacity": 0.5}]})j";

double kindOf(const std::string& a, uint32_t l) { return a == "kind" ? double(l % 3) : double(l); }

/// The name of the material a label takes in `drawn` ("" for none), so tests read as a table.
std::vector<std::string> namesTaken(const MaterialDocument& drawn, uint32_t n) {
    std::vector<std::string> out;
    for (int m : takenBy(drawn, n, kindOf)) out.push_back(m < 0 ? "" : drawn.materials[size_t(m)].name);
    return out;
}

} // namespace

TEST(Materials, VisibilityOverlayParsesStrictlyAndRoundTrips) {
    MaterialDocument d = docOf(R"j({"materials": [], "hidden": [9, 3, 3, 0], "only": [4294967294]})j");
    EXPECT_EQ(d.hidden, (std::vector<uint32_t>{0, 3, 9})); // sorted, once each
    EXPECT_EQ(d.only, (std::vector<uint32_t>{4294967294u}));
    EXPECT_EQ(docOf(serializeMaterials(d)).hidden, d.hidden);
    EXPECT_EQ(docOf(serializeMaterials(d, -1)).only, d.only);
    // Without an overlay nothing is written: documents read as before.
    EXPECT_EQ(serializeMaterials(defaultMaterials()).find("hidden"), std::string::npos);
    EXPECT_EQ(docOf(R"j({"hidden": [5]})j").materials.size(), 1u); // default materials, overlay kept
    for (const char* bad : {R"j({"hidden": 5})j", R"j({"hidden": [-1]})j", R"j({"only": [1.5]})j",
                            R"j({"only": ["7"]})j", R"j({"hidden": [4294967295]})j"}) {
        Result<MaterialDocument> r = parseMaterials(bad);
        ASSERT_FALSE(r.isOk()) << bad;
        EXPECT_NE(r.message().find("label"), std::string::npos) << r.message();
    }
}

TEST(Materials, HideKeepsTheMaterialsAndShowAllRestoresThem) {
    MaterialDocument d = docOf(kTwoMaterials);
    const std::string original = serializeMaterials(d);
    const std::vector<std::string> before = namesTaken(effectiveMaterials(d, kindOf), 12);
    EXPECT_EQ(before, (std::vector<std::string>{"", "red", "red", "red", "red", "kind 2", "rest", "rest", "kind 2",
                                                "rest", "", "kind 2"}));
    hideLabelOver(d, 3); // a label interval holds it
    hideLabelOver(d, 8); // "kind 2" (another attribute) holds it
    hideLabelOver(d, 11);
    EXPECT_EQ(d.materials.size(), 3u); // the user's materials are untouched
    std::vector<std::string> hidden = before;
    hidden[3] = hidden[8] = hidden[11] = "";
    const MaterialDocument drawn = effectiveMaterials(d, kindOf);
    std::vector<std::string> got = namesTaken(drawn, 12);
    // A hidden label may be taken by a transparent "hidden" material: invisible either way.
    MaterialEvaluator e(drawn, kindOf);
    for (uint32_t l : {3u, 8u, 11u}) {
        const int m = e.materialOf(l);
        EXPECT_TRUE(m < 0 || drawn.materials[size_t(m)].opacity == 0.0f) << "label " << l;
        got[l] = "";
    }
    EXPECT_EQ(got, hidden);
    // The same colours for the labels still shown.
    MaterialEvaluator was(d, kindOf);
    for (uint32_t l : {1u, 2u, 4u, 5u, 6u, 9u})
        EXPECT_EQ(e.colorOf(l, e.materialOf(l)), was.colorOf(l, was.materialOf(l))) << "label " << l;
    showAllLabels(d);
    EXPECT_EQ(serializeMaterials(d), original);
    EXPECT_EQ(namesTaken(effectiveMaterials(d, kindOf), 12), before);
}

TEST(Materials, ShowOnlyKeepsTheMaterialsAndTheLabelsLook) {
    MaterialDocument d = docOf(kTwoMaterials);
    hideLabelOver(d, 6);
    showOnlyLabelOver(d, 6); // shown again: it leaves "hidden"
    EXPECT_TRUE(d.hidden.empty());
    EXPECT_EQ(d.only, (std::vector<uint32_t>{6}));
    EXPECT_EQ(d.materials.size(), 3u);
    MaterialDocument drawn = effectiveMaterials(d, kindOf);
    std::vector<std::string> want(12, "");
    want[6] = "rest";
    EXPECT_EQ(namesTaken(drawn, 12), want);
    ASSERT_EQ(drawn.materials.size(), 1u);
    EXPECT_EQ(drawn.materials[0].opacity, 0.5f); // its own material's look
    EXPECT_TRUE(drawn.hidden.empty() && drawn.only.empty());
    // Through another attribute, and several labels: runs in one material share an interval.
    d.only = {1, 2, 3, 8, 10};
    hideLabelOver(d, 2);
    drawn = effectiveMaterials(d, kindOf);
    want.assign(12, "");
    want[1] = want[3] = "red";
    want[8] = "kind 2";
    EXPECT_EQ(namesTaken(drawn, 12), want); // 2 hidden, 10 taken by no material
    showAllLabels(d);
    EXPECT_EQ(serializeMaterials(d), serializeMaterials(docOf(kTwoMaterials)));
}

TEST(Materials, EffectiveMaterialsWithoutAnOverlayAreTheMaterials) {
    const MaterialDocument d = docOf(kTwoMaterials);
    EXPECT_EQ(serializeMaterials(effectiveMaterials(d, kindOf)), serializeMaterials(d));
    // Attribute values unknown (no table): a hidden label is still never drawn.
    MaterialDocument h = d;
    hideLabelOver(h, 8);
    const MaterialDocument drawn = effectiveMaterials(h, {});
    MaterialEvaluator e(drawn, kindOf);
    const int m = e.materialOf(8);
    EXPECT_TRUE(m < 0 || drawn.materials[size_t(m)].opacity == 0.0f);
}

TEST(Materials, SelectionParsesStrictlyEditsAndRoundTrips) {
    MaterialDocument d = docOf(R"j({"materials": [], "selected": [9, 3, 3], "selectionStyle": "dim",
                                    "selectionColor": [0, 1, 0.5]})j");
    EXPECT_EQ(d.selected, (std::vector<uint32_t>{3, 9}));
    EXPECT_EQ(d.selectionStyle, MaterialDocument::SelectionStyle::Dim);
    EXPECT_EQ(d.selectionColor, (std::array<float, 3>{{0, 1, 0.5f}}));
    const MaterialDocument back = docOf(serializeMaterials(d));
    EXPECT_EQ(back.selected, d.selected);
    EXPECT_EQ(back.selectionStyle, d.selectionStyle);
    EXPECT_EQ(back.selectionColor, d.selectionColor);
    // The defaults are not written: a document without a selection reads as it always did.
    EXPECT_EQ(serializeMaterials(docOf(kTwoMaterials)).find("select"), std::string::npos);
    editSelection(d, {7, 3, 7}, SelectionEdit::Add);
    EXPECT_EQ(d.selected, (std::vector<uint32_t>{3, 7, 9}));
    editSelection(d, {3, 4}, SelectionEdit::Remove);
    EXPECT_EQ(d.selected, (std::vector<uint32_t>{7, 9}));
    editSelection(d, {1}, SelectionEdit::Replace);
    EXPECT_EQ(d.selected, (std::vector<uint32_t>{1}));
    EXPECT_EQ(d.selectionStyle, MaterialDocument::SelectionStyle::Dim); // the look stays
    editSelection(d, {}, SelectionEdit::Replace);
    EXPECT_TRUE(d.selected.empty());
    {
        std::string many = R"j({"selected": [)j";
        for (size_t i = 0; i <= kMaxOverlayLabels; ++i) many += (i ? "," : "") + std::to_string(2 * i);
        Result<MaterialDocument> r = parseMaterials(many + "]}");
        ASSERT_FALSE(r.isOk());
        EXPECT_NE(r.message().find("more than 1000000"), std::string::npos) << r.message();
    }
    for (const char* bad : {R"j({"selected": [-2]})j", R"j({"selected": 3})j", R"j({"selectionStyle": "glow"})j",
                            R"j({"selectionStyle": 1})j", R"j({"selectionColor": [1, 0]})j",
                            R"j({"selectionColor": [1, 0, 2]})j", R"j({"selectionColor": "red"})j"}) {
        Result<MaterialDocument> r = parseMaterials(bad);
        ASSERT_FALSE(r.isOk()) << bad;
        EXPECT_NE(r.message().find("select"), std::string::npos) << r.message();
    }
}

TEST(Materials, SelectionHighlightsOrDimsOnlyWhatIsDrawn) {
    MaterialDocument d = docOf(kTwoMaterials);
    const std::vector<std::string> before = namesTaken(effectiveMaterials(d, kindOf), 12);
    hideLabelOver(d, 3);
    editSelection(d, {2, 3, 6, 8, 10}, SelectionEdit::Replace); // 3 hidden, 10 no material takes
    MaterialDocument drawn = effectiveMaterials(d, kindOf);
    std::vector<std::string> want = before;
    want[2] = want[6] = want[8] = "selected";
    want[3] = "";
    std::vector<std::string> got = namesTaken(drawn, 12);
    MaterialEvaluator e(drawn, kindOf);
    if (const int m = e.materialOf(3); m >= 0 && drawn.materials[size_t(m)].opacity == 0) got[3] = "";
    EXPECT_EQ(got, want);
    for (uint32_t l : {2u, 6u, 8u}) {
        const int m = e.materialOf(l);
        EXPECT_EQ(e.colorOf(l, m), (std::array<float, 3>{{1, 0, 1}})) << l;
        EXPECT_EQ(drawn.materials[size_t(m)].opacity, 1.0f) << l; // "rest" is translucent: the highlight is not
    }
    // The rest as the document without a selection draws it.
    MaterialDocument unselected = d;
    editSelection(unselected, {}, SelectionEdit::Replace);
    const MaterialDocument plain = effectiveMaterials(unselected, kindOf);
    MaterialEvaluator p(plain, kindOf);
    for (uint32_t l : {1u, 4u, 5u, 7u, 9u, 11u}) {
        EXPECT_EQ(e.colorOf(l, e.materialOf(l)), p.colorOf(l, p.materialOf(l))) << l;
        EXPECT_EQ(drawn.materials[size_t(e.materialOf(l))].opacity, plain.materials[size_t(p.materialOf(l))].opacity);
    }
    // Consecutive selected labels share one highlight material.
    editSelection(d, {4, 5, 6, 7}, SelectionEdit::Replace);
    drawn = effectiveMaterials(d, kindOf);
    EXPECT_EQ(drawn.materials.size(), plain.materials.size() + 1);

    // "dim": the selected labels keep their look, the others fade.
    d.selectionStyle = MaterialDocument::SelectionStyle::Dim;
    editSelection(d, {2, 3, 6, 8}, SelectionEdit::Replace);
    drawn = effectiveMaterials(d, kindOf);
    MaterialEvaluator dim(drawn, kindOf);
    for (uint32_t l = 0; l < 12; ++l) {
        const int m = dim.materialOf(l), q = p.materialOf(l);
        ASSERT_EQ(m < 0, q < 0) << l;
        if (m < 0) continue;
        const float wantOpacity = plain.materials[size_t(q)].opacity * (l == 2 || l == 6 || l == 8 ? 1.0f : kDimmedOpacity);
        EXPECT_FLOAT_EQ(drawn.materials[size_t(m)].opacity, wantOpacity) << l;
        EXPECT_EQ(dim.colorOf(l, m), p.colorOf(l, q)) << l;
    }
    const int hidden = dim.materialOf(3); // hidden stays hidden
    EXPECT_TRUE(hidden < 0 || drawn.materials[size_t(hidden)].opacity == 0.0f);
}

TEST(Materials, FirstIntervalIsTheFirstIntervalHoldingAValue) {
    // Against a scan, over random overlapping, nested, adjacent and empty intervals.
    std::mt19937 rng(41);
    for (int round = 0; round < 200; ++round) {
        std::vector<std::pair<uint64_t, uint64_t>> v;
        const int n = 1 + int(rng() % 40);
        for (int i = 0; i < n; ++i) {
            const uint64_t a = rng() % 100, len = rng() % 30;
            v.emplace_back(a + 3, rng() % 8 == 0 ? a + 2 - len % 3 : a + 3 + len); // some empty (lo > hi)
        }
        const FirstInterval f(v);
        for (uint64_t x = 0; x < 140; ++x) {
            int64_t want = -1;
            for (size_t i = 0; i < v.size() && want < 0; ++i)
                if (v[i].first <= x && x <= v[i].second) want = int64_t(i);
            ASSERT_EQ(f.find(x), want) << "round " << round << " value " << x;
        }
    }
    EXPECT_EQ(FirstInterval({{0, 4294967295ull}}).find(4294967295ull), 0);
    EXPECT_EQ(FirstInterval({{5, ~0ull}, {0, ~0ull}}).find(4), 1);
}

TEST(Materials, AHundredThousandSelectedLabelsAreDrawnWithoutAScanPerLabel) {
    MaterialDocument d = docOf(kTwoMaterials);
    d.materials[2].filterMax = 4294967294.0; // "rest": 5 and up
    std::vector<uint32_t> many;
    for (uint32_t l = 10; l < 400000; l += 4) many.push_back(l);
    editSelection(d, many, SelectionEdit::Replace);
    // (A scan of 100,000 materials per label made this take minutes.)
    const MaterialDocument drawn = effectiveMaterials(d, kindOf);
    MaterialEvaluator e(drawn, kindOf);
    uint64_t selected = 0;
    for (uint32_t l = 0; l < 400000; ++l)
        if (const int m = e.materialOf(l); m >= 0) selected += drawn.materials[size_t(m)].name == "selected";
    // Labels with kind 2 (l % 3 == 2) take "kind 2", drawn too: every selected label is drawn.
    EXPECT_EQ(selected, many.size());
}
