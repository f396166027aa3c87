// SPDX-License-Identifier: MIT
#include "InputCommon.h"

#include "csgv/base/Checked.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <dirent.h>
#include <fcntl.h>
#include <unistd.h>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <locale>
#include <sstream>

#include <nlohmann/json.hpp>

namespace csgv {
namespace inputs {

Status fail(const std::string& path, const std::string& what) { return Status::error(path + ": " + what); }

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

bool endsWith(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string trim(const std::string& s) {
    size_t b = 0, e = s.size();
    while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
    while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
    return s.substr(b, e - b);
}

std::string formatDouble(double v) {
    std::ostringstream o;
    o.imbue(std::locale::classic());
    o.precision(17);
    o << v;
    return o.str();
}

bool parseDouble(const std::string& text, double& out) {
    const std::string t = lower(trim(text));
    if (t == "nan" || t == "+nan" || t == "-nan") {
        out = std::numeric_limits<double>::quiet_NaN();
        return true;
    }
    if (t == "inf" || t == "+inf" || t == "infinity" || t == "+infinity" || t == "-inf" || t == "-infinity") {
        out = t[0] == '-' ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
        return true;
    }
    if (t.empty()) return false;
    std::istringstream in(t);
    in.imbue(std::locale::classic());
    double v = 0;
    if (!(in >> v)) return false;
    char extra = 0;
    if (in >> extra) return false;
    out = v;
    return true;
}

bool parseInt64(const std::string& text, int64_t& out) {
    const std::string t = trim(text);
    size_t i = 0;
    bool negative = false;
    if (i < t.size() && (t[i] == '+' || t[i] == '-')) negative = t[i++] == '-';
    if (i == t.size()) return false;
    uint64_t v = 0;
    for (; i < t.size(); ++i) {
        if (t[i] < '0' || t[i] > '9') return false;
        const uint64_t digit = uint64_t(t[i] - '0');
        if (v > (uint64_t(1) << 62) / 10) return false; // far beyond any size or skip a header may name
        v = v * 10 + digit;
    }
    out = negative ? -int64_t(v) : int64_t(v);
    return true;
}

std::vector<std::string> splitWords(const std::string& s) {
    std::istringstream in(s);
    std::vector<std::string> words;
    std::string w;
    while (in >> w) words.push_back(w);
    return words;
}

bool isFile(const std::string& path) {
    std::error_code ec;
    return std::filesystem::is_regular_file(path, ec);
}

bool isDir(const std::string& path) {
    std::error_code ec;
    return std::filesystem::is_directory(path, ec);
}

Status readBoundedFile(const std::string& file, uint64_t limit, std::vector<uint8_t>& out) {
    const bool gz = endsWithNoCase(file, ".gz");
    if (!gz) {
        Result<uint64_t> size = fileSize(file);
        if (!size) return size.status();
        if (*size > limit)
            return fail(file, "file of " + std::to_string(*size) + " bytes is larger than the limit of " +
                                  std::to_string(limit) + " bytes");
    }
    InputStream in;
    if (Status s = in.open(file, gz ? InputStream::Mode::Inflate : InputStream::Mode::Plain); !s)
        return fail(file, (in.failure() == InputStream::Failure::Open ? "cannot open: " : "cannot inflate: ") + s.message());
    constexpr size_t kStep = size_t(1) << 20;
    size_t have = 0;
    for (;;) {
        // One byte beyond the limit shows a file that holds more.
        const size_t step = size_t(std::min<uint64_t>(kStep, limit + 1 - have));
        if (Status s = resizeOrFail(out, have + step, file); !s) return s;
        Result<size_t> got = in.read(out.data() + have, step);
        if (!got) return fail(file, (gz ? "cannot inflate: " : "cannot read: ") + got.status().message());
        have += *got;
        if (have > limit)
            return fail(file, (gz ? "inflates to more than the limit of " : "holds more than the limit of ") +
                                  std::to_string(limit) + " bytes");
        if (*got < step) break;
    }
    out.resize(have);
    return Status::ok();
}

Status listFolder(const std::string& dir, const std::function<bool(const char* name)>& visit) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        // What a stat of a chunk name below it would call missing (PathGuard's notRegularFile).
        if (errno == ENOENT || errno == ENOTDIR || errno == ELOOP) return Status::ok();
        return fail(dir, "cannot list the chunk folder: " + errnoText());
    }
    DIR* d = ::fdopendir(fd);
    if (!d) {
        const std::string why = errnoText();
        ::close(fd);
        return fail(dir, "cannot list the chunk folder: " + why);
    }
    struct Closer {
        DIR* d;
        ~Closer() { ::closedir(d); }
    } closer{d};
    for (;;) {
        errno = 0; // readdir returns null at the end and on errors alike
        const dirent* e = ::readdir(d);
        if (!e) break;
        if (std::strcmp(e->d_name, ".") == 0 || std::strcmp(e->d_name, "..") == 0) continue;
        if (!visit(e->d_name)) return Status::ok();
    }
    if (errno != 0) return fail(dir, "cannot list the chunk folder: " + errnoText());
    return Status::ok();
}

void ChunkIndex::start(uint64_t budgetBytes) {
    m_positions = std::vector<Position>();
    m_capacity = std::min(kMaxChunks, budgetBytes / (2 * sizeof(Position)));
    m_listed = 0;
}

void ChunkIndex::add(uint32_t x, uint32_t y, uint32_t z) {
    if (++m_listed > m_capacity) {
        if (m_positions.capacity()) m_positions = std::vector<Position>(); // not indexed: nothing held
        return;
    }
    if (m_positions.size() == m_positions.capacity()) {
        // Grown by hand so that it never holds more than m_capacity (twice that while copying).
        const uint64_t next = std::min<uint64_t>(m_capacity, std::max<uint64_t>(256, 2 * m_positions.capacity()));
        try {
            m_positions.reserve(size_t(next));
        } catch (const std::exception&) {
            m_capacity = 0; // out of memory: not indexed, chunks are looked up by name
            m_listed = 1;
            m_positions = std::vector<Position>();
            return;
        }
    }
    m_positions.push_back({z, y, x});
}

void ChunkIndex::finish() {
    if (!complete()) {
        m_positions = std::vector<Position>();
        return;
    }
    std::sort(m_positions.begin(), m_positions.end());
    m_positions.erase(std::unique(m_positions.begin(), m_positions.end()), m_positions.end());
}

ChunkIndex::Range ChunkIndex::layer(uint32_t z) const {
    const Position* b = m_positions.data();
    const Position* e = b + m_positions.size();
    const auto first = std::lower_bound(b, e, z, [](const Position& p, uint32_t v) { return p.z < v; });
    return {first, std::upper_bound(first, e, z, [](uint32_t v, const Position& p) { return v < p.z; })};
}

ChunkIndex::Range ChunkIndex::row(uint32_t y, uint32_t z) const {
    const Range l = layer(z);
    const auto first = std::lower_bound(l.first, l.second, y, [](const Position& p, uint32_t v) { return p.y < v; });
    return {first, std::upper_bound(first, l.second, y, [](uint32_t v, const Position& p) { return v < p.y; })};
}

uint64_t ChunkIndex::largestLayer() const {
    uint64_t largest = 0, run = 0;
    for (size_t i = 0; i < m_positions.size(); ++i) {
        run = i > 0 && m_positions[i].z == m_positions[i - 1].z ? run + 1 : 1;
        largest = std::max(largest, run);
    }
    return largest;
}

Status ChunkIndex::checkLookups(const std::string& dir, uint64_t gridChunks) const {
    if (complete() || gridChunks <= std::max(kMaxLookups, mulSaturate(kLookupsPerFile, m_listed))) return Status::ok();
    return fail(dir, "its chunk grid has " + std::to_string(gridChunks) + " chunks and the folder " +
                         std::to_string(m_listed) + " chunk files, more than the " + std::to_string(m_capacity) +
                         " that the working memory bound lets this reader list; looking each chunk up by name is "
                         "refused beyond " + std::to_string(kLookupsPerFile) + " per chunk file (or " +
                         std::to_string(kMaxLookups) + " in all)");
}

void ChunkIndex::absentBoxes(const std::array<uint64_t, 3>& chunk, const std::array<uint32_t, 3>& dim, uint32_t z0,
                             uint32_t depth, uint32_t y0, uint32_t rows, uint64_t fill, std::vector<UniformBox>& out) const {
    if (depth == 0 || rows == 0) return;
    const uint64_t W = dim[0], yEnd = uint64_t(y0) + rows, zEnd = uint64_t(z0) + depth;
    const uint64_t gridX = (W + chunk[0] - 1) / chunk[0];
    const uint64_t gy0 = y0 / chunk[1], gy1 = (yEnd - 1) / chunk[1]; // the rows of chunks asked about
    // Where chunk row (or column, or layer) g begins, clipped to the region.
    const auto at = [](uint64_t g, uint64_t size, uint64_t lo, uint64_t hi) {
        return uint32_t(std::clamp<uint64_t>(mulSaturate(g, size), lo, hi));
    };
    const auto box = [&](uint64_t xa, uint64_t xb, uint32_t ya, uint32_t yb, uint32_t za, uint32_t zb) {
        out.push_back({{{at(xa, chunk[0], 0, W), ya, za}}, {{at(xb, chunk[0], 0, W), yb, zb}}, fill});
    };
    uint64_t emptyFrom = ~uint64_t(0); // where the current run of layers without a file here starts
    for (uint64_t gz = z0 / chunk[2]; mulSaturate(gz, chunk[2]) < zEnd; ++gz) {
        const uint32_t za = at(gz, chunk[2], z0, zEnd), zb = at(gz + 1, chunk[2], z0, zEnd);
        const Range l = layer(uint32_t(gz));
        const Position* p = std::lower_bound(l.first, l.second, gy0, [](const Position& q, uint64_t v) { return q.y < v; });
        const Position* end = std::upper_bound(p, l.second, gy1, [](uint64_t v, const Position& q) { return v < q.y; });
        if (p == end) {
            if (emptyFrom == ~uint64_t(0)) emptyFrom = za;
            continue;
        }
        if (emptyFrom != ~uint64_t(0)) box(0, gridX, y0, uint32_t(yEnd), uint32_t(emptyFrom), za);
        emptyFrom = ~uint64_t(0);
        uint64_t gy = gy0; // the first row of chunks not yet listed
        while (p != end) {
            const uint64_t row = p->y;
            if (row > gy) box(0, gridX, at(gy, chunk[1], y0, yEnd), at(row, chunk[1], y0, yEnd), za, zb);
            const uint32_t ya = at(row, chunk[1], y0, yEnd), yb = at(row + 1, chunk[1], y0, yEnd);
            uint64_t x = 0; // the first chunk of the row not yet listed
            for (; p != end && p->y == row; ++p) {
                if (p->x > x) box(x, p->x, ya, yb, za, zb);
                x = uint64_t(p->x) + 1;
            }
            if (x < gridX) box(x, gridX, ya, yb, za, zb);
            gy = row + 1;
        }
        if (gy <= gy1) box(0, gridX, at(gy, chunk[1], y0, yEnd), uint32_t(yEnd), za, zb);
    }
    if (emptyFrom != ~uint64_t(0)) box(0, gridX, y0, uint32_t(yEnd), uint32_t(emptyFrom), uint32_t(zEnd));
}

Status checkSlab(const InputInfo& info, uint32_t z0, uint32_t depth, const std::string& path) {
    if (uint64_t(z0) + depth <= info.dim[2]) return Status::ok();
    return fail(path, "slab z " + std::to_string(z0) + " to " + std::to_string(uint64_t(z0) + depth) +
                          " is beyond the volume's depth " + std::to_string(info.dim[2]));
}

Status checkRows(const InputInfo& info, uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, const std::string& path) {
    if (Status s = checkSlab(info, z0, depth, path); !s) return s;
    if (uint64_t(y0) + rows <= info.dim[1]) return Status::ok();
    return fail(path, "rows y " + std::to_string(y0) + " to " + std::to_string(uint64_t(y0) + rows) +
                          " are beyond the volume's height " + std::to_string(info.dim[1]));
}

Status checkDimensions(const InputInfo& info, const std::string& path) {
    if (mulSaturate(product3(info.dim[0], info.dim[1], info.dim[2]), 8) != kSaturated) return Status::ok();
    return fail(path, dimText({{info.dim[0], info.dim[1], info.dim[2]}}) +
                          " voxels need 2^64 bytes or more as 64-bit labels; no input can be that large");
}

unsigned typeBytes(LabelType type) {
    switch (type) {
    case LabelType::U8:
    case LabelType::I8: return 1;
    case LabelType::U16:
    case LabelType::I16: return 2;
    case LabelType::U32:
    case LabelType::I32:
    case LabelType::F32: return 4;
    default: return 8;
    }
}

std::string voxelDetail(LabelType type, bool bigEndian, bool compressed) {
    const char* order = typeBytes(type) == 1 ? "" : bigEndian ? " big-endian" : " little-endian";
    return std::string(labelTypeName(type)) + order + (compressed ? ", gzip" : ", raw");
}

std::string dimText(const std::array<uint64_t, 3>& d) {
    return std::to_string(d[0]) + " x " + std::to_string(d[1]) + " x " + std::to_string(d[2]);
}

Status checkBudget(const std::string& path, const std::array<uint64_t, 3>& d, uint64_t maxBytes) {
    const uint64_t need = mulSaturate(product3(d[0], d[1], d[2]), 8);
    if (need == kSaturated)
        return fail(path, dimText(d) + " voxels need more than 2^64 bytes");
    if (need > maxBytes)
        return fail(path, dimText(d) + " voxels need " + std::to_string(need) +
                              " bytes as 64-bit labels, more than the limit of " + std::to_string(maxBytes));
    return Status::ok();
}

namespace {

template <unsigned W>
inline uint64_t loadBits(const uint8_t* p, bool bigEndian) {
    uint64_t v = 0;
    if (bigEndian)
        for (unsigned b = 0; b < W; ++b) v = (v << 8) | p[b];
    else
        for (unsigned b = W; b-- > 0;) v = (v << 8) | p[b];
    return v;
}

template <unsigned W, bool Big, bool Signed>
void loadRun(const uint8_t* p, uint64_t* out, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        uint64_t v = loadBits<W>(p + i * W, Big);
        if (Signed && W < 8) {
            const unsigned shift = 64 - 8 * W;
            v = uint64_t(int64_t(v << shift) >> shift);
        }
        out[i] = v;
    }
}

/// Byte order and signedness as template arguments: each loop's byte loads then compile to one
/// load (and a byte swap), which keeps decoding at memory speed.
template <unsigned W>
void loadIntegers(const uint8_t* p, bool bigEndian, bool isSigned, uint64_t* out, size_t n) {
    if (bigEndian) {
        if (isSigned) loadRun<W, true, true>(p, out, n);
        else loadRun<W, true, false>(p, out, n);
    } else {
        if (isSigned) loadRun<W, false, true>(p, out, n);
        else loadRun<W, false, false>(p, out, n);
    }
}

std::string voxelName(uint64_t i, const std::array<uint32_t, 3>& dim) {
    const uint64_t x = i % dim[0], y = (i / dim[0]) % dim[1], z = i / (uint64_t(dim[0]) * dim[1]);
    return "voxel " + std::to_string(i) + " (x " + std::to_string(x) + ", y " + std::to_string(y) + ", z " +
           std::to_string(z) + ")";
}

} // namespace

