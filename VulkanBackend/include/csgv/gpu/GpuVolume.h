// SPDX-License-Identifier: MIT
#pragma once
/// @file GpuVolume.h
/// @brief A compressed volume in GPU memory (it stays compressed there) and GPU brick decoding
/// into cache regions. Each encoding array is its own buffer, reached through a table of device
/// addresses, so volumes of any size work within per-allocation limits.

#include "csgv/codec/Container.h"
#include "csgv/codec/Partition.h"
#include "csgv/codec/Decoder.h"
#include "csgv/gpu/Context.h"
#include "csgv/gpu/DetailStream.h"
#include "csgv/gpu/LabelLookup.h"
#include "csgv/gpu/FrameLayout.h"
#include "csgv/gpu/ShaderCompiler.h"

#include <array>
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

namespace csgv::gpu {


/// One brick to decode: `lod` 0 is full resolution; `cacheOffset` is the first word of its region
/// ((B >> lod)^3 words), where the labels land in Morton order.
struct BrickRequest {
    uint32_t brick = 0;
    uint32_t lod = 0;
    uint32_t cacheOffset = 0;
};

/// Text for a decode result code of the shader ("ok", "stream runs past its end", ...).
const char* decodeResultText(uint32_t code);

/// Whether the finest level's encoding stays in host memory (detail separation, rANS two-table
/// encodings only): automatically when the whole encoding would take more than half the budget.
enum class DetailSeparation { Auto, Never, Always };

/// @brief How decoded bricks are stored in a cache, and what of the encoding the device holds.
struct GpuVolumeOptions {
    /// Cache paletting (the paper's "Cache paletting"): store packed indices into each brick's
    /// palette, ceil(log2(largest palette + 1)) bits, floor(32 / bits) to a word, instead of 32-bit
    /// labels. Ignored when the palettes are so large that no two indices fit a word.
    bool cachePaletting = false;
    /// Device-memory budget in bytes (0: automaticDeviceMemoryBudget of the device): an encoding
    /// that does not fit (without its finest level when separated) is refused before anything is
    /// uploaded.
    uint64_t deviceMemoryBytes = 0;
    /// Detail separation: the device holds each brick's header, coarse levels and palette; its
    /// finest-level stream stays in the CompressedVolume (which the caller keeps in host memory
    /// anyway) and is streamed into a detail buffer when wanted (DetailStream.h: the renderer's
    /// frames; decode() uploads the streams of its requests for the call).
    DetailSeparation separateDetail = DetailSeparation::Auto;
    /// Bricks are decoded on the host (decodesOnHost() of the renderers' Decode): the device holds
    /// only what rendering reads of the encoding, each brick's palette with cache paletting, else
    /// nothing; GPU decoding of this upload is refused. No detail separation then.
    bool hostDecoding = false;
    /// The bricks this process draws (an MPI rank's piece placed in its volume's index space,
    /// embedPiece); the others are absent: never visible, requested or decoded. Empty: all.
    BrickBox owned;
    /// The volume is tiers->coarse() (TieredVolume.h: the finest level stays in the file): GPU
    /// decoding separates detail (the streams come from the file through a DetailStream), host
    /// decoding reads the finest level from tiers->full(). Null: the volume is whole.
    std::shared_ptr<const TieredVolume> tiers;
    /// The volume's palette summary when its owner has it (summarizePalettes with a cap of at
    /// least kMaterialTableLabels, of this volume or of the full volume of `tiers`, whose coarse
    /// tier holds the same palettes): the upload then reads no palette for its stored labels.
    /// Null: summarized here.
    std::shared_ptr<const PaletteSummary> palettes;
    /// Host memory the upload takes at a time (whole bricks a piece, at least the largest brick):
    /// the encoding goes up in pieces, its palettes' labels replaced by ids on the way.
    uint64_t uploadChunkBytes = uint64_t(64) << 20;
    /// Uniform levels (csgv/codec/Layout.h kUniformLevelShift) in the cache words of bricks at the
    /// finest level, where the cache holds 32-bit labels all below kUniformLabelMask: rays step over
    /// the largest uniform cube around a voxel, not only over uniform sub-blocks. False: the
    /// sub-blocks alone (as with cache paletting or larger labels).
    bool uniformLevels = true;
};

class GpuVolume {
public:
    /// Uploads the encoding. Precondition, not checked again here: the volume passed
    /// checkContainer() (parseCsgv's result and the encoder's output do). The GpuVolume keeps a
    /// reference to `volume` (for its header fields): keep it alive as long as the GpuVolume.
    static Result<std::unique_ptr<GpuVolume>> create(Context& context, const CompressedVolume& volume,
                                                     const GpuVolumeOptions& options = {});

