// SPDX-License-Identifier: MIT
#pragma once
/// @file CsgvFile.h
/// @brief A `.csgv` file opened with whatever lies beside it (the attribute database), so that
/// every caller decodes original labels the same way.

#include "csgv/AttributeDb.h"
#include "csgv/Container.h"
#include "csgv/Decoder.h"

#include <string>

namespace csgv {

/// @brief A compressed volume and, when `<stem>_csgv.db3` exists, its id -> label mapping.
struct CsgvFile {
    std::string path;
    CompressedVolume volume;
    bool hasAttributes = false;
    AttributeDatabase attributes;
    std::vector<uint32_t> idToLabel; ///< filled when hasAttributes

    /// Options that make decoders return original labels.
    DecodeOptions decodeOptions(int threads = 0) const {
        DecodeOptions o;
        o.threads = threads;
        if (hasAttributes) o.idToLabel = &idToLabel;
        return o;
    }
};

/// Reads the container and, when present, the attribute database (whose volume size must match).
Result<CsgvFile> openCsgv(const std::string& path);

} // namespace csgv
