// SPDX-License-Identifier: MIT
#pragma once
/// @file Compress.h
/// @brief From any supported input to `.csgv` + `.csgv.json` (+ `_csgv.db3` when relabelled):
/// the one path that `csgv compress`, benchmarks and the ParaView writer share.
///
/// Inputs: `synth:WxHxD[:seed]` (generated slab by slab) and every form openInput() recognises
/// (Inputs.h), read slab by slab and handed to encodeToFile through LabelSlabAdapter, so no step
/// holds the decoded volume. Labels that fit the format are encoded in one pass. Labels that do
/// not (negative, 0xFFFFFFFF, wider than 32 bits), or `relabel`, take two passes: pass 1 finds
/// each label's first visiting position (StreamingRelabeller), pass 2 encodes the ids. Types that
/// may hold such values (uint32, signed, 64-bit, float) are encoded optimistically and restarted
/// with two passes at the first value that does not fit: files whose labels fit (the common
/// uint32/uint64 case) are read once, and a restart wastes at most one partial encode, where a
/// pre-scan would cost every such file a full extra read.
///
/// Working memory: the encoder's band (a slab, W * H * min(brickSize, D) * 4 bytes, unless the input
/// reads rows, as every format but TIFF, Zarr and precomputed does: then about
/// EncodeToFileOptions::maxBandBytes, at least one brick row) + the adapter's scratch
/// (kScratchBytes; at least one slice at 8 bytes a voxel for an input that does not read rows,
/// else one row) + the source's working set (InputSource::workingBytes) + the label map when
/// relabelling (about 50 bytes a label; its first pass reads within kScratchBytes the same way)
/// + what encodeToFile holds for the output (Encoder.h: 8 bytes a brick of index, checked as soon as
/// the input is open against CompressOptions::maxIndexBytes, and bounded per-slab state). Regions
/// the input knows to hold one value (InputSource::uniformBoxes: HDF5 chunks never written) are
/// neither read nor scanned, in either pass: a volume of fill values costs time per brick, and no
/// band of labels at all. Progress is reported after every read of the
/// input (LabelSlabAdapter::onRead) as well as after each slab of bricks, and long reads inside
/// the input ask whether to go on (InputSource::setKeepGoing), so a cancel is seen between them.

#include "csgv/codec/Encoder.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Inputs.h"
#include "csgv/inputs/Relabel.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace csgv {

/// The relabelling pass's share of the progress left when it starts (the encoding pass has the rest).
constexpr double kRelabellingShare = 0.5;

/// Called now and then during compression with the fraction of the whole compression done
/// (0..1, never decreasing, reaching 1) and the stage. With two passes "relabelling" covers
/// [0, kRelabellingShare) and "encoding" [kRelabellingShare, 1]; with one pass "encoding" covers
/// [0, 1]. When an optimistic pass restarts at fraction r, the two passes that follow share
/// [r, 1] the same way ("relabelling" [r, r + (1 - r) * kRelabellingShare), then "encoding"), so
/// a progress bar never goes backwards. Returning false cancels: nothing is written (what was
/// written under temporary names is removed) and compressToFile returns an error saying the
/// compression was cancelled.
using CompressProgress = std::function<bool(double fraction, const char* stage)>;

struct CompressOptions {
    EncodeOptions encode;
    InputOptions input;
    CompressProgress progress;
    bool relabel = false;                          ///< force dense relabelling
    uint64_t maxOutputBytes = uint64_t(64) << 30;
    /// Bound on the encoder's brick index (EncodeToFileOptions::maxIndexBytes; 0: automatic),
    /// checked as soon as the input is open, before any voxel is read.
    uint64_t maxIndexBytes = 0;
};