    /// Bits per cache entry with cache paletting: ceil(log2(largest palette + 1)), or 32 when the
    /// palettes are so large that no two indices fit a word (paletting is then ignored).
    static uint32_t paletteBits(const CompressedVolume& volume);
    /// Device memory the encoding of `volume` takes once uploaded (create() allocates exactly this).
    static uint64_t encodingBytes(const CompressedVolume& volume);
    /// Device memory an upload for GPU decoding under `budget` takes (without the finest level
    /// where the budget separates it; DetailSeparation::Auto).
    static uint64_t gpuDecodingBytes(const CompressedVolume& volume, uint64_t budget);

    /// The finest level stays in host memory (GpuVolumeOptions::separateDetail): decoding level 0
    /// needs the brick's stream in a DetailStream.
    bool separated() const { return m_separated; }
    /// The tiers the volume was uploaded from (GpuVolumeOptions::tiers), or null.
    const TieredVolume* tiers() const { return m_tiers.get(); }
    /// A separated volume's finest-level streams (measured once, when uploaded).
    const DetailSizes& detailSizes() const { return m_detailSizes; }
    /// Uploaded for host decoding (GpuVolumeOptions::hostDecoding): no encoding to decode from.
    bool hostDecoding() const { return m_hostDecoding; }
    /// Whether this process draws brick `b` (GpuVolumeOptions::owned).
    bool owns(uint64_t b) const;
    /// The bricks whose header words fail checkBrick (found when uploaded), ascending: never
    /// decoded or drawn (the renderer draws them empty and counts them as bad bricks).
    const std::vector<uint64_t>& unsound() const { return m_palettes->unsound; }
    /// What the palettes hold (GpuVolumeOptions::palettes, or made when uploaded): among it each
    /// brick's first palette entry, which the visibility sweep takes without reading the palette.
    const PaletteSummary& palettes() const { return *m_palettes; }
    bool sound(uint64_t b) const {
        const std::vector<uint64_t>& bad = m_palettes->unsound;
        return bad.empty() || !std::binary_search(bad.begin(), bad.end(), b);
    }
    const BrickBox& owned() const { return m_owned; }
    /// Whether create() separates `volume` under `budget` bytes (0 is not automatic here).
    static bool separates(const CompressedVolume& volume, uint64_t budget, DetailSeparation separation);
    /// A brick's labels (Morton order, kInvalidLabel outside) as its cache region stores them:
    /// copied (as ids with labelIds), or with cache paletting packed as palette indices
    /// (labelsFromRegion's inverse);
    /// `n` labels, (n + entries per word - 1) / entries per word words.
    void packRegion(uint32_t brick, const uint32_t* labels, uint64_t n, uint32_t* out) const;
    /// Decodes a brick at `lod` on the host with `decoder` (of this volume) into its cache region
    /// `out` (regionWords(lod) words, packed as the cache stores it); a brick whose stream fails
    /// reads as outside the volume (all kNone) and the decoder's error is returned (naming the
    /// brick, and the file where it changed under its mapping: MappedFile::damagedAt).
    Status decodeRegion(BrickDecoder& decoder, uint32_t brick, uint32_t lod, uint32_t* out) const;
    /// The labels as the device stores them (LabelLookup.h StoredLabels): with ids (ascending, a
    /// label's id is its index) the device's palettes and the cache hold ids; without (empty),
    /// the labels themselves.
    const std::vector<uint32_t>& labelIds() const { return m_labels.ids; }
    /// A label as the device stores it (StoredLabels::storedOf).
    uint32_t storedOf(uint32_t label) const { return m_labels.storedOf(label); }
    uint32_t largestStoredLabel() const { return m_labels.largest; }
    /// Bits per cache entry: 32 (labels) or fewer (palette indices, cache paletting).
    uint32_t cacheBits() const { return m_cacheBits; }
    uint32_t cacheEntriesPerWord() const { return m_cacheBits == 32 ? 1 : 32 / m_cacheBits; }
    /// Whether the cache words of bricks at the finest level carry their uniform levels
    /// (GpuVolumeOptions::uniformLevels; the shaders' UNIFORM_LEVELS): decodeRegion writes them,
    /// cache_uniform.comp after GPU decoding, and rays step by them.
    bool uniformLevels() const { return m_uniformLevels; }
    /// Cache words of one brick decoded at `lod`.
    uint64_t regionWords(uint32_t lod) const;
    /// Labels (Morton order, kInvalidLabel outside the volume) of a brick's cache region as
    /// decoded at `lod`, unpacked through the brick's palette when paletted.
    std::vector<uint32_t> labelsFromRegion(uint32_t brick, uint32_t lod, const uint32_t* regionWords) const;
    /// Device addresses of the encoding arrays' address table and of the brick starts.
    uint64_t arraysAddress() const { return m_addresses.address(); }
    uint64_t startsAddress() const { return m_starts.address(); }

