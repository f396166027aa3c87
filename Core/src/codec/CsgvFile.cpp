// SPDX-License-Identifier: MIT
#include "csgv/codec/CsgvFile.h"
#include "csgv/base/FileUtil.h"

#include <cerrno>
#include <sys/stat.h>

namespace csgv {

namespace {

/// "WxHxD" for messages.
std::string dimText(const std::array<uint32_t, 3>& d) {
    return std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
}

/// What lies at a sidecar's path: nothing, a regular file, or something a reader must not take
/// for "no sidecar" (a directory, a FIFO, a dangling link): that is an error naming the path.
enum class Sidecar { Absent, File };
Result<Sidecar> sidecarAt(const std::string& path, const char* what) {
    struct stat l {};
    if (::lstat(path.c_str(), &l) != 0) {
        if (errno == ENOENT) return Sidecar::Absent;
        return Status::error(std::string("cannot open the ") + what + " '" + path + "': " + errnoText());
    }
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0)
        return Status::error(std::string("the ") + what + " '" + path + "' is a link to nothing (" + errnoText() + ")");
    if (!S_ISREG(st.st_mode))
        return Status::error(std::string("the ") + what + " '" + path + "' is not a regular file");
    return Sidecar::File;
}

/// The sidecars of `f.path` (metadata, attribute database) for the volume already in `f`.
Result<CsgvFile> openSidecars(CsgvFile f) {
    const std::string& path = f.path;
    f.metadata.dim = f.volume.dim;
    const std::string mdPath = metadataPathFor(path);
    Result<Sidecar> md = sidecarAt(mdPath, "metadata");
    if (!md) return md.status();
    if (*md == Sidecar::File) {
        Result<VolumeMetadata> read = readMetadata(mdPath);
        if (!read) return read.status();
        if (read->dim != f.volume.dim && read->dim != std::array<uint32_t, 3>{0, 0, 0})
            return Status::error("metadata '" + mdPath + "' describes a " + dimText(read->dim) + " volume, but '" +
                                 path + "' is " + dimText(f.volume.dim));
        f.metadata = std::move(*read);
        f.metadata.dim = f.volume.dim;
        f.hasMetadata = true;
    }
    const std::string dbPath = attributeDbPathFor(path);
    Result<Sidecar> dbAt = sidecarAt(dbPath, "attribute database");
    if (!dbAt) return dbAt.status();
    if (*dbAt == Sidecar::Absent) {
        // Without its database a relabelled volume holds ids, not the labels it was made from:
        // decoding it would silently give other values than the source had.
        if (f.hasMetadata && f.metadata.relabelled)
            return Status::error("'" + path + "' was relabelled (its metadata '" + mdPath +
                                 "' says so), but its attribute database '" + dbPath +
                                 "' with the original labels is missing");
        return f;
    }
    Result<AttributeDatabase> db = readAttributeDb(dbPath);
    if (!db) return db.status();
    if (db->volumeDim != f.volume.dim)
        return Status::error("attribute database '" + dbPath + "' describes a " + dimText(db->volumeDim) +
                             " volume, but '" + path + "' is " + dimText(f.volume.dim));
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

Result<CsgvFile> openCsgvMapped(const std::string& path) { return withSidecars(path, readCsgvMapped(path)); }

Result<CsgvFile> openCsgvHeader(const std::string& path) { return withSidecars(path, readCsgvHeader(path)); }

} // namespace csgv
