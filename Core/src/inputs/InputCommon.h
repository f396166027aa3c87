// SPDX-License-Identifier: MIT
#pragma once
/// @file InputCommon.h
/// @brief What the input formats share (private to Core/src/inputs): header text parsing in the
/// classic locale, bounded quoting of file text and JSON values in messages, the JSON nesting and
/// metadata size limits, bounded whole-file reads, allocation without exceptions, the one slab
/// bounds check, the memory budget, the index of a chunked format's chunk files (ChunkIndex: Zarr
/// and precomputed), the decoding of stored voxels to full-width labels, and
/// VoxelFileSource, the one streaming source of voxels
/// that lie in a file raw or gzip-compressed (vraw, NRRD and NIfTI build on it).

#include "../base/JsonText.h"
#include "csgv/base/FileUtil.h"
#include "csgv/base/Status.h"
#include "csgv/inputs/Inputs.h"

#include <nlohmann/json_fwd.hpp>

#include <array>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace csgv {
namespace inputs {

// ---- the formats (one file each); Inputs.cpp's table dispatches on claimsX, in its order.
// claimsX: does the path have this format's form (suffix, `:/dataset`, folder layout)?
// openX: reads the header/metadata and returns a source (Inputs.h states the contract).
bool claimsVraw(const std::string& path);
Result<std::unique_ptr<InputSource>> openVraw(const std::string& path, const InputOptions& options);
bool claimsNrrd(const std::string& path);
Result<std::unique_ptr<InputSource>> openNrrd(const std::string& path, const InputOptions& options);
bool claimsNifti(const std::string& path);
Result<std::unique_ptr<InputSource>> openNifti(const std::string& path, const InputOptions& options);
bool claimsHdf5(const std::string& path);
Result<std::unique_ptr<InputSource>> openHdf5(const std::string& path, const InputOptions& options);
bool claimsZarr(const std::string& path);
Result<std::unique_ptr<InputSource>> openZarr(const std::string& path, const InputOptions& options);
bool claimsPrecomputed(const std::string& path);
Result<std::unique_ptr<InputSource>> openPrecomputed(const std::string& path, const InputOptions& options);
bool claimsTiff(const std::string& path);
Result<std::unique_ptr<InputSource>> openTiff(const std::string& path, const InputOptions& options);

// readNrrd and readNifti (Inputs.h) are openNrrdSource/openNiftiSource with the whole-volume
// budget checked among the header checks (where it always was), then readAll.
Result<std::unique_ptr<InputSource>> openNrrdSource(const std::string& path, const InputOptions& options,
                                                    const uint64_t* wholeVolumeBudget);
Result<std::unique_ptr<InputSource>> openNiftiSource(const std::string& path, const InputOptions& options,
                                                     const uint64_t* wholeVolumeBudget);

// ---- messages and header text
Status fail(const std::string& path, const std::string& what);
std::string lower(std::string s);
bool endsWith(const std::string& s, const std::string& suffix);
std::string trim(const std::string& s);
// Numbers in headers are parsed and printed in the classic locale: a host application may have
// set a locale whose decimal separator is a comma.
std::string formatDouble(double v);
bool parseDouble(const std::string& text, double& out);
bool parseInt64(const std::string& text, int64_t& out);
std::vector<std::string> splitWords(const std::string& s);

// ---- metadata files and folders
/// The largest metadata file (Zarr `.zarray`/`.zattrs`, precomputed `info`) read: real ones are a
/// few KiB; this leaves room for any list of scales while bounding what a file can make us hold.
constexpr uint64_t kMaxMetadataBytes = uint64_t(16) << 20;
/// Regular file / directory tests that never throw (std::filesystem with an error_code).
bool isFile(const std::string& path);
bool isDir(const std::string& path);

/// Resizes `v` to `n` elements, turning an allocation failure (bad_alloc, length_error) into an
/// error naming `path`: nothing a file makes us allocate may throw out of Core.
template <class T>
Status resizeOrFail(std::vector<T>& v, size_t n, const std::string& path) {
    try {
        v.resize(n);
        return Status::ok();
    } catch (const std::bad_alloc&) {
    } catch (const std::length_error&) {
    }
    return Status::error(path + ": out of memory for " + std::to_string(n) + " elements of " +
                         std::to_string(sizeof(T)) + " bytes");
}

/// Reads a whole chunk file into `out`, inflating it when its name ends in `.gz`, and refuses
/// (naming the file) one that holds or inflates to more than `limit` bytes: never more than
/// limit + 1 bytes are held, whatever the file claims.
Status readBoundedFile(const std::string& file, uint64_t limit, std::vector<uint8_t>& out);

/// The one check at the top of every readSlab: [z0, z0 + depth) must lie inside the volume.
Status checkSlab(const InputInfo& info, uint32_t z0, uint32_t depth, const std::string& path);
/// The same for readRows: the slab, and rows [y0, y0 + rows) inside the volume.
Status checkRows(const InputInfo& info, uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, const std::string& path);
/// Refuses (naming `path`) dimensions whose full-width values would need 2^64 bytes or more, so
/// that InputInfo::voxelCount() and every product built on it are exact. openInput calls it on
/// every opened source.
Status checkDimensions(const InputInfo& info, const std::string& path);

/// @brief Closes a C file on every return path.
class CFile {
public:
    explicit CFile(std::FILE* f) : m_file(f) {}
    ~CFile() {
        if (m_file) std::fclose(m_file);
    }
    CFile(const CFile&) = delete;
    CFile& operator=(const CFile&) = delete;
    std::FILE* get() const { return m_file; }

private:
    std::FILE* m_file;
};

// ---- chunk files, found by listing their folder once
/// Calls `visit` with the name of each entry of folder `dir` ("." and ".." left out), in the file
/// system's order, until it returns false. A `dir` that is not there or is no folder (a file, a
/// FIFO, a dangling link) lists nothing, as a stat of a name below it finds nothing; any other
/// failure is an error naming the folder. Never blocks (O_DIRECTORY | O_NONBLOCK: a FIFO is not
/// opened).
Status listFolder(const std::string& dir, const std::function<bool(const char* name)>& visit);

/// @brief Where a chunked format's chunk files are: the grid positions (x, y, z) of the chunks
/// that have a file, from one listing of the chunk folder(s), so that a chunk without one is
/// known to be fill value without a stat of its name. A grid of 1-voxel chunks cost a stat per
/// voxel that way (52 s for a 256^3 Zarr array, an hour for a 1024^3 one with no chunk file).
///
/// Memory: 12 bytes a chunk that has a file, for at most kMaxChunks of them (96 MiB), fewer when
/// the working-memory bound leaves less (start), and at most twice that while the index grows. A
/// folder holding more is not indexed (complete() false): the format then looks each chunk up
/// by name as before, and refuses (checkLookups) a grid with so many more names than files
/// that looking them up would dominate. Nothing is held per chunk name of the grid, so a grid
/// declaring 10^9 chunks and holding a few costs what the few cost.
class ChunkIndex {
public:
    struct Position {
        uint32_t z, y, x; ///< in this order: a layer's chunks lie together, each row's in increasing x
        bool operator<(const Position& o) const {
            return z != o.z ? z < o.z : y != o.y ? y < o.y : x < o.x;
        }
        bool operator==(const Position& o) const { return z == o.z && y == o.y && x == o.x; }
    };
    using Range = std::pair<const Position*, const Position*>;
    /// The most chunk files an index holds (12 bytes each: 96 MiB).
    static constexpr uint64_t kMaxChunks = uint64_t(1) << 23;
    /// Without an index, at most this many names per chunk file (or kMaxLookups in all) are
    /// looked up one by one.
    static constexpr uint64_t kLookupsPerFile = 16;
    static constexpr uint64_t kMaxLookups = uint64_t(1) << 24;

