// SPDX-License-Identifier: MIT
#include "csgv/codec/TieredVolume.h"

#include "csgv/base/FileUtil.h"
#include "csgv/base/MappedFile.h"
#include "csgv/base/Math.h"

#include <algorithm>
#include <cstdio>
#include <sys/resource.h>

namespace csgv {

namespace {

/// Stream B of a brick: [begin, end) in its words (CSGV-FORMAT.md section 4.2).
struct FinestRange {
    uint32_t begin = 0, end = 0;
};
FinestRange finestRange(const CompressedVolume& v, uint64_t b) {
    const BrickWords bw = v.brick(b);
    const uint32_t L = v.levels();
    // An unsound brick (checkBrick) stays whole in the coarse tier, where its decoders refuse it
    // as they would in the file: no finest-level stream.
    if (!brickSound(v, b)) return {bw.size, bw.size};
    const uint32_t begin = std::min(bw.words[L - 1] / 8, bw.size), palette = bw.words[L];
    const uint32_t end = bw.size >= palette ? bw.size - palette : 0;
    return {begin, std::max(begin, end)};
}

/// Bricks apart that estimate the coarse tier's size.
constexpr uint64_t kEstimateStride = 64;


} // namespace

uint64_t TieredVolume::automaticBudget() { return availableMemoryBytes() / 2; }

bool TieredVolume::wanted(const CompressedVolume& full, uint64_t budgetBytes) {
    const uint64_t budget = budgetBytes ? budgetBytes : automaticBudget();
    if (budget == 0 || !tierable(full)) return false;
    uint64_t bytes = 0;
    for (const WordArray& a : full.arrays) bytes += uint64_t(a.size()) * 4;
    return bytes > budget;
}

bool TieredVolume::tierable(const CompressedVolume& full) {
    if (full.encoding != kEncodingRans2 || full.levels() < 2 || full.arrays.empty()) return false;
    for (const WordArray& a : full.arrays)
        if (!a.isView() || (a.size() && !MappedFile::mappedAt(a.bytes()))) return false;
    return true;
}

Result<std::shared_ptr<const TieredVolume>> TieredVolume::create(std::shared_ptr<const CompressedVolume> full,
                                                                   const Options& options) {
    if (!full || !tierable(*full))
        return Status::error("only a rANS two-table encoding read from a mapped file can keep its finest level on disk");
    const CompressedVolume& v = *full;
    std::shared_ptr<TieredVolume> t(new TieredVolume());
    t->m_full = full;
    CompressedVolume& c = t->m_coarse;
    // Every header field as it is; the arrays hold the coarse bricks, in the full volume's
    // arrays (a coarse brick is never longer than its brick, so every array still fits).
    c = v.headerFields();
    const uint64_t n = v.brickCount();
    const uint64_t per = v.bricksPerArray == kSingleArray ? n + 1 : v.bricksPerArray;
    const uint64_t budget = options.budgetBytes;
    // Stream lengths need the bricks' headers, so the budget is checked as the sweep goes; the
    // arrays reserve what the budget allows (untouched reserved pages take no memory), so that
    // they never grow by copying.
    try {
        t->m_finestWords.resize(size_t(n));
        c.brickStarts.assign(size_t(n) + 1, 0u);
        c.arrays.assign(v.arrays.size(), WordArray());
        for (size_t a = 0; a < v.arrays.size(); ++a)
            c.arrays[a].owned().reserve(size_t(budget ? std::min<uint64_t>(v.arrays[a].size(), budget / 4) : v.arrays[a].size()));
    } catch (const std::bad_alloc&) {
        return Status::error("no memory for the tables of " + std::to_string(n) + " bricks");
    }
    uint64_t resident = t->residentBytes();
    // Without a resident tier the finest table goes too (streams are measured when asked for).
    auto noCoarseTier = [&] {
        t->m_coarse = CompressedVolume{};
        t->m_finestWords = {};
        t->m_hasCoarse = false;
        return std::shared_ptr<const TieredVolume>(std::move(t));
    };
    if (options.progress && !options.progress(0.0)) return Status::error("cancelled");
    // Coarse levels far past the budget are not copied to find that out: every 64th brick's
    // estimate decides first (within an eighth of the budget, the sweep decides).
    if (budget) {
        uint64_t words = 0, sampled = 0;
        std::unique_ptr<ReleaseBehind> behind; // a touch maps a large folio: release as it goes
        for (uint64_t b = 0; b < n; b += kEstimateStride, ++sampled) {
            if (!behind || b % per < kEstimateStride)
                behind = std::make_unique<ReleaseBehind>(v.arrays[size_t(b / per)].bytes(), v.arrays[size_t(b / per)].size() * 4);
            const BrickWords bw = v.brick(b);
            behind->reached(bw.words.bytes());
            const FinestRange f = finestRange(v, b);
            words += f.begin == bw.size ? bw.size : uint64_t(f.begin) + 1 + (bw.size - f.end);
            // From a cold disk the samples read much of the file: ask now and then.
            if (sampled % 4096 == 4095 && options.progress && !options.progress(0.0)) return Status::error("cancelled");
        }
        behind.reset();
        if (sampled && resident + words * 4 / sampled * n > budget + budget / 8) return noCoarseTier();
    }
    // The copy, in chunks whose pages leave behind it (sweepBricks).
    bool fits = !budget || resident <= budget, cancelled = false;
    sweepBricks(v, kSweepBricks, [&](uint64_t from, uint64_t to) {
        for (uint64_t b = from; b < to && fits; ++b) {
            const BrickWords bw = v.brick(b);
            const FinestRange f = finestRange(v, b);
            const bool whole = f.begin == bw.size;
            const uint32_t palette = bw.size - f.end;
            const uint64_t words = whole ? bw.size : uint64_t(f.begin) + 1 + palette;
            resident += words * 4;
            std::vector<uint32_t>& out = c.arrays[size_t(b / per)].owned();
            if ((budget && resident > budget) || out.size() + words > out.capacity()) {
                fits = false; // the coarse levels do not fit: every level is read from the file
                break;
            }
            const size_t at = out.size();
            out.resize(at + size_t(words));
            if (whole) {
                bw.words.copyTo(out.data() + at, bw.size);
            } else {
                bw.words.copyTo(out.data() + at, f.begin);
                out[at + f.begin] = kRansLowerBound; // the bare initial state: a stream B of no symbols
                (bw.words + std::ptrdiff_t(f.end)).copyTo(out.data() + at + f.begin + 1, palette);
            }
            c.brickStarts[size_t(b) + 1] = uint32_t(out.size());
            t->m_finestWords[size_t(b)] = f.end - f.begin;
            t->m_longest = std::max(t->m_longest, f.end - f.begin);
            t->m_finestTotal += f.end - f.begin;
        }
        cancelled = fits && options.progress && !options.progress(double(to) / double(n));
        return fits && !cancelled;
    });
    if (cancelled) return Status::error("cancelled");
    if (!fits) return noCoarseTier();
    // Arrays that start a new array: brick starts as the container stores them (CSGV-FORMAT.md
    // section 7: the stored start of a brick opening an array is the previous array's length).
    for (uint64_t b = per; b < n; b += per) c.brickStarts[size_t(b)] = uint32_t(c.arrays[size_t(b / per) - 1].size());
    t->m_hasCoarse = true;
    return std::shared_ptr<const TieredVolume>(std::move(t));
}

uint32_t TieredVolume::finestWords(uint64_t brick) const {
    if (m_hasCoarse) return m_finestWords[size_t(brick)];
    const FinestRange f = finestRange(*m_full, brick);
    return f.end - f.begin;
}

uint64_t TieredVolume::residentBytes() const {
    uint64_t n = uint64_t(m_coarse.brickStarts.size()) * 4 + uint64_t(m_finestWords.size()) * 4;
    for (const WordArray& a : m_coarse.arrays) n += uint64_t(a.size()) * 4; // reserved, untouched pages take nothing
    return n;
}

void TieredVolume::count(const void* bytes, size_t size) const {
    m_bricks.fetch_add(1, std::memory_order_relaxed);
    m_bytes.fetch_add(size, std::memory_order_relaxed);
    m_disk.fetch_add(MappedFile::absentBytesAt(bytes, size), std::memory_order_relaxed);
}

void TieredVolume::copyFinest(uint64_t brick, uint32_t* dst) const {
    const BrickWords bw = m_full->brick(brick);
    const FinestRange f = finestRange(*m_full, brick);
    const WordPtr from = bw.words + std::ptrdiff_t(f.begin);
    count(from.bytes(), size_t(f.end - f.begin) * 4);
    from.copyTo(dst, f.end - f.begin);
}

void TieredVolume::noteRead(uint64_t brick) const {
    const BrickWords bw = m_full->brick(brick);
    count(bw.words.bytes(), size_t(bw.size) * 4);
}

void TieredVolume::release(size_t bricks) const {
    // A fault on a file mapping maps more than the page it needs (Linux's fault-around, large
    // folios): no brick range names all that the reads mapped. Every page of the file goes
    // (one madvise over the mapping; unmapped stretches cost nothing), and a brick another view
    // is reading meanwhile is read again from the page cache.
    if (bricks > 0) releaseFile();
    m_released.fetch_add(bricks, std::memory_order_relaxed);
}

void TieredVolume::releaseFile() const {
    for (const WordArray& a : m_full->arrays) MappedFile::releaseAt(a.bytes(), a.size() * 4);
}

void TieredVolume::readAhead(const uint32_t* bricks, size_t count) const {
    for (size_t i = 0; i < count; ++i) {
        if (bricks[i] >= m_full->brickCount()) continue;
        const BrickWords bw = m_full->brick(bricks[i]);
        MappedFile::willNeedAt(bw.words.bytes(), size_t(bw.size) * 4);
    }
    m_readAhead.fetch_add(count, std::memory_order_relaxed);
}

TierCounts TieredVolume::counts() const {
    TierCounts c;
    c.fileBricks = m_bricks.load();
    c.fileBytes = m_bytes.load();
    c.diskBytes = m_disk.load();
    c.readAheadBricks = m_readAhead.load();
    c.releasedBricks = m_released.load();
    return c;
}

} // namespace csgv
