// SPDX-License-Identifier: MIT
/// @file RendererMaterials.cpp
/// @brief The renderer's material room: materials packed as the shaders read them, their
/// tables and attribute arrays on the device, label visibility (hidden / only / no material),
/// ghost faces and coarse stand-ins, and Renderer::setMaterials.
#include "RendererImpl.h"

#include "csgv/codec/UniformLevels.h"

namespace csgv::gpu {

namespace renderer_detail {

/// Materials as the shaders read them, with the colormap samples and the attributes they name.
struct PackedMaterials {
    std::vector<GpuMaterial> materials;
    std::vector<std::array<float, 4>> colormapSamples;
    std::vector<std::string> attributeNames; ///< index = GpuMaterial's attribute number

    uint32_t attributeIndex(const std::string& name) {
        if (name == "label") return kNone;
        for (size_t i = 0; i < attributeNames.size(); ++i)
            if (attributeNames[i] == name) return uint32_t(i);
        attributeNames.push_back(name);
        return uint32_t(attributeNames.size() - 1);
    }
};

/// The number of labels that per-label arrays cover (they must agree), or an error.
Result<uint64_t> perLabelCount(const std::map<std::string, std::vector<float>>& attributes,
                               const std::vector<uint32_t>& storedToOriginal) {
    uint64_t labelCount = storedToOriginal.size();
    for (const auto& a : attributes) {
        if (labelCount != 0 && a.second.size() != labelCount)
            return Status::error("attribute '" + a.first + "' has " + std::to_string(a.second.size()) +
                                 " values, other per-label arrays have " + std::to_string(labelCount));
        labelCount = a.second.size();
    }
    if (labelCount >= kNone) return Status::error("too many labels with attributes");
    return labelCount;
}

/// One material in the GPU's layout; colormaps are sampled into `out.colormapSamples`.
Result<GpuMaterial> packMaterial(const Material& m, size_t index, PackedMaterials& out) {
    GpuMaterial g{};
    g.select[0] = out.attributeIndex(m.filterAttribute);
    // Label filters compare integers (empty: select[1] > select[2]), as the CPU evaluator does.
    const auto [lo, hi] = labelInterval(m);
    g.select[1] = uint32_t(lo);
    g.select[2] = uint32_t(hi);
    g.select[3] = m.colorMode == Material::ColorMode::Constant   ? kColorConstant
                  : m.colorMode == Material::ColorMode::Colormap ? kColorColormap
                                                                 : kColorRandom;
    g.range[0] = float(m.filterMin);
    g.range[1] = float(m.filterMax);
    g.range[2] = float(m.colorMin);
    g.range[3] = float(m.colorMax);
    g.rgba[0] = m.rgb[0];
    g.rgba[1] = m.rgb[1];
    g.rgba[2] = m.rgb[2];
    g.rgba[3] = std::clamp(m.opacity, 0.0f, 1.0f);
    g.colour[0] = m.colorMode == Material::ColorMode::Colormap ? out.attributeIndex(m.colorAttribute) : kNone;
    g.colour[1] = m.wrap == Material::Wrap::Repeat ? 1u : 0u;
    const std::string which = "material " + std::to_string(index + 1) + (m.name.empty() ? "" : " ('" + m.name + "')");
    if (!m.colormap.points.empty()) {
        if (m.colormap.points.size() < 2) return Status::error(which + ": a colormap needs two points");
        g.colour[2] = uint32_t(out.colormapSamples.size());
        g.colour[3] = kColormapSamples;
        for (uint32_t k = 0; k < kColormapSamples; ++k) {
            const auto c = m.colormap.at(double(k) / (kColormapSamples - 1));
            out.colormapSamples.push_back({c[0], c[1], c[2], 1.0f});
        }
    } else if (m.colorMode == Material::ColorMode::Colormap) {
        if (!m.colormap.name.empty())
            return Status::error(which + ": colormap '" + m.colormap.name + "' is not resolved to points");
        return Status::error(which + ": colormap mode without a colormap");
    }
    g.extra[0] = std::max(m.emission, 0.0f);
    return g;
}

Result<PackedMaterials> packMaterials(const MaterialDocument& doc) {
    PackedMaterials out;
    for (size_t i = 0; i < doc.materials.size(); ++i) {
        Result<GpuMaterial> g = packMaterial(doc.materials[i], i, out);
        if (!g) return g.status();
        out.materials.push_back(*g);
    }
    return out;
}

/// The leading materials that filter on `label`, as one index (a selection or "only" overlay puts
/// one material per run of labels there, 100,000 for as many scattered labels).
FirstInterval leadingLabelMaterials(const PackedMaterials& packed) {
    std::vector<std::pair<uint64_t, uint64_t>> leading;
    for (const GpuMaterial& g : packed.materials) {
        if (g.select[0] != kNone) break;
        leading.emplace_back(g.select[1], g.select[2]); // select[1] > select[2]: holds none
    }
    return FirstInterval(leading);
}

/// The first material whose filter holds a stored label, with the GPU's own comparisons
/// (integers for `label`, floats for attributes): what render_common.glsl's materialOf does.
struct MaterialMatcher {
    const PackedMaterials& packed;
    const std::map<std::string, std::vector<float>>& attributes;
    const std::vector<uint32_t>& storedToOriginal;
    uint64_t labelCount;
    FirstInterval leading = leadingLabelMaterials(packed);

