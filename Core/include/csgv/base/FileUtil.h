// SPDX-License-Identifier: MIT
#pragma once
/// @file FileUtil.h
/// @brief Atomic file output (temporary name, then rename) and whole-file input.

#include "csgv/base/Status.h"

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace csgv {

/// @brief Writes to `<path>.tmp-<pid>-<n>` beside the target and renames it into place on
/// commit(); destroying it uncommitted removes the temporary, so a failure never leaves a half
/// file under the target name.
class AtomicFile {
public:
    AtomicFile() = default;
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    Status open(const std::string& path);
    Status write(const void* data, size_t bytes);
    /// Flushes, closes and renames over the target path.
    Status commit();
    void discard();

private:
    std::string m_path;
    std::string m_tmp;
    std::FILE* m_file = nullptr;
};

/// Size of a regular file, or an error naming the path.
Result<uint64_t> fileSize(const std::string& path);
/// Reads a whole file, refusing files larger than maxBytes.
Result<std::vector<uint8_t>> readFile(const std::string& path, uint64_t maxBytes);
/// Reads a whole file, transparently inflating gzip (`.gz`) content; refuses more than maxBytes.
Result<std::vector<uint8_t>> readFileMaybeGz(const std::string& path, uint64_t maxBytes);
/// True when the path names an existing file.
bool fileExists(const std::string& path);
/// True when `s` ends with `suffix` (lowercase ASCII), ignoring case: file extensions.
bool endsWithNoCase(const std::string& s, const char* suffix);

} // namespace csgv
