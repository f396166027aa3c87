// SPDX-License-Identifier: MIT
#include "csgv/codec/CsgvFile.h"
#include "csgv/base/FileUtil.h"

namespace csgv {

namespace {

/// The sidecars of `f.path` (metadata, attribute database) for the volume already in `f`.
Result<CsgvFile> openSidecars(CsgvFile f) {
    const std::string& path = f.path;
    f.metadata.dim = f.volume.dim;
    const std::string mdPath = metadataPathFor(path);
    if (fileExists(mdPath)) {
        Result<VolumeMetadata> md = readMetadata(mdPath);
        if (!md) return md.status();
        if (md->dim != f.volume.dim && md->dim != std::array<uint32_t, 3>{0, 0, 0})
            return Status::error("metadata '" + mdPath + "' describes another volume size than '" + path + "'");
        f.metadata = std::move(*md);
        f.metadata.dim = f.volume.dim;
        f.hasMetadata = true;
    }
    const std::string dbPath = attributeDbPathFor(path);
    if (!fileExists(dbPath)) return f;
    Result<AttributeDatabase> db = readAttributeDb(dbPath);
    if (!db) return db.status();
    if (db->volumeDim != f.volume.dim)
        return Status::error("attribute database '" + dbPath + "' describes a " + std::to_string(db->volumeDim[0]) +
                             "x" + std::to_string(db->volumeDim[1]) + "x" + std::to_string(db->volumeDim[2]) +
                             " volume, but '" + path + "' is " + std::to_string(f.volume.dim[0]) + "x" +
                             std::to_string(f.volume.dim[1]) + "x" + std::to_string(f.volume.dim[2]));
    Result<std::vector<uint32_t>> map = db->labelsAsUint32();
    if (map) f.idToLabel = std::move(*map);
    else f.wideLabels = true;
    f.attributes = std::move(*db);
    f.hasAttributes = true;
    return f;
}

/// The file at `path` with the volume (or header) read from it and its sidecars.
Result<CsgvFile> withSidecars(const std::string& path, Result<CompressedVolume> vol) {
    if (!vol) return vol.status();
    CsgvFile f;
    f.path = path;
    f.volume = std::move(*vol);
    return openSidecars(std::move(f));
}

} // namespace

Result<CsgvFile> openCsgv(const std::string& path) { return withSidecars(path, readCsgv(path)); }

Result<CsgvFile> openCsgvHeader(const std::string& path) { return withSidecars(path, readCsgvHeader(path)); }

} // namespace csgv
