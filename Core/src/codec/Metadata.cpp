// SPDX-License-Identifier: MIT
#include "csgv/codec/Metadata.h"
#include "csgv/base/FileUtil.h"
#include "../base/JsonText.h"

#include <cmath>
#include <nlohmann/json.hpp>

namespace csgv {

using nlohmann::json;

std::string metadataPathFor(const std::string& csgvPath) { return csgvPath + ".json"; }

namespace {
/// Moves the origin by `halves` half voxels along every index axis.
Geometry shiftedOrigin(const Geometry& g, double halves) {
    Geometry out = g;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) out.origin[r] += 0.5 * halves * g.direction[3 * r + c] * g.spacing[c];
    return out;
}
} // namespace

Geometry cellGeometryFromPointGeometry(const Geometry& g) { return shiftedOrigin(g, -1); }

Geometry pointGeometryFromCellGeometry(const Geometry& g) { return shiftedOrigin(g, +1); }

Status writeMetadata(const std::string& path, const VolumeMetadata& md) {
    json j;
    j["format"] = "csgv-metadata";
    j["version"] = 1;
    j["dimensions"] = md.dim;
    j["spacing"] = md.geometry.spacing;
    j["origin"] = md.geometry.origin;
    j["direction"] = md.geometry.direction;
    j["original_type"] = md.originalType;
    j["relabelled"] = md.relabelled;
    j["source"] = md.source;
    // The source and type names come from outside (a file name, a ParaView array name) and may be
    // any bytes; JSON text is UTF-8, so invalid sequences are written as U+FFFD (dump() would throw).
    const std::string text = j.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
    AtomicFile f;
    Status s = f.open(path);
    if (s) s = f.write(text.data(), text.size());
    if (s) s = f.commit();
    return s;
}

Result<VolumeMetadata> readMetadata(const std::string& path) {
    Result<std::vector<uint8_t>> bytes = readFile(path, 1 << 20);
    if (!bytes) return bytes.status();
    const std::string where = "metadata '" + path + "': ";
    const std::string deep = jsonTooDeep(reinterpret_cast<const char*>(bytes->data()), bytes->size());
    if (!deep.empty()) return Status::error(where + deep);
    json j = json::parse(bytes->begin(), bytes->end(), nullptr, false);
    if (j.is_discarded() || !j.is_object()) return Status::error(where + "not a JSON object");
    VolumeMetadata md;
    auto numbers = [&](const char* key, double* out, size_t n, bool positive) -> Status {
        if (!j.contains(key)) return Status::ok();
        const json& a = j[key];
        if (!a.is_array() || a.size() != n) return Status::error(where + "'" + key + "' must be " + std::to_string(n) + " numbers");
        for (size_t i = 0; i < n; ++i) {
            if (!a[i].is_number()) return Status::error(where + "'" + key + "' must be " + std::to_string(n) + " numbers");
            out[i] = a[i].get<double>();
            if (!std::isfinite(out[i]) || (positive && out[i] <= 0))
                return Status::error(where + "'" + key + "' holds " + jsonText(a[i]) + (positive ? ", not a positive number" : ", not a finite number"));
        }
        return Status::ok();
    };
    if (j.contains("version") && (!j["version"].is_number_integer() || j["version"].get<int64_t>() != 1))
        return Status::error(where + "unsupported version " + jsonText(j["version"]));
    double dims[3] = {0, 0, 0};
    Status s = numbers("dimensions", dims, 3, true);
    if (s) s = numbers("spacing", md.geometry.spacing.data(), 3, true);
    if (s) s = numbers("origin", md.geometry.origin.data(), 3, false);
    if (s) s = numbers("direction", md.geometry.direction.data(), 9, false);
    if (!s) return s;
    for (int a = 0; a < 3; ++a) {
        // Whole voxel counts a volume can have (a cast of 0.5 or 1e10 would give 0 or be undefined).
        if (j.contains("dimensions") && (dims[a] != std::floor(dims[a]) || dims[a] > 4294967295.0))
            return Status::error(where + "'dimensions' holds " + jsonText(j["dimensions"][a]) +
                                 ", not a whole number of voxels from 1 to 4294967295");
        md.dim[a] = uint32_t(dims[a]);
    }
    if (j.contains("original_type")) {
        if (!j["original_type"].is_string()) return Status::error(where + "'original_type' must be a string");
        md.originalType = j["original_type"].get<std::string>();
    }
    if (j.contains("relabelled")) {
        if (!j["relabelled"].is_boolean()) return Status::error(where + "'relabelled' must be true or false");
        md.relabelled = j["relabelled"].get<bool>();
    }
    if (j.contains("source") && j["source"].is_string()) md.source = j["source"].get<std::string>();
    return md;
}

} // namespace csgv