bool floatToInt64(double v, int64_t& out) {
    if (!std::isfinite(v) || v != std::trunc(v)) return false;
    if (v < -9223372036854775808.0 || v >= 9223372036854775808.0) return false;
    out = int64_t(v);
    return true;
}

std::string notAnIntegerLabel(double v) { return "holds " + formatDouble(v) + ", which is not an integer label"; }

size_t widenSamples(const uint8_t* p, LabelType type, bool bigEndian, uint64_t* out, size_t n, double& bad) {
    const bool sgn = isSignedType(type);
    switch (type) {
    case LabelType::U8:
    case LabelType::I8: loadIntegers<1>(p, bigEndian, sgn, out, n); return n;
    case LabelType::U16:
    case LabelType::I16: loadIntegers<2>(p, bigEndian, sgn, out, n); return n;
    case LabelType::U32:
    case LabelType::I32: loadIntegers<4>(p, bigEndian, sgn, out, n); return n;
    case LabelType::U64:
    case LabelType::I64: loadIntegers<8>(p, bigEndian, false, out, n); return n;
    case LabelType::F32:
    case LabelType::F64: break;
    }
    const bool f32 = type == LabelType::F32;
    for (size_t i = 0; i < n; ++i) {
        double v;
        if (f32) {
            const uint32_t bits = uint32_t(loadBits<4>(p + 4 * i, bigEndian));
            float f;
            std::memcpy(&f, &bits, 4);
            v = f;
        } else {
            const uint64_t bits = loadBits<8>(p + 8 * i, bigEndian);
            std::memcpy(&v, &bits, 8);
        }
        int64_t iv;
        if (!floatToInt64(v, iv)) {
            bad = v;
            return i;
        }
        out[i] = uint64_t(iv);
    }
    return n;
}

