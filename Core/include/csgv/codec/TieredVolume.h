// SPDX-License-Identifier: MIT
#pragma once
/// @file TieredVolume.h
/// @brief An encoding larger than the host memory it may take (issue 40): the coarse levels
/// resident, the finest level read from the mapped file on demand.
///
/// A rANS two-table encoding (CSGV-FORMAT.md section 4.2) keeps each brick's finest level in a
/// stream of its own (stream B), which is most of the encoding. A TieredVolume splits a volume
/// whose arrays view a mapped `.csgv` (readCsgvMapped, or a reader's mapped bytes) in two tiers:
///
/// - **coarse()**: a private copy of every brick with stream B replaced by the bare rANS state
///   (one word, as for a brick whose finest level visits no node): a valid CompressedVolume that
///   every decoder reads unchanged for levels 1 and coarser (half resolution and below), and that
///   a device uploads as the coarse part of detail separation. Its bytes are the host memory the
///   tiers keep resident.
/// - **the finest level**: each brick's stream B stays in the file. copyFinest() copies one out
///   (detail streaming, host decoding at full resolution); release() hands the pages of bricks
///   done with back to the kernel (MADV_DONTNEED: the page cache may keep them, touching them
///   again reads them from there or the disk); readAhead() asks the kernel to start reading the
///   bricks the next frames will want (MADV_WILLNEED).
///
/// Building the coarse tier is one sweep over the file that releases the pages behind it, so the
/// process's resident memory stays near coarse + a sweep window however large the file is. The
/// host-memory budget bounds the coarse tier and its tables. Where the coarse levels do not fit
/// it, the sweep stops as soon as they pass it and no level is resident: coarse() is the whole
/// (mapped) volume, every brick is read from the file when decoded, and its pages are released
/// after (hasCoarseTier() false). Host decoding works either way; GPU decoding then uploads the
/// coarse part from the file as detail separation does.
///
/// Decisions: the coarse tier keeps each brick's header and palette unchanged (palette entries
/// first used at the finest level included: cache paletting and palette lookups see the same
/// palettes as the whole encoding); decoding level 0 from coarse() is the caller's error (it
/// fails the rANS end-of-stream check, never reads past the brick).

#include "csgv/codec/Container.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace csgv {

/// What the finest tier moved since the tiers were built.
struct TierCounts {
    uint64_t fileBricks = 0; ///< streams copied out (copyFinest) and bricks decoded from the file (noteRead)
    uint64_t fileBytes = 0;  ///< their bytes (a stream's; a decoded brick's whole encoding)
    uint64_t diskBytes = 0;  ///< of those, bytes whose pages were not in memory when asked (read from disk)
    uint64_t readAheadBricks = 0;
    uint64_t releasedBricks = 0;
};

class TieredVolume {
public:
    struct Options {
        /// Host memory the tiers may keep resident (0: no limit): the coarse tier and the table.
        uint64_t budgetBytes = 0;
        /// Called with the fraction swept (0..1) now and then; false stops with "cancelled".
        std::function<bool(double)> progress;
    };

    /// The host-memory budget when the caller sets none (0): half the memory available now
    /// (MemAvailable in /proc/meminfo), or no limit (0) where that is unknown.
    static uint64_t automaticBudget();
    /// Whether `full` is to be tiered under `budgetBytes` (0: automaticBudget()): tierable, and
    /// its encoding arrays take more than the budget.
    static bool wanted(const CompressedVolume& full, uint64_t budgetBytes);
    /// Whether `full` can be tiered: a rANS two-table encoding of at least two levels whose
    /// arrays view a mapping of a file (MappedFile::mappedAt).
    static bool tierable(const CompressedVolume& full);
    /// Sweeps `full` (tierable; checked by checkContainer) once, copying the coarse tier and
    /// measuring the finest streams (no coarse tier where it would exceed the budget); an error
    /// when the sweep is cancelled or the brick tables find no memory.
    static Result<std::shared_ptr<const TieredVolume>> create(std::shared_ptr<const CompressedVolume> full,
                                                               const Options& options);

    /// Whether the coarse levels are resident (they fit the budget).
    bool hasCoarseTier() const { return m_hasCoarse; }
    /// The volume to draw from: the coarse tier, or the whole volume without one.
    const CompressedVolume& coarse() const { return m_hasCoarse ? m_coarse : *m_full; }
    const CompressedVolume& full() const { return *m_full; }
    std::shared_ptr<const CompressedVolume> fullShared() const { return m_full; }

    /// Words of brick b's finest-level stream (stream B: 1 or more in a valid brick; 0 where the
    /// container leaves no room for it, which then fails to decode).
    uint32_t finestWords(uint64_t brick) const;
    /// With a coarse tier: the longest stream and all streams together (measured by the sweep).
    uint32_t longestFinestWords() const { return m_longest; }
    uint64_t finestBytesTotal() const { return m_finestTotal * 4; }
    /// Host memory the tiers hold: the coarse tier's arrays and starts, the finest table.
    uint64_t residentBytes() const;

    /// Copies brick b's finest-level stream (finestWords(b) words) to `dst`. Thread-safe.
    void copyFinest(uint64_t brick, uint32_t* dst) const;
    /// Counts brick b as read from the file by a decoder of full() (host decoding at full
    /// resolution); call before decoding it. Thread-safe.
    void noteRead(uint64_t brick) const;
    /// After `bricks` bricks were copied or decoded from the file: the file's pages leave the
    /// process (all of them, since a fault maps neighbouring pages too (fault-around, large
    /// folios) that no brick range names; a reader elsewhere reads them again from the page cache).
    void release(size_t bricks) const;
    /// Every page of the file leaves the process (after a sweep over the whole volume: an upload,
    /// a palette scan).
    void releaseFile() const;
    /// Starts reading these bricks' pages in the background.
    void readAhead(const uint32_t* bricks, size_t count) const;

    TierCounts counts() const;

private:
    TieredVolume() = default;
    void count(const void* bytes, size_t size) const;
    std::shared_ptr<const CompressedVolume> m_full;
    CompressedVolume m_coarse;
    std::vector<uint32_t> m_finestWords;
    bool m_hasCoarse = false;
    uint32_t m_longest = 1;
    uint64_t m_finestTotal = 0;
    mutable std::atomic<uint64_t> m_bricks{0}, m_bytes{0}, m_disk{0}, m_readAhead{0}, m_released{0};
};

} // namespace csgv
