// SPDX-License-Identifier: MIT
/// @file RendererHostDecode.cpp
/// @brief The renderer's host room: bricks decoded by Core's decoder on the host (CPU devices,
/// and Decode::Host), straight into a host-visible cache or staged for copies into a device one,
/// their uniform sub-block masks, and detail streaming's requests and commits between frames.
#include "RendererImpl.h"

namespace csgv::gpu {

Status Renderer::Impl::decodeOnHost() {
    stagedCopies.clear();
    stagedCacheCopies = 0;
    const uint32_t n = std::min(allocWords()[kAllocDecodes], maxRequests);
    const uint32_t* list = static_cast<const uint32_t*>(decodes.mapped());
    const uint32_t L = levels;
    if (n == 0) return Status::ok();
    auto entry = [&](uint64_t i, uint32_t& brick, uint32_t& lod, uint32_t& offset) {
        const uint32_t* e = list + kDecodeEntryWords * i;
        brick = e[0];
        lod = L - 1 - std::min(e[1], L - 1);
        offset = e[2];
        return uint64_t(offset) + volume->regionWords(lod) <= cache.size() / 4 && brick < brickCount;
    };
    if (!stagedDecode) {
        uint32_t* cacheWords = static_cast<uint32_t*>(cache.mapped());
        uint64_t* uniformMasks = static_cast<uint64_t*>(uniformSubs.mapped());
        decodeInBatches(n, [&](uint64_t i, unsigned worker) {
            uint32_t brick, lod, offset;
            if (!entry(i, brick, lod, offset)) return;
            BrickDecoder& d = decoderFor(worker, lod);
            readsFile(brick, lod);
            const Status st = volume->decodeRegion(d, brick, lod, cacheWords + offset);
            const bool ok = st.isOk();
            if (!ok) noteBadBrick(st);
            if (lod == 0) uniformMasks[brick] = ok ? uniformSubBlocks(d.labels(), brick) : 0;
        });
        return Status::ok();
    }
    // Each brick's labels, then (decoded at the finest level) its uniform sub-block mask, one
    // after another in the host buffer; the copies take them to the cache and the masks.
    struct Staged {
        uint32_t brick = 0, lod = 0, offset = 0;
        uint64_t at = 0, labelBytes = 0; // labelBytes 0: an entry that is not decoded
    };
    std::vector<Staged> staged(n);
    uint64_t bytes = 0;
    for (uint64_t i = 0; i < n; ++i) {
        Staged& e = staged[i];
        if (!entry(i, e.brick, e.lod, e.offset)) continue;
        e.at = bytes;
        e.labelBytes = uint64_t(volume->regionWords(e.lod)) * 4;
        bytes += e.labelBytes + (e.lod == 0 ? 8 : 0);
    }
    if (decodeStaging.size() < bytes) {
        const uint64_t grown = std::max<uint64_t>(bytes, decodeStaging.size() * 2);
        decodeStaging = Buffer{};
        Result<Buffer> b = ctx.createBuffer(grown, MemoryKind::HostVisible);
        if (!b) return Status(b.status()).prefix("allocating host memory for decoded bricks");
        decodeStaging = std::move(*b);
    }
    uint8_t* host = static_cast<uint8_t*>(decodeStaging.mapped());
    decodeInBatches(n, [&](uint64_t i, unsigned worker) {
        const Staged& e = staged[i];
        if (e.labelBytes == 0) return;
        BrickDecoder& d = decoderFor(worker, e.lod);
        readsFile(e.brick, e.lod);
        const Status st = volume->decodeRegion(d, e.brick, e.lod, reinterpret_cast<uint32_t*>(host + e.at));
        const bool ok = st.isOk();
        if (!ok) noteBadBrick(st);
        if (e.lod == 0) {
            const uint64_t mask = ok ? uniformSubBlocks(d.labels(), e.brick) : 0;
            std::memcpy(host + e.at + e.labelBytes, &mask, 8);
        }
    });
    for (const Staged& e : staged)
        if (e.labelBytes) stagedCopies.push_back({e.at, uint64_t(e.offset) * 4, e.labelBytes});
    stagedCacheCopies = uint32_t(stagedCopies.size());
    for (const Staged& e : staged)
        if (e.labelBytes && e.lod == 0) stagedCopies.push_back({e.at + e.labelBytes, uint64_t(e.brick) * 8, 8});
    return Status::ok();
}

std::vector<Context::Dispatch> Renderer::Impl::withStagedCopies(const Context::Dispatch* first, size_t count) const {
    std::vector<Context::Dispatch> list;
    Context::Dispatch c;
    c.copyFrom = &decodeStaging;
    c.copyTo = &cache;
    c.copyRegions = stagedCopies.data();
    c.copyRegionCount = stagedCacheCopies;
    if (c.copyRegionCount) list.push_back(c);
    c.copyTo = &uniformSubs;
    c.copyRegions = stagedCopies.data() + stagedCacheCopies;
    c.copyRegionCount = uint32_t(stagedCopies.size()) - stagedCacheCopies;
    if (c.copyRegionCount) list.push_back(c);
    list.insert(list.end(), first, first + count);
    return list;
}

void Renderer::Impl::decodeInBatches(uint32_t n, const std::function<void(uint64_t, unsigned)>& decode) {
    const uint32_t* list = static_cast<const uint32_t*>(decodes.mapped());
    if (!volume->tiers()) return hostWorkers().parallelFor(n, decode);
    // Bricks read from the file give their pages back batch by batch (a batch of a frame's
    // thousands would map hundreds of MiB of it first).
    constexpr uint32_t kBatch = 256;
    for (uint32_t from = 0; from < n; from += kBatch) {
        const uint32_t count = std::min(kBatch, n - from);
        hostWorkers().parallelFor(count, [&](uint64_t i, unsigned worker) { decode(from + i, worker); });
        afterHostDecode(list + kDecodeEntryWords * size_t(from), count);
    }
}

void Renderer::Impl::afterHostDecode(const uint32_t* list, uint32_t n) {
    const TieredVolume* tiers = volume->tiers();
    if (!tiers) return;
    size_t fromFile = 0;
    std::vector<uint32_t> next;
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t* e = list + kDecodeEntryWords * i;
        if (e[0] >= brickCount) continue;
        if (e[1] >= levels - 1 || !tiers->hasCoarseTier()) ++fromFile; // read from the file
        if (e[1] == levels - 2) next.push_back(e[0]); // inverse level L - 1 is full resolution
    }
    tiers->release(fromFile);
    tiers->readAhead(next.data(), next.size());
}