Status decodeVoxels(const uint8_t* p, LabelType type, bool bigEndian, const std::array<uint32_t, 3>& dim,
                    const std::string& path, uint64_t first, uint64_t* out, size_t n) {
    double bad = 0;
    const size_t i = widenSamples(p, type, bigEndian, out, n, bad);
    if (i == n) return Status::ok();
    return fail(path, voxelName(first + i, dim) + " " + notAnIntegerLabel(bad) + " (" + labelTypeName(type) +
                          " voxels must hold integers within int64)");
}

// ---- SlabStore

SlabStore::~SlabStore() { clear(); }

void SlabStore::clear() {
    if (m_fd >= 0) ::close(m_fd);
    m_fd = -1;
    std::vector<uint8_t>().swap(m_memory);
}

Status SlabStore::reset(uint64_t bytes, uint64_t memoryLimit, const std::string& directory, const std::string& path) {
    m_path = path;
    if (bytes <= memoryLimit) {
        if (m_fd >= 0) clear();
        return resizeOrFail(m_memory, size_t(bytes), path);
    }
    clear();
    std::string dir = directory;
    if (dir.empty()) {
        const char* tmp = std::getenv("TMPDIR");
        dir = tmp && *tmp ? tmp : "/tmp";
    }
    m_name = dir + "/csgv-slab-XXXXXX";
    std::vector<char> name(m_name.begin(), m_name.end());
    name.push_back('\0');
    m_fd = ::mkstemp(name.data());
    if (m_fd < 0) return fail(path, "cannot create a scratch file in '" + dir + "' for a slab of " +
                                        std::to_string(bytes) + " bytes: " + errnoText());
    m_name = name.data();
    ::unlink(m_name.c_str()); // open only: nothing is left behind, whatever happens
    return Status::ok();
}