    /// Shader defines that specialise decoding to this volume.
    const Defines& defines() const { return m_defines; }
    uint64_t deviceBytes() const;
    const CompressedVolume& volume() const { return m_volume; }

    /// Decodes requests into `cache`; result codes (0 = ok) per request into `codes` when given.
    Status decode(const std::vector<BrickRequest>& requests, Buffer& cache, std::vector<uint32_t>* codes = nullptr);
    /// Decodes into a temporary cache and returns each request's labels ((B >> lod)^3 in Morton
    /// order, unpacked when paletted), concatenated in order; an error names the first brick whose
    /// stream is invalid.
    Result<std::vector<uint32_t>> decodeToHost(const std::vector<BrickRequest>& requests);

    /// @brief Push constants and parameters of a frame's decode dispatches (keep while they are used).
    struct FrameDecode {
        std::vector<DecodePush> pushes;
        Buffer params;
        bool overlapped = false; ///< Carry::overlap took: the first dispatch publishes, the last may run beside the next
    };
    /// For the frame pipeline: appends the dispatches that decode requests written by the GPU
    /// (kDecodeEntryWords each at address `requests`: brick, inverse level, cache word offset; their
    /// count in the word at `countAddress`; at most `maxRequests`) into the cache at `cacheAddress`,
    /// with kDecodeStateWords of state per request at `statesAddress`. Enough steps for the finest
    /// level. The dispatches depend on nothing but these arguments: build them once.
    /// A separated volume's finest levels are read from `detail` (required then), whose table
    /// says which bricks' streams are there: keep it alive while the dispatches are used.
    /// With `carry` (its addresses set), a frame's decoding stops after stepsPerFrame steps of each
    /// brick: the frame's last dispatch moves the decodes still running, their states too, to the
    /// list at `carry.next` for the next frame (whose first entries they are; kAllocCarry,
    /// kAllocCarried), and a decode that ends sets its brick's level in the brick table (until then
    /// the brick is missing to the rays; with `overlap`, the next frame's publishing dispatch).
    struct Carry {
        uint32_t stepsPerFrame = 0;  ///< 0: every step (the carried decodes end in this frame too)
        uint64_t alloc = 0;          ///< the cache counters (0: no carry)
        uint64_t bricks = 0;         ///< the brick table, a word a brick after it (kInFlightValid: 20 bytes a brick in all)
        uint64_t next = 0, nextStates = 0; ///< the next frame's decode list and states
        /// Where the frame's steps are one dispatch (stepsPerFrame set): its decodes may run beside
        /// what follows them (the render), which then must not read what they write. A decode that
        /// ends is not published in its frame but moved to the next list too; a first dispatch
        /// (kDecodeParamPublish), to run first in every frame (before its request pass), publishes
        /// those of the previous frame and the progress of the running ones (FrameDecode::overlapped).
        bool overlap = false;
    };
    Status appendFrameDecode(uint64_t requests, uint64_t countAddress, uint64_t cacheAddress, uint64_t statesAddress,
                             uint32_t maxRequests, FrameDecode& storage, std::vector<Context::Dispatch>& out,
                             const DetailStream* detail = nullptr, const Carry* carry = nullptr);
    /// Decoder steps of one brick to the finest level (csgv_decode.glsl: the root, each level's
    /// parents and a step to close each level); coarser levels take fewer.
    uint64_t decodeSteps() const;

private:
    GpuVolume(Context& c, const CompressedVolume& v) : m_context(c), m_volume(v) {}
    Context& m_context;
    const CompressedVolume& m_volume;
    BrickBox m_owned;
    std::shared_ptr<const PaletteSummary> m_palettes;
    std::vector<Buffer> m_arrays;
    Buffer m_addresses, m_starts;
    Defines m_defines;
    uint64_t m_decodePipeline = 0;
    uint32_t m_decodeGroup = 1; ///< decode_bricks.comp's DECODE_GROUP: decodes a workgroup (GpuVolume.cpp decodeGroup)
    uint32_t m_cacheBits = 32;
    bool m_uniformLevels = false;
    StoredLabels m_labels;
    bool m_separated = false;
    bool m_hostDecoding = false;
    DetailSizes m_detailSizes;
    std::shared_ptr<const TieredVolume> m_tiers;
    /// Device memory that encoding arrays and brick starts take once uploaded.
    static uint64_t uploadBytes(const std::vector<WordArray>& arrays, const std::vector<uint32_t>& starts);
    /// What the device holds of each brick when not all of it (arrays and starts as the container's).
    enum class DevicePart { Whole, Coarse, Palette, Nothing };
    static void devicePart(const CompressedVolume& volume, DevicePart part, std::vector<WordArray>& arrays,
                           std::vector<uint32_t>& starts);
};

} // namespace csgv::gpu