    /// Starts a listing kept in at most `budgetBytes` (transiently, while it grows).
    void start(uint64_t budgetBytes);
    /// A chunk that has a file (a name listed twice, flat and nested, counts once once finished).
    void add(uint32_t x, uint32_t y, uint32_t z);
    /// Ends the listing: sorted when complete, freed when not.
    void finish();
    /// Every chunk file listed is held: a chunk not in the index has no file.
    bool complete() const { return m_listed <= m_capacity; }
    uint64_t bytes() const { return m_positions.capacity() * sizeof(Position); }
    /// The chunks with a file in layer z (rows in increasing y, each in increasing x).
    Range layer(uint32_t z) const;
    /// The chunks with a file in row (y, z), in increasing x.
    Range row(uint32_t y, uint32_t z) const;
    /// The most chunks with a file that one layer holds.
    uint64_t largestLayer() const;
    /// An incomplete index (too many files to hold) leaves a lookup per chunk name: refused, naming
    /// the counts and limits, when the grid's `gridChunks` names are more than kLookupsPerFile per
    /// file listed and more than kMaxLookups.
    Status checkLookups(const std::string& dir, uint64_t gridChunks) const;
    /// InputSource::uniformBoxes for the chunks without a file (value `fill`) of a grid of
    /// `chunk`-sized chunks over a volume of `dim`, merged into runs along x, runs of rows along y
    /// and runs of layers along z: time per layer and chunk file in the region, not per chunk name.
    void absentBoxes(const std::array<uint64_t, 3>& chunk, const std::array<uint32_t, 3>& dim, uint32_t z0,
                     uint32_t depth, uint32_t y0, uint32_t rows, uint64_t fill, std::vector<UniformBox>& out) const;

private:
    std::vector<Position> m_positions;
    uint64_t m_capacity = 0; ///< the most positions held
    uint64_t m_listed = 0;   ///< chunk files listed, held or not
};

// ---- voxels
unsigned typeBytes(LabelType type);
std::string dimText(const std::array<uint64_t, 3>& d);
/// "int16 big-endian, gzip": how voxels are stored, for InputInfo::detail.
std::string voxelDetail(LabelType type, bool bigEndian, bool compressed);
/// Refuses volumes whose full-width values (8 bytes a voxel) exceed maxBytes, before anything
/// of that size is allocated.
Status checkBudget(const std::string& path, const std::array<uint64_t, 3>& d, uint64_t maxBytes);

/// Decodes `n` voxels of `type` stored at `p` (the given byte order) into full-width values:
/// unsigned as they are, signed sign-extended, floats holding integers as those integers. A float
/// that is not an integer within int64 is an error naming the voxel: `first` is the index of the
/// first of the `n` in the volume of dimensions `dim` stored in `path`.
/// Converts a float that must hold an integer label; false for fractions, NaN, infinities and
/// values outside int64.
bool floatToInt64(double v, int64_t& out);
/// "holds V, which is not an integer label": the one wording for a float voxel that is no label.
std::string notAnIntegerLabel(double v);

/// Widens `n` samples of `type` stored at `p` into full-width values (decodeVoxels' rules);
/// returns n, or the index of the first float that is not an integer label (its value in `bad`).
size_t widenSamples(const uint8_t* p, LabelType type, bool bigEndian, uint64_t* out, size_t n, double& bad);

Status decodeVoxels(const uint8_t* p, LabelType type, bool bigEndian, const std::array<uint32_t, 3>& dim,
                    const std::string& path, uint64_t first, uint64_t* out, size_t n);

/// @brief Bytes written once and then read at any offset: in memory up to a limit, beyond it in a
/// scratch file that is unlinked as soon as it is open (nothing is left behind, whatever happens,
/// and the disk space returns when the store is reset or destroyed).
class SlabStore {
public:
    SlabStore() = default;
    ~SlabStore();
    SlabStore(const SlabStore&) = delete;
    SlabStore& operator=(const SlabStore&) = delete;