namespace {
/// pwrite or pread of all `bytes` at `at`, going on after short transfers and EINTR; false with
/// errno (or 0 at an unexpected end) when the file fails.
template <class Transfer>
bool transferAll(Transfer transfer, uint64_t at, size_t bytes, uint64_t& failedAt) {
    for (size_t done = 0; done < bytes;) {
        const ssize_t n = transfer(done, off_t(at + done));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            failedAt = at + done;
            return false;
        }
        done += size_t(n);
    }
    return true;
}
} // namespace

Status SlabStore::write(uint64_t at, const uint8_t* data, size_t bytes) {
    if (m_fd < 0) {
        std::memcpy(m_memory.data() + at, data, bytes);
        return Status::ok();
    }
    uint64_t failedAt = 0;
    if (!transferAll([&](size_t done, off_t off) { return ::pwrite(m_fd, data + done, bytes - done, off); }, at, bytes,
                     failedAt))
        return fail(m_path, "cannot write " + std::to_string(bytes) + " bytes to the scratch file '" + m_name +
                                "' at offset " + std::to_string(failedAt) + ": " + errnoText());
    return Status::ok();
}

Status SlabStore::read(uint64_t at, uint8_t* data, size_t bytes) const {
    if (m_fd < 0) {
        std::memcpy(data, m_memory.data() + at, bytes);
        return Status::ok();
    }
    uint64_t failedAt = 0;
    if (!transferAll([&](size_t done, off_t off) { return ::pread(m_fd, data + done, bytes - done, off); }, at, bytes,
                     failedAt))
        return fail(m_path, "cannot read back " + std::to_string(bytes) + " bytes of the scratch file '" + m_name +
                                "' at offset " + std::to_string(failedAt) + ": " + errnoText());
    return Status::ok();
}

