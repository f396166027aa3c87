// SPDX-License-Identifier: MIT
#pragma once
/// @file Container.h
/// @brief The `.csgv` container (Volcanite file versions 0015 and 0016): reading, checking, writing.
///
/// Format (little-endian, no padding; see shared/CSGV-FORMAT.md, sections 3, 4 and 7):
/// ```
///  offset  type          field
///  0       char[8]       "CMPSGVOL"
///  8       char[4]       "0016" (also read: "0015")
///  12      u32           brick size B in {8, 16, 32, 64, 128}
///  16      u32 x 3       volume W, H, D (x fastest)
///  28      i32           encoding mode: 0 nibble | 1 rANS one table | 2 rANS two tables
///  32      u8            random access (0/1)
///  33      u32           largest palette of any brick
///  37      u32           operation mask (PARENT 1, NX 2, NY 4, NZ 8, PALETTE_LAST 32,
///                        legacy delta 64, PALETTE_D 128, stop bits 256)
///  41      ...           mode 1: u32[16] frequencies; mode 2: u32[16] table A + u32[16] table B
///          u32           bricks per encoding array (0xFFFFFFFF: a single array)
///          u64 n, u32[n] brick starts (n = bricks + 1), word offsets inside their array
///          u64 m, m x (u64 len, u32[len])   encoding arrays
///          u8            detail separated (0 in files)
///
///  one brick, in 32-bit words, L = log2(B) + 1 levels:
///  [ header[0..L-1]: level starts (in 4-bit symbols) | header[L]: palette size ]
///  [ operation stream(s), symbol k of a word in bits 31-4k..28-4k, zero padded  ]
///  [ palette reversed: entry n-1 ... entry 1, entry 0 (the root label)        ]
///  mode 2: stream A (levels 0..L-2) from word L+1 up to word header[L-1]/8,
///          stream B (finest level) from there up to the palette.
/// ```
///
/// Decisions where the format description is silent (tested in Testing/Core):
/// - Version 0015 has the same layout as 0016; it always uses the single-symbol PALETTE_D distance.
/// - Encoding modes 4 and 8 (wavelet matrices) are recognised and refused with a clear message.
/// - A file whose "detail separated" byte is not 0 is refused (separation is a load-time step).
/// - The last brick of an encoding array may end before the array's end (slack is allowed and
///   ignored); bricks may not overlap and must each hold at least the minimal brick.
/// - Writers produce version 0016 with one array per 2^29 words, through a temporary file renamed
///   into place, and never set the legacy-delta bit.

