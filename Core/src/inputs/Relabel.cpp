// SPDX-License-Identifier: MIT
/// @file Relabel.cpp
/// @brief Dense relabelling by first visiting position (Relabel.h), streamed or in memory.
#include "csgv/inputs/Relabel.h"
#include "csgv/base/Morton.h"

#include <algorithm>

namespace csgv {

namespace {

uint64_t spread21(uint64_t v) {
    v &= 0x1FFFFF;
    v = (v | v << 32) & 0x1F00000000FFFFull;
    v = (v | v << 16) & 0x1F0000FF0000FFull;
    v = (v | v << 8) & 0x100F00F00F00F00Full;
    v = (v | v << 4) & 0x10C30C30C30C30C3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
}

bool validBrickSize(uint32_t b) { return b >= 8 && b <= 128 && (b & (b - 1)) == 0; }

} // namespace

uint64_t morton3x21(uint32_t x, uint32_t y, uint32_t z) { return spread21(x) | spread21(y) << 1 | spread21(z) << 2; }

VisitPosition visitPosition(uint32_t x, uint32_t y, uint32_t z, uint32_t brickShift) {
    const uint32_t mask = (1u << brickShift) - 1;
    return {morton3x21(x >> brickShift, y >> brickShift, z >> brickShift), morton3(x & mask, y & mask, z & mask)};
}

bool typeAlwaysFitsFormat(LabelType type) { return type == LabelType::U8 || type == LabelType::U16; }

bool labelsFitFormat(const InputVolume& in) {
    return std::all_of(in.values.begin(), in.values.end(), labelFitsFormat);
}

StreamingRelabeller::StreamingRelabeller(const std::array<uint32_t, 3>& dim, uint32_t brickSize) : m_dim(dim) {
    while ((1u << m_shift) < brickSize) ++m_shift;
}

void StreamingRelabeller::observe(uint32_t z0, uint32_t depth, const uint64_t* values) {
    observeBox({0, 0, z0}, {m_dim[0], m_dim[1], depth}, values);
}

void StreamingRelabeller::observeBox(const std::array<uint32_t, 3>& lo, const std::array<uint32_t, 3>& size,
                                     const uint64_t* values) {
    // Along a row (fixed y, z) positions grow with x: inside a brick the Morton index grows with
    // x, and the next brick along x has a larger brick code. So a run of equal values is first
    // visited at its first voxel, and one lookup per run suffices.
    const uint32_t W = size[0], H = size[1];
    uint64_t lastValue = 0;
    Entry* last = nullptr;
    for (uint32_t z = 0; z < size[2]; ++z)
        for (uint32_t y = 0; y < H; ++y) {
            const uint64_t* row = values + (uint64_t(z) * H + y) * W;
            for (uint32_t x = 0; x < W;) {
                const uint64_t v = row[x];
                const uint32_t start = x;
                while (x < W && row[x] == v) ++x;
                if (v == 0) continue;
                const VisitPosition p = visitPosition(lo[0] + start, lo[1] + y, lo[2] + z, m_shift);
                if (!last || v != lastValue) {
                    auto ins = m_entries.try_emplace(v, Entry{p, 0});
                    last = &ins.first->second; // node addresses survive rehashing
                    lastValue = v;
                    if (ins.second) continue;
                }
                if (p < last->first) last->first = p;
            }
        }
}

std::vector<std::pair<uint64_t, VisitPosition>> StreamingRelabeller::firstVisits() const {
    std::vector<std::pair<uint64_t, VisitPosition>> out;
    out.reserve(m_entries.size());
    for (const auto& kv : m_entries) out.push_back({kv.first, kv.second.first});
    return out;
}

void StreamingRelabeller::observeUniform(const UniformBox& box) {
    if (box.voxels() == 0) return;
    takeFirstVisit(box.value, visitPosition(box.lo[0], box.lo[1], box.lo[2], m_shift));
}

void StreamingRelabeller::takeFirstVisit(uint64_t value, const VisitPosition& position) {
    if (value == 0) return;
    auto ins = m_entries.try_emplace(value, Entry{position, 0});
    if (!ins.second && position < ins.first->second.first) ins.first->second.first = position;
}

Status StreamingRelabeller::useIds(const std::vector<uint64_t>& originalBits) {
    if (originalBits.empty() || originalBits[0] != 0 || originalBits.size() > 0xFFFFFFFFull)
        return Status::error("an id table starts with id 0 for label 0 and has fewer than 2^32 ids");
    size_t found = 0;
    for (size_t id = 1; id < originalBits.size(); ++id) {
        auto it = m_entries.find(originalBits[id]);
        if (it == m_entries.end()) continue;
        it->second.id = uint32_t(id);
        ++found;
    }
    if (found != m_entries.size())
        for (const auto& kv : m_entries)
            if (kv.second.id == 0)
                return Status::error("label " + std::to_string(kv.first) + " has no id in the shared id table");
    m_originalBits = originalBits;
    m_finished = true;
    return Status::ok();
}

Status StreamingRelabeller::finish() {
    if (m_entries.size() >= 0xFFFFFFFFull)
        return Status::error("the volume has more than 2^32 - 1 distinct labels");
    std::vector<std::pair<VisitPosition, uint64_t>> order;
    order.reserve(m_entries.size());
    for (const auto& kv : m_entries) order.push_back({kv.second.first, kv.first});
    // Two labels share a position only when brick codes alias (more than 2^21 bricks on an
    // axis); the label then breaks the tie so the ids never depend on hashing.
    std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) {
        return a.first < b.first || (!(b.first < a.first) && a.second < b.second);
    });
    m_originalBits.assign(1, 0);
    m_originalBits.reserve(order.size() + 1);
    for (const auto& o : order) {
        m_entries[o.second].id = uint32_t(m_originalBits.size());
        m_originalBits.push_back(o.second);
    }
    m_finished = true;
    return Status::ok();
}

