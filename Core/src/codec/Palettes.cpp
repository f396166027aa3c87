// SPDX-License-Identifier: MIT
#include "csgv/codec/Palettes.h"

#include <omp.h>

#include <algorithm>
#include <limits>
#include <new>

namespace csgv {

void sortWords(std::vector<uint32_t>& v) {
    // std::sort of every palette entry of a large volume took a quarter of `csgv render`'s set-up
    // (perf: 25% of it on synth 1280^3, 1.6 million entries).
    if (v.size() < 4096) {
        std::sort(v.begin(), v.end());
        return;
    }
    std::vector<uint32_t> tmp(v.size());
    std::vector<size_t> start(65537);
    for (int shift : {0, 16}) {
        std::fill(start.begin(), start.end(), size_t(0));
        for (uint32_t x : v) ++start[((x >> shift) & 0xFFFFu) + 1];
        for (size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
        for (uint32_t x : v) tmp[start[(x >> shift) & 0xFFFFu]++] = x;
        v.swap(tmp);
    }
}

namespace {

/// One thread's share of the sweep.
struct Local {
    uint64_t entries = 0;
    uint32_t smallest = std::numeric_limits<uint32_t>::max(), largest = 0;
    std::vector<uint32_t> labels;
    /// Labels seen lately, direct-mapped (neighbouring bricks hold the same labels: most repeats
    /// stay out of the list to sort); 64-bit slots so that no 32-bit label matches an empty one.
    std::vector<uint64_t> seen;
    bool over = false; ///< more distinct labels than the cap: no list
    size_t compactAt = 0; ///< the list is made unique when it grows past this (then holds no repeats)
};

void sortUnique(std::vector<uint32_t>& v) {
    sortWords(v);
    v.erase(std::unique(v.begin(), v.end()), v.end());
}

} // namespace

PaletteSummary summarizePalettes(const CompressedVolume& vol, size_t labelCap) {
    Result<PaletteSummary> r = summarizePalettes(vol, labelCap, {});
    if (!r) throw std::bad_alloc(); // without a progress callback, only memory fails it
    return std::move(*r);
}

Result<PaletteSummary> summarizePalettes(const CompressedVolume& vol, size_t labelCap,
                                         const std::function<bool(double)>& progress) {
    PaletteSummary out;
    bool cancelled = false;
    const uint64_t bricks = vol.brickCount();
    if (progress && !progress(0.0)) return Status::error("cancelled");
    try {
        out.first.assign(size_t(bricks), 0u);
    } catch (const std::bad_alloc&) {
        return Status::error("no memory for the root labels of " + std::to_string(bricks) + " bricks");
    }
    const uint32_t L = vol.levels();
    const int threads = std::max(1, omp_get_max_threads());
    std::vector<Local> local(static_cast<size_t>(threads));
    // A thread's list is made unique when it grows past twice the cap (at most 2^24 entries, and
    // never below twice what it then holds: a list near the limit is not sorted again and again).
    const size_t firstCompact = std::min<size_t>(labelCap, size_t(1) << 23) * 2 + (size_t(1) << 16);
    std::vector<uint8_t> bad;
    sweepBricks(vol, kSweepBricks, [&](uint64_t from, uint64_t to) {
        bad.assign(size_t(to - from), 0);
#pragma omp parallel num_threads(threads)
        {
            Local& me = local[size_t(omp_get_thread_num())];
            if (me.seen.empty()) {
                me.seen.assign(size_t(1) << 16, ~uint64_t(0));
                me.compactAt = firstCompact;
            }
#pragma omp for schedule(dynamic, 256)
            for (int64_t b = int64_t(from); b < int64_t(to); ++b) {
                if (!brickSound(vol, uint64_t(b))) {
                    bad[size_t(b - int64_t(from))] = 1;
                    continue;
                }
                const BrickWords bw = vol.brick(uint64_t(b));
                const uint32_t n = bw.words[L];
                out.first[size_t(b)] = bw.words[bw.size - 1]; // a sound brick's palette has an entry
                me.entries += n;
                for (uint32_t k = 0; k < n; ++k) {
                    const uint32_t l = bw.words[bw.size - 1 - k];
                    me.smallest = std::min(me.smallest, l);
                    me.largest = std::max(me.largest, l);
                    if (me.over) continue;
                    uint64_t& slot = me.seen[(l * 0x9E3779B1u) >> 16];
                    if (slot == l) continue;
                    slot = l;
                    me.labels.push_back(l);
                    if (me.labels.size() > me.compactAt) {
                        sortUnique(me.labels);
                        me.compactAt = std::max(me.compactAt, 2 * me.labels.size());
                        if (me.labels.size() > labelCap) {
                            me.over = true;
                            std::vector<uint32_t>().swap(me.labels);
                        }
                    }
                }
            }
        }
        for (uint64_t b = from; b < to; ++b)
            if (bad[size_t(b - from)]) out.unsound.push_back(b);
        cancelled = progress && !progress(double(to) / double(bricks));
        return !cancelled;
    });
    if (cancelled) return Status::error("cancelled");
    bool over = false;
    size_t listed = 0;
    for (const Local& me : local) {
        if (me.entries) {
            out.smallest = out.entries ? std::min(out.smallest, me.smallest) : me.smallest;
            out.largest = std::max(out.largest, me.largest);
        }
        out.entries += me.entries;
        over = over || me.over;
        listed += me.labels.size();
    }
    if (over) return out;
    out.labels.reserve(listed);
    for (Local& me : local) {
        out.labels.insert(out.labels.end(), me.labels.begin(), me.labels.end());
        std::vector<uint32_t>().swap(me.labels);
    }
    sortUnique(out.labels);
    if (out.labels.size() > labelCap) {
        std::vector<uint32_t>().swap(out.labels);
        return out;
    }
    out.labelsComplete = true;
    return out;
}

} // namespace csgv