    uint32_t operator()(uint32_t stored) const {
        if (stored == kNone) return kNone;
        if (leading.size() > 0) {
            const uint32_t l = !storedToOriginal.empty() && stored < labelCount ? storedToOriginal[stored] : stored;
            if (const int64_t i = leading.find(l); i >= 0) return uint32_t(i);
        }
        for (size_t i = leading.size(); i < packed.materials.size(); ++i) {
            const GpuMaterial& g = packed.materials[i];
            if (g.select[0] == kNone) {
                const uint32_t l = !storedToOriginal.empty() && stored < labelCount ? storedToOriginal[stored] : stored;
                if (l >= g.select[1] && l <= g.select[2]) return uint32_t(i);
            } else {
                if (stored >= labelCount) continue;
                const float v = attributes.at(packed.attributeNames[g.select[0]])[stored];
                if (v >= g.range[0] && v <= g.range[1]) return uint32_t(i);
            }
        }
        return kNone;
    }
};

/// The per-label arrays and the label map as the shaders index them where the volume stores
/// labels as ids (GpuVolume::labelIds; `byId`): value i is the given one of label ids[i] (NaN past
/// the given arrays' `count` labels, as the shaders read an attribute there), and the label map
/// gives each id its original label (the given map's, or the label itself).
struct PerStored {
    bool byId = false;
    std::map<std::string, std::vector<float>> attributes;
    std::vector<uint32_t> storedToOriginal;
};
PerStored inStoredLabels(const std::vector<uint32_t>& ids, const std::map<std::string, std::vector<float>>& attributes,
                         const std::vector<uint32_t>& storedToOriginal, uint64_t count) {
    PerStored out;
    if (ids.empty()) return out;
    out.byId = true;
    out.storedToOriginal.resize(ids.size());
    for (size_t i = 0; i < ids.size(); ++i)
        out.storedToOriginal[i] = !storedToOriginal.empty() && ids[i] < count ? storedToOriginal[ids[i]] : ids[i];
    for (const auto& [name, values] : attributes) {
        std::vector<float>& v = out.attributes[name];
        v.resize(ids.size());
        for (size_t i = 0; i < ids.size(); ++i) v[i] = ids[i] < count ? values[ids[i]] : std::numeric_limits<float>::quiet_NaN();
    }
    return out;
}

/// A 64-bit digest of everything setMaterials uploads (the packed materials, their colormap
/// samples, the attribute arrays they name, the label map and count): equal digests, equal images.
uint64_t materialsFingerprint(const PackedMaterials& packed, const std::map<std::string, std::vector<float>>& attributes,
                              const std::vector<uint32_t>& storedToOriginal, uint64_t labels) {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    auto mix = [&h](const void* data, size_t bytes) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (size_t i = 0; i < bytes; i += 8) {
            uint64_t w = 0;
            std::memcpy(&w, p + i, std::min<size_t>(8, bytes - i));
            h = (h ^ w) * 0x100000001B3ull;
            h ^= h >> 29;
        }
        h = (h ^ bytes) * 0xFF51AFD7ED558CCDull;
    };
    mix(packed.materials.data(), packed.materials.size() * sizeof(GpuMaterial));
    mix(packed.colormapSamples.data(), packed.colormapSamples.size() * sizeof(packed.colormapSamples[0]));
    for (const std::string& name : packed.attributeNames) {
        const std::vector<float>& values = attributes.at(name);
        mix(name.data(), name.size());
        mix(values.data(), values.size() * 4);
    }
    mix(storedToOriginal.data(), storedToOriginal.size() * 4);
    mix(&labels, sizeof labels);
    return h == 0 ? 1 : h; // 0 means "nothing uploaded"
}

/// The largest label of `labels` (kNone aside; 0 when none).
uint32_t largestLabel(const std::vector<uint32_t>& labels) {
    uint32_t largest = 0;
    for (uint32_t l : labels)
        if (l != kNone) largest = std::max(largest, l);
    return largest;
}

/// A piece whose dense table was made to cover other ranks' labels up to `lookup.largest`
/// (RendererOptions::largestOtherLabel): labels beyond it (`largest` of them) would be drawn as
/// no material's.
Status checkOtherLabels(const LabelLookup& lookup, uint32_t largest, const std::string& what) {
    if (lookup.kind != kLookupDense || largest <= lookup.largest) return Status::ok(); // the scan takes every label
    return Status::error(what + " hold label " + std::to_string(largest) + ", beyond the largest the renderer was made for (" +
                         std::to_string(lookup.largest) + ": RendererOptions::largestOtherLabel)");
}

} // namespace renderer_detail