WorkerPool& Renderer::Impl::hostWorkers() {
    if (!workers) workers = std::make_unique<WorkerPool>();
    while (decoders.size() < workers->size()) decoders.push_back(std::make_unique<BrickDecoder>(volume->volume()));
    if (const TieredVolume* tiers = volume->tiers())
        while (finestDecoders.size() < workers->size()) finestDecoders.push_back(std::make_unique<BrickDecoder>(tiers->full()));
    return *workers;
}

Status Renderer::Impl::requestDetail(FrameStats& stats) {
    const uint32_t n = std::min(allocWords()[kAllocDetailRequests], maxRequests);
    stats.detailRequests = n;
    return detail->request(static_cast<const uint32_t*>(detailRequests.mapped()), n);
}

Status Renderer::Impl::commitDetail() {
    const uint64_t before = detail->counts().uploadedBricks;
    Status s = detail->commit();
    detailUploads = uint32_t(detail->counts().uploadedBricks - before);
    return s;
}

uint64_t Renderer::Impl::uniformSubBlocks(const uint32_t* labels, uint32_t brick) const {
    const CompressedVolume& vol = volume->volume();
    const uint32_t shift = log2u(vol.brickSize);
    if (shift < kUniformShift) return 0;
    const uint32_t subShift = shift - kUniformShift, n = 1u << (3 * subShift);
    const std::array<uint32_t, 3> grid = vol.brickGrid();
    const uint32_t b[3] = {brick % grid[0] << shift, brick / grid[0] % grid[1] << shift, brick / (grid[0] * grid[1]) << shift};
    uint64_t mask = 0;
    for (uint32_t j = 0; j < 64; ++j) {
        if (!uniformSubBlockInside(j, subShift, b[0], b[1], b[2], vol.dim[0], vol.dim[1], vol.dim[2])) continue;
        const uint32_t* run = labels + size_t(j) * n;
        if (std::all_of(run + 1, run + n, [&](uint32_t l) { return l == run[0]; })) mask |= uint64_t(1) << j;
    }
    return mask;
}

} // namespace csgv::gpu
