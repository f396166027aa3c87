// SPDX-License-Identifier: MIT
#include "csgv/gpu/GpuVolume.h"
#include "csgv/gpu/LabelLookup.h"
#include "csgv/gpu/DetailStream.h"
#include "csgv/gpu/FrameLayout.h"

#include "csgv/base/Checked.h"
#include "csgv/base/MappedFile.h"
#include "csgv/codec/UniformLevels.h"

#include <algorithm>
#include <unordered_map>

namespace csgv::gpu {

namespace {

/// Writes the words from `w0` on of array `i` of the device's encoding arrays (laid out as
/// `starts` says: a brick's palette ends where its next starts, CSGV-FORMAT.md section 3) into
/// `out`, whole bricks up to `room` words, with every palette entry replaced by its id when the
/// volume stores ids: the count written, 0 when a brick does not fit.
uint64_t fillArray(const GpuVolume& g, const CompressedVolume& volume, size_t i, const WordArray& array,
                   const std::vector<uint32_t>& starts, uint64_t w0, uint32_t* out, uint64_t room) {
    const uint64_t n = volume.brickCount(), per = volume.bricksPerArray == kSingleArray ? n : volume.bricksPerArray;
    const uint64_t first = i * per, last = std::min<uint64_t>(n, (i + 1) * per); // the array's bricks
    // Bricks [b0, b1) end in (w0, w1]: from the first ending after w0 to the last ending in room.
    auto endOf = [&](uint64_t b) { return uint64_t(starts[size_t(b) + 1]); };
    auto firstEndingAfter = [&](uint64_t w) {
        uint64_t lo = first, hi = last;
        while (lo < hi) {
            const uint64_t mid = lo + (hi - lo) / 2;
            if (endOf(mid) <= w) lo = mid + 1;
            else hi = mid;
        }
        return lo;
    };
    const uint64_t b0 = firstEndingAfter(w0), b1 = firstEndingAfter(w0 + room);
    const uint64_t w1 = w0 + room >= array.size() ? array.size() : (b1 > b0 ? endOf(b1 - 1) : w0);
    if (w1 <= w0) return 0;
    array.copyTo(out, size_t(w0), size_t(w1 - w0));
    if (g.labelIds().empty()) return w1 - w0;
    const uint32_t L = volume.levels();
    const int64_t from = int64_t(b0), to = int64_t(std::min(b1, last));
#pragma omp parallel for schedule(static, 4096)
    for (int64_t b = from; b < to; ++b) {
        if (!g.sound(uint64_t(b))) continue; // never decoded: its words go up as they are
        const uint64_t end = endOf(uint64_t(b)) - w0;
        for (uint32_t k = 0; k < volume.brick(uint64_t(b)).words[L]; ++k) out[end - 1 - k] = g.storedOf(out[end - 1 - k]);
    }
    return w1 - w0;
}

/// Steps per dispatch on CPU devices: llvmpipe ends an invocation's loops after 65535 iterations
/// in total, and a step takes at most 97 (csgv_decode.glsl).
constexpr uint64_t kCpuDeviceSteps = 512;

/// Decodes per workgroup of decode_bricks.comp. A brick's decoder branches on every symbol (its
/// operation), so bricks that share a GPU's warp wait for each other's paths: on an H200 at
/// 1920x1080, 32 bricks a group decoded 1 brick in 5 ms, 13 in 17 ms and 2977 in 24 ms; GPUs
/// therefore run one brick a group (a warp of its own). One brick stays 5-6 ms there: its
/// symbols are one sequential chain (eight lanes a brick, all decoding the symbols and each
/// writing one child of a parent, took 7-8 ms). CPU devices run a group's invocations in SIMD
/// lanes and decode kGroupDecodes a group.
uint32_t decodeGroup(const DeviceInfo& device) { return device.type == "cpu" ? kGroupDecodes : 1u; }

std::string uintArray(const std::array<uint32_t, 17>& v) {
    std::string s = "uint[17](";
    for (size_t i = 0; i < v.size(); ++i) s += (i ? "," : "") + std::to_string(v[i]) + "u";
    return s + ")";
}

std::string uvec3Of(uint32_t x, uint32_t y, uint32_t z) {
    return "uvec3(" + std::to_string(x) + "u," + std::to_string(y) + "u," + std::to_string(z) + "u)";
}

void tableDefines(const std::array<uint32_t, 16>& f, const char* cumName, Defines& d) {
    std::array<uint32_t, 17> cum{};
    for (int s = 0; s < 16; ++s) cum[s + 1] = cum[s] + f[s];
    d.emplace_back(cumName, uintArray(cum));
}

/// Steps the shader needs for a brick decoded to inverse level `target` (csgv_decode.glsl): the
/// root, then each level's parents and one step to close the level.
uint64_t stepsToLevel(uint32_t target) {
    uint64_t n = 1;
    for (uint32_t l = 1; l <= target; ++l) n += (uint64_t(1) << (3 * (l - 1))) + 1;
    return n;
}

constexpr const char* kNoEncodingOnTheDevice =
    "the volume was uploaded for host decoding: the device holds no encoding to decode from";

} // namespace

const char* decodeResultText(uint32_t code) {
    switch (code) {
    case kDecodeOk: return "ok";
    case kDecodeStreamEnd: return "the stream runs past its end";
    case kDecodeBadRoot: return "root operation is not PALETTE_ADV";
    case kDecodeBadOperation: return "operation symbol 7";
    case kDecodeStopAtFinest: return "stop bit at the finest level";
    case kDecodeBadNeighbour: return "neighbour outside the brick or not in the volume";
    case kDecodePaletteOverflow: return "more PALETTE_ADV than the palette size (or a reserved label)";
    case kDecodeBadDistance: return "PALETTE_D points past the palette or has more than 11 groups";
    case kDecodeRansIntegrity: return "the rANS stream fails its end-of-stream check";
    case kDecodeNoDetail: return "the finest level's stream is not in the detail buffer";
    case kDecodeRunning: return "decoding did not finish";
    default: return "unknown decode result";
    }
}

Result<std::unique_ptr<GpuVolume>> GpuVolume::create(Context& context, const CompressedVolume& volume,
                                                     const GpuVolumeOptions& options) {
    // A parse checks the layout (checkLayout); bricks whose header words are wrong are found here,
    // once, and never decoded or drawn (Renderer counts them as bad bricks).
    Status s;
    if (volume.brickCount() >= (uint64_t(1) << 32)) return Status::error("more than 2^32 bricks are not supported on the GPU");
    const uint64_t budget = options.deviceMemoryBytes ? options.deviceMemoryBytes : automaticDeviceMemoryBudget(context.device());
    std::unique_ptr<GpuVolume> g(new GpuVolume(context, volume));
    const bool separable = volume.encoding == kEncodingRans2;
    const bool host = options.hostDecoding;
    if (options.tiers && &options.tiers->coarse() != &volume)
        return Status::error("an upload of tiers takes their coarse volume");
    // Tiers keep the finest level in the file: a GPU decoder streams it like a separated one's.
    const bool separate = !host && (options.tiers || separates(volume, budget, options.separateDetail));
    if (options.cachePaletting) g->m_cacheBits = paletteBits(volume);
    // What the device holds of each brick: all of it; without its finest-level stream
    // (separated); with host decoding its palette (cache paletting) or nothing.
    const DevicePart part = host ? (g->m_cacheBits < 32 ? DevicePart::Palette : DevicePart::Nothing)
                                 : (separate ? DevicePart::Coarse : DevicePart::Whole);
    // Large labels are stored as ids (StoredLabels): in the palettes the device holds, and in the
    // cache regions host decoding writes. An MPI rank's piece keeps its labels.
    try {
        g->m_palettes = options.palettes ? options.palettes
                                         : std::make_shared<const PaletteSummary>(summarizePalettes(volume, kMaterialTableLabels));
    } catch (const std::bad_alloc&) {
        return Status::error("no memory for the palette summary of " + std::to_string(volume.brickCount()) + " bricks");
    }
    if (g->m_palettes->first.size() != volume.brickCount())
        return Status::error("the palette summary given is not this volume's");
    g->m_labels = storedLabels(*g->m_palettes, !options.owned.empty());
    g->m_uniformLevels = options.uniformLevels && g->m_cacheBits == 32 && g->m_labels.largest < kUniformLabelMask;
    std::vector<WordArray> partArrays;
    std::vector<uint32_t> partStarts;
    if (part != DevicePart::Whole) devicePart(volume, part, partArrays, partStarts);
    const std::vector<WordArray>& arrays = part == DevicePart::Whole ? volume.arrays : partArrays;
    const std::vector<uint32_t>& starts = part == DevicePart::Whole ? volume.brickStarts : partStarts;
    const uint64_t need = uploadBytes(arrays, starts);
    if (need > budget)
        return Status::error("the encoding needs " + mebibytes(need) + " of device memory" +
                             (separate ? " without its finest level" : host ? " for its palettes" : "") +
                             ", more than the device-memory budget of " + mebibytes(budget) +
                             (separable || separate || host ? "" : " (only rANS two-table encodings can keep their finest level in host memory)"));
    g->m_separated = separate;
    g->m_hostDecoding = host;
    g->m_owned = options.owned;
    g->m_tiers = options.tiers;
    if (separate) g->m_detailSizes = options.tiers ? DetailStream::sizes(*options.tiers) : DetailStream::sizes(volume);
    std::vector<uint64_t> addresses;
    // Pieces of whole bricks: at least the largest brick a piece (a brick that begins an array
    // begins at its word 0).
    uint64_t chunk = std::max<uint64_t>(options.uploadChunkBytes, 4);
    {
        const uint64_t n = volume.brickCount(), per = volume.bricksPerArray == kSingleArray ? n + 1 : volume.bricksPerArray;
        for (uint64_t b = 0; b < n && b + 1 < starts.size(); ++b) {
            const uint64_t begin = b > 0 && b % per == 0 ? 0 : starts[size_t(b)], end = starts[size_t(b) + 1];
            if (end > begin) chunk = std::max<uint64_t>(chunk, (end - begin) * 4);
        }
    }
    for (size_t i = 0; i < arrays.size(); ++i) {
        const WordArray& a = arrays[i];
        Result<Buffer> b = context.createBuffer(a.size() * 4, MemoryKind::DeviceLocal);
        if (!b) return Status(b.status()).prefix("uploading the encoding");
        // A chunk at a time, with ids the palettes' labels replaced on the way (none to replace
        // when the device holds no palettes).
        const bool ids = part != DevicePart::Nothing;
        s = context.uploadFilled(*b, a.size() * 4, chunk, [&](uint64_t offset, void* out, uint64_t room) {
            const uint64_t w0 = offset / 4;
            if (!ids) {
                a.copyTo(static_cast<uint32_t*>(out), size_t(w0), size_t(room / 4));
                return room / 4 * 4;
            }
            return 4 * fillArray(*g, volume, i, a, starts, w0, static_cast<uint32_t*>(out), room / 4);
        });
        if (!s) return Status(s).prefix("uploading the encoding");
        addresses.push_back(b->address());
        g->m_arrays.push_back(std::move(*b));
    }
    // The palettes scanned and the words uploaded are the file's only if no page of it was cut
    // off meanwhile (MappedFile's guard: a page once replaced by zeros stays marked).
    for (const WordArray& a : volume.arrays)
        if (MappedFile::damagedAt(a.bytes(), a.size() * 4))
            return Status::error("the file changed on disk while it was open (it was cut short); open it again");
    Result<Buffer> addr = context.createBuffer(addresses.size() * 8, MemoryKind::DeviceLocal);
    if (!addr) return addr.status();
    if (!(s = context.upload(*addr, 0, addresses.data(), addresses.size() * 8))) return s;
    g->m_addresses = std::move(*addr);
    Result<Buffer> startBuffer = context.createBuffer(starts.size() * 4, MemoryKind::DeviceLocal);
    if (!startBuffer) return startBuffer.status();
    if (!(s = context.upload(*startBuffer, 0, starts.data(), starts.size() * 4))) return s;
    g->m_starts = std::move(*startBuffer);
    if (options.tiers) options.tiers->releaseFile(); // the palette scan and the upload read it all

    Defines& d = g->m_defines;
    const auto grid = volume.brickGrid();
    d.emplace_back("BRICK_SIZE", std::to_string(volume.brickSize) + "u");
    d.emplace_back("LEVELS", std::to_string(volume.levels()) + "u");
    d.emplace_back("ENCODING", std::to_string(volume.encoding));
    d.emplace_back("LEGACY_DELTA", volume.legacyDelta() ? "1" : "0");
    d.emplace_back("VOLUME_DIM", uvec3Of(volume.dim[0], volume.dim[1], volume.dim[2]));
    d.emplace_back("BRICK_GRID", uvec3Of(grid[0], grid[1], grid[2]));
    d.emplace_back("BRICKS_PER_ARRAY", std::to_string(volume.bricksPerArray) + "u");
    d.emplace_back("CACHE_BITS", std::to_string(g->m_cacheBits));
    d.emplace_back("SEPARATED", separate ? "1" : "0");
    if (volume.encoding != kEncodingNibble) tableDefines(volume.freqA, "CUM_A", d);
    if (volume.encoding == kEncodingRans2) tableDefines(volume.freqB, "CUM_B", d);
    if (host) return g; // nothing to decode from on the device
    Defines decodeDefines = d;
    g->m_decodeGroup = decodeGroup(context.device());
    decodeDefines.emplace_back("DECODE_GROUP", std::to_string(g->m_decodeGroup) + "u");
    Result<std::vector<uint32_t>> spirv = compileComputeShader("decode_bricks.comp", decodeDefines);
    if (!spirv) return spirv.status();
    Result<uint64_t> pipeline = context.createComputePipeline(*spirv, sizeof(DecodePush));
    if (!pipeline) return pipeline.status();
    g->m_decodePipeline = *pipeline;
    return g;
}

bool GpuVolume::separates(const CompressedVolume& volume, uint64_t budget, DetailSeparation separation) {
    // Detail separation: an encoding that would take more than half the budget keeps its finest
    // level in host memory (mode 2 only: there the finest level is a stream of its own).
    if (volume.encoding != kEncodingRans2 || volume.levels() < 2) return false;
    return separation == DetailSeparation::Always || (separation == DetailSeparation::Auto && encodingBytes(volume) > budget / 2);
}

void GpuVolume::devicePart(const CompressedVolume& volume, DevicePart part, std::vector<WordArray>& arrays,
                            std::vector<uint32_t>& starts) {
    // Coarse: each brick without its finest-level stream (mode 2: stream B, from word
    // header[L-1] / 8 to the palette): header, stream A, palette. Palette: the palette alone (its
    // end is where the render pass finds it, as in the whole encoding). Arrays and starts follow
    // the container's rules (CSGV-FORMAT.md section 7): start[i] is where brick i - 1 ends, a new
    // array begins at 0.
    const uint32_t L = volume.levels();
    const uint64_t n = volume.brickCount();
    arrays.assign(volume.arrays.size(), {});
    starts.assign(size_t(n) + 1, 0u);
    if (part == DevicePart::Nothing) return; // no words: every brick starts (and ends) at 0
    sweepBricks(volume, kSweepBricks, [&](uint64_t from, uint64_t to) { // a mapped file's pages go behind it
        for (uint64_t b = from; b < to; ++b) {
            const BrickWords bw = volume.brick(b);
            std::vector<uint32_t>& a = arrays[volume.bricksPerArray == kSingleArray ? 0 : size_t(b / volume.bricksPerArray)].owned();
            if (!brickSound(volume, b)) { // never decoded: no words on the device
                starts[size_t(b) + 1] = uint32_t(a.size());
                continue;
            }
            const uint32_t palette = bw.words[L];
            if (part == DevicePart::Coarse) appendWords(a, bw.words, bw.words[L - 1] / 8);
            appendWords(a, bw.words + (bw.size - palette), palette);
            starts[size_t(b) + 1] = uint32_t(a.size());
        }
        return true;
    });
    (void)n;
}

uint32_t GpuVolume::paletteBits(const CompressedVolume& volume) {
    // Indices 0 .. maxPalette - 1, and the all-ones index for voxels outside the volume.
    uint32_t bits = 1;
    while (bits < 32 && ((uint64_t(1) << bits) - 1) < uint64_t(volume.maxPalette)) ++bits;
    return bits <= 16 ? bits : 32;
}

uint64_t GpuVolume::uploadBytes(const std::vector<WordArray>& arrays, const std::vector<uint32_t>& starts) {
    // As create() allocates them: each array, the address table, the brick starts (the Context
    // makes no buffer smaller than 4 bytes).
    auto bytes = [](uint64_t n) { return std::max<uint64_t>(n, 4); };
    uint64_t n = bytes(arrays.size() * 8) + bytes(starts.size() * 4);
    for (const auto& a : arrays) n += bytes(a.size() * 4);
    return n;
}

uint64_t GpuVolume::encodingBytes(const CompressedVolume& volume) { return uploadBytes(volume.arrays, volume.brickStarts); }

uint64_t GpuVolume::gpuDecodingBytes(const CompressedVolume& volume, uint64_t budget) {
    if (!separates(volume, budget, DetailSeparation::Auto)) return encodingBytes(volume);
    // As devicePart(Coarse) would lay it out, counted without copying.
    const uint32_t L = volume.levels();
    std::vector<uint64_t> words(volume.arrays.size(), 0);
    sweepBricks(volume, kSweepBricks, [&](uint64_t from, uint64_t to) {
        for (uint64_t b = from; b < to; ++b) {
            const BrickWords bw = volume.brick(b);
            if (brickSound(volume, b))
                words[volume.bricksPerArray == kSingleArray ? 0 : size_t(b / volume.bricksPerArray)] += bw.words[L - 1] / 8 + bw.words[L];
        }
        return true;
    });
    auto bytes = [](uint64_t n) { return std::max<uint64_t>(n, 4); }; // as uploadBytes
    uint64_t n = bytes(words.size() * 8) + bytes((volume.brickCount() + 1) * 4);
    for (uint64_t w : words) n += bytes(w * 4);
    return n;
}

uint64_t GpuVolume::deviceBytes() const {
    uint64_t n = m_addresses.size() + m_starts.size();
    for (const Buffer& b : m_arrays) n += b.size();
    return n;
}

Status GpuVolume::decode(const std::vector<BrickRequest>& requests, Buffer& cache, std::vector<uint32_t>* codes) {
    if (m_hostDecoding) return Status::error(kNoEncodingOnTheDevice);
    if (requests.empty()) return Status::ok();
    const uint32_t L = m_volume.levels();
    std::vector<uint32_t> words;
    words.reserve(requests.size() * 3);
    for (const BrickRequest& r : requests) {
        if (r.brick >= m_volume.brickCount()) return Status::error("request for brick " + std::to_string(r.brick) + ", which does not exist");
        if (r.lod >= L) return Status::error("request for level of detail " + std::to_string(r.lod));
        if (!sound(r.brick)) return checkBrick(m_volume, r.brick); // the GPU decoder trusts a brick's header
        if ((uint64_t(r.cacheOffset) + regionWords(r.lod)) * 4 > cache.size())
            return Status::error("brick " + std::to_string(r.brick) + " does not fit the cache at word " +
                                 std::to_string(r.cacheOffset));
        words.push_back(r.brick);
        words.push_back(L - 1 - r.lod);
        words.push_back(r.cacheOffset);
    }
    Result<Buffer> req = m_context.createBuffer(words.size() * 4, MemoryKind::HostVisible);
    if (!req) return req.status();
    Status s = m_context.upload(*req, 0, words.data(), words.size() * 4);
    if (!s) return s;
    Result<Buffer> states = m_context.createBuffer(requests.size() * kDecodeStateWords * 4, MemoryKind::HostVisible);
    if (!states) return states.status();
    // Every brick needs the same fixed number of dispatches for its level: no host round trip.
    uint64_t steps = 0;
    for (const BrickRequest& r : requests) steps = std::max(steps, stepsToLevel(L - 1 - r.lod));
    const uint64_t perDispatch = m_context.device().type == "cpu" ? kCpuDeviceSteps : steps;
    std::vector<uint32_t> params;
    for (uint64_t done = 0; done < steps; done += perDispatch) {
        params.push_back(uint32_t(requests.size()));
        params.push_back(uint32_t(std::min<uint64_t>(perDispatch, steps - done)));
        params.push_back(done == 0 ? 1u : 0u);
        params.resize(params.size() + kDecodeParamWords - 3, 0u); // failures reported here
    }
    Result<Buffer> paramBuffer = m_context.createBuffer(params.size() * 4, MemoryKind::HostVisible);
    if (!paramBuffer) return paramBuffer.status();
    if (!(s = m_context.upload(*paramBuffer, 0, params.data(), params.size() * 4))) return s;
    // A separated volume's finest-level streams go to a detail buffer of their own for this call.
    std::unique_ptr<DetailStream> detail;
    if (m_separated) {
        std::vector<uint32_t> finest;
        for (const BrickRequest& r : requests)
            if (r.lod == 0) finest.push_back(r.brick);
        std::sort(finest.begin(), finest.end());
        finest.erase(std::unique(finest.begin(), finest.end()), finest.end());
        uint64_t bytes = 0;
        for (uint32_t b : finest) bytes += DetailStream::brickBytes(m_volume, b, m_tiers.get());
        Result<std::unique_ptr<DetailStream>> d = DetailStream::create(
            m_context, m_volume, std::max(2 * bytes, m_detailSizes.smallestBytes), &m_detailSizes, m_tiers.get());
        if (!d) return d.status();
        detail = std::move(*d);
        if (!(s = detail->request(finest.data(), finest.size())) || !(s = detail->commit())) return s;
    }
    const uint64_t detailTable = detail ? detail->tableAddress() : 0, detailRing = detail ? detail->ringAddress() : 0;
    std::vector<DecodePush> pushes;
    for (size_t k = 0; k < params.size() / kDecodeParamWords; ++k)
        pushes.push_back(DecodePush{m_addresses.address(), m_starts.address(), req->address(), cache.address(),
                                    states->address(), paramBuffer->address() + 4 * kDecodeParamWords * k,
                                    paramBuffer->address() + 4 * kDecodeParamWords * k, detailTable, detailRing, 0, 0, 0, 0});
    std::vector<Context::Dispatch> dispatches;
    for (const DecodePush& push : pushes) {
        Context::Dispatch d;
        d.pipeline = m_decodePipeline;
        d.pushConstants = &push;
        d.pushConstantBytes = sizeof(push);
        d.groups[0] = uint32_t((requests.size() + m_decodeGroup - 1) / m_decodeGroup);
        dispatches.push_back(d);
    }
    if (!(s = m_context.run(dispatches))) return s;
    std::vector<uint32_t> status(requests.size(), kDecodeOk);
    if (codes) {
        std::vector<uint32_t> words(requests.size() * kDecodeStateWords);
        if (!(s = m_context.download(*states, 0, words.data(), words.size() * 4))) return s;
        for (size_t i = 0; i < requests.size(); ++i) status[i] = words[kDecodeStateWords * i + kDecodeStateStatus];
    }
    if (codes) *codes = std::move(status);
    return Status::ok();
}

Status GpuVolume::appendFrameDecode(uint64_t requests, uint64_t countAddress, uint64_t cacheAddress,
                                    uint64_t statesAddress, uint32_t maxRequests, FrameDecode& storage,
                                    std::vector<Context::Dispatch>& out, const DetailStream* detail, const Carry* carryOrNull) {
    if (m_hostDecoding) return Status::error(kNoEncodingOnTheDevice);
    if (m_separated && !detail) return Status::error("GPU decoding of a separated volume needs a detail stream");
    const Carry carry = carryOrNull ? *carryOrNull : Carry{};
    const bool carries = carry.alloc != 0;
    if (carries && detail) return Status::error("decodes that carry over frames cannot stream detail");
    const uint64_t steps = carry.stepsPerFrame ? std::min<uint64_t>(carry.stepsPerFrame, decodeSteps()) : decodeSteps();
    const uint64_t perDispatch = m_context.device().type == "cpu" ? kCpuDeviceSteps : steps;
    const bool overlapped = carries && carry.overlap && carry.stepsPerFrame != 0 && steps <= perDispatch;
    std::vector<uint32_t> params;
    if (overlapped) { // the publishing dispatch: no steps
        params.resize(kDecodeParamWords, 0u);
        params[kDecodeParamPublish] = 1u;
    }
    for (uint64_t done = 0; done < steps; done += perDispatch) {
        params.push_back(0u);
        params.push_back(uint32_t(std::min<uint64_t>(perDispatch, steps - done)));
        params.push_back(done == 0 ? 1u : 0u);
        params.resize(params.size() + kDecodeParamWords - 3, 0u); // failures reported here
        params[params.size() - kDecodeParamWords + kDecodeParamCarry] = carries && done + perDispatch >= steps ? 1u : 0u;
        params[params.size() - kDecodeParamWords + kDecodeParamMarkFailed] = 1u; // cache_uniform.comp fills failed regions
        params[params.size() - kDecodeParamWords + kDecodeParamDefer] = overlapped ? 1u : 0u;
    }
    Result<Buffer> paramBuffer = m_context.createBuffer(params.size() * 4, MemoryKind::HostVisible);
    if (!paramBuffer) return paramBuffer.status();
    Status s = m_context.upload(*paramBuffer, 0, params.data(), params.size() * 4);
    if (!s) return s;
    storage.pushes.clear();
    storage.pushes.reserve(params.size() / kDecodeParamWords);
    for (size_t k = 0; k < params.size() / kDecodeParamWords; ++k)
        storage.pushes.push_back(DecodePush{m_addresses.address(), m_starts.address(), requests, cacheAddress, statesAddress,
                                            paramBuffer->address() + 4 * kDecodeParamWords * k, countAddress,
                                            detail ? detail->tableAddress() : 0, detail ? detail->ringAddress() : 0,
                                            carry.alloc, carry.bricks, carry.next, carry.nextStates});
    storage.params = std::move(*paramBuffer);
    storage.overlapped = overlapped;
    for (const auto& push : storage.pushes) {
        Context::Dispatch d;
        d.pipeline = m_decodePipeline;
        d.pushConstants = &push;
        d.pushConstantBytes = sizeof(DecodePush);
        d.groups[0] = (maxRequests + m_decodeGroup - 1) / m_decodeGroup;
        out.push_back(d);
    }
    if (overlapped) out.back().overlapsNext = true;
    return Status::ok();
}

uint64_t GpuVolume::decodeSteps() const { return stepsToLevel(m_volume.levels() - 1); }

Result<std::vector<uint32_t>> GpuVolume::decodeToHost(const std::vector<BrickRequest>& requests) {
    std::vector<BrickRequest> placed = requests;
    uint64_t words = 0;
    for (BrickRequest& r : placed) {
        if (r.lod >= m_volume.levels()) return Status::error("request for level of detail " + std::to_string(r.lod));
        r.cacheOffset = uint32_t(words);
        words += regionWords(r.lod);
        if (words * cacheEntriesPerWord() >= (uint64_t(1) << 32)) return Status::error("too many bricks for one host decode");
    }
    Result<Buffer> cache = m_context.createBuffer(words * 4, MemoryKind::DeviceLocal);
    if (!cache) return cache.status();
    std::vector<uint32_t> codes;
    Status s = decode(placed, *cache, &codes);
    if (!s) return s;
    for (size_t i = 0; i < codes.size(); ++i)
        if (codes[i] != kDecodeOk)
            return Status::error("brick " + std::to_string(placed[i].brick) + ", GPU decode: " + decodeResultText(codes[i]));
    std::vector<uint32_t> raw(words);
    if (!(s = m_context.download(*cache, 0, raw.data(), words * 4))) return s;
    std::vector<uint32_t> out;
    for (const BrickRequest& r : placed) {
        const std::vector<uint32_t> labels = labelsFromRegion(r.brick, r.lod, raw.data() + r.cacheOffset);
        out.insert(out.end(), labels.begin(), labels.end());
    }
    return out;
}

uint64_t GpuVolume::regionWords(uint32_t lod) const {
    const uint64_t edge = lod < 32 ? (m_volume.brickSize >> lod) : 0;
    const uint64_t entries = std::max<uint64_t>(edge * edge * edge, 1);
    const uint64_t per = cacheEntriesPerWord();
    return (entries + per - 1) / per;
}

Status GpuVolume::decodeRegion(BrickDecoder& decoder, uint32_t brick, uint32_t lod, uint32_t* out) const {
    Status s = decoder.decode(brick, lod); // refuses a brick of a file cut short under its mapping
    if (!s) {
        std::fill(out, out + regionWords(lod), kNone);
        return s;
    }
    const uint64_t edge = decoder.gridSize();
    packRegion(brick, decoder.labels(), edge * edge * edge, out);
    if (lod == 0 && m_uniformLevels) { // each word's uniform level above its label (Layout.h)
        thread_local std::vector<uint8_t> levels; // decodeRegion runs on the host workers (one a run of eight)
        levels.resize(edge * edge * edge / 8);
        uniformLevelsOfBrick(out, floorLog2(m_volume.brickSize), brick, {m_volume.dim[0], m_volume.dim[1], m_volume.dim[2]},
                             levels.data());
        for (uint64_t r = 0; r < levels.size(); ++r)
            if (const uint32_t bits = uint32_t(levels[r]) << kUniformLevelShift)
                for (uint32_t* w = out + 8 * r; w != out + 8 * r + 8; ++w) *w |= bits;
    }
    return Status::ok();
}

void GpuVolume::packRegion(uint32_t brick, const uint32_t* labels, uint64_t n, uint32_t* out) const {
    if (m_cacheBits == 32 && m_labels.ids.empty()) {
        std::copy(labels, labels + n, out);
        return;
    }
    if (m_cacheBits == 32) { // ids: one search a run of one label (runs are the rule in Morton order)
        uint32_t lastLabel = kInvalidLabel, lastId = kNone;
        for (uint64_t e = 0; e < n; ++e) {
            if (labels[e] != lastLabel) {
                lastLabel = labels[e];
                lastId = lastLabel == kInvalidLabel ? kNone : m_labels.storedOf(lastLabel);
            }
            out[e] = lastId;
        }
        return;
    }
    const BrickWords bw = m_volume.brick(brick);
    const uint32_t paletteSize = sound(brick) ? bw.words[m_volume.levels()] : 0; // never decoded when unsound
    const uint32_t per = cacheEntriesPerWord(), outside = (1u << m_cacheBits) - 1u;
    std::fill(out, out + (n + per - 1) / per, 0u);
    std::unordered_map<uint32_t, uint32_t> indexOf; // long palettes only
    if (paletteSize > 32)
        for (uint32_t k = paletteSize; k-- > 0;) indexOf[bw.words[bw.size - 1 - k]] = k;
    uint32_t lastLabel = kInvalidLabel, lastIndex = outside;
    for (uint64_t e = 0; e < n; ++e) {
        const uint32_t l = labels[e];
        if (l != lastLabel) { // runs of one label are the rule: one palette search a run
            lastLabel = l;
            lastIndex = outside;
            if (paletteSize > 32) {
                const auto it = indexOf.find(l);
                if (it != indexOf.end() && l != kInvalidLabel) lastIndex = it->second;
            } else {
                for (uint32_t k = 0; k < paletteSize && l != kInvalidLabel; ++k)
                    if (bw.words[bw.size - 1 - k] == l) {
                        lastIndex = k;
                        break;
                    }
            }
        }
        out[e / per] |= lastIndex << ((e % per) * m_cacheBits);
    }
}

std::vector<uint32_t> GpuVolume::labelsFromRegion(uint32_t brick, uint32_t lod, const uint32_t* words) const {
    const uint64_t edge = m_volume.brickSize >> lod, n = edge * edge * edge;
    std::vector<uint32_t> labels(n);
    if (m_cacheBits == 32) {
        const std::vector<uint32_t>& ids = m_labels.ids;
        for (uint64_t e = 0; e < n; ++e) {
            // Uniform levels ride above the labels of bricks at the finest level (kNone stays all ones).
            const uint32_t w = m_uniformLevels && words[e] != kNone ? words[e] & kUniformLabelMask : words[e];
            labels[e] = ids.empty() ? w : (w < ids.size() ? ids[w] : kInvalidLabel);
        }
        return labels;
    }
    const uint32_t per = cacheEntriesPerWord(), mask = (1u << m_cacheBits) - 1u;
    const BrickWords bw = m_volume.brick(brick);
    const uint32_t paletteSize = sound(brick) ? bw.words[m_volume.levels()] : 0; // never decoded when unsound
    for (uint64_t e = 0; e < n; ++e) {
        const uint32_t index = (words[e / per] >> ((e % per) * m_cacheBits)) & mask;
        labels[e] = index == mask || index >= paletteSize ? kInvalidLabel : bw.words[bw.size - 1 - index];
    }
    return labels;
}

bool GpuVolume::owns(uint64_t b) const {
    if (m_owned.empty()) return true;
    const std::array<uint32_t, 3> grid = m_volume.brickGrid();
    return m_owned.contains(uint32_t(b % grid[0]), uint32_t(b / grid[0] % grid[1]), uint32_t(b / grid[0] / grid[1]));
}

} // namespace csgv::gpu
