// SPDX-License-Identifier: MIT
#pragma once
/// @file CsgvFile.h
/// @brief A `.csgv` file opened with whatever lies beside it (the `.csgv.json` metadata and the
/// `_csgv.db3` attribute database), so that every caller sees geometry and original labels the
/// same way.

#include "csgv/attributes/AttributeDb.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Metadata.h"

#include <string>

namespace csgv {

/// @brief A compressed volume, its metadata and, when present, its id -> label mapping.
struct CsgvFile {
    std::string path;
    CompressedVolume volume;
    VolumeMetadata metadata;   ///< defaults (spacing 1, origin 0) when no `.csgv.json` exists
    bool hasMetadata = false;
    bool hasAttributes = false;
    AttributeDatabase attributes;
    /// Original labels wider than the format (64-bit or negative): decoders return ids, and
    /// originalLabel() maps them. Otherwise idToLabel maps ids to uint32 labels.
    bool wideLabels = false;
    std::vector<uint32_t> idToLabel; ///< filled when hasAttributes && !wideLabels

    /// Options that make decoders return original labels (ids when wideLabels).
    DecodeOptions decodeOptions(int threads = 0) const {
        DecodeOptions o;
        o.threads = threads;
        if (hasAttributes && !wideLabels) o.idToLabel = &idToLabel;
        return o;
    }
    /// The original label of an id as int64 bits (uint64 bits when attributes.labelsUnsigned64).
    int64_t originalLabel(uint32_t id) const {
        return hasAttributes && id < attributes.labels.size() ? attributes.labels[id] : int64_t(id);
    }
};

/// Reads the container and, when present, the metadata and the attribute database (whose volume
/// size must match).
Result<CsgvFile> openCsgv(const std::string& path);
/// The same with the container memory-mapped (readCsgvMapped): the encoding arrays view the
/// file, so opening costs no copy of it. For callers that hold the volume while nobody rewrites
/// the file in place (the command-line tools); a long-lived session that must survive a file
/// truncated under it reads it (openCsgv).
Result<CsgvFile> openCsgvMapped(const std::string& path);
/// The same without the encoding arrays (readCsgvHeader): the volume's header fields and brick
/// starts and the sidecars, for readers that read bricks later (readCsgvPiece).
Result<CsgvFile> openCsgvHeader(const std::string& path);

} // namespace csgv
