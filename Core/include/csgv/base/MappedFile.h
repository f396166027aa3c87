// SPDX-License-Identifier: MIT
#pragma once
/// @file MappedFile.h
/// @brief A file's bytes, read-only, memory-mapped where the system allows it (so that opening a
/// file of gigabytes costs neither time nor private memory: pages come from the page cache as
/// they are touched), else read into memory (a pipe, an empty file, a file system that cannot
/// map).

#include "csgv/base/Status.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace csgv {

/// @brief The bytes of one file, alive as long as the object (hand out a shared_ptr to it as the
/// keeper of views into them: WordArray::view).
///
/// A mapping shows the file as it is on disk: the file must not be truncated or rewritten in
/// place while the object lives (touching a page past a truncated end raises SIGBUS); a new file
/// renamed over the path does no harm, the mapping keeps the old one. Writers in this project
/// write through a temporary and rename (AtomicFile).
class MappedFile {
public:
    struct Options {
        /// Read the file into memory instead of mapping it (what happens anyway where mapping
        /// fails); for tests and for callers that want private bytes.
        bool read = false;
        /// Refuse to read more than this into memory (a pipe has no size to check beforehand;
        /// the limit does not apply to a mapping, which takes no private memory).
        uint64_t maxReadBytes = ~uint64_t(0);
    };

    /// Opens `path`: a regular file is mapped (an empty one needs no mapping), and read where
    /// mapping fails; a pipe, socket or character device is read to its end. Errors name the file:
    /// one that cannot be opened (and why), one that is not a regular file or a stream (a
    /// folder), a read or mapping failure, a stream longer than maxReadBytes.
    static Result<std::shared_ptr<const MappedFile>> open(const std::string& path, const Options& options);
    static Result<std::shared_ptr<const MappedFile>> open(const std::string& path) { return open(path, Options{}); }

    ~MappedFile();
    MappedFile(const MappedFile&) = delete;
    MappedFile& operator=(const MappedFile&) = delete;

    /// The bytes (null when the file is empty) and their count.
    const uint8_t* data() const { return m_data; }
    size_t size() const { return m_size; }
    /// True when the bytes are a mapping of the file, false when they were read into memory.
    bool isMapped() const { return m_mapped; }
    const std::string& path() const { return m_path; }
    /// Bytes of private memory the object holds (a mapping: none; it is the page cache's).
    size_t privateBytes() const { return m_mapped ? 0 : m_size; }

private:
    MappedFile() = default;
    std::string m_path;
    const uint8_t* m_data = nullptr;
    size_t m_size = 0;
    bool m_mapped = false;
    std::vector<uint8_t> m_read; ///< the bytes where they were read, not mapped
};

} // namespace csgv