bool StreamingRelabeller::toIds(const uint64_t* values, size_t count, uint32_t* ids, size_t* missAt) const {
    uint64_t lastValue = 0;
    uint32_t lastId = 0;
    for (size_t i = 0; i < count; ++i) {
        const uint64_t v = values[i];
        if (v != lastValue) {
            lastValue = v;
            lastId = 0; // 0 stays 0 and is not in the map
            if (v != 0) {
                auto it = m_entries.find(v);
                if (it == m_entries.end()) {
                    if (missAt) *missAt = i;
                    return false;
                }
                lastId = it->second.id;
            }
        }
        ids[i] = lastId;
    }
    return true;
}

uint64_t StreamingRelabeller::memoryBytes() const {
    // A node holds the key, the entry, the next pointer and the cached hash; plus a bucket pointer.
    const uint64_t node = sizeof(uint64_t) + sizeof(Entry) + 2 * sizeof(void*);
    return m_entries.size() * node + m_entries.bucket_count() * sizeof(void*) + m_originalBits.capacity() * 8;
}

Result<LabelVolume> prepareLabels(const InputVolume& in, uint32_t brickSize, bool forceRelabel, LabelMapping& mapping) {
    if (in.values.size() != in.voxelCount())
        return Status::error("input volume holds " + std::to_string(in.values.size()) + " values, expected " +
                             std::to_string(in.voxelCount()));
    if (!validBrickSize(brickSize))
        return Status::error("brick size " + std::to_string(brickSize) + " is not a power of two from 8 to 128");
    mapping = LabelMapping{};
    mapping.type = in.type;
    LabelVolume out;
    out.dim = in.dim;
    out.labels.resize(in.values.size());
    if (!forceRelabel && labelsFitFormat(in)) {
        for (size_t i = 0; i < in.values.size(); ++i) out.labels[i] = uint32_t(in.values[i]);
        return out;
    }
    // The streaming relabeller over the whole volume as one slab: the same order as any stream.
    StreamingRelabeller relabeller(in.dim, brickSize);
    relabeller.observe(0, in.dim[2], in.values.data());
    if (Status s = relabeller.finish(); !s) return s;
    relabeller.toIds(in.values.data(), in.values.size(), out.labels.data());
    mapping.relabelled = true;
    mapping.originalBits = relabeller.originalBits();
    return out;
}

std::vector<uint64_t> relabelDense(LabelVolume& volume, uint32_t brickSize) {
    InputVolume in;
    in.dim = volume.dim;
    in.values.assign(volume.labels.begin(), volume.labels.end());
    LabelMapping m;
    Result<LabelVolume> r = prepareLabels(in, brickSize, true, m);
    volume = std::move(*r);
    return m.originalBits;
}

} // namespace csgv
