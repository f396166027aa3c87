// SPDX-License-Identifier: MIT
#pragma once
/// @file DetailStream.h
/// @brief Detail streaming (the paper's "Memory management"): a separated volume keeps its finest
/// level's encoding in host memory; the bricks a frame wants at full resolution have their
/// finest-level streams copied into a detail buffer on the device, where the GPU decoder finds them
/// through a per-brick table. The buffer is a ring: the oldest upload is evicted first, and a
/// brick's stream is only needed until the brick is decoded (its cache region holds the labels).
///
/// Between frames: request() takes the bricks a frame asked for, places them in the ring (evicting
/// what they overwrite: their table entries read "absent" at once) and starts copying their
/// streams out of the encoding on a host thread; commit(), before the next frame, waits for that
/// copy, transfers the data into the ring in one submission and only then writes the bricks'
/// table entries. No frame reads a stream while it is being written, and none waits for a
/// transfer it did not ask for in an earlier frame.

#include "csgv/codec/Container.h"
#include "csgv/codec/TieredVolume.h"
#include "csgv/gpu/Context.h"

#include <cstdint>
#include <deque>
#include <future>
#include <memory>
#include <vector>

namespace csgv::gpu {

/// What a detail stream moved, since its creation.
struct DetailCounts {
    uint64_t uploadedBricks = 0, uploadedBytes = 0, evictedBricks = 0;
};

/// A volume's finest-level streams, measured in one pass over its bricks (DetailStream::sizes).
struct DetailSizes {
    uint64_t smallestBytes = 0; ///< the smallest ring: twice the longest stream (a batch may take half)
    uint64_t streamBytes = 0;   ///< all streams together (a ring this large never evicts)
};

class DetailStream {
public:
    /// The ring holds `capacityBytes` (at least smallestBytes); the table takes 8 bytes a brick
    /// (host-visible: written between frames). `volume` must be a rANS two-table encoding with at
    /// least two levels and outlive the stream. `sizes`: the volume's, when known (else measured).
    /// `tiers`: the volume is tiers->coarse(); the streams are read from the file (copyFinest),
    /// whose pages are released once copied, and the bricks a batch could not take are read ahead
    /// (they are asked for again by the next frames).
    static Result<std::unique_ptr<DetailStream>> create(Context& context, const CompressedVolume& volume,
                                                        uint64_t capacityBytes, const DetailSizes* sizes = nullptr,
                                                        const TieredVolume* tiers = nullptr);
    ~DetailStream();
    DetailStream(const DetailStream&) = delete;
    DetailStream& operator=(const DetailStream&) = delete;

    static DetailSizes sizes(const CompressedVolume& volume);
    static DetailSizes sizes(const TieredVolume& tiers);
    static uint64_t smallestBytes(const CompressedVolume& volume) { return sizes(volume).smallestBytes; }
    /// Ring bytes one brick's finest-level stream takes.
    static uint64_t brickBytes(const CompressedVolume& volume, uint64_t brick, const TieredVolume* tiers = nullptr);
    static uint64_t streamBytes(const CompressedVolume& volume) { return sizes(volume).streamBytes; }
    /// Device memory of a stream with a ring of `capacityBytes`: ring and table.
    static uint64_t deviceBytes(const CompressedVolume& volume, uint64_t capacityBytes);

    /// Queues the uploads of these bricks' finest-level streams, skipping resident or queued ones
    /// and what exceeds half the ring in this batch (they are asked for again by later frames).
    /// Call between frames; at most one batch is pending (a second call commits the first).
    Status request(const uint32_t* bricks, size_t count);
    /// Makes the queued streams resident (waits for the host copy; one transfer). Call before a
    /// frame that may decode them.
    Status commit();
    /// Whether a brick's stream is in the ring (committed).
    bool resident(uint32_t brick) const;
    /// A resident brick's stream as the ring holds it (read back; for checks).
    Result<std::vector<uint32_t>> readStream(uint32_t brick) const;

    /// Device addresses: the table (uvec2 per brick: word offset in the ring, kNone when absent;
    /// words) and the ring.
    uint64_t tableAddress() const { return m_table.address(); }
    uint64_t ringAddress() const { return m_ring.address(); }
    uint64_t deviceBytes() const { return m_table.size() + m_ring.size(); }
    uint64_t capacityBytes() const { return m_ring.size(); }

    const DetailCounts& counts() const { return m_counts; }

private:
    DetailStream(Context& c, const CompressedVolume& v, const TieredVolume* t) : m_context(c), m_volume(v), m_tiers(t) {}
    /// Brick b's finest-level stream: its words, and a copy of them to `dst`.
    uint32_t streamWords(uint64_t b) const;
    void copyStream(uint64_t b, uint32_t* dst) const;
    struct Entry {
        uint32_t brick;
        uint32_t offset; ///< ring word
        uint32_t words;  ///< ring words taken (at least 1)
        bool pending;    ///< queued in the batch not yet committed
    };
    /// Takes `words` ring words at the head, evicting the oldest entries in the way; false when that
    /// would evict an entry of the pending batch.
    bool place(uint32_t words, uint32_t& offset);
    void evictFront();
    uint32_t* table() const { return static_cast<uint32_t*>(m_table.mapped()); }

    Context& m_context;
    const CompressedVolume& m_volume;
    const TieredVolume* m_tiers = nullptr;
    Buffer m_ring, m_table;
    uint32_t m_capacity = 0; ///< ring words
    uint32_t m_head = 0;     ///< next free ring word
    std::deque<Entry> m_entries; ///< oldest first
    std::vector<uint8_t> m_queued; ///< per brick: in the pending batch
    // The pending batch: its entries' data, copied on a host thread into `m_staging`.
    std::vector<Context::CopyRegion> m_regions;
    std::vector<uint32_t> m_staging;
    std::vector<Entry> m_batch;
    std::future<void> m_copy;
    DetailCounts m_counts;
};

} // namespace csgv::gpu