#include "csgv/codec/Layout.h"
#include "csgv/codec/Partition.h"
#include "csgv/codec/WordArray.h"
#include "csgv/base/Checked.h"
#include "csgv/base/Status.h"

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace csgv {

/// Encoding modes as stored in the file.
enum EncodingMode : int32_t {
    kEncodingNibble = 0,
    kEncodingRans1 = 1,
    kEncodingRans2 = 2,
    kEncodingWaveletMatrix = 4,
    kEncodingHuffmanWaveletMatrix = 8,
};

// Operation codes, the rANS constants and kInvalidLabel: Layout.h (shared with the shaders).

/// Bits of the operation mask in the file header.
enum OperationMaskBits : uint32_t {
    kMaskParent = 1,
    kMaskNeighborX = 2,
    kMaskNeighborY = 4,
    kMaskNeighborZ = 8,
    kMaskPaletteLast = 32,
    kMaskLegacyDelta = 64,
    kMaskPaletteD = 128,
    kMaskStopBits = 256,
    kMaskDefault = 0x12F, ///< Volcanite's default: everything but PALETTE_D ("pnls")
    kMaskAll = 0x1AF,     ///< with unlimited PALETTE_D ("pnlds")
};

constexpr uint32_t kMaxWordsPerArray = 1u << 29;     ///< 2 GiB per encoding array
constexpr uint32_t kSingleArray = 0xFFFFFFFFu;
constexpr uint64_t kMaxBricks = uint64_t(1) << 40; ///< far beyond any real volume; keeps counts exact

/// Limits set by the caller on anything allocated or written on behalf of untrusted input.
/// Levels of detail of a volume with this brick size (2^n gives n + 1: full resolution down to
/// one voxel per brick).
uint32_t levelCount(uint32_t brickSize);

struct Limits {
    uint64_t maxOutputBytes = uint64_t(16) << 30; ///< decoded images, written files
};

/// Words of one brick inside its encoding array (at any byte address: read through WordPtr).
struct BrickWords {
    WordPtr words;
    uint32_t size = 0;
};

/// @brief A compressed segmentation volume as stored in a `.csgv` file, fully in memory.
struct CompressedVolume {
    uint32_t version = 16;         ///< 15 or 16
    uint32_t brickSize = 32;
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    int32_t encoding = kEncodingRans2;
    bool randomAccess = false;
    uint32_t maxPalette = 0;
    uint32_t opMask = kMaskDefault;
    std::array<uint32_t, 16> freqA{}; ///< mode 1: the table; mode 2: levels 0..L-2
    std::array<uint32_t, 16> freqB{}; ///< mode 2: the finest level
    uint32_t bricksPerArray = kSingleArray;
    std::vector<uint32_t> brickStarts; ///< bricks + 1 entries (see BrickWords brick())
    std::vector<WordArray> arrays;    ///< owned, or views into a mapped file (readCsgvMapped)

    /// Number of levels L = log2(B) + 1 (level 0 = one node per brick).
    uint32_t levels() const;
    /// Bricks along each axis.
    std::array<uint32_t, 3> brickGrid() const;
    uint64_t brickCount() const; ///< saturating
    uint64_t voxelCount() const { return product3(dim[0], dim[1], dim[2]); } ///< saturating
    /// True when PALETTE_D is followed by one 4-bit distance symbol (version 0015, mask bit 64).
    bool legacyDelta() const { return version == 15 || (opMask & kMaskLegacyDelta) != 0; }
    /// The words of brick i (brick starts checked: checkLayout(); its header words: checkBrick()).
    BrickWords brick(uint64_t i) const;
    /// Bytes the container occupies when written.
    uint64_t serializedSize() const;
    /// A volume with this one's header fields (everything but the brick starts and the arrays),
    /// for one made from it: a piece, a tier, a volume a piece is placed in.
    CompressedVolume headerFields() const {
        CompressedVolume h;
        h.version = version;
        h.brickSize = brickSize;
        h.dim = dim;
        h.encoding = encoding;
        h.randomAccess = randomAccess;
        h.maxPalette = maxPalette;
        h.opMask = opMask;
        h.freqA = freqA;
        h.freqB = freqB;
        h.bricksPerArray = bricksPerArray;
        return h;
    }
};

/// @brief Where the encoding arrays split: bricks per array (all of them when one array holds
/// everything, else the largest equal count whose arrays stay within the limit), the stored
/// brick starts (a brick that opens an array starts at word 0; its stored start is the previous
/// array's length) and each array's length.
struct ArrayLayout {
    uint64_t perArray = 0;
    std::vector<uint32_t> brickStarts;
    std::vector<uint64_t> arrayWords;
};
/// The layout of bricks of these word counts with at most `arrayLimit` (<= 2^29) words an array;
/// an error when they need more than `maxOutputBytes` or a brick more than an array holds.
Result<ArrayLayout> layoutArrays(const std::vector<uint32_t>& brickWords, uint64_t arrayLimit, uint64_t maxOutputBytes);
/// Moves a layout's brick starts and bricks per array into `vol` (its arrays are the caller's).
void applyLayout(ArrayLayout&& layout, CompressedVolume& vol);
/// Lays out bricks of these word counts (layoutArrays) and fills `vol`'s arrays: `append(i, array)`
/// appends brick i's words to its array, bricks in order (a caller may release them as it goes).
Status fillArrays(CompressedVolume& vol, const std::vector<uint32_t>& brickWords, uint64_t arrayLimit,
                  uint64_t maxOutputBytes, const std::function<void(uint64_t, std::vector<uint32_t>&)>& append);

/// Bricks a sweep over a whole volume reads between releasing a mapped file's pages
/// (sweepBricks): about 100 MiB of a typical encoding.
constexpr uint64_t kSweepBricks = uint64_t(1) << 16;
/// Runs `f(from, to)` over consecutive ranges of at most `chunk` bricks [from, to), in order;
/// after each, the pages of those bricks leave the process where the volume views a mapped file
/// (MappedFile::releaseAt), so that a sweep over a volume larger than memory keeps about a chunk
/// of it resident. `f` returns false to stop the sweep.
void sweepBricks(const CompressedVolume& vol, uint64_t chunk, const std::function<bool(uint64_t, uint64_t)>& f);

/// Size of the smallest valid brick in words for a level count and encoding (section 3).
uint32_t minimalBrickWords(uint32_t levels, int32_t encoding);

/// The checks of CSGV-FORMAT.md section 9 that need no brick's words: header fields,
/// frequencies, array sizes, brick starts in order and within their arrays, every brick at least
/// the minimal brick. O(header + brick starts): what a parse checks, so that opening a file reads
/// none of its bricks.
Status checkLayout(const CompressedVolume& vol);
/// Brick i's header words (level starts, palette size) on a volume that passed checkLayout():
/// an error names the brick and what is wrong. Whatever reads a brick's header or palette checks
/// the brick first: decoders refuse it (BrickDecoder::decode), sweeps skip it (brickSound), the
/// renderer draws it empty.
Status checkBrick(const CompressedVolume& vol, uint64_t i);
/// checkBrick without the message (a sweep's test, before it reads a palette).
bool brickSound(const CompressedVolume& vol, uint64_t i);
/// checkLayout and checkBrick of every brick: all container-level checks (an encoder's output,
/// a writer's input). Stream contents are checked while decoding.
Status checkContainer(const CompressedVolume& vol);

/// Parses a container from memory; the result has passed checkLayout() (its bricks are checked
/// when reached: checkBrick).
Result<CompressedVolume> parseCsgv(const uint8_t* data, size_t size);
/// The same, with the encoding arrays as views into `data` (WordArray::view, at whatever byte
/// address the words lie): `keeper` keeps `data` alive and unchanged while the volume, or any copy
/// of it, lives. One copy of an encoding then serves the bytes and the parse. Without a keeper,
/// parseCsgv.
Result<CompressedVolume> parseCsgvShared(const uint8_t* data, size_t size, std::shared_ptr<const void> keeper);
/// Where a `.csgv`'s bytes may start, modulo 4, to put the encoding arrays' words on 4-byte
/// boundaries: they start at byte 69 + 4k of a file (CSGV-FORMAT.md). Views no longer need it
/// (words are read with memcpy loads), but aligned words let a consumer that wants a
/// `const uint32_t*` (a GPU upload API, SIMD code) take them as they are.
constexpr size_t kCsgvBytesPhase = 3;
/// A buffer of `size` bytes for a `.csgv` at an address of kCsgvBytesPhase modulo 4 (null when
/// no memory is to be had), freed by freeCsgvBytes (a C-style free function, so that a VTK array
/// can own it: VTK_DATA_ARRAY_USER_DEFINED).
uint8_t* newCsgvBytes(size_t size);
void freeCsgvBytes(void* bytes);
/// newCsgvBytes, owned by a shared pointer.
std::shared_ptr<uint8_t> allocateCsgvBytes(size_t size);
/// Reads a `.csgv` file; never reads or allocates more than the file holds.
Result<CompressedVolume> readCsgv(const std::string& path);
/// The same checks and errors as readCsgv, without copying the file: the file is memory-mapped
/// read-only (MappedFile; read into memory where it cannot be mapped: a pipe, an empty file) and
/// the encoding arrays are views into the mapping, which they keep alive. Only the header and
/// brick starts are copied. The caller must not let the file be truncated or rewritten in place
/// while the volume lives (a rename over it is fine): touching a page past a truncated end
/// raises SIGBUS.
Result<CompressedVolume> readCsgvMapped(const std::string& path);
/// Reads the bricks of `box` (whole bricks: Partition.h) of a `.csgv` file as a volume of their
/// own: the piece's dimensions (bricks cut by the volume's end stay cut), its bricks' words as
/// stored (an interior brick's encoding does not depend on its neighbours), the file's tables,
/// the piece's largest palette. Reads the header, the brick starts and only those bricks' bytes
/// (`bytesRead` counts them); the result has passed checkLayout() (a brick whose header words are
/// wrong is refused by checkBrick when reached, as in the whole file).
Result<CompressedVolume> readCsgvPiece(const std::string& path, const BrickBox& box, uint64_t* bytesRead = nullptr);
/// The same piece of a volume in memory (its layout checked: checkLayout(); an unsound brick in
/// the box makes it an error naming the brick).
Result<CompressedVolume> extractPiece(const CompressedVolume& whole, const BrickBox& box);
/// The inverse of extractPiece: one volume of dimensions `dim` from whole-brick pieces,
/// `boxes[i]` holding the bricks of `pieces[i]` (pieces with empty boxes are skipped). The boxes
/// must cover the brick grid once and the pieces agree on every header field but their
/// dimensions (an error names the first that does not); the result is laid out as the encoder
/// lays out a volume (layoutArrays), so the pieces of an encoding give back its bytes. The pieces
/// are emptied once joined.
Result<CompressedVolume> joinPieces(const std::array<uint32_t, 3>& dim, const std::vector<BrickBox>& boxes,
                                    std::vector<CompressedVolume>& pieces, uint64_t arrayLimit = kMaxWordsPerArray,
                                    uint64_t maxOutputBytes = ~uint64_t(0));
/// A file's header fields (checked) and brick starts, nothing after them: what a reader needs to
/// describe the volume without reading it (the result has no encoding arrays).
Result<CompressedVolume> readCsgvHeader(const std::string& path);

/// Serialises as version 0016.
std::vector<uint8_t> serializeCsgv(const CompressedVolume& vol);
/// Writes version 0016 through a temporary file renamed into place; refuses volumes that fail
/// checkContainer() or exceed limits.maxOutputBytes, and leaves no file behind on failure.
Status writeCsgv(const std::string& path, const CompressedVolume& vol, const Limits& limits = {});

/// Takes bytes; an error stops whoever writes through it.
using ByteSink = std::function<Status(const void* data, size_t bytes)>;
/// Writes version 0016 when the encoding arrays are too large to hold (encodeToFile): `vol` has
/// every field but its arrays (left empty), `arrayWords[a]` is array a's length in words, and
/// `words(a, out)` writes exactly that many words of array a through `out`. Same temporary name
/// and rename as writeCsgv; the header fields and brick starts are checked, the words are not.
Status writeCsgvStreamed(const std::string& path, const CompressedVolume& vol, const std::vector<uint64_t>& arrayWords,
                         const Limits& limits, const std::function<Status(size_t array, const ByteSink& out)>& words);

/// Writes `src` repeated times[0] x times[1] x times[2] (its bricks copied as stored: a whole
/// brick's encoding does not depend on where it lies) to `path` (writeCsgvStreamed: a temporary
/// renamed into place): a volume far larger than memory, or than any encoder run here would
/// make, from a smaller encoding (benchmarks of the host-memory budget). Refused unless every
/// dimension is a multiple of the brick size and every brick passes checkBrick. `progress(f)`
/// returns false to cancel (nothing is left behind).
Status writeTiledCsgv(const std::string& path, const CompressedVolume& src, const std::array<uint32_t, 3>& times,
                      const Limits& limits = {}, const std::function<bool(double)>& progress = {});

/// "nibble", "rans1", "rans2", "wavelet-matrix", "huffman-wavelet-matrix" or "unknown".
const char* encodingName(int32_t encoding);
/// Operation letters of a mask ("pnls", "pnlds", ...), with "L" appended for legacy delta.
std::string operationLetters(uint32_t opMask);

} // namespace csgv