/// @brief What a compression did. dim, inputFormat, originalType and voxels are filled as soon as
/// the input is open, so a progress callback holding the report may read them.
struct CompressReport {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    uint64_t voxels = 0;
    std::string inputFormat;   ///< "synth", "vraw", "NRRD", "NIfTI", "HDF5", ...
    std::vector<std::string> namedFiles; ///< the input's InputInfo::namedFiles
    uint64_t outputBytes = 0;
    bool relabelled = false;
    uint64_t labelCount = 0;   ///< ids in the database when relabelled (0 included)
    std::string originalType;
    int passes = 0;            ///< reads of the input: 1, 2 (relabelled), 3 (optimistic pass restarted)
    bool restarted = false;    ///< an optimistic single pass met a label that does not fit
    /// Estimated peak working memory: encoder slab + adapter scratch + the source's largest working
    /// set + the label map (not the encoder's output buffers).
    uint64_t workingBytes = 0;
    double readSeconds = 0;    ///< opening the input
    double relabelSeconds = 0; ///< pass 1
    double encodeSeconds = 0;  ///< the encoding pass (reading, mapping, encoding, writing the .csgv)
    double writeSeconds = 0;   ///< sidecars and the final rename
    double mvoxelsPerSecond = 0; ///< voxels over the whole compression's seconds, in millions
};

/// @brief The encoder's uint32 slabs from an InputSource: reads each slab in sub-slabs of a few
/// slices into a bounded uint64 scratch (never a whole brick-deep slab at 8 bytes a voxel) and
/// writes format labels: ids through a relabeller, or the values themselves after checking they
/// fit. A value that does not fit fails the read and sets misfit(), so the caller can restart
/// with relabelling. Memory: the scratch, kScratchBytes at 8 bytes a voxel, at least one slice
/// when whole slabs are read, one row when bands of rows are.
class LabelSlabAdapter : public SlabSource {
public:
    static constexpr uint64_t kScratchBytes = uint64_t(32) << 20;
    /// `relabeller` (finished) maps values to ids; null: values must fit the format.
    /// `maxScratchBytes` bounds the scratch (one slice at least).
    LabelSlabAdapter(InputSource& source, const StreamingRelabeller* relabeller, uint64_t maxScratchBytes = kScratchBytes);
    std::array<uint32_t, 3> dimensions() const override { return m_source.info().dim; }
    Status readSlab(uint32_t z0, uint32_t depth, uint32_t* out) override;
    /// Bands of rows when the input reads rows (InputSource::readsRows), else whole slabs.
    bool readsRows() const override { return m_source.readsRows(); }
    uint32_t chunkDepth() const override { return m_source.info().chunkDepth; }
    Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint32_t* out) override;
    /// The source's uniform boxes (InputSource::uniformBoxes) with their values made labels as
    /// readRows makes them (ids through the relabeller). A value that is no label (negative,
    /// wider than 32 bits, 0xFFFFFFFF, unknown to the relabeller) drops its box: the read then
    /// meets it and fails as it would have (misfit()).
    void uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, std::vector<UniformBox>& out) override;
    /// Called after every read of the source with the fraction of the volume's voxels read so far
    /// in the encoder's order (slab after slab, bands of rows within); returning false cancels
    /// (the read fails with "cancelled"). The encoder reports progress once per slab of bricks,
    /// which on a very wide volume is minutes apart; reads are at most the scratch apart.
    /// The same callback, with the last fraction, is the source's keepGoing (InputSource::setKeepGoing)
    /// while this adapter lives.
    void onRead(std::function<bool(double fraction)> callback);
    ~LabelSlabAdapter() override;
    bool misfit() const { return m_misfit; }
    uint64_t scratchBytes() const { return m_scratch.capacity() * sizeof(uint64_t); }
    uint64_t maxSourceWorkingBytes() const { return m_maxSourceWorking; }

private:
    Status readRegion(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint32_t* out);

    InputSource& m_source;
    const StreamingRelabeller* m_relabeller;
    uint64_t m_maxScratchBytes;
    std::vector<uint64_t> m_scratch;
    bool m_misfit = false;
    uint64_t m_maxSourceWorking = 0;
    std::function<bool(double)> m_onRead;
    double m_lastRead = 0; ///< the fraction last reported to m_onRead
};