uint64_t Renderer::Impl::materialBytes(const PackedMaterials& packed,
                                       const std::map<std::string, std::vector<float>>& attributeArrays,
                                       const std::vector<uint32_t>& storedToOriginal) {
    auto made = [](uint64_t bytes) { return std::max<uint64_t>(bytes, 16); }; // as uploadDeviceLocal allocates
    uint64_t n = made(packed.materials.size() * sizeof(GpuMaterial)) + made(packed.colormapSamples.size() * 16) +
                 made(packed.attributeNames.size() * 8) + made(storedToOriginal.size() * 4);
    for (const std::string& name : packed.attributeNames) n += made(attributeArrays.at(name).size() * 4);
    // The label colours are allocated once (their size is the lookup's): counted when not yet there.
    return n + made(lookup.tableBytes()) + (labelColors.size() == 0 && lookup.colorBytes() > 0 ? made(lookup.colorBytes()) : 0);
}

Status Renderer::Impl::uploadDeviceLocal(Buffer& dst, const void* data, uint64_t bytes) {
    Result<Buffer> b = ctx.createBuffer(std::max<uint64_t>(bytes, 16), MemoryKind::DeviceLocal);
    if (!b) return b.status();
    Status s = ctx.upload(*b, 0, data, bytes);
    if (!s) return s;
    dst = std::move(*b);
    return Status::ok();
}

Status Renderer::Impl::uploadMaterials(const PackedMaterials& packed,
                                       const std::map<std::string, std::vector<float>>& attributeArrays,
                                       const std::vector<uint32_t>& storedToOriginal, uint64_t labels) {
    std::vector<uint64_t> addresses;
    std::vector<Buffer> buffers;
    Status s;
    for (const std::string& name : packed.attributeNames) {
        const std::vector<float>& values = attributeArrays.at(name);
        Buffer b;
        if (!(s = uploadDeviceLocal(b, values.data(), values.size() * 4))) return s.prefix("attribute '" + name + "'");
        addresses.push_back(b.address());
        buffers.push_back(std::move(b));
    }
    const std::vector<GpuMaterial>& mats = packed.materials;
    if (!(s = uploadDeviceLocal(materials, mats.data(), mats.size() * sizeof(GpuMaterial)))) return s;
    if (!(s = uploadDeviceLocal(colormaps, packed.colormapSamples.data(), packed.colormapSamples.size() * 16))) return s;
    if (!(s = uploadDeviceLocal(attributeTable, addresses.data(), addresses.size() * 8))) return s;
    if (!(s = uploadDeviceLocal(labelMap, storedToOriginal.data(), storedToOriginal.size() * 4))) return s;
    attributes = std::move(buffers);
    materialCount = uint32_t(mats.size());
    labelCount = uint32_t(labels);
    hasLabelMap = !storedToOriginal.empty();
    return Status::ok();
}

