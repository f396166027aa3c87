// SPDX-License-Identifier: MIT
#pragma once
/// @file Encoder.h
/// @brief CSGV encoding (modes 0, 1, 2; every operation mask; bricks 8 to 128), in parallel over
/// bricks with output that is byte-identical whatever the thread count, from a volume in memory
/// or from any source that delivers z-slabs, so volumes larger than memory encode with memory
/// bounded by the output plus a few slabs.
///
/// Choices where the format leaves the writer free (CSGV-FORMAT.md section 4.3):
/// - Operation per node: the first of PARENT, NEIGHBOR_X/Y/Z, PALETTE_LAST, PALETTE_D,
///   PALETTE_ADV that reproduces the label and that the mask enables (Volcanite's order).
/// - Frequency tables are counted over every symbol of every brick (not a sample), then scaled to
///   16384 with every emitted symbol at least 1, so no table ever lacks a symbol it must code.
/// - header[1..L-1] of modes 1 and 2 hold the pre-entropy (nibble) level starts, as in mode 0.
/// - Bricks go into one encoding array while they fit in 2^29 words; otherwise into the fewest
///   arrays of a constant brick count that each fit.
/// - Bricks a source knows to hold one label without reading them (SlabSource::uniformBoxes: an
///   HDF5 chunk never written) are copied from a constant brick encoded once per brick extent,
///   with the same bytes as encoding their voxels: a volume of fill values costs time per brick.

#include "csgv/codec/Container.h"
#include "csgv/codec/LabelVolume.h"
#include "csgv/codec/Partition.h"
#include "csgv/base/UniformBox.h"

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace csgv {

/// @brief Pass 1's result: how often each symbol occurs over a volume's bricks, per table (A:
/// levels 0..L-2, or every level in mode 1; B: the finest level in mode 2). The counts of
/// whole-brick pieces (Partition.h) add up to the whole volume's.
struct SymbolCounts {
    std::array<uint64_t, 16> a{}, b{};
    SymbolCounts& operator+=(const SymbolCounts& o) {
        for (int k = 0; k < 16; ++k) {
            a[k] += o.a[k];
            b[k] += o.b[k];
        }
        return *this;
    }
};

struct EncodeOptions {
    uint32_t brickSize = 32;
    int32_t encoding = kEncodingRans2;
    uint32_t opMask = kMaskDefault;
    int threads = 0; ///< 0: OpenMP's default
    /// Use these frequency tables instead of counting (for example another file's, to reproduce
    /// it byte for byte); every emitted symbol must have a nonzero frequency or encoding fails.
    bool fixedTables = false;
    /// Largest encoding array in words (the format's limit is 2^29; smaller values test splitting).
    uint32_t maxArrayWords = kMaxWordsPerArray;
    std::array<uint32_t, 16> tableA{}, tableB{};
    /// Encoding one volume in whole-brick pieces (one per process) that joinPieces (Container.h)
    /// makes one file of: called once after pass 1 with this piece's counts, it returns the
    /// counts of the whole volume (the sum over the pieces), or an error that stops the encoding.
    /// Tables come from what it returns (unless fixedTables), so every piece's bricks get the
    /// words they get in the whole volume's encoding. Not called when pass 1 fails.
    std::function<Result<SymbolCounts>(const SymbolCounts&)> shareCounts;
    /// Trust SlabSource::uniformBoxes: a brick they cover whole with one label is written as the
    /// constant brick of that label and extent without reading or scanning its voxels, and a band
    /// of rows whose bricks are all such is not read. The bytes are those of reading every voxel
    /// (false: the tests compare the two).
    bool useUniformBoxes = true;
};

/// @brief Labels delivered slab by slab: z-slabs of brickSize slices (fewer at the end), x fastest.
/// Labels must not be 0xFFFFFFFF (reserved).
///
/// A source that can read part of a slab as cheaply as all of it (a chunked or uncompressed file,
/// a generator) says so with readsRows(); the encoder then reads each slab in bands of brick
/// rows (EncodeToFileOptions::maxBandBytes), as deep as chunkDepth(), so its memory no longer grows
/// with W * H and a chunked source need not cache a whole layer of chunks.
class SlabSource {
public:
    virtual ~SlabSource() = default;
    virtual std::array<uint32_t, 3> dimensions() const = 0;
    /// Fills out (W * H * depth labels) with slices [z0, z0 + depth).
    virtual Status readSlab(uint32_t z0, uint32_t depth, uint32_t* out) = 0;
    /// True when readRows works (and is not much dearer per voxel than readSlab).
    virtual bool readsRows() const { return false; }
    /// Slices the source stores together (a chunked file's chunk depth; 1 for slices): bands of
    /// rows are read this deep (rounded up to whole slabs), so that no chunk is read twice.
    virtual uint32_t chunkDepth() const { return 1; }
    /// Fills out (W * rows * depth labels, x fastest) with rows [y0, y0 + rows) of slices
    /// [z0, z0 + depth). Called only when readsRows(); the default reads whole slices only.
    virtual Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint32_t* out);
    /// Sources already in memory return slice z0's labels here, saving readSlab's copy.
    virtual const uint32_t* slabInMemory(uint32_t /*z0*/) const { return nullptr; }
    /// Boxes of rows [y0, y0 + rows) of slices [z0, z0 + depth) known to hold one label each
    /// (UniformBox::value a label), without reading: put in `out`, disjoint, inside the region
    /// (InputSource::uniformBoxes's contract, with labels). The encoder asks before reading each
    /// band. The default lists none.
    virtual void uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, std::vector<UniformBox>& out) {
        (void)z0, (void)depth, (void)y0, (void)rows;
        out.clear();
    }
};