    /// Makes room for `bytes`: held in memory when they fit `memoryLimit`, else in a scratch file
    /// in `directory` (InputOptions::scratchDirectory's rule). `path` names the input in errors.
    Status reset(uint64_t bytes, uint64_t memoryLimit, const std::string& directory, const std::string& path);
    Status write(uint64_t at, const uint8_t* data, size_t bytes);
    Status read(uint64_t at, uint8_t* data, size_t bytes) const;
    /// Memory held (the scratch file's bytes are on disk, not counted).
    uint64_t memoryBytes() const { return m_memory.capacity(); }
    bool inFile() const { return m_fd >= 0; }
    void clear();

private:
    std::string m_path, m_name;
    std::vector<uint8_t> m_memory;
    int m_fd = -1;
};

/// @brief Where a volume's voxels lie in a file and how they are stored.
struct VoxelData {
    std::string file;        ///< the file that holds them
    bool compressed = false; ///< a gzip/zlib stream (read sequentially), else raw bytes
    InputStream::Mode mode = InputStream::Mode::Inflate; ///< how a compressed stream is opened
    /// Raw: the byte of voxel 0 in the file. Compressed: the first byte of the stream.
    uint64_t fileOffset = 0;
    uint64_t skip = 0; ///< compressed: inflated bytes before voxel 0 (NRRD byte skip, NIfTI vox_offset)
    LabelType stored = LabelType::U8; ///< the type as stored (what is decoded)
    bool bigEndian = false;
};

/// @brief A source of voxels stored in one file, raw or compressed, read slab by slab.
///
/// Raw data: each slab is read with positioned reads (pread) of just its bytes, in pieces of at
/// most kChunkBytes, each decoded into the caller's buffer. Compressed data: one InputStream is
/// kept open between calls; a slab after the last one continues it (skipping forward inflates
/// and discards), a slab before it restarts the stream from the data's start (the InputSource
/// contract allows this; reading in increasing z never restarts).
///
/// Both read rows (readsRows), so the encoder holds a band of about 64 MiB, not a brick-deep slab
/// of uint32 labels (W x H x 32 x 4 bytes: 2 GiB for 4000 x 4000). A gzip stream cannot seek, so
/// the first band of rows of a slab inflates the slab's slices once, at the file's native width,
/// into a SlabStore; the slab's further bands are read from there. That slab stays in memory up to
/// kSlabMemoryBytes and goes to a scratch file (InputOptions::scratchDirectory) beyond it. Bands
/// one slice deep are read from the stream itself (a slice's rows lie together). Long reads ask
/// keepGoing() every 8 MiB of the stream.
///
/// Working memory: the decode buffer (at most kChunkBytes) plus, for compressed data, the stream
/// (kStreamBytes: its 256 KiB input buffer, zlib's inflate state and 32 KiB window) and the
/// slab when read in bands (at most kSlabMemoryBytes in memory); never anything the size of the
/// volume, and nothing proportional to a slice beyond kSlabMemoryBytes.
///
/// The formats word their own errors (their tests pin the messages): truncated() when the data
/// end early, streamFailure() when the stream cannot be opened, read or inflated, atDataEnd()
/// for what they check once the last voxel has been delivered.
class VoxelFileSource : public InputSource {
public:
    static constexpr size_t kChunkBytes = size_t(128) << 10;
    static constexpr uint64_t kStreamBytes = (uint64_t(256) + 48) << 10;
    /// An inflated slab read in bands stays in memory up to this size (within
    /// InputOptions::maxWorkingBytes), else it goes to a scratch file.
    static constexpr uint64_t kSlabMemoryBytes = uint64_t(64) << 20;