// ---- VoxelFileSource

Status VoxelFileSource::init(const std::string& path, const InputInfo& info, const VoxelData& data,
                             const InputOptions& options) {
    m_path = path;
    m_info = info;
    m_data = data;
    m_width = typeBytes(data.stored);
    m_dataBytes = mulSaturate(info.voxelCount(), m_width); // the header parsers refuse sizes beyond 2^64 bytes
    // The decode buffer holds whole voxels, no more than the data, within the budget.
    const uint64_t fixed = data.compressed ? kStreamBytes : 0;
    if (options.maxWorkingBytes < fixed + m_width)
        return fail(path, "reading needs at least " + std::to_string(fixed + m_width) +
                              " bytes of working memory, more than the limit of " +
                              std::to_string(options.maxWorkingBytes));
    const uint64_t chunk = std::min({uint64_t(kChunkBytes), std::max<uint64_t>(m_dataBytes, m_width),
                                     options.maxWorkingBytes - fixed});
    m_chunkBytes = size_t(chunk / m_width * m_width);
    m_slabMemoryLimit = std::min(kSlabMemoryBytes, options.maxWorkingBytes - fixed - m_chunkBytes);
    m_scratchDirectory = options.scratchDirectory;
    if (!data.compressed) {
        m_fd = ::open(data.file.c_str(), O_RDONLY | O_CLOEXEC);
        if (m_fd < 0) return fail(path, "cannot open '" + data.file + "': " + errnoText());
    }
    return Status::ok();
}

