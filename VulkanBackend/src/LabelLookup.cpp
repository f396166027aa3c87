// SPDX-License-Identifier: MIT
#include "csgv/gpu/LabelLookup.h"

#include <algorithm>

namespace csgv::gpu {

namespace {

/// Sorts 32-bit words in two passes of 16 bits (least significant first): linear in their count,
/// where std::sort of every palette entry of a large volume took a quarter of `csgv render`'s
/// set-up (perf: 25% of it on synth 1280^3, 1.6 million entries).
void sortWords(std::vector<uint32_t>& v) {
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

} // namespace

StoredLabels storedLabels(const CompressedVolume& vol, bool piece) {
    const uint32_t L = vol.levels();
    StoredLabels out;
    uint32_t largest = 0;
    uint64_t entries = 0;
    // In chunks, so that a mapped file's pages leave the process behind the sweep. Bricks whose
    // header words are wrong are found here (a parse checks the layout only): never drawn, their
    // palettes are not read.
    std::vector<uint8_t> bad;
    sweepBricks(vol, kSweepBricks, [&](uint64_t from, uint64_t to) {
        bad.assign(size_t(to - from), 0);
#pragma omp parallel for reduction(max : largest) reduction(+ : entries) schedule(dynamic, 64)
        for (int64_t b = int64_t(from); b < int64_t(to); ++b) {
            if (!brickSound(vol, uint64_t(b))) {
                bad[size_t(b - int64_t(from))] = 1;
                continue;
            }
            const BrickWords bw = vol.brick(uint64_t(b));
            entries += bw.words[L];
            for (uint32_t k = 0; k < bw.words[L]; ++k) largest = std::max(largest, bw.words[bw.size - 1 - k]);
        }
        for (uint64_t b = from; b < to; ++b)
            if (bad[size_t(b - from)]) out.unsound.push_back(b);
        return true;
    });
    auto sound = [&](uint64_t b) { return out.unsound.empty() || !std::binary_search(out.unsound.begin(), out.unsound.end(), b); };
    out.largest = largest;
    if (piece || largest < kMaterialTableLabels || entries > (uint64_t(1) << 25)) return out;
    std::vector<uint32_t> labels;
    // Neighbouring bricks hold the same labels: a direct-mapped table of labels seen lately
    // keeps most repeats out of the list to sort (kNone, which it starts with, is no label).
    std::vector<uint32_t> seen(size_t(1) << 16, kNone);
    sweepBricks(vol, kSweepBricks, [&](uint64_t from, uint64_t to) {
        for (uint64_t b = from; b < to; ++b) {
            if (!sound(b)) continue;
            const BrickWords bw = vol.brick(b);
            for (uint32_t k = 0; k < bw.words[L]; ++k) {
                const uint32_t l = bw.words[bw.size - 1 - k];
                uint32_t& slot = seen[(l * 0x9E3779B1u) >> 16];
                if (slot == l) continue;
                slot = l;
                labels.push_back(l);
            }
        }
        return true;
    });
    sortWords(labels);
    labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    if (!labels.empty() && labels.back() == kNone) labels.pop_back(); // not a label
    if (labels.empty() || labels.size() > kMaterialTableLabels) return out;
    out.largest = uint32_t(labels.size() - 1);
    out.ids = std::move(labels);
    return out;
}

uint32_t idOfLabel(const std::vector<uint32_t>& ids, uint32_t label) {
    const auto it = std::lower_bound(ids.begin(), ids.end(), label);
    return it != ids.end() && *it == label ? uint32_t(it - ids.begin()) : kNone;
}

LabelLookup planLabelLookup(uint32_t largestStored, bool piece, uint64_t budgetBytes) {
    LabelLookup out;
    out.largest = largestStored;
    // A piece's rays meet other ranks' labels too (the scan takes those beyond its table).
    out.kind = !piece && out.largest < kMaterialTableLabels ? kLookupDense : kLookupScan;
    if (out.kind != kLookupScan && out.tableBytes() + out.colorBytes() > budgetBytes / 64) out.kind = kLookupScan;
    return out;
}

uint32_t LabelLookup::hostMaterial(const std::vector<uint32_t>& t, uint32_t stored) const {
    return stored < t.size() ? t[stored] : kNone;
}

} // namespace csgv::gpu