/// Slices per sub-slab of at most `depth` slices of `sliceVoxels` uint64 values within
/// `maxBytes` (at least 1).
uint32_t subSlabDepth(uint64_t sliceVoxels, uint32_t depth, uint64_t maxBytes = LabelSlabAdapter::kScratchBytes);

/// Calls `fn(z, d)` for slices [z0, z0 + depth) in consecutive sub-slabs of at most `step`
/// slices (z the first slice, d the sub-slab's depth); returns fn's first failure.
template <typename Fn>
Status forEachSubSlab(uint32_t z0, uint32_t depth, uint32_t step, Fn&& fn) {
    step = step ? step : 1;
    for (uint32_t z = z0; z < z0 + depth; z += step)
        if (Status s = fn(z, step < z0 + depth - z ? step : z0 + depth - z); !s) return s;
    return Status::ok();
}

/// Voxel (x, y, z) of linear index `index` (x fastest) in a slab of slices of `dim`'s size
/// starting at slice z0, as text for messages: "(x, y, z)".
std::string voxelText(uint64_t index, const std::array<uint32_t, 3>& dim, uint32_t z0 = 0);
/// The same in a band: rows [y0, y0 + rows) of slices `width` wide, starting at slice z0.
std::string voxelText(uint64_t index, uint32_t width, uint32_t y0, uint32_t rows, uint32_t z0);

/// The name an input goes by in a volume's metadata: the file or folder it names with what
/// selects inside it (`a.h5:/labels/seg`, `b.zarr/0`, `cells#8_8_8`), without leading folders or
/// a trailing slash; `synth:` names stay whole.
std::string inputSourceName(const std::string& input);

/// Opens `synth:WxHxD[:seed]` (a uint32 source generated slab by slab, format "synth") or any
/// input openInput() opens: what compress, verify and info accept as an input.
Result<std::unique_ptr<InputSource>> openCompressInput(const std::string& input, const InputOptions& options = {});

/// Compresses `input` to `output` (and its sidecars). The volume is encoded under a temporary
/// name; then the set is published all or nothing: the new sidecars are written complete under
/// temporary names too, and only then renamed over the old ones, the `.csgv` last (a stale
/// `_csgv.db3` is removed when no relabelling happened). Any error or cancel before that (a full
/// disk included) leaves the old volume and sidecars byte-identical and no new file. Errors (out
/// of memory included) are returned, never thrown.
Status compressToFile(const std::string& input, const std::string& output, const CompressOptions& options,
                      CompressReport* report = nullptr);
/// The same from a source already open (`name` for messages and the metadata's source field).
Status compressSourceToFile(InputSource& source, const std::string& name, const std::string& output,
                            const CompressOptions& options, CompressReport* report = nullptr);
/// Publishes a volume written complete at `volumeTmp` (a temporary name beside `output`) as
/// `output`, with its sidecars: all or nothing. The metadata (`md`, its relabelled flag from
/// `mapping`) and, when relabelled, the attribute database are written complete under temporary
/// names first; a failure there (a full disk) leaves the old set byte-identical and no new file.
/// Then each file is renamed over its old one, sidecars first and the volume last, each old file
/// moved aside first (a stale `_csgv.db3` of an earlier relabelling goes): a rename that fails puts
/// the old set back whole. On failure `volumeTmp` is still there for the caller to remove.
Status publishVolumeFiles(const std::string& output, const std::string& volumeTmp, const VolumeMetadata& md,
                          const LabelMapping& mapping);
/// Writes `volume` complete under a temporary name and publishes it with its sidecars
/// (publishVolumeFiles): all or nothing, the temporary removed on failure, the error naming
/// `output` rather than any temporary. What ParaView's writer calls.
Status writeVolumeFiles(const std::string& output, const CompressedVolume& volume, const VolumeMetadata& md,
                        const LabelMapping& mapping);

} // namespace csgv