VoxelFileSource::~VoxelFileSource() {
    if (m_fd >= 0) ::close(m_fd);
}

uint64_t VoxelFileSource::workingBytes() const {
    return m_buffer.capacity() + (m_stream ? kStreamBytes : 0) + m_slab.memoryBytes();
}

Status VoxelFileSource::readSlab(uint32_t z0, uint32_t depth, uint64_t* out) {
    if (Status s = checkSlab(m_info, z0, depth, m_path); !s) return s;
    if (depth == 0) return Status::ok();
    if (m_buffer.empty())
        if (Status s = resizeOrFail(m_buffer, m_chunkBytes, m_path); !s) return s;
    const uint64_t slice = uint64_t(m_info.dim[0]) * m_info.dim[1];
    return m_data.compressed ? readCompressed(slice * z0, slice * depth, out) : readRaw(slice * z0, slice * depth, out);
}

Status VoxelFileSource::readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) {
    if (y0 == 0 && rows == m_info.dim[1]) return readSlab(z0, depth, out);
    if (Status s = checkRows(m_info, z0, depth, y0, rows, m_path); !s) return s;
    if (depth == 0 || rows == 0) return Status::ok();
    if (m_buffer.empty())
        if (Status s = resizeOrFail(m_buffer, m_chunkBytes, m_path); !s) return s;
    const uint64_t W = m_info.dim[0], slice = W * m_info.dim[1], band = W * rows;
    if (!m_data.compressed) {
        for (uint32_t z = 0; z < depth; ++z)
            if (Status s = readRaw(slice * (z0 + z) + W * y0, band, out + band * z); !s) return s;
        return Status::ok();
    }
    // One slice's rows lie together in the stream: bands read in increasing y (the encoder's
    // order on a volume one slice deep, `info`'s samples) need no slab, only skipping forward.
    if (depth == 1 && !(m_slabDepth > 0 && z0 >= m_slabZ0 && z0 < m_slabZ0 + m_slabDepth))
        return readCompressed(slice * z0 + W * y0, band, out);
    if (Status s = holdSlab(z0, depth); !s) return s;
    const uint64_t perChunk = m_chunkBytes / m_width;
    for (uint32_t z = 0; z < depth; ++z) {
        const uint64_t first = slice * (z0 + z) + W * y0; // the voxel in the volume
        const uint64_t inSlab = slice * (z0 + z - m_slabZ0) + W * y0;
        for (uint64_t done = 0; done < band;) {
            const size_t n = size_t(std::min(perChunk, band - done));
            if (Status s = m_slab.read((inSlab + done) * m_width, m_buffer.data(), n * m_width); !s) return s;
            if (Status s = decodeVoxels(m_buffer.data(), m_data.stored, m_data.bigEndian, m_info.dim, m_path,
                                        first + done, out + band * z + done, n);
                !s)
                return s;
            done += n;
        }
    }
    return Status::ok();
}

