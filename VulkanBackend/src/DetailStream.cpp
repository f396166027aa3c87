// SPDX-License-Identifier: MIT
#include "csgv/gpu/DetailStream.h"
#include "csgv/gpu/FrameLayout.h"

#include <algorithm>
#include <cstring>

namespace csgv::gpu {

namespace {

/// A brick's finest-level stream (mode 2: stream B, from word header[L-1] / 8 to the palette).
struct Stream {
    WordPtr words; ///< any alignment (a mapped file's view)
    uint32_t count;
};
Stream finestStream(const CompressedVolume& volume, uint64_t brick) {
    const BrickWords bw = volume.brick(brick);
    const uint32_t L = volume.levels();
    if (!brickSound(volume, brick)) return {bw.words, 0u}; // never decoded (GpuVolume::unsound)
    const uint32_t begin = bw.words[L - 1] / 8, end = bw.size - bw.words[L];
    return {bw.words + begin, end > begin ? end - begin : 0u};
}

} // namespace

DetailStream::~DetailStream() {
    if (m_copy.valid()) m_copy.wait();
}

DetailSizes DetailStream::sizes(const TieredVolume& tiers) {
    if (!tiers.hasCoarseTier()) return sizes(tiers.full()); // measured on the file
    return DetailSizes{2 * uint64_t(std::max<uint32_t>(tiers.longestFinestWords(), 1)) * 4,
                       tiers.finestBytesTotal()}; // a valid brick's stream B has a word at least
}

uint32_t DetailStream::streamWords(uint64_t b) const {
    return m_tiers ? m_tiers->finestWords(b) : finestStream(m_volume, b).count;
}

void DetailStream::copyStream(uint64_t b, uint32_t* dst) const {
    if (m_tiers) return m_tiers->copyFinest(b, dst);
    const Stream st = finestStream(m_volume, b);
    st.words.copyTo(dst, st.count);
}

DetailSizes DetailStream::sizes(const CompressedVolume& volume) {
    uint64_t longest = 1, words = 0;
    sweepBricks(volume, kSweepBricks, [&](uint64_t from, uint64_t to) { // a mapped file's pages go behind it
        for (uint64_t b = from; b < to; ++b) {
            const uint32_t n = std::max<uint32_t>(finestStream(volume, b).count, 1);
            longest = std::max<uint64_t>(longest, n);
            words += n;
        }
        return true;
    });
    return DetailSizes{2 * longest * 4, words * 4};
}

uint64_t DetailStream::brickBytes(const CompressedVolume& volume, uint64_t brick, const TieredVolume* tiers) {
    return uint64_t(std::max<uint32_t>(tiers ? tiers->finestWords(brick) : finestStream(volume, brick).count, 1)) * 4;
}

uint64_t DetailStream::deviceBytes(const CompressedVolume& volume, uint64_t capacityBytes) {
    return (capacityBytes & ~uint64_t(3)) + std::max<uint64_t>(volume.brickCount() * 8, 16);
}

Result<std::unique_ptr<DetailStream>> DetailStream::create(Context& context, const CompressedVolume& volume,
                                                           uint64_t capacityBytes, const DetailSizes* sizes,
                                                           const TieredVolume* tiers) {
    if (volume.encoding != kEncodingRans2 || volume.levels() < 2)
        return Status::error("detail streaming needs a rANS two-table encoding with at least two levels");
    if (volume.brickCount() >= kNone) return Status::error("too many bricks for detail streaming");
    if (tiers && &tiers->coarse() != &volume) return Status::error("detail streaming of tiers needs their coarse volume");
    const uint64_t smallest = sizes ? sizes->smallestBytes : tiers ? DetailStream::sizes(*tiers).smallestBytes : smallestBytes(volume);
    if (capacityBytes < smallest)
        return Status::error("a detail buffer of " + mebibytes(capacityBytes) + " is smaller than the " +
                             mebibytes(smallest) + " the longest finest-level stream needs");
    const uint64_t words = std::min<uint64_t>(capacityBytes / 4, kNone - 1);
    std::unique_ptr<DetailStream> d(new DetailStream(context, volume, tiers));
    Result<Buffer> ring = context.createBuffer(words * 4, MemoryKind::DeviceLocal);
    if (!ring) return Status(ring.status()).prefix("allocating the detail buffer");
    Result<Buffer> table = context.createBuffer(std::max<uint64_t>(volume.brickCount() * 8, 16), MemoryKind::HostVisible);
    if (!table) return Status(table.status()).prefix("allocating the detail table");
    d->m_ring = std::move(*ring);
    d->m_table = std::move(*table);
    d->m_capacity = uint32_t(words);
    uint32_t* t = d->table();
    for (uint64_t b = 0; b < volume.brickCount(); ++b) {
        t[2 * b] = kNone;
        t[2 * b + 1] = 0;
    }
    d->m_queued.assign(size_t(volume.brickCount()), 0);
    return d;
}

bool DetailStream::resident(uint32_t brick) const { return brick < m_volume.brickCount() && table()[2 * size_t(brick)] != kNone; }

Result<std::vector<uint32_t>> DetailStream::readStream(uint32_t brick) const {
    if (!resident(brick)) return Status::error("brick " + std::to_string(brick) + " has no stream in the detail buffer");
    std::vector<uint32_t> words(table()[2 * size_t(brick) + 1]);
    Status s = m_context.download(m_ring, uint64_t(table()[2 * size_t(brick)]) * 4, words.data(), words.size() * 4);
    if (!s) return s;
    return words;
}

void DetailStream::evictFront() {
    const Entry e = m_entries.front();
    m_entries.pop_front();
    if (table()[2 * size_t(e.brick)] != e.offset) return; // never committed (a failed transfer)
    table()[2 * size_t(e.brick)] = kNone; // between frames: no GPU work reads the table now
    table()[2 * size_t(e.brick) + 1] = 0;
    ++m_counts.evictedBricks;
}

bool DetailStream::place(uint32_t words, uint32_t& offset) {
    // The live entries occupy the ring from the oldest one's offset up to the head (circularly);
    // an allocation at the head evicts the oldest entries it overlaps. Entries never wrap: an
    // allocation that does not fit before the end starts at word 0 (the end stays unused).
    uint32_t start = m_head;
    auto evictWhile = [&](auto inTheWay) {
        while (!m_entries.empty() && inTheWay(m_entries.front())) {
            if (m_entries.front().pending) return false;
            evictFront();
        }
        return true;
    };
    if (uint64_t(start) + words > m_capacity) {
        if (!evictWhile([&](const Entry& e) { return e.offset >= start; })) return false;
        start = 0;
    }
    if (!evictWhile([&](const Entry& e) { return e.offset >= start && e.offset < start + words; })) return false;
    offset = start;
    m_head = start + words;
    return true;
}

Status DetailStream::request(const uint32_t* bricks, size_t count) {
    Status s = commit();
    if (!s) return s;
    const uint64_t batchLimit = m_capacity / 2;
    uint64_t batchWords = 0;
    size_t i = 0;
    for (; i < count; ++i) {
        const uint32_t b = bricks[i];
        if (b >= m_volume.brickCount() || m_queued[b] || resident(b)) continue;
        const uint32_t words = std::max<uint32_t>(streamWords(b), 1);
        if (batchWords + words > batchLimit) break; // later frames ask again
        uint32_t offset = 0;
        if (!place(words, offset)) break;
        m_entries.push_back({b, offset, words, true});
        m_batch.push_back(m_entries.back());
        m_queued[b] = 1;
        batchWords += words;
    }
    // What this batch could not take, the next frames ask for: their pages are read meanwhile.
    if (m_tiers && i < count) m_tiers->readAhead(bricks + i, std::min<size_t>(count - i, m_batch.size() + 64));
    if (m_batch.empty()) return Status::ok();
    // The streams are copied out of the encoding on a host thread while the caller goes on.
    m_staging.assign(size_t(batchWords), 0u);
    m_regions.clear();
    uint64_t at = 0;
    for (const Entry& e : m_batch) {
        m_regions.push_back({at * 4, uint64_t(e.offset) * 4, uint64_t(e.words) * 4});
        at += e.words;
    }
    m_copy = std::async(std::launch::async, [this] {
        uint64_t at = 0;
        for (const Entry& e : m_batch) {
            copyStream(e.brick, m_staging.data() + at);
            at += e.words;
        }
        if (m_tiers) m_tiers->release(m_batch.size()); // in the staging buffer now
    });
    return Status::ok();
}

Status DetailStream::commit() {
    if (m_batch.empty()) return Status::ok();
    m_copy.get();
    Status s = m_context.uploadRegions(m_ring, m_staging.data(), m_regions);
    // The table only now names the new streams: a failed transfer leaves them absent.
    // The batch is the newest entries (pending ones are never evicted).
    for (size_t i = 0; i < m_batch.size(); ++i) m_entries[m_entries.size() - 1 - i].pending = false;
    for (const Entry& e : m_batch) {
        m_queued[e.brick] = 0;
        if (!s) continue;
        table()[2 * size_t(e.brick)] = e.offset;
        table()[2 * size_t(e.brick) + 1] = streamWords(e.brick);
        ++m_counts.uploadedBricks;
        m_counts.uploadedBytes += uint64_t(e.words) * 4;
    }
    m_batch.clear();
    m_regions.clear();
    m_staging = {};
    return s;
}

} // namespace csgv::gpu