    /// `info` is what the header said; `data` where the voxels are. Fails (naming `path`) when
    /// the working memory would exceed options.maxWorkingBytes.
    Status init(const std::string& path, const InputInfo& info, const VoxelData& data, const InputOptions& options);
    ~VoxelFileSource() override;

    Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) override;
    /// Uncompressed data reads rows (one pread per slice); a compressed stream through its slab.
    bool readsRows() const override { return true; }
    Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) override;
    uint64_t workingBytes() const override;

protected:
    /// The data end after `available` bytes (of the voxels, counted from voxel 0).
    virtual Status truncated(uint64_t available) const = 0;
    /// The compressed stream failed (in.failure() says at which step; `s` carries the reason).
    virtual Status streamFailure(const InputStream& in, const Status& s) const = 0;
    /// Compressed data: called once the last voxel has been read, with the stream right after it.
    virtual Status atDataEnd(InputStream& in);

    const std::string& path() const { return m_path; }
    const VoxelData& data() const { return m_data; }
    uint64_t dataBytes() const { return m_dataBytes; }

private:
    Status readRaw(uint64_t first, uint64_t count, uint64_t* out);
    Status readCompressed(uint64_t first, uint64_t count, uint64_t* out);
    /// Opens the stream at the data's start and skips to voxel 0.
    Status restart();
    /// Reads exactly `bytes` of the stream into the decode buffer's start; fewer is truncation.
    Status readStream(size_t bytes);
    Status truncatedInSlice(uint64_t available) const;
    /// Compressed data: makes the slab store hold slices [z0, z0 + depth) at native width.
    Status holdSlab(uint32_t z0, uint32_t depth);
    /// Compressed data: positions the stream at voxel `first` (restarting it when behind).
    Status seekStream(uint64_t first);

    std::string m_path;
    VoxelData m_data;
    unsigned m_width = 1;
    uint64_t m_dataBytes = 0;
    size_t m_chunkBytes = kChunkBytes;
    std::vector<uint8_t> m_buffer;
    int m_fd = -1;                           ///< raw data
    std::unique_ptr<InputStream> m_stream;   ///< compressed data, between calls
    uint64_t m_next = 0;                     ///< the voxel the stream delivers next
    uint64_t m_pieces = 0;                   ///< stream reads so far (keepGoing every 64)
    SlabStore m_slab;                        ///< compressed data read in bands: one slab, native width
    uint32_t m_slabZ0 = 0, m_slabDepth = 0;  ///< the slices m_slab holds (depth 0: none)
    uint64_t m_slabMemoryLimit = 0;
    std::string m_scratchDirectory;
};

} // namespace inputs
} // namespace csgv