Status Renderer::Impl::uploadVisibility(const MaterialMatcher& materialOf) {
    // A table label -> material (LabelLookup) replaces the shader's scan of the material list.
    const std::vector<uint32_t> table = lookup.table(materialOf);
    Status s = uploadDeviceLocal(materialTable, table.data(), table.size() * 4);
    if (!s) return s;
    materialTableSize = uint32_t(table.size());
    // The drawn labels' interval: the table's when it covers every stored label (kLookupDense),
    // else any label may be drawn. None drawn: an empty interval.
    drawnFirst = 0;
    drawnLast = kNone - 1;
    if (lookup.kind == kLookupDense) {
        const auto drawn = [](uint32_t m) { return m != kNone; };
        const auto first = std::find_if(table.begin(), table.end(), drawn);
        const auto last = std::find_if(table.rbegin(), table.rend(), drawn);
        drawnFirst = first == table.end() ? 1u : uint32_t(first - table.begin());
        drawnLast = first == table.end() ? 0u : uint32_t(table.rend() - last) - 1u;
    }
    if (lookup.colorBytes() > 0) { // the labels' colours, computed by the next frame (label_colors.comp)
        if (labelColors.size() == 0) {
            Result<Buffer> colors = ctx.createBuffer(lookup.colorBytes(), MemoryKind::DeviceLocal);
            if (!colors) return colors.status();
            labelColors = std::move(*colors);
        }
        materialState.labelColorsPending = true;
    }
    // Which bricks can show anything: their palettes against the materials.
    auto materialOfStored = [&](uint32_t stored) {
        return stored >= table.size() ? materialOf(stored) : lookup.hostMaterial(table, stored);
    };
    // The palettes' labels as the shaders see them (ids where the volume stores them).
    auto storedOf = [&](uint32_t label) { return volume->storedOf(label); };
    const CompressedVolume& vol = volume->volume();
    const uint32_t L = vol.levels();
    // The sub-blocks without drawn labels (kSlotHidden) are made anew, where the volume holds two
    // labels or more that no material draws (hiddenLabels; Core's castRaysStable decides alike):
    // with one, such a sub-block holds it alone, a uniform one, and the masks stay 0 (no pass).
    // Materials that draw the same labels (another colour, opacity) keep the masks: the table's
    // entries drawn or not, fingerprinted (without a table: made anew).
    uint64_t drawn = 1469598103934665603ull;
    for (uint32_t m : table) drawn = (drawn ^ (m == kNone ? 0x9Eu : 0x37u)) * 1099511628211ull;
    if (table.empty() || drawn != materialState.drawnFingerprint) materialState.hiddenAllPending = true;
    materialState.drawnFingerprint = table.empty() ? 0 : drawn;
    auto severalUndrawn = [&] {
        const auto undrawn = std::count(table.begin(), table.end(), kNone);
        if (!volume->labelIds().empty()) return undrawn > 1; // the table holds the palettes' labels alone
        if (!table.empty() && undrawn < 2) return false; // not even among all labels
        // The palette summary's labels (a whole volume's), without reading a palette again.
        if (const PaletteSummary& palettes = volume->palettes(); palettes.labelsComplete && volume->owned().empty()) {
            int count = 0;
            for (uint32_t l : palettes.labels)
                if (materialOfStored(storedOf(l)) == kNone && ++count > 1) return true;
            return false;
        }
        uint32_t first = kNone; // the palettes' labels, until a second undrawn one
        bool several = false;
        sweepBricks(vol, kSweepBricks, [&](uint64_t from, uint64_t to) {
            for (uint64_t b = from; b < to && !several; ++b) {
                if (!volume->owns(b) || !volume->sound(b)) continue;
                const BrickWords bw = vol.brick(b);
                for (uint32_t k = 0; k < bw.words[L] && !several; ++k)
                    if (const uint32_t l = bw.words[bw.size - 1 - k]; materialOfStored(l) == kNone) {
                        several = first != kNone && l != first;
                        first = l;
                    }
            }
            return !several;
        });
        return several;
    };
    materialState.hiddenLabels = resolved.hiddenWanted && severalUndrawn();
    // Per brick its preview label and that label's material (what a view ray shows of the brick
    // while it is not cached: its coarsest level, the root label, else the first palette entry a
    // material draws), kNone twice when no palette entry is drawn (the brick is invisible).
    std::vector<uint32_t> vis(size_t(brickCount) * 2, kNone);
    const std::vector<uint32_t>& first = volume->palettes().first;
    sweepBricks(vol, kSweepBricks, [&](uint64_t from, uint64_t to) {
#pragma omp parallel for schedule(dynamic, 64)
        for (int64_t b = int64_t(from); b < int64_t(to); ++b) {
            if (!volume->owns(uint64_t(b))) { // another process's brick (MPI): absent here
                vis[2 * size_t(b) + 1] = kBrickAbsent;
                continue;
            }
            if (!volume->sound(uint64_t(b))) continue; // drawn empty: never requested (a bad brick)
            // The root label, from the palette summary: drawn (the rule), the palette is not read
            // (for a file larger than memory: not read from disk again).
            if (const uint32_t l = storedOf(first[size_t(b)]), m = materialOfStored(l); m != kNone) {
                vis[2 * size_t(b)] = l;
                vis[2 * size_t(b) + 1] = m;
                continue;
            }
            const BrickWords bw = vol.brick(uint64_t(b));
            const uint32_t n = bw.words[L];
            for (uint32_t k = 1; k < n && vis[2 * size_t(b)] == kNone; ++k)
                if (const uint32_t l = storedOf(bw.words[bw.size - 1 - k]), m = materialOfStored(l); m != kNone) {
                    vis[2 * size_t(b)] = l;
                    vis[2 * size_t(b) + 1] = m;
                }
        }
        return true;
    });
    cacheState.visibilityChanged = cacheState.prefetchPending = true;
    visibleBricks = 0;
    for (size_t b = 0; b < brickCount; ++b) visibleBricks += vis[2 * b] != kNone ? 1 : 0;
    if (Status u = ctx.upload(visible, 0, vis.data(), vis.size() * 4); !u) return u;
    const std::vector<uint32_t> groups = emptyGroupLevels(
        vol.brickGrid(), [&](uint64_t b) { return vis[2 * b] == kNone && vis[2 * b + 1] != kBrickAbsent; });
    return ctx.upload(emptyGroups, 0, groups.data(), groups.size() * 4);
}

