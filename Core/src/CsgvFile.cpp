// SPDX-License-Identifier: MIT
#include "csgv/CsgvFile.h"
#include "csgv/FileUtil.h"

namespace csgv {

Result<CsgvFile> openCsgv(const std::string& path) {
    CsgvFile f;
    f.path = path;
    Result<CompressedVolume> vol = readCsgv(path);
    if (!vol) return vol.status();
    f.volume = std::move(*vol);
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
    if (!map) return map.status();
    f.idToLabel = std::move(*map);
    f.attributes = std::move(*db);
    f.hasAttributes = true;
    return f;
}

} // namespace csgv
