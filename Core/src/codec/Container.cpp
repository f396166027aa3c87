// SPDX-License-Identifier: MIT
#include "csgv/codec/Container.h"
#include "csgv/base/FileUtil.h"
#include "csgv/base/MappedFile.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>

namespace csgv {

namespace {

constexpr char kMagic[8] = {'C', 'M', 'P', 'S', 'G', 'V', 'O', 'L'};

bool isPowerOfTwo(uint32_t v) { return v && !(v & (v - 1)); }


/// Sequential little-endian reader over a file or memory, always knowing how much is left, so
/// that no length read from the input is trusted before it is compared with the bytes that remain.
class ByteSource {
public:
    virtual ~ByteSource() = default;
    virtual bool readRaw(void* dst, size_t n) = 0;
    uint64_t offset() const { return m_offset; }
    uint64_t remaining() const { return m_size - m_offset; }

    Status read(void* dst, size_t n, const char* field) {
        if (n > remaining())
            return Status::error(std::string("file truncated: field '") + field + "' needs " + std::to_string(n) +
                                 " bytes at offset " + std::to_string(m_offset) + ", only " +
                                 std::to_string(remaining()) + " remain");
        if (n && !readRaw(dst, n)) return Status::error(std::string("read error in field '") + field + "'");
        m_offset += n;
        return Status::ok();
    }
    template <typename T>
    Status get(T& v, const char* field) {
        return read(&v, sizeof(T), field); // hosts are little-endian (x86-64, aarch64)
    }

protected:
    uint64_t m_size = 0;
    uint64_t m_offset = 0;
};

class MemorySource : public ByteSource {
public:
    MemorySource(const uint8_t* data, size_t size) : m_data(data) { m_size = size; }
    bool readRaw(void* dst, size_t n) override {
        std::memcpy(dst, m_data + m_offset, n);
        return true;
    }
    /// The bytes at the current offset (parseCsgvShared's views).
    const uint8_t* here() const { return m_data + m_offset; }
    bool skip(uint64_t n) {
        if (n > remaining()) return false;
        m_offset += n;
        return true;
    }

private:
    const uint8_t* m_data;
};

class FileSource : public ByteSource {
public:
    ~FileSource() override {
        if (m_file) std::fclose(m_file);
    }
    Status open(const std::string& path) {
        Result<uint64_t> size = fileSize(path);
        if (!size) return size.status();
        m_size = *size;
        m_file = std::fopen(path.c_str(), "rb");
        if (!m_file) return Status::error("cannot open '" + path + "': " + std::strerror(errno));
        return Status::ok();
    }
    bool readRaw(void* dst, size_t n) override { return std::fread(dst, 1, n, m_file) == n; }
    /// Moves to `offset` (at most the file's size): later reads go on from there.
    bool seek(uint64_t offset) {
        if (offset > m_size || fseeko(m_file, off_t(offset), SEEK_SET) != 0) return false;
        m_offset = offset;
        return true;
    }

private:
    std::FILE* m_file = nullptr;
};

#define CSGV_TRY(expr)                                                                                                 \
    do {                                                                                                               \
        Status _s = (expr);                                                                                            \
        if (!_s) return _s;                                                                                            \
    } while (0)

Status readWords(ByteSource& src, std::vector<uint32_t>& out, uint64_t count, const char* field) {
    if (count > src.remaining() / 4)
        return Status::error(std::string("file truncated: field '") + field + "' claims " + std::to_string(count) +
                             " words at offset " + std::to_string(src.offset()) + ", only " +
                             std::to_string(src.remaining()) + " bytes remain");
    out.resize(size_t(count));
    return src.read(out.data(), size_t(count) * 4, field);
}

/// Header fields that bound every later allocation, checked before arrays are read.
Status checkHeaderFields(const CompressedVolume& v) {
    if (v.version != 15 && v.version != 16)
        return Status::error("unsupported file version " + std::to_string(v.version) + " (expected 0015 or 0016)");
    if (!isPowerOfTwo(v.brickSize) || v.brickSize < 8 || v.brickSize > 128)
        return Status::error("field 'brick size' is " + std::to_string(v.brickSize) +
                             ", expected a power of two from 8 to 128");
    for (int a = 0; a < 3; ++a)
        if (v.dim[a] == 0) return Status::error("field 'volume dimensions': dimension " + std::to_string(a) + " is 0");
    if (v.brickCount() > kMaxBricks)
        return Status::error("field 'volume dimensions': " + std::to_string(v.dim[0]) + " x " + std::to_string(v.dim[1]) +
                             " x " + std::to_string(v.dim[2]) + " needs more than 2^40 bricks");
    if (v.encoding == kEncodingWaveletMatrix || v.encoding == kEncodingHuffmanWaveletMatrix)
        return Status::error("encoding mode " + std::to_string(v.encoding) + " (" + encodingName(v.encoding) +
                             ", random access CSGV-R) is not supported");
    if (v.encoding != kEncodingNibble && v.encoding != kEncodingRans1 && v.encoding != kEncodingRans2)
        return Status::error("field 'encoding mode' is " + std::to_string(v.encoding) + ", expected 0, 1 or 2");
    auto checkTable = [](const std::array<uint32_t, 16>& f, const char* name) {
        uint64_t sum = 0;
        for (uint32_t x : f) sum += x;
        if (sum != kRansTotal)
            return Status::error(std::string("frequency table ") + name + " sums to " + std::to_string(sum) +
                                 ", expected 16384");
        return Status::ok();
    };
    if (v.encoding == kEncodingRans1) CSGV_TRY(checkTable(v.freqA, "of mode 1"));
    if (v.encoding == kEncodingRans2) {
        CSGV_TRY(checkTable(v.freqA, "A (levels above the finest)"));
        CSGV_TRY(checkTable(v.freqB, "B (finest level)"));
    }
    return Status::ok();
}

/// Writes the container field by field to a sink, so that files are never assembled in memory.
/// Everything before the encoding arrays' contents, ending with their count.
void emitHead(const CompressedVolume& v, uint64_t arrayCount, const std::function<void(const void*, size_t)>& out) {
    auto put = [&](const auto& x) { out(&x, sizeof(x)); };
    out(kMagic, 8);
    out("0016", 4);
    put(v.brickSize);
    put(v.dim[0]);
    put(v.dim[1]);
    put(v.dim[2]);
    put(v.encoding);
    const uint8_t ra = v.randomAccess ? 1 : 0;
    put(ra);
    put(v.maxPalette);
    put(uint32_t(v.opMask & ~uint32_t(kMaskLegacyDelta)) | (v.legacyDelta() ? uint32_t(kMaskLegacyDelta) : 0u));
    if (v.encoding == kEncodingRans1 || v.encoding == kEncodingRans2) out(v.freqA.data(), 64);
    if (v.encoding == kEncodingRans2) out(v.freqB.data(), 64);
    put(v.bricksPerArray);
    put(uint64_t(v.brickStarts.size()));
    out(v.brickStarts.data(), v.brickStarts.size() * 4);
    put(arrayCount);
}

constexpr uint8_t kNotDetailSeparated = 0;

void emit(const CompressedVolume& v, const std::function<void(const void*, size_t)>& out) {
    emitHead(v, v.arrays.size(), out);
    for (const auto& a : v.arrays) {
        const uint64_t len = a.size();
        out(&len, 8);
        out(a.bytes(), a.size() * 4);
    }
    out(&kNotDetailSeparated, 1);
}

/// Everything before the encoding arrays: the header fields, checked, and the brick starts.
Status parseHead(ByteSource& src, CompressedVolume& v) {
    char magic[8];
    CSGV_TRY(src.read(magic, 8, "magic"));
    if (std::memcmp(magic, kMagic, 8) != 0) return Status::error("not a CSGV file: the magic 'CMPSGVOL' is missing");
    char ver[4];
    CSGV_TRY(src.read(ver, 4, "version"));
    if (std::memcmp(ver, "0016", 4) == 0)
        v.version = 16;
    else if (std::memcmp(ver, "0015", 4) == 0)
        v.version = 15;
    else {
        std::string shown;
        for (char c : ver) shown += (c >= 32 && c < 127) ? c : '?';
        return Status::error("unsupported file version '" + shown + "' (expected 0015 or 0016)");
    }
    CSGV_TRY(src.get(v.brickSize, "brick size"));
    CSGV_TRY(src.read(v.dim.data(), 12, "volume dimensions"));
    CSGV_TRY(src.get(v.encoding, "encoding mode"));
    uint8_t ra = 0;
    CSGV_TRY(src.get(ra, "random access"));
    if (ra > 1) return Status::error("field 'random access' is " + std::to_string(ra) + ", expected 0 or 1");
    v.randomAccess = ra != 0;
    CSGV_TRY(src.get(v.maxPalette, "largest palette"));
    CSGV_TRY(src.get(v.opMask, "operation mask"));
    if (v.encoding == kEncodingRans1 || v.encoding == kEncodingRans2)
        CSGV_TRY(src.read(v.freqA.data(), 64, "frequency table A"));
    if (v.encoding == kEncodingRans2) CSGV_TRY(src.read(v.freqB.data(), 64, "frequency table B"));
    CSGV_TRY(checkHeaderFields(v));
    CSGV_TRY(src.get(v.bricksPerArray, "bricks per encoding array"));
    uint64_t n = 0;
    CSGV_TRY(src.get(n, "brick start count"));
    if (n != v.brickCount() + 1)
        return Status::error("field 'brick start count' is " + std::to_string(n) + ", expected " +
                             std::to_string(v.brickCount() + 1) + " for " + std::to_string(v.brickCount()) + " bricks");
    CSGV_TRY(readWords(src, v.brickStarts, n, "brick starts"));
    return Status::ok();
}

/// The container's last field, and nothing after it.
Status parseTail(ByteSource& src) {
    uint8_t detail = 0;
    CSGV_TRY(src.get(detail, "detail separated"));
    if (detail != 0)
        return Status::error("field 'detail separated' is " + std::to_string(detail) +
                             ": files on disk must not be detail separated");
    if (src.remaining() != 0)
        return Status::error(std::to_string(src.remaining()) + " unexpected bytes after the last field at offset " +
                             std::to_string(src.offset()));
    return Status::ok();
}

/// `viewed`: a memory source whose arrays are kept as views (parseCsgvShared, readCsgvMapped), at
/// whatever byte address they lie (WordArray reads them through WordPtr).
Result<CompressedVolume> parse(ByteSource& src, MemorySource* viewed = nullptr,
                               const std::shared_ptr<const void>& keeper = nullptr) {
    CompressedVolume v;
    CSGV_TRY(parseHead(src, v));
    uint64_t m = 0;
    CSGV_TRY(src.get(m, "encoding array count"));
    if (m == 0 || m > src.remaining() / 8)
        return Status::error("field 'encoding array count' is " + std::to_string(m) + ", which the file cannot hold");
    v.arrays.resize(size_t(m));
    for (uint64_t i = 0; i < m; ++i) {
        uint64_t len = 0;
        CSGV_TRY(src.get(len, "encoding array length"));
        if (len > kMaxWordsPerArray)
            return Status::error("encoding array " + std::to_string(i) + " has " + std::to_string(len) +
                                 " words, more than 2^29");
        if (viewed) {
            const uint8_t* words = viewed->here();
            if (len > src.remaining() / 4 || !viewed->skip(len * 4))
                return Status::error("file truncated: field 'encoding array' claims " + std::to_string(len) +
                                     " words at offset " + std::to_string(src.offset()) + ", only " +
                                     std::to_string(src.remaining()) + " bytes remain");
            v.arrays[size_t(i)] = WordArray::view(words, size_t(len), keeper);
            continue;
        }
        CSGV_TRY(readWords(src, v.arrays[size_t(i)].owned(), len, "encoding array"));
    }
    CSGV_TRY(parseTail(src));
    CSGV_TRY(checkLayout(v));
    return v;
}

} // namespace

uint32_t levelCount(uint32_t brickSize) { return floorLog2(brickSize) + 1; }

uint32_t CompressedVolume::levels() const { return levelCount(brickSize); }

std::array<uint32_t, 3> CompressedVolume::brickGrid() const {
    std::array<uint32_t, 3> g{};
    for (int a = 0; a < 3; ++a) g[a] = brickSize ? (dim[a] ? (dim[a] - 1) / brickSize + 1 : 0) : 0;
    return g;
}

uint64_t CompressedVolume::brickCount() const {
    const auto g = brickGrid();
    return product3(g[0], g[1], g[2]);
}

BrickWords CompressedVolume::brick(uint64_t i) const {
    // One array (the rule): a brick starts where the one before ends. Hot: every palette scan and
    // upload calls it once a brick (the brick count's divisions were a tenth of a 2048^3 upload).
    if (bricksPerArray == kSingleArray) {
        const uint32_t begin = brickStarts[size_t(i)], end = brickStarts[size_t(i + 1)];
        return BrickWords{arrays[0].words() + begin, end - begin};
    }
    const uint64_t bpa = bricksPerArray;
    const auto& arr = arrays[size_t(i / bpa)];
    const uint32_t begin = (i > 0 && i % bpa == 0) ? 0 : brickStarts[size_t(i)];
    const uint32_t end = brickStarts[size_t(i + 1)];
    return BrickWords{arr.words() + begin, end - begin};
}

uint64_t CompressedVolume::serializedSize() const {
    uint64_t size = 41;
    if (encoding == kEncodingRans1) size += 64;
    if (encoding == kEncodingRans2) size += 128;
    size += 4 + 8 + 4 * uint64_t(brickStarts.size()) + 8;
    for (const auto& a : arrays) size += 8 + 4 * uint64_t(a.size());
    return size + 1;
}

void sweepBricks(const CompressedVolume& vol, uint64_t chunk, const std::function<bool(uint64_t, uint64_t)>& f) {
    const uint64_t n = vol.brickCount();
    chunk = std::max<uint64_t>(chunk, 1);
    const uint64_t per = vol.bricksPerArray == kSingleArray ? n + 1 : vol.bricksPerArray;
    for (uint64_t from = 0; from < n; from += chunk) {
        const uint64_t to = std::min(n, from + chunk);
        const bool more = f(from, to);
        // The chunk's bricks, array by array (a new array may begin inside it).
        for (uint64_t a = from; a < to; a = (a / per + 1) * per) {
            const uint64_t b = std::min(to, (a / per + 1) * per) - 1;
            const BrickWords first = vol.brick(a), last = vol.brick(b);
            const auto* p = static_cast<const uint8_t*>(first.words.bytes());
            const auto* e = static_cast<const uint8_t*>(last.words.bytes()) + size_t(last.size) * 4;
            if (e > p) MappedFile::releaseAt(p, size_t(e - p));
        }
        if (!more) return;
    }
}

uint32_t minimalBrickWords(uint32_t levels, int32_t encoding) {
    return levels + (encoding == kEncodingRans2 ? 4 : 3);
}

Status checkLayout(const CompressedVolume& v) {
    CSGV_TRY(checkHeaderFields(v));
    const uint64_t bricks = v.brickCount();
    if (v.brickStarts.size() != bricks + 1)
        return Status::error("brick starts: " + std::to_string(v.brickStarts.size()) + " entries, expected " +
                             std::to_string(bricks + 1));
    uint64_t expectedArrays = 1;
    if (v.bricksPerArray != kSingleArray) {
        if (v.bricksPerArray == 0) return Status::error("field 'bricks per encoding array' is 0");
        expectedArrays = (bricks + v.bricksPerArray - 1) / v.bricksPerArray;
    }
    if (v.arrays.size() != expectedArrays)
        return Status::error("the file has " + std::to_string(v.arrays.size()) + " encoding arrays, expected " +
                             std::to_string(expectedArrays));
    for (size_t a = 0; a < v.arrays.size(); ++a)
        if (v.arrays[a].size() > kMaxWordsPerArray)
            return Status::error("encoding array " + std::to_string(a) + " exceeds 2^29 words");

    const uint32_t minWords = minimalBrickWords(v.levels(), v.encoding);
    const uint64_t bpa = v.bricksPerArray == kSingleArray ? bricks + 1 : v.bricksPerArray;
    // The brick starts alone: no brick's words are read (a file larger than memory opens without
    // reading it; checkBrick checks a brick's header words when a sweep or decoder reaches it).
    for (uint64_t i = 0; i < bricks; ++i) {
        const size_t arrayIndex = size_t(i / bpa);
        const uint64_t arrayLen = v.arrays[arrayIndex].size();
        const uint64_t begin = (i > 0 && i % bpa == 0) ? 0 : v.brickStarts[size_t(i)];
        const uint64_t end = v.brickStarts[size_t(i + 1)];
        if (end < begin)
            return Status::error("brick " + std::to_string(i) + ": brick starts out of order (" + std::to_string(begin) +
                                 " then " + std::to_string(end) + ")");
        if (end > arrayLen)
            return Status::error("brick " + std::to_string(i) + ": ends at word " + std::to_string(end) +
                                 ", past the end of encoding array " + std::to_string(arrayIndex) + " (" +
                                 std::to_string(arrayLen) + " words)");
        if (end - begin < minWords)
            return Status::error("brick " + std::to_string(i) + ": " + std::to_string(end - begin) +
                                 " words, less than the minimal brick of " + std::to_string(minWords));
    }
    return Status::ok();
}

namespace {

/// checkBrick's checks; the message only where `why` asks for it (sweeps ask brickSound).
bool brickHeaderSound(const CompressedVolume& v, uint64_t i, std::string* why) {
    auto fail = [&](const std::string& s) {
        if (why) *why = "brick " + std::to_string(i) + s;
        return false;
    };
    const uint32_t L = v.levels();
    const BrickWords bw = v.brick(i);
    const uint64_t size = bw.size; // at least the minimal brick (checkLayout)
    const WordPtr w = bw.words;
    if (w[0] != (L + 1) * 8)
        return fail(": level 0 start is " + std::to_string(w[0]) + ", expected " + std::to_string((L + 1) * 8));
    const uint32_t palette = w[L];
    if (palette == 0) return fail(": palette size is 0");
    if (palette > v.maxPalette)
        return fail(": palette size " + std::to_string(palette) + " exceeds the file's largest palette " +
                    std::to_string(v.maxPalette));
    const uint64_t streamWords = (v.encoding == kEncodingRans2) ? 2 : 1;
    if (uint64_t(palette) + L + 1 + streamWords > size)
        return fail(": palette size " + std::to_string(palette) + " does not fit in its " + std::to_string(size) +
                    " words");
    const uint64_t paletteStart = size - palette; // first palette word
    if (v.encoding == kEncodingNibble) {
        for (uint32_t l = 1; l < L; ++l)
            if (w[l] < w[l - 1])
                return fail(", level " + std::to_string(l) + ": start " + std::to_string(w[l]) + " is before level " +
                            std::to_string(l - 1) + "'s start " + std::to_string(w[l - 1]));
        if (w[L - 1] > paletteStart * 8)
            return fail(", level " + std::to_string(L - 1) + ": start " + std::to_string(w[L - 1]) +
                        " lies in the palette");
    } else if (v.encoding == kEncodingRans2) {
        const uint32_t s = w[L - 1];
        if (s % 8 != 0 || s < w[0] + 8 || s / 8 >= paletteStart)
            return fail(", level " + std::to_string(L - 1) + ": stream B start " + std::to_string(s) +
                        " is not a word boundary between " + std::to_string(w[0] + 8) + " and the palette at symbol " +
                        std::to_string(paletteStart * 8));
    }
    return true;
}

} // namespace

bool brickSound(const CompressedVolume& v, uint64_t i) { return brickHeaderSound(v, i, nullptr); }

Status checkBrick(const CompressedVolume& v, uint64_t i) {
    std::string why;
    return brickHeaderSound(v, i, &why) ? Status::ok() : Status::error(why);
}

Status checkContainer(const CompressedVolume& v) {
    CSGV_TRY(checkLayout(v));
    const uint64_t bricks = v.brickCount();
    const uint64_t bpa = v.bricksPerArray == kSingleArray ? bricks + 1 : v.bricksPerArray;
    // A mapped file's pages leave the process behind the sweep (a file larger than memory).
    std::unique_ptr<ReleaseBehind> behind;
    size_t behindArray = ~size_t(0);
    for (uint64_t i = 0; i < bricks; ++i) {
        const size_t arrayIndex = size_t(i / bpa);
        if (arrayIndex != behindArray) {
            behind.reset();
            behind = std::make_unique<ReleaseBehind>(v.arrays[arrayIndex].bytes(), v.arrays[arrayIndex].size() * 4);
            behindArray = arrayIndex;
        }
        behind->reached(v.brick(i).words.bytes());
        CSGV_TRY(checkBrick(v, i));
    }
    return Status::ok();
}

Result<CompressedVolume> parseCsgv(const uint8_t* data, size_t size) {
    MemorySource src(data, size);
    return parse(src);
}

Result<CompressedVolume> parseCsgvShared(const uint8_t* data, size_t size, std::shared_ptr<const void> keeper) {
    MemorySource src(data, size);
    if (!keeper) return parse(src);
    return parse(src, &src, keeper);
}

uint8_t* newCsgvBytes(size_t size) {
    // A 16-byte aligned block, the bytes kCsgvBytesPhase into it (freeCsgvBytes steps back).
    constexpr size_t kAlign = 16;
    if (size > SIZE_MAX - kAlign) return nullptr;
    void* block = nullptr;
    if (posix_memalign(&block, kAlign, size + kAlign) != 0) return nullptr;
    return static_cast<uint8_t*>(block) + kCsgvBytesPhase;
}

void freeCsgvBytes(void* bytes) {
    if (bytes) std::free(static_cast<uint8_t*>(bytes) - kCsgvBytesPhase);
}

std::shared_ptr<uint8_t> allocateCsgvBytes(size_t size) {
    uint8_t* bytes = newCsgvBytes(size);
    if (!bytes) return nullptr;
    return std::shared_ptr<uint8_t>(bytes, freeCsgvBytes);
}

Result<CompressedVolume> readCsgv(const std::string& path) {
    FileSource src;
    Status s = src.open(path);
    if (!s) return s;
    Result<CompressedVolume> r = parse(src);
    if (!r) return Status(r.status()).prefix(path);
    return r;
}

Result<CompressedVolume> readCsgvMapped(const std::string& path) {
    Result<std::shared_ptr<const MappedFile>> file = MappedFile::open(path);
    if (!file) return file.status();
    const MappedFile& bytes = **file;
    MemorySource src(bytes.data(), bytes.size());
    Result<CompressedVolume> r = parse(src, &src, *file);
    if (!r) return Status(r.status()).prefix(path);
    return r;
}

namespace {

/// Fills `piece` (header fields set, dimensions of the piece, the whole volume's largest palette)
/// with the bricks' words in the piece's order, laid out as a writer would (layoutArrays), with
/// its largest palette; then checks its layout. A brick whose header words are wrong stays so in
/// the piece (its palette size, past the whole's largest, is not taken for the piece's), so that
/// the piece's decoders and renderer name it when it is reached and draw the rest.
Status assemblePiece(CompressedVolume& piece, std::vector<std::vector<uint32_t>>& words) {
    std::vector<uint32_t> sizes(words.size());
    const uint32_t L = piece.levels();
    const uint32_t wholeLargest = piece.maxPalette;
    piece.maxPalette = 1;
    for (size_t i = 0; i < words.size(); ++i) {
        sizes[i] = uint32_t(words[i].size());
        if (words[i].size() > L && words[i][L] <= wholeLargest) piece.maxPalette = std::max(piece.maxPalette, words[i][L]);
    }
    Status s = fillArrays(piece, sizes, kMaxWordsPerArray, ~uint64_t(0), [&](uint64_t i, std::vector<uint32_t>& arr) {
        arr.insert(arr.end(), words[size_t(i)].begin(), words[size_t(i)].end());
        std::vector<uint32_t>().swap(words[size_t(i)]);
    });
    if (!s) return s;
    return checkLayout(piece);
}

/// The header of a piece of `whole` made of the bricks `box` (dimensions of the piece), or an
/// error naming a box outside the grid.
Result<CompressedVolume> pieceHeader(const CompressedVolume& whole, const BrickBox& box) {
    const std::array<uint32_t, 3> grid = whole.brickGrid();
    for (int a = 0; a < 3; ++a)
        if (box.lo[a] >= box.hi[a] || box.hi[a] > grid[a])
            return Status::error("piece of bricks [" + std::to_string(box.lo[a]) + ", " + std::to_string(box.hi[a]) +
                                 ") along axis " + std::to_string(a) + " is empty or outside the " +
                                 std::to_string(grid[a]) + " bricks of the volume");
    CompressedVolume piece = whole.headerFields(); // its largest palette and array split are its own (assemblePiece)
    piece.bricksPerArray = kSingleArray;
    for (int a = 0; a < 3; ++a)
        piece.dim[a] = std::min(box.hi[a] * whole.brickSize, whole.dim[a]) - box.lo[a] * whole.brickSize;
    return piece;
}

Result<CompressedVolume> readPiece(FileSource& src, const BrickBox& box, uint64_t* bytesRead) {
    CompressedVolume whole;
    CSGV_TRY(parseHead(src, whole));
    // The arrays' lengths and where they lie; their words stay on disk.
    uint64_t m = 0;
    CSGV_TRY(src.get(m, "encoding array count"));
    if (m == 0 || m > src.remaining() / 8)
        return Status::error("field 'encoding array count' is " + std::to_string(m) + ", which the file cannot hold");
    std::vector<uint64_t> offsets(static_cast<size_t>(m)), lengths(static_cast<size_t>(m));
    for (uint64_t a = 0; a < m; ++a) {
        CSGV_TRY(src.get(lengths[size_t(a)], "encoding array length"));
        if (lengths[size_t(a)] > kMaxWordsPerArray)
            return Status::error("encoding array " + std::to_string(a) + " has " + std::to_string(lengths[size_t(a)]) +
                                 " words, more than 2^29");
        if (lengths[size_t(a)] > src.remaining() / 4)
            return Status::error("file truncated: encoding array " + std::to_string(a) + " claims " +
                                 std::to_string(lengths[size_t(a)]) + " words at offset " + std::to_string(src.offset()) +
                                 ", only " + std::to_string(src.remaining()) + " bytes remain");
        offsets[size_t(a)] = src.offset();
        if (!src.seek(src.offset() + lengths[size_t(a)] * 4)) return Status::error("cannot seek in the file");
    }
    CSGV_TRY(parseTail(src));
    const uint64_t bricks = whole.brickCount();
    const uint64_t expectedArrays =
        whole.bricksPerArray == kSingleArray ? 1 : (whole.bricksPerArray ? (bricks + whole.bricksPerArray - 1) / whole.bricksPerArray : 0);
    if (m != expectedArrays)
        return Status::error("the file has " + std::to_string(m) + " encoding arrays, expected " + std::to_string(expectedArrays));
    const std::array<uint32_t, 3> grid = whole.brickGrid();
    Result<CompressedVolume> made = pieceHeader(whole, box);
    if (!made) return made.status();
    CompressedVolume& piece = *made;
    uint64_t read = src.offset(); // all but the arrays, which were skipped
    for (uint64_t len : lengths) read -= len * 4;
    const uint64_t bpa = whole.bricksPerArray == kSingleArray ? bricks + 1 : whole.bricksPerArray;
    const uint32_t minWords = minimalBrickWords(whole.levels(), whole.encoding);
    // Bricks in the piece's order (x fastest), read a run of x-neighbours at a time: they lie one
    // after the other in the file unless an array ends between them.
    std::vector<std::vector<uint32_t>> words;
    words.reserve(size_t(box.bricks()));
    std::vector<uint32_t> run;
    for (uint32_t z = box.lo[2]; z < box.hi[2]; ++z)
        for (uint32_t y = box.lo[1]; y < box.hi[1]; ++y)
            for (uint32_t x = box.lo[0]; x < box.hi[0];) {
                const uint64_t first = x + uint64_t(grid[0]) * (y + uint64_t(grid[1]) * z);
                const size_t array = size_t(first / bpa);
                uint64_t count = 0;
                while (x + count < box.hi[0] && (first + count) / bpa == array) ++count;
                uint64_t begin[2] = {0, 0};
                std::vector<std::pair<uint64_t, uint64_t>> spans; // per brick, within the array
                for (uint64_t k = 0; k < count; ++k) {
                    const uint64_t i = first + k;
                    const uint64_t b = (i > 0 && i % bpa == 0) ? 0 : whole.brickStarts[size_t(i)];
                    const uint64_t e = whole.brickStarts[size_t(i + 1)];
                    if (e < b || e > lengths[array] || e - b < minWords)
                        return Status::error("brick " + std::to_string(i) + ": words [" + std::to_string(b) + ", " +
                                             std::to_string(e) + ") are not a brick inside encoding array " +
                                             std::to_string(array) + " (" + std::to_string(lengths[array]) + " words)");
                    if (k > 0 && b < spans.back().second)
                        return Status::error("brick " + std::to_string(i) + ": brick starts out of order");
                    spans.push_back({b, e});
                }
                begin[0] = spans.front().first;
                begin[1] = spans.back().second;
                run.resize(size_t(begin[1] - begin[0]));
                if (!src.seek(offsets[array] + begin[0] * 4))
                    return Status::error("cannot seek in the file");
                CSGV_TRY(src.read(run.data(), run.size() * 4, "encoding array"));
                read += run.size() * 4;
                for (const auto& sp : spans)
                    words.emplace_back(run.begin() + ptrdiff_t(sp.first - begin[0]), run.begin() + ptrdiff_t(sp.second - begin[0]));
                x += uint32_t(count);
            }
    CSGV_TRY(assemblePiece(piece, words));
    if (bytesRead) *bytesRead = read;
    return std::move(piece);
}

} // namespace

Result<ArrayLayout> layoutArrays(const std::vector<uint32_t>& brickWords, uint64_t arrayLimit, uint64_t maxOutputBytes) {
    const uint64_t bricks = brickWords.size();
    uint64_t total = 0, largestBrick = 0;
    for (uint32_t w : brickWords) {
        total += w;
        largestBrick = std::max<uint64_t>(largestBrick, w);
    }
    if (total > maxOutputBytes / 4)
        return Status::error("the compressed volume needs " + std::to_string(total * 4) +
                             " bytes, more than the output limit of " + std::to_string(maxOutputBytes));
    arrayLimit = std::min<uint64_t>(std::max<uint64_t>(arrayLimit, 1), kMaxWordsPerArray);
    if (largestBrick > arrayLimit)
        return Status::error("a brick needs " + std::to_string(largestBrick) + " words, more than an encoding array holds");
    ArrayLayout out;
    out.perArray = bricks;
    if (total > arrayLimit) {
        auto fits = [&](uint64_t n) {
            for (uint64_t first = 0; first < bricks; first += n) {
                uint64_t sum = 0;
                for (uint64_t i = first; i < std::min(bricks, first + n); ++i) sum += brickWords[size_t(i)];
                if (sum > arrayLimit) return false;
            }
            return true;
        };
        uint64_t lo = 1, hi = bricks;
        while (lo < hi) {
            const uint64_t mid = (lo + hi + 1) / 2;
            if (fits(mid)) lo = mid;
            else hi = mid - 1;
        }
        out.perArray = lo;
    }
    out.brickStarts.assign(size_t(bricks + 1), 0);
    uint64_t len = 0;
    for (uint64_t i = 0; i < bricks; ++i) {
        if (i % out.perArray == 0 && i > 0) {
            out.arrayWords.push_back(len);
            out.brickStarts[size_t(i)] = uint32_t(len);
            len = 0;
        } else {
            out.brickStarts[size_t(i)] = uint32_t(len);
        }
        len += brickWords[size_t(i)];
    }
    out.arrayWords.push_back(len);
    out.brickStarts[size_t(bricks)] = uint32_t(len);
    return out;
}

Status fillArrays(CompressedVolume& vol, const std::vector<uint32_t>& brickWords, uint64_t arrayLimit,
                  uint64_t maxOutputBytes, const std::function<void(uint64_t, std::vector<uint32_t>&)>& append) {
    Result<ArrayLayout> layout = layoutArrays(brickWords, arrayLimit, maxOutputBytes);
    if (!layout) return layout.status();
    vol.arrays.assign(layout->arrayWords.size(), {});
    for (size_t a = 0; a < vol.arrays.size(); ++a) vol.arrays[a].owned().reserve(size_t(layout->arrayWords[a]));
    const uint64_t perArray = layout->perArray;
    applyLayout(std::move(*layout), vol);
    for (uint64_t i = 0; i < brickWords.size(); ++i) append(i, vol.arrays[size_t(i / perArray)].owned());
    return Status::ok();
}

void applyLayout(ArrayLayout&& layout, CompressedVolume& vol) {
    // (Moved, not copied: a copy would hold the brick starts twice, 8 bytes a brick, not 4.)
    vol.bricksPerArray = layout.perArray == layout.brickStarts.size() - 1 ? kSingleArray : uint32_t(layout.perArray);
    vol.brickStarts = std::move(layout.brickStarts);
}

Result<CompressedVolume> readCsgvHeader(const std::string& path) {
    FileSource src;
    Status s = src.open(path);
    if (!s) return s;
    CompressedVolume v;
    s = parseHead(src, v);
    if (!s) return s.prefix(path);
    return v;
}

Result<CompressedVolume> extractPiece(const CompressedVolume& whole, const BrickBox& box) {
    Result<CompressedVolume> made = pieceHeader(whole, box);
    if (!made) return made.status();
    const std::array<uint32_t, 3> grid = whole.brickGrid();
    std::vector<std::vector<uint32_t>> words;
    words.reserve(size_t(box.bricks()));
    for (uint32_t z = box.lo[2]; z < box.hi[2]; ++z)
        for (uint32_t y = box.lo[1]; y < box.hi[1]; ++y)
            for (uint32_t x = box.lo[0]; x < box.hi[0]; ++x) {
                const BrickWords bw = whole.brick(x + uint64_t(grid[0]) * (y + uint64_t(grid[1]) * z));
                words.emplace_back(bw.size);
                bw.words.copyTo(words.back().data(), bw.size);
            }
    Status s = assemblePiece(*made, words);
    if (!s) return s;
    return made;
}

Result<CompressedVolume> joinPieces(const std::array<uint32_t, 3>& dim, const std::vector<BrickBox>& boxes,
                                    std::vector<CompressedVolume>& pieces, uint64_t arrayLimit,
                                    uint64_t maxOutputBytes) {
    if (boxes.size() != pieces.size())
        return Status::error(std::to_string(pieces.size()) + " pieces for " + std::to_string(boxes.size()) + " boxes");
    const CompressedVolume* first = nullptr;
    for (size_t i = 0; i < pieces.size() && !first; ++i)
        if (!boxes[i].empty()) first = &pieces[i];
    if (!first) return Status::error("no piece holds a brick");
    CompressedVolume vol;
    vol.version = first->version;
    vol.brickSize = first->brickSize;
    vol.dim = dim;
    vol.encoding = first->encoding;
    vol.opMask = first->opMask;
    vol.freqA = first->freqA;
    vol.freqB = first->freqB;
    if (vol.brickCount() > kMaxBricks) return Status::error("the volume needs more than 2^40 bricks");
    const std::array<uint32_t, 3> grid = vol.brickGrid();
    const uint32_t B = vol.brickSize;
    // Which piece holds each brick (-1: none yet).
    std::vector<int32_t> owner(size_t(vol.brickCount()), -1);
    for (size_t i = 0; i < pieces.size(); ++i) {
        const BrickBox& box = boxes[i];
        if (box.empty()) continue;
        const CompressedVolume& p = pieces[i];
        const std::string where = "piece " + std::to_string(i);
        if (p.version != vol.version || p.brickSize != B || p.encoding != vol.encoding || p.opMask != vol.opMask ||
            p.freqA != vol.freqA || p.freqB != vol.freqB || p.randomAccess)
            return Status::error(where + " differs from piece 0 in its version, brick size, encoding, operations or "
                                 "frequency tables");
        for (int a = 0; a < 3; ++a) {
            if (box.hi[a] > grid[a])
                return Status::error(where + ": bricks [" + std::to_string(box.lo[a]) + ", " +
                                     std::to_string(box.hi[a]) + ") along axis " + std::to_string(a) +
                                     " lie outside the " + std::to_string(grid[a]) + " bricks of the volume");
            const uint32_t size = std::min(box.hi[a] * B, dim[a]) - box.lo[a] * B;
            if (p.dim[a] != size)
                return Status::error(where + " is " + std::to_string(p.dim[a]) + " voxels along axis " +
                                     std::to_string(a) + ", its bricks cover " + std::to_string(size));
        }
        for (uint32_t z = box.lo[2]; z < box.hi[2]; ++z)
            for (uint32_t y = box.lo[1]; y < box.hi[1]; ++y)
                for (uint32_t x = box.lo[0]; x < box.hi[0]; ++x) {
                    int32_t& o = owner[size_t(x + uint64_t(grid[0]) * (y + uint64_t(grid[1]) * z))];
                    if (o >= 0)
                        return Status::error("brick (" + std::to_string(x) + ", " + std::to_string(y) + ", " +
                                             std::to_string(z) + ") is in pieces " + std::to_string(o) + " and " +
                                             std::to_string(i));
                    o = int32_t(i);
                }
    }
    // Each brick's words and where they are: (piece, brick index in the piece).
    std::vector<uint32_t> sizes(owner.size());
    auto local = [&](uint64_t brick) {
        const uint64_t x = brick % grid[0], y = brick / grid[0] % grid[1], z = brick / grid[0] / grid[1];
        const BrickBox& box = boxes[size_t(owner[size_t(brick)])];
        const uint64_t w = box.hi[0] - box.lo[0], h = box.hi[1] - box.lo[1];
        return (x - box.lo[0]) + w * ((y - box.lo[1]) + h * (z - box.lo[2]));
    };
    for (uint64_t i = 0; i < owner.size(); ++i) {
        if (owner[size_t(i)] < 0)
            return Status::error("brick " + std::to_string(i % grid[0]) + ", " + std::to_string(i / grid[0] % grid[1]) +
                                 ", " + std::to_string(i / grid[0] / grid[1]) + " is in no piece");
        const BrickWords bw = pieces[size_t(owner[size_t(i)])].brick(local(i));
        sizes[size_t(i)] = uint32_t(bw.size);
        vol.maxPalette = std::max(vol.maxPalette, bw.words[vol.levels()]);
    }
    Status s = fillArrays(vol, sizes, arrayLimit, maxOutputBytes, [&](uint64_t i, std::vector<uint32_t>& arr) {
        const BrickWords bw = pieces[size_t(owner[size_t(i)])].brick(local(i));
        appendWords(arr, bw.words, bw.size);
    });
    if (!s) return s;
    for (CompressedVolume& p : pieces) p = CompressedVolume{};
    s = checkContainer(vol);
    if (!s) return s;
    return vol;
}

Result<CompressedVolume> readCsgvPiece(const std::string& path, const BrickBox& box, uint64_t* bytesRead) {
    FileSource src;
    Status s = src.open(path);
    if (!s) return s;
    Result<CompressedVolume> r = readPiece(src, box, bytesRead);
    if (!r) return Status(r.status()).prefix(path);
    return r;
}

std::vector<uint8_t> serializeCsgv(const CompressedVolume& vol) {
    std::vector<uint8_t> bytes;
    bytes.reserve(size_t(vol.serializedSize()));
    emit(vol, [&](const void* p, size_t n) {
        const auto* b = static_cast<const uint8_t*>(p);
        bytes.insert(bytes.end(), b, b + n);
    });
    return bytes;
}

Status writeCsgv(const std::string& path, const CompressedVolume& vol, const Limits& limits) {
    Status s = checkContainer(vol);
    if (!s) return s.prefix("refusing to write '" + path + "'");
    if (vol.serializedSize() > limits.maxOutputBytes)
        return Status::error("refusing to write '" + path + "': " + std::to_string(vol.serializedSize()) +
                             " bytes exceed the output limit of " + std::to_string(limits.maxOutputBytes));
    AtomicFile file;
    CSGV_TRY(file.open(path));
    Status ws;
    emit(vol, [&](const void* p, size_t n) {
        if (ws) ws = file.write(p, n);
    });
    if (!ws) return ws;
    return file.commit();
}

Status writeCsgvStreamed(const std::string& path, const CompressedVolume& vol, const std::vector<uint64_t>& arrayWords,
                         const Limits& limits, const std::function<Status(size_t array, const ByteSink& out)>& words) {
    const std::string refusing = "refusing to write '" + path + "'";
    CSGV_TRY(checkHeaderFields(vol).prefix(refusing));
    const uint64_t bricks = vol.brickCount();
    const uint64_t expectedArrays =
        vol.bricksPerArray == kSingleArray ? 1 : (bricks + std::max<uint32_t>(vol.bricksPerArray, 1) - 1) / std::max<uint32_t>(vol.bricksPerArray, 1);
    if (vol.brickStarts.size() != bricks + 1 || arrayWords.size() != expectedArrays || !vol.arrays.empty())
        return Status::error(refusing + ": brick starts or array count do not match the volume");
    uint64_t size = vol.serializedSize();
    for (uint64_t w : arrayWords) {
        if (w > kMaxWordsPerArray) return Status::error(refusing + ": an encoding array exceeds 2^29 words");
        size += 8 + 4 * w;
    }
    if (size > limits.maxOutputBytes)
        return Status::error(refusing + ": " + std::to_string(size) + " bytes exceed the output limit of " +
                             std::to_string(limits.maxOutputBytes));
    AtomicFile file;
    CSGV_TRY(file.open(path));
    Status ws;
    const ByteSink sink = [&](const void* p, size_t n) { return file.write(p, n); };
    emitHead(vol, arrayWords.size(), [&](const void* p, size_t n) {
        if (ws) ws = file.write(p, n);
    });
    for (size_t a = 0; ws && a < arrayWords.size(); ++a) {
        ws = sink(&arrayWords[a], 8);
        if (ws) ws = words(a, sink);
    }
    if (ws) ws = sink(&kNotDetailSeparated, 1);
    if (!ws) return ws;
    return file.commit();
}

Status writeTiledCsgv(const std::string& path, const CompressedVolume& src, const std::array<uint32_t, 3>& times,
                      const Limits& limits, const std::function<bool(double)>& progress) {
    const std::string refusing = "refusing to tile into '" + path + "'";
    CSGV_TRY(checkLayout(src).prefix(refusing));
    CompressedVolume vol = src.headerFields();
    const std::array<uint32_t, 3> grid = src.brickGrid();
    for (int a = 0; a < 3; ++a) {
        if (times[a] == 0) return Status::error(refusing + ": a repeat count is 0");
        if (src.dim[a] % src.brickSize != 0)
            return Status::error(refusing + ": dimension " + std::to_string(a) + " (" + std::to_string(src.dim[a]) +
                                 ") is not a multiple of the brick size " + std::to_string(src.brickSize) +
                                 ": only volumes of whole bricks tile");
        const uint64_t d = uint64_t(src.dim[a]) * times[a];
        if (d > uint64_t(std::numeric_limits<int32_t>::max()))
            return Status::error(refusing + ": dimension " + std::to_string(a) + " would be " + std::to_string(d));
        vol.dim[a] = uint32_t(d);
    }
    const uint64_t n = vol.brickCount();
    if (n >= (uint64_t(1) << 31))
        return Status::error(refusing + ": " + std::to_string(n) + " bricks, 2^31 or more");
    const std::string changed = "'" + path + "': the input changed on disk while it was read (it was cut short)";
    for (uint64_t b = 0; b < src.brickCount(); ++b) { // every brick copied many times: each checked once
        if (brickSound(src, b)) continue;
        const BrickWords bw = src.brick(b);
        if (MappedFile::cutShortAt(bw.words.bytes(), size_t(bw.size) * 4)) return Status::error(changed);
        return checkBrick(src, b).prefix(refusing);
    }
    const std::array<uint32_t, 3> big = vol.brickGrid();
    auto source = [&](uint64_t i) {
        const uint64_t x = i % big[0], y = i / big[0] % big[1], z = i / big[0] / big[1];
        return x % grid[0] + uint64_t(grid[0]) * (y % grid[1] + uint64_t(grid[1]) * (z % grid[2]));
    };
    std::vector<uint32_t> sizes;
    try {
        sizes.resize(size_t(n));
    } catch (const std::bad_alloc&) {
        return Status::error(refusing + ": no memory for the sizes of " + std::to_string(n) + " bricks");
    }
    for (uint64_t i = 0; i < n; ++i) sizes[size_t(i)] = src.brick(source(i)).size;
    Result<ArrayLayout> layout = layoutArrays(sizes, kMaxWordsPerArray, limits.maxOutputBytes);
    if (!layout) return Status(layout.status()).prefix(refusing);
    std::vector<uint32_t>().swap(sizes);
    const uint64_t per = layout->perArray;
    const std::vector<uint64_t> arrayWords = layout->arrayWords;
    applyLayout(std::move(*layout), vol);
    return writeCsgvStreamed(path, vol, arrayWords, limits, [&](size_t a, const ByteSink& out) -> Status {
        const uint64_t from = uint64_t(a) * per, to = std::min(n, from + per);
        for (uint64_t i = from; i < to; ++i) {
            if (progress && i % 65536 == 0 && !progress(double(i) / double(n))) return Status::error("cancelled");
            const BrickWords bw = src.brick(source(i));
            CSGV_TRY(out(bw.words.bytes(), size_t(bw.size) * 4)); // the file's bytes: little-endian words
        }
        // A mapped source cut short meanwhile reads zeros (MappedFile's guard): no file of them.
        for (const WordArray& s : src.arrays)
            if (MappedFile::damagedAt(s.bytes(), s.size() * 4)) return Status::error(changed);
        return Status::ok();
    });
}

const char* encodingName(int32_t encoding) {
    switch (encoding) {
    case kEncodingNibble: return "nibble";
    case kEncodingRans1: return "rans1";
    case kEncodingRans2: return "rans2";
    case kEncodingWaveletMatrix: return "wavelet-matrix";
    case kEncodingHuffmanWaveletMatrix: return "huffman-wavelet-matrix";
    default: return "unknown";
    }
}

std::string operationLetters(uint32_t m) {
    std::string s;
    if (m & kMaskParent) s += 'p';
    const uint32_t n = kMaskNeighborX | kMaskNeighborY | kMaskNeighborZ;
    if ((m & n) == n)
        s += 'n';
    else {
        if (m & kMaskNeighborX) s += 'x';
        if (m & kMaskNeighborY) s += 'y';
        if (m & kMaskNeighborZ) s += 'z';
    }
    if (m & kMaskPaletteLast) s += 'l';
    if (m & kMaskPaletteD) s += 'd';
    if (m & kMaskStopBits) s += 's';
    if (m & kMaskLegacyDelta) s += 'L';
    return s;
}

} // namespace csgv