Status Renderer::setGhostFaces(const std::array<uint32_t, 3>& lo, const std::array<uint32_t, 3>& hi,
                               const std::array<std::vector<uint32_t>, 6>& faces) {
    Impl& im = *m_impl;
    if (im.volume->owned().empty()) return Status::error("ghost faces are for an MPI rank's piece (GpuVolumeOptions::owned)");
    std::vector<uint32_t> words(kGhostHeaderWords, 0u);
    for (int a = 0; a < 3; ++a) {
        if (hi[a] <= lo[a]) return Status::error("the piece's box is empty along axis " + std::to_string(a));
        words[size_t(a)] = lo[a];
        words[size_t(3 + a)] = hi[a];
    }
    for (int side = 0; side < 6; ++side) {
        const int a = side / 2, u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
        const std::vector<uint32_t>& f = faces[size_t(side)];
        if (f.empty()) continue;
        if (f.size() != size_t(hi[u] - lo[u]) * (hi[v] - lo[v]))
            return Status::error("ghost face " + std::to_string(side) + " holds " + std::to_string(f.size()) +
                                 " labels, not the piece's face");
        if (Status s = checkOtherLabels(im.lookup, largestLabel(f), "the ghost faces"); !s) return s;
        words[size_t(6 + side)] = uint32_t(words.size());
        words.insert(words.end(), f.begin(), f.end());
    }
    if (words.size() > 0xFFFFFFFFull) return Status::error("the ghost faces are too large");
    Status s = im.uploadDeviceLocal(im.ghost, words.data(), words.size() * 4);
    if (!s) return s.prefix("ghost faces");
    im.resetAccumulation();
    return Status::ok();
}