/// Parses "default" (pnls), "all" (pnlds) or letters p, x, y, z, n, l, d, s into an operation mask.
Result<uint32_t> parseOperationMask(const std::string& text);
/// Checks options before any work: brick size, encoding, mask bits.
Status checkEncodeOptions(const EncodeOptions& options);

/// Encodes a volume in memory.
Result<CompressedVolume> encodeVolume(const LabelVolume& volume, const EncodeOptions& options);
/// @brief How encodeToFile works and reports.
struct EncodeToFileOptions {
    uint64_t maxOutputBytes = uint64_t(64) << 30;
    /// Brick symbols (pass 1's result, a few times the output) are held in memory up to this
    /// many bytes; beyond it, all of them go to a scratch file beside the output.
    uint64_t heldSymbolBytes = uint64_t(256) << 20;
    /// Labels read at once from a source that readsRows(): bands of whole brick rows of about this
    /// many bytes (at least one brick row, at most the slab), SlabSource::chunkDepth() deep
    /// rounded up to whole slabs. Other sources give whole slabs.
    uint64_t maxBandBytes = uint64_t(64) << 20;
    /// Called after each slab of bricks and while writing, with the fraction done (0..1);
    /// returning false cancels (nothing is left at `path`).
    std::function<bool(double fraction)> progress;
    /// Bound on the brick index (encoderIndexBytes), checked before any work. 0: automatic, half
    /// the smaller of the machine's memory and the process's address-space limit (ulimit -v).
    uint64_t maxIndexBytes = 0;
};

/// Bytes of the per-brick state encodeToFile holds for the whole volume whatever its labels: each
/// brick's word count, then its start in the file, 4 bytes each and both at once while the
/// encoding arrays are laid out (8 bytes a brick). 65536^3 voxels in bricks of 32^3 are 2^33
/// bricks: 64 GiB.
uint64_t encoderIndexBytes(const std::array<uint32_t, 3>& dim, uint32_t brickSize);
/// The limit maxIndexBytes = 0 stands for, and how it is worded in messages ("half of ...").
uint64_t automaticIndexLimit(std::string* why = nullptr);
/// Refuses, before any work, a volume whose brick index passes `maxIndexBytes` (0: automatic), in
/// one line naming the dimensions, the bytes needed, the limit and a brick size that would fit.
Status checkEncoderIndex(const std::array<uint32_t, 3>& dim, uint32_t brickSize, uint64_t maxIndexBytes = 0);

/// Encodes from a slab source straight into a `.csgv` file at `path` (written under a temporary
/// name and renamed), giving the bytes writeCsgv(encodeVolume(...)) gives. Unlike encodeVolume,
/// the compressed volume is never in memory at once: memory is one band of labels (a slab unless
/// the source readsRows; none while every band is uniform), the held symbols (serialized, bounded
/// by heldSymbolBytes), one slab of bricks' symbols and words, and the brick index, 8 bytes a
/// brick of the whole volume (encoderIndexBytes; refused before any work past maxIndexBytes); the
/// rest passes through two scratch files beside the output, unlinked while open.
///
/// Per brick, on a volume of one label (every brick constant: the least a volume costs; bricks
/// of 32^3, rans2, measured): 8 bytes of index; 49 bytes of held symbols until heldSymbolBytes,
/// then in the scratch file; about 350 bytes a brick of one slab (its BrickSymbols in pass 1, its
/// symbols and words in pass 2: a 32768 x 32768 slab of 2^20 bricks is 360 MiB); 36 bytes of words
/// in the second scratch file and 40 in the output. Peaks: 4096^3 (2^21 bricks) 150 MiB, 8192^3
/// 290 MiB (the held symbols spill past 256 MiB), 65536^3 refused (64 GiB of index).
Status encodeToFile(SlabSource& source, const EncodeOptions& options, const std::string& path,
                    const EncodeToFileOptions& fileOptions = {}, uint64_t* outputBytes = nullptr);

/// Bytes of labels encodeToFile holds for `source` at once (its band; 0 for a source in memory).
uint64_t encoderBandBytes(const SlabSource& source, uint32_t brickSize,
                          uint64_t maxBandBytes = EncodeToFileOptions().maxBandBytes);

/// Encodes from a slab source; `maxOutputBytes` bounds the compressed result.
Result<CompressedVolume> encodeVolume(SlabSource& source, const EncodeOptions& options,
                                      uint64_t maxOutputBytes = uint64_t(64) << 30);

/// A piece (extractPiece, readCsgvPiece) in the index space of its whole volume (dimensions
/// `dim`): the piece's bricks at `box`, every other brick absent, stored as a brick of label 0 of
/// the piece's encoding and tables (a few words; renderers told the box never draw them). Lets
/// every MPI rank render in the same index space, so rays and level-of-detail choices agree.
Result<CompressedVolume> embedPiece(const CompressedVolume& piece, const BrickBox& box, const std::array<uint32_t, 3>& dim);

} // namespace csgv
