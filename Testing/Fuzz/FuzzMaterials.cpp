// SPDX-License-Identifier: MIT
/// @file FuzzMaterials.cpp
/// @brief Fuzz entry point over the material document (Materials.h, shared/MATERIALS.md): the
/// input is the JSON text. A document that parses must serialise to text that parses back to the
/// same text, and every function a layer calls on it (drawable materials, the visibility overlay
/// turned into plain materials, colormap names, the CPU evaluator) must run on it.

#include "FuzzFiles.h"

#include "csgv/materials/Materials.h"

#include <cmath>
#include <limits>
#include <string>

using namespace csgv;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    Result<MaterialDocument> doc = parseMaterialsOrDefault(text);
    if (!doc) {
        fuzz::require(!doc.message().empty());
        return 0;
    }
    // Round trip: what parses serialises to a document that parses back to the same text.
    const std::string once = serializeMaterials(*doc);
    Result<MaterialDocument> back = parseMaterials(once);
    fuzz::require(back.isOk());
    fuzz::require(serializeMaterials(*back) == once);
    fuzz::require(serializeMaterials(*back, -1) == serializeMaterials(*doc, -1));

    // An attribute function as a table gives: some attributes known, others NaN.
    const auto attribute = [](const std::string& name, uint32_t label) {
        if (name == "volume") return double(label % 97);
        if (name == "side") return double(label & 1);
        return std::numeric_limits<double>::quiet_NaN();
    };
    const std::vector<std::string> available = {"volume", "side"};
    std::vector<std::string> skipped;
    const MaterialDocument drawable = drawableMaterials(*doc, &available, &skipped);
    fuzz::require(drawable.materials.size() + skipped.size() == doc->materials.size());
    (void)checkAttributes(*doc, available);

    const MaterialDocument plain = effectiveMaterials(*doc, attribute);
    fuzz::require(plain.hidden.empty() && plain.only.empty());
    if (doc->only.empty() && doc->hidden.size() <= 64) {
        // The overlay draws what the pick panel's hideLabel does, label by label: each label is
        // drawn (or not) by a material of the same look.
        MaterialDocument oneByOne = *doc;
        oneByOne.hidden.clear();
        for (uint32_t x : doc->hidden)
            hideLabel(oneByOne, x, [&attribute, x](const std::string& name) { return attribute(name, x); });
        std::vector<double> probes = {0, 1, 2, 3, 255, 256, 65535, 65536, kMaxMaterialLabel};
        for (uint32_t x : doc->hidden) probes.insert(probes.end(), {double(x) - 1, double(x), double(x) + 1});
        for (size_t i = 0; i < doc->materials.size() && i < 16; ++i)
            for (double b : {doc->materials[i].filterMin, doc->materials[i].filterMax})
                for (double d : {-1.0, 0.0, 1.0}) probes.push_back(std::floor(b) + d), probes.push_back(std::ceil(b) + d);
        const MaterialEvaluator a(oneByOne, attribute), b(plain, attribute);
        const auto look = [](const MaterialDocument& d, const MaterialEvaluator& e, uint32_t label) {
            const int m = e.materialOf(label);
            if (m < 0 || d.materials[size_t(m)].opacity == 0) return std::string("invisible");
            const Material& mat = d.materials[size_t(m)];
            const std::array<float, 3> c = e.colorOf(label, m);
            return mat.name + " " + std::to_string(mat.opacity) + " " + std::to_string(mat.emission) + " " +
                   std::to_string(c[0]) + " " + std::to_string(c[1]) + " " + std::to_string(c[2]);
        };
        for (double p : probes)
            if (p >= 0 && p <= kMaxMaterialLabel)
                FUZZ_REQUIRE(look(oneByOne, a, uint32_t(p)) == look(plain, b, uint32_t(p)));
        // One run per material and hidden label at most (hideLabel by label made far more).
        const size_t runs = doc->materials.size() * 3 + doc->hidden.size() * 2;
        FUZZ_REQUIRE(plain.materials.size() <= runs);
    }
    MaterialDocument resolved = plain;
    if (resolveColormapNames(resolved)) {
        const MaterialEvaluator evaluator(resolved, attribute);
        const MaterialEvaluator original(*doc, attribute);
        for (uint32_t label : {0u, 1u, 2u, 3u, 7u, 255u, 65536u, 4294967294u}) {
            const int m = evaluator.materialOf(label);
            fuzz::require(m >= -1 && m < int(resolved.materials.size()));
            if (m >= 0)
                for (float c : evaluator.colorOf(label, m)) fuzz::require(std::isfinite(c));
            // A hidden label is never drawn; with "only", nothing else is.
            const bool hidden = std::binary_search(doc->hidden.begin(), doc->hidden.end(), label);
            const bool notOnly = !doc->only.empty() && !std::binary_search(doc->only.begin(), doc->only.end(), label);
            if (hidden || notOnly) fuzz::require(m < 0 || resolved.materials[size_t(m)].opacity == 0);
            (void)original.materialOf(label);
        }
    }

    // The pick panel's edits.
    MaterialDocument edited = *doc;
    hideLabelOver(edited, 5);
    showOnlyLabelOver(edited, 6);
    showAllLabels(edited);
    hideLabel(edited, 3, [](const std::string&) { return 1.0; });
    showOnlyLabel(edited, 9);
    fuzz::require(edited.materials.size() == 1);
    return 0;
}