Status VoxelFileSource::holdSlab(uint32_t z0, uint32_t depth) {
    if (m_slabDepth > 0 && z0 >= m_slabZ0 && uint64_t(z0) + depth <= uint64_t(m_slabZ0) + m_slabDepth)
        return Status::ok();
    m_slabDepth = 0;
    const uint64_t slice = uint64_t(m_info.dim[0]) * m_info.dim[1];
    const uint64_t bytes = slice * depth * m_width;
    Status s = [&]() -> Status {
        if (Status r = seekStream(slice * z0); !r) return r;
        // Nothing the size of the slab is held before the file is known to be able to fill it.
        if (bytes > m_stream->remainingBound())
            return fail(m_path, "slices z " + std::to_string(z0) + ".." + std::to_string(z0 + depth - 1) + " need " +
                                    std::to_string(bytes) + " bytes, more than the " +
                                    std::to_string(m_stream->remainingBound()) +
                                    " the rest of the file can inflate to (the header claims more voxels than the "
                                    "file holds)");
        if (Status r = m_slab.reset(bytes, m_slabMemoryLimit, m_scratchDirectory, m_path); !r) return r;
        for (uint64_t done = 0; done < bytes;) {
            const size_t n = size_t(std::min<uint64_t>(m_chunkBytes, bytes - done));
            if (Status r = readStream(n); !r) return r;
            if (Status r = m_slab.write(done, m_buffer.data(), n); !r) return r;
            m_next += n / m_width;
            done += n;
        }
        if (m_next == m_info.voxelCount()) return atDataEnd(*m_stream);
        return Status::ok();
    }();
    if (!s) {
        m_stream.reset(); // the next call starts afresh
        m_slab.clear();
        return s;
    }
    m_slabZ0 = z0;
    m_slabDepth = depth;
    return Status::ok();
}

Status VoxelFileSource::seekStream(uint64_t first) {
    if (!m_stream || first < m_next)
        if (Status r = restart(); !r) return r;
    const uint64_t perChunk = m_chunkBytes / m_width;
    while (m_next < first) { // skipping forward: inflate and discard
        const size_t n = size_t(std::min(perChunk, first - m_next));
        if (Status r = readStream(n * m_width); !r) return r;
        m_next += n;
    }
    return Status::ok();
}

