// SPDX-License-Identifier: MIT
#pragma once
/// @file JsonText.h
/// @brief JSON from files or users, safely (private to Core): a nesting bound checked before
/// parsing, and values for messages that never dump a container. nlohmann's copy, dump and
/// comparison recurse, so a deeply nested document would otherwise overflow the stack. Used by
/// the input metadata (Zarr, precomputed), `.csgv.json` and the material document.

#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>

namespace csgv {

/// JSON nesting accepted in documents: real files nest a handful of levels (OME transformations
/// are the deepest, about 6). Anything deeper is refused before parsing, so that no recursive
/// walk of a parsed value (nlohmann's copy, dump, comparison) can overflow the stack.
constexpr unsigned kMaxJsonDepth = 64;
/// Empty when the JSON text nests arrays/objects at most kMaxJsonDepth deep, else the reason
/// (strings are skipped with their escapes; the text need not be valid JSON).
std::string jsonTooDeep(const char* text, size_t size);
/// A JSON value for a message, without ever dumping a container (which recurses): scalars as
/// their JSON text (cut to 60 characters), containers as "an array of N elements", "an object".
std::string jsonText(const nlohmann::json& v);

} // namespace csgv