Status Renderer::setCoarseStandIns(uint32_t first, const std::vector<std::vector<uint32_t>>& levels) {
    Impl& im = *m_impl;
    const CompressedVolume& v = im.volume->volume();
    if (im.volume->owned().empty())
        return Status::error("coarse stand-ins are for an MPI rank's piece (GpuVolumeOptions::owned)");
    if (first >= v.levels() || levels.size() != v.levels() - first)
        return Status::error("coarse stand-ins: levels " + std::to_string(first) + " to the coarsest (" +
                             std::to_string(v.levels() - 1) + ") are needed, " + std::to_string(levels.size()) + " given");
    // Where every label fits below the uniform levels' bits, each word carries its node's uniform
    // level (the largest aligned cube of one label around it, within a brick): secondary rays
    // step over another rank's uniform regions whole, as over the rank's own bricks' (a level-0
    // stand-in stepped voxel by voxel cost path tracing at 2 ranks 15-20 % a frame on lavapipe).
    uint32_t largest = 0;
    for (const std::vector<uint32_t>& level : levels) largest = std::max(largest, largestLabel(level));
    if (Status s = checkOtherLabels(im.lookup, largest, "the coarse stand-ins"); !s) return s;
    const bool packed = largest <= kUniformLabelMask;
    std::vector<uint32_t> words{first, uint32_t(levels.size()), packed ? 1u : 0u};
    static_assert(kCoarseHeaderWords == 3 && kCoarseLevelWords == 4, "the header written here");
    words.resize(kCoarseHeaderWords + kCoarseLevelWords * levels.size());
    for (size_t i = 0; i < levels.size(); ++i) {
        const std::array<uint32_t, 3> d = lodDimensions(v.dim, first + uint32_t(i));
        if (levels[i].size() != size_t(d[0]) * d[1] * d[2])
            return Status::error("coarse stand-ins: " + std::to_string(levels[i].size()) + " labels do not fill level " +
                                 std::to_string(first + i) + " of the volume");
        if (words.size() + levels[i].size() > 0xFFFFFFFFull) return Status::error("coarse stand-ins: too large");
        uint32_t* e = words.data() + kCoarseHeaderWords + kCoarseLevelWords * i;
        e[0] = uint32_t(words.size());
        std::copy(d.begin(), d.end(), e + 1);
        const size_t at = words.size();
        words.insert(words.end(), levels[i].begin(), levels[i].end());
        if (packed) {
            const uint32_t level = first + uint32_t(i), brickShift = log2u(v.brickSize);
            const std::vector<uint8_t> u = gridUniformLevels(levels[i], d, level < brickShift ? brickShift - level : 0);
            for (size_t n = 0; n < u.size(); ++n)
                if (words[at + n] != kNone) words[at + n] |= uint32_t(u[n]) << kUniformLevelShift;
        }
    }
    Status s = im.uploadDeviceLocal(im.coarse, words.data(), words.size() * 4);
    if (!s) return s.prefix("coarse stand-ins");
    im.resetAccumulation();
    return Status::ok();
}

Status Renderer::setMaterials(const MaterialDocument& doc, const std::map<std::string, std::vector<float>>& attributes,
                              const std::vector<uint32_t>& storedToOriginal) {
    Impl& im = *m_impl;
    std::vector<std::string> names{"label"};
    for (const auto& a : attributes) names.push_back(a.first);
    Status s = checkAttributes(doc, names);
    if (!s) return s;
    Result<uint64_t> given = perLabelCount(attributes, storedToOriginal);
    if (!given) return given.status();
    Result<PackedMaterials> packed = packMaterials(doc);
    if (!packed) return packed.status();
    // What the shaders would read is what they read already (attributes loaded that no material
    // names, a document written anew with the same content): the accumulated image stays. (The
    // volume's ids, below, are the renderer's for good: the same inputs, the same arrays by id.)
    const uint64_t fingerprint = materialsFingerprint(*packed, attributes, storedToOriginal, *given);
    if (fingerprint == im.materialState.materialsFingerprint) return Status::ok();
    im.materialState.materialsFingerprint = 0;
    // Where the volume stores ids, the shaders index the per-label arrays and the label map by id.
    const PerStored perStored = inStoredLabels(im.volume->labelIds(), attributes, storedToOriginal, *given);
    const auto& attrs = perStored.byId ? perStored.attributes : attributes;
    const std::vector<uint32_t>& map = perStored.byId ? perStored.storedToOriginal : storedToOriginal;
    const uint64_t labels = perStored.byId ? perStored.storedToOriginal.size() : *given;
    resetAccumulation(); // before the uploads: a failure among them must not leave an image called exact
    if (!(s = im.makeRoom(im.materialBytes(*packed, attrs, map), "the materials and attributes"))) return s;
    if (!(s = im.uploadMaterials(*packed, attrs, map, labels))) return s;
    if (!(s = im.uploadVisibility(MaterialMatcher{*packed, attrs, map, labels}))) return s;
    im.materialState.materialsFingerprint = fingerprint;
    return Status::ok();
}

} // namespace csgv::gpu