Status VoxelFileSource::readRaw(uint64_t first, uint64_t count, uint64_t* out) {
    const uint64_t perChunk = m_chunkBytes / m_width;
    for (uint64_t done = 0; done < count;) {
        const size_t n = size_t(std::min(perChunk, count - done));
        const size_t bytes = n * m_width;
        const uint64_t at = m_data.fileOffset + (first + done) * m_width;
        for (size_t got = 0; got < bytes;) {
            const ssize_t r = ::pread(m_fd, m_buffer.data() + got, bytes - got, off_t(at + got));
            if (r < 0 && errno == EINTR) continue;
            if (r < 0)
                return fail(m_data.file, "cannot read " + std::to_string(bytes) + " bytes at offset " +
                                             std::to_string(at + got) + ": " + errnoText());
            // The size was checked when the file was opened: it has shrunk since.
            if (r == 0) return truncatedInSlice((first + done) * m_width + got);
            got += size_t(r);
        }
        if (Status s = decodeVoxels(m_buffer.data(), m_data.stored, m_data.bigEndian, m_info.dim, m_path, first + done,
                                    out + done, n);
            !s)
            return s;
        done += n;
    }
    return Status::ok();
}

Status VoxelFileSource::readCompressed(uint64_t first, uint64_t count, uint64_t* out) {
    const uint64_t perChunk = m_chunkBytes / m_width;
    Status s = [&]() -> Status {
        if (Status r = seekStream(first); !r) return r;
        for (uint64_t done = 0; done < count;) {
            const size_t n = size_t(std::min(perChunk, count - done));
            if (Status r = readStream(n * m_width); !r) return r;
            if (Status r = decodeVoxels(m_buffer.data(), m_data.stored, m_data.bigEndian, m_info.dim, m_path,
                                        first + done, out + done, n);
                !r)
                return r;
            m_next += n;
            done += n;
        }
        if (m_next == m_info.voxelCount()) return atDataEnd(*m_stream);
        return Status::ok();
    }();
    if (!s) m_stream.reset(); // the next call starts afresh
    return s;
}

Status VoxelFileSource::restart() {
    m_stream = std::make_unique<InputStream>();
    m_next = 0;
    if (Status s = m_stream->open(m_data.file, m_data.mode, m_data.fileOffset); !s)
        return streamFailure(*m_stream, s);
    for (uint64_t left = m_data.skip; left > 0;) {
        const size_t n = size_t(std::min<uint64_t>(left, m_chunkBytes));
        Result<size_t> got = m_stream->read(m_buffer.data(), n);
        if (!got) return streamFailure(*m_stream, got.status());
        if (*got < n) return truncatedInSlice(0);
        left -= n;
    }
    return Status::ok();
}

Status VoxelFileSource::readStream(size_t bytes) {
    // Every 64 pieces (8 MiB, a few ms of inflating): a slab, or a skip to a deep slice, can take
    // seconds.
    if (++m_pieces % 64 == 0 && !keepGoing()) return fail(m_path, "cancelled");
    Result<size_t> got = m_stream->read(m_buffer.data(), bytes);
    if (!got) return streamFailure(*m_stream, got.status());
    if (*got < bytes) return truncatedInSlice(m_stream->position() - std::min(m_stream->position(), m_data.skip));
    return Status::ok();
}

Status VoxelFileSource::truncatedInSlice(uint64_t available) const {
    const uint64_t slice = uint64_t(m_info.dim[0]) * m_info.dim[1];
    return Status::error(truncated(available).message() + " (the data run out in slice z " +
                         std::to_string(available / m_width / slice) + ")");
}

Status VoxelFileSource::atDataEnd(InputStream& in) {
    // A member's checksum follows its last byte: verify it, as a reader of the whole file would.
    if (Status s = in.checkMemberEnd(); !s) return streamFailure(in, s);
    return Status::ok();
}

} // namespace inputs
} // namespace csgv
