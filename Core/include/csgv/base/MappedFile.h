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
/// A mapping shows the file as it is on disk; a new file renamed over the path does no harm (the
/// mapping keeps the old one; writers in this project write through a temporary and rename:
/// AtomicFile). A file truncated under the mapping would raise SIGBUS where a page past its new
/// end is touched: every mapping is guarded against that. A process-wide SIGBUS handler (installed
/// with the first mapping, chained to whatever handler was there before) replaces such a page
/// with zeros and marks the mapping damaged, so the reader sees zeros (a `.csgv` brick of zeros
/// fails to decode with a clear error) instead of dying; damaged() and damagedAt() tell callers
/// to say why. Faults outside the mappings go to the previous handler as before.
class MappedFile {
public:
    struct Options {
        /// Read the file into memory instead of mapping it (what happens anyway where mapping
        /// fails); for tests and for callers that want private bytes.
        bool read = false;
        /// Map copy-on-write (MAP_PRIVATE, readable and writable): a write to the bytes changes
        /// this process's copy of that page, never the file, and never faults. For bytes handed
        /// to code that may write to them (a VTK array a user's script can change); the pages no
        /// one writes are the page cache's as with a read-only mapping.
        bool copyOnWrite = false;
        /// Refuse to read more than this into memory (a pipe has no size to check beforehand;
        /// the limit does not apply to a mapping, which takes no private memory). Unset, a pipe
        /// or socket is read up to half the memory available when it is opened.
        uint64_t maxReadBytes = ~uint64_t(0);
    };

    /// Opens `path`: a regular file is mapped (an empty one needs no mapping), and read where
    /// mapping fails; a pipe or socket is read to its end. Errors name the file: one that cannot
    /// be opened (and why), a character device (/dev/zero never ends), one that is not a regular
    /// file or a stream (a folder), a read or mapping failure, a stream longer than the limit.
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

    /// True once a page of the mapping had to be replaced by zeros because the file shrank under it.
    bool damaged() const;
    /// Whether [address, address + size) lies in a live guarded mapping and reaches a page that
    /// was replaced by zeros (for callers that hold only a view of the bytes: what they read there
    /// is not the file's). A file cut short fails every page past its new end, and the first such
    /// page touched is the lowest: bytes before it are the file's.
    static bool damagedAt(const void* address, size_t size = 1);
    /// Whether [address, address + size) in a live mapping lies past the file's end now (or
    /// reached a page of zeros): the file was cut short under the mapping. Asks the file's size
    /// (a system call): for explaining an error, not for every read. Bytes of the page that holds
    /// the new end read as zeros without a fault, which only this tells.
    static bool cutShortAt(const void* address, size_t size);
    /// Whether `address` lies in a live mapping of a file that was written to since it was mapped
    /// (its modification time changed: rewritten in place, the mapping's bytes are the new
    /// file's). Asks the file (a system call): for explaining an error.
    static bool rewrittenAt(const void* address);
    /// Whether `address` lies in a live mapping of a file (whose pages release() may drop: they
    /// are read again from the file when touched).
    static bool mappedAt(const void* address);

    /// Page control of a mapping, for `address` and `size` within one mapping of a file
    /// (mappedAt); else nothing happens (anonymous memory must never be released: it would read
    /// as zeros). Byte ranges are widened to whole pages. releaseAt(): the process gives the
    /// range's pages back (MADV_DONTNEED; the kernel's page cache may keep them, and touching them
    /// again reads them from the cache or the file), so its resident memory stays bounded however
    /// much of the file it sweeps. willNeedAt(): starts reading the range in the background
    /// (MADV_WILLNEED: read-ahead).
    static void releaseAt(const void* address, size_t size);
    static void willNeedAt(const void* address, size_t size);
    /// Of [address, address + size) within a mapping, the bytes whose pages are not in memory
    /// (those a touch must read from the disk); 0 outside mappings.
    static size_t absentBytesAt(const void* address, size_t size);

private:
    MappedFile() = default;
    std::string m_path;
    const uint8_t* m_data = nullptr;
    size_t m_size = 0;
    bool m_mapped = false;
    int m_slot = -1; ///< its entry in the guard's registry (a mapping)
    int m_fd = -1;   ///< the mapped file (a mapping keeps it open)
    std::vector<uint8_t> m_read; ///< the bytes where they were read, not mapped
};

/// @brief Gives back the pages a forward sweep over a mapped file has passed (MappedFile::
/// releaseAt every `window` bytes, and the whole range when the sweep ends), so that a sweep over
/// a file larger than memory keeps a window of it resident, not all of it. Nothing happens for
/// memory that is not a mapping of a file.
class ReleaseBehind {
public:
    ReleaseBehind(const void* begin, size_t size, size_t window = size_t(32) << 20)
        : m_begin(static_cast<const uint8_t*>(begin)), m_done(m_begin), m_size(size), m_window(window),
          m_active(size > 0 && MappedFile::mappedAt(begin)) {}
    ~ReleaseBehind() {
        if (m_active) MappedFile::releaseAt(m_begin, m_size);
    }
    ReleaseBehind(const ReleaseBehind&) = delete;
    ReleaseBehind& operator=(const ReleaseBehind&) = delete;
    /// The sweep has read everything before `at`.
    void reached(const void* at) {
        const uint8_t* p = static_cast<const uint8_t*>(at);
        if (!m_active || p < m_done + m_window) return;
        MappedFile::releaseAt(m_done, size_t(p - m_done));
        m_done = p;
    }

private:
    const uint8_t* m_begin;
    const uint8_t* m_done;
    size_t m_size, m_window;
    bool m_active;
};

} // namespace csgv
