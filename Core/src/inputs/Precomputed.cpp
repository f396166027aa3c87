// SPDX-License-Identifier: MIT
/// @file Precomputed.cpp
/// @brief Neuroglancer precomputed segmentation from a local folder (unsharded), streamed chunk
/// layer by chunk layer.
///
/// Forms: `DIR`, `DIR/` or `DIR/info`, each optionally followed by a scale selector `#N` (index
/// into the info's `scales`, 0 = full resolution, the default) or `#KEY` (a scale's `key`, e.g.
/// `DIR#16_16_16`). Chunks are `<key>/<x0>-<x1>_<y0>-<y1>_<z0>-<z1>` (voxel coordinates including
/// voxel_offset, clipped at the volume's end), or that name plus `.gz` (gzip-compressed), or the
/// nested `<key>/<x0>-<x1>/<y0>-<y1>/<z0>-<z1>`; a chunk with no file is background (zeros), listed
/// as a uniform box without reading (uniformBoxes: a volume of background compresses per brick).
/// Which chunks have a file is learnt by listing the scale's folder (and the nested folders whose
/// names are chunk ranges) once when it is opened, into a ChunkIndex (InputCommon.h), so a chunk
/// without a file costs no stat: time goes with the chunk files, not with the grid's chunk names
/// (a 256^3 scale of 1-voxel chunks took minutes). A folder with more chunk files than the index
/// holds is read as before, a stat per name, unless that means far more names than files.
/// Encodings `raw` and `compressed_segmentation` (PrecomputedFormat.h); `type` "segmentation",
/// or "image" with an unsigned integer data_type (an integer image is read as labels). A scale's
/// key must name a folder inside the dataset's folder unless InputOptions::allowOutsidePaths
/// (PathGuard.h); a chunk name that is there but no regular file is an error, not background.
///
/// Geometry: spacing = resolution (nm), origin = voxel_offset * resolution, taking integer voxel
/// coordinates as voxel centres (Inputs.h's convention, and CloudVolume's). Neuroglancer itself
/// draws voxel v over [v, v + 1) * resolution, i.e. half a voxel further along each axis.
///
/// Working memory: the decoded chunk layer that the last slab touched (W * H * chunk depth * 8
/// bytes) when it fits InputOptions::maxWorkingBytes together with one decoded chunk; otherwise
/// chunks are decoded again for each request and only one decoded chunk is held. Either way one
/// chunk file's bytes are held while it is decoded: at most its encoding's worst case (raw: its
/// exact size; compressed_segmentation: compressedSegmentationBound), capped at what
/// maxWorkingBytes leaves beside the decoded chunk; a larger file, or a `.gz` one inflating past
/// that, is refused. The layer is cached only when it fits beside both.
#include "InputCommon.h"

#include "csgv/inputs/PathGuard.h"
#include "csgv/inputs/PrecomputedFormat.h"

#include <zlib.h>

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstring>

namespace csgv {
namespace inputs {

namespace {

/// @brief A precomputed path split into the folder and the scale selector.
struct PrecomputedPath {
    std::string dir;      ///< the folder holding `info`, without a trailing '/'
    std::string selector; ///< after '#', empty for the default scale
};

PrecomputedPath splitPath(const std::string& path) {
    PrecomputedPath p;
    std::string rest = path;
    const size_t hash = rest.rfind('#');
    if (hash != std::string::npos && rest.find('/', hash) == std::string::npos) {
        p.selector = rest.substr(hash + 1);
        rest.resize(hash);
    }
    if (rest == "info" || endsWith(rest, "/info")) rest.resize(rest.size() - 4);
    while (rest.size() > 1 && rest.back() == '/') rest.pop_back();
    p.dir = rest.empty() ? "." : rest;
    return p;
}

Result<size_t> selectScale(const std::string& infoPath, const PrecomputedInfo& info, const std::string& selector) {
    if (selector.empty()) return size_t(0);
    for (size_t i = 0; i < info.scales.size(); ++i)
        if (info.scales[i].key == selector) return i;
    int64_t index = -1;
    const bool digits = std::all_of(selector.begin(), selector.end(), [](char c) { return std::isdigit((unsigned char)c); });
    if (digits && parseInt64(selector, index) && index >= 0 && uint64_t(index) < info.scales.size())
        return size_t(index);
    // At most kListed keys: an info file may list thousands, and the message is one line.
    constexpr size_t kListed = 8;
    std::string keys;
    for (size_t i = 0; i < std::min(info.scales.size(), kListed); ++i) keys += (i ? ", " : "") + quotedText(info.scales[i].key);
    if (info.scales.size() > kListed) keys += ", ...";
    return fail(infoPath, "no scale " + quotedText(selector) + " (scales 0.." + std::to_string(info.scales.size() - 1) +
                              ": " + keys + ")");
}

std::string encodingText(const PrecomputedScale& s) {
    if (s.encoding == PrecomputedScale::Encoding::Raw) return "raw";
    return "compressed_segmentation " + std::to_string(s.blockSize[0]) + "x" + std::to_string(s.blockSize[1]) + "x" +
           std::to_string(s.blockSize[2]);
}

/// @brief Closes a file descriptor and ends a zlib stream on every return path.
struct GzipChunkReader {
    int fd = -1;
    z_stream z{};
    bool started = false;
    ~GzipChunkReader() {
        if (started) inflateEnd(&z);
        if (fd >= 0) ::close(fd);
    }
};

/// Inflates a `.gz` chunk file into `out`, holding at most `limit` + 1 inflated bytes and a
/// 64 KiB input buffer, and says what is wrong in its own words: corrupt data with zlib's reason,
/// a stream cut before its end (an empty or half-written file) with the byte counts, or more
/// than `limit` bytes. (Reading it as a stream and letting the chunk decoder find the size wrong
/// would call a cut file a "raw chunk of 0 bytes".) Further gzip members are read on, as gzip does.
Status inflateChunkFile(const std::string& file, uint64_t limit, std::vector<uint8_t>& out) {
    GzipChunkReader r;
    Result<int> fd = openRegularFile(file);
    if (!fd) return fail(file, "cannot open chunk: " + fd.message());
    r.fd = *fd;
    // 15 + 32: a 32 KiB window, gzip or zlib wrapper detected (as the stream reader did).
    if (inflateInit2(&r.z, 15 + 32) != Z_OK) return fail(file, "cannot start zlib");
    r.started = true;
    std::vector<uint8_t> in(size_t(64) << 10);
    uint64_t fileBytes = 0, have = 0;
    bool ended = false; // the last member read so far has ended (inflate said Z_STREAM_END)
    out.clear();
    for (;;) {
        const ssize_t n = ::read(r.fd, in.data(), in.size());
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return fail(file, "cannot read chunk: " + errnoText());
        if (n == 0) break;
        fileBytes += uint64_t(n);
        r.z.next_in = in.data();
        r.z.avail_in = uInt(n);
        while (r.z.avail_in > 0) {
            if (ended) inflateReset(&r.z); // another member follows
            ended = false;
            const size_t step = size_t(std::min<uint64_t>(uint64_t(1) << 20, limit + 1 - have));
            if (Status s = resizeOrFail(out, size_t(have + step), file); !s) return s;
            r.z.next_out = out.data() + have;
            r.z.avail_out = uInt(step);
            const int ret = inflate(&r.z, Z_NO_FLUSH);
            have += step - r.z.avail_out;
            if (have > limit)
                return fail(file, "inflates to more than the limit of " + std::to_string(limit) + " bytes");
            if (ret == Z_STREAM_END) ended = true;
            else if (ret != Z_OK && ret != Z_BUF_ERROR)
                return fail(file, "gzip data is corrupt (" + std::string(r.z.msg ? r.z.msg : "zlib error " + std::to_string(ret)) +
                                      ") at inflated byte " + std::to_string(have));
        }
    }
    if (fileBytes == 0) return fail(file, "gzip chunk file is empty");
    if (!ended)
        return fail(file, "gzip data are cut: the file's " + std::to_string(fileBytes) +
                              " bytes end inside the compressed stream, at inflated byte " + std::to_string(have));
    out.resize(size_t(have));
    return Status::ok();
}

/// @brief The chunks of one scale, read and decoded one at a time.
class PrecomputedSource final : public InputSource {
public:
    /// `root` is the dataset's folder, which every chunk file must lie in unless `allowOutside`.
    PrecomputedSource(std::string root, std::string chunkDir, bool allowOutside, PrecomputedInfo info, size_t scale,
                      bool cacheLayers, uint64_t maxFileBytes)
        : m_root(std::move(root)), m_chunkDir(std::move(chunkDir)), m_allowOutside(allowOutside),
          m_meta(std::move(info)), m_scale(m_meta.scales[scale]), m_cacheLayers(cacheLayers),
          m_maxFileBytes(maxFileBytes) {
        describe();
    }

    Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) override {
        const auto& d = m_info.dim;
        if (Status s = checkSlab(m_info, z0, depth, m_chunkDir); !s) return s;
        if (depth == 0) return Status::ok();
        const uint32_t cz = m_scale.chunkSize[2];
        for (uint32_t layer = z0 / cz; layer <= (z0 + depth - 1) / cz; ++layer) {
            const uint32_t lz0 = std::max(z0, layer * cz);
            const uint32_t lz1 = std::min<uint64_t>(uint64_t(z0) + depth, uint64_t(layer + 1) * cz);
            uint64_t* slabPart = out + uint64_t(d[0]) * d[1] * (lz0 - z0);
            Status s = m_cacheLayers ? copyFromLayer(layer, lz0, lz1, slabPart) : decodeInto(layer, lz0, lz1, slabPart);
            if (!s) return s;
        }
        return Status::ok();
    }

    /// Rows for about their share of a slice's cost when chunk layers are cached (each layer is
    /// decoded once for all the bands of rows that read it, so a sparse scale is read a band at a
    /// time, not a slab of whole slices at a time); otherwise whole slices only.
    bool readsRows() const override { return m_cacheLayers; }

    Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) override {
        if (!m_cacheLayers || (y0 == 0 && rows == m_info.dim[1])) return InputSource::readRows(z0, depth, y0, rows, out);
        if (Status s = checkRows(m_info, z0, depth, y0, rows, m_chunkDir); !s) return s;
        const uint64_t W = m_info.dim[0], H = m_info.dim[1];
        for (uint32_t z = z0; z < z0 + depth; ++z) {
            const uint32_t layer = z / m_scale.chunkSize[2];
            if (Status s = holdLayer(layer); !s) return s;
            const auto from = m_layer.begin() + W * (y0 + H * (z - layer * m_scale.chunkSize[2]));
            std::copy(from, from + W * rows, out + W * rows * (z - z0));
        }
        return Status::ok();
    }

    uint64_t workingBytes() const override {
        return (m_layer.capacity() + m_chunk.capacity()) * sizeof(uint64_t) + m_index.bytes();
    }

    /// Reads the scale's chunk folder into the chunk index, keeping it within `budgetBytes`; an
    /// error when the folder cannot be listed, or holds too many files to index for its grid.
    Status listChunks(uint64_t budgetBytes) {
        m_index.start(budgetBytes);
        Status inner; // a failure listing a nested folder
        Status s = listFolder(m_chunkDir, [&](const char* name) {
            if (addFlat(name)) return true;
            uint32_t gx = 0;
            if (rangeIndex(name, std::strlen(name), 0, gx)) inner = listNested(m_chunkDir + "/" + name, gx);
            return inner.isOk();
        });
        m_index.finish();
        if (!s || !inner) return s ? inner : s;
        return m_index.checkLookups(m_chunkDir, product3(chunksAlong(0), chunksAlong(1), chunksAlong(2)));
    }

    /// Chunks with no file are background (0): boxes found in the chunk index, merged along x, y
    /// and z (ChunkIndex::absentBoxes), or, when the folder held too many files to index, one box
    /// per run along x found with a stat of each name a chunk may have (InputSource::uniformBoxes).
    /// A name that is there but refused (chunkFile's errors) is no box: the read reports it.
    void uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, std::vector<UniformBox>& out) override {
        out.clear();
        if (!checkRows(m_info, z0, depth, y0, rows, m_chunkDir) || depth == 0 || rows == 0) return;
        if (m_index.complete()) {
            const std::array<uint32_t, 3>& c = m_scale.chunkSize;
            m_index.absentBoxes({{c[0], c[1], c[2]}}, m_info.dim, z0, depth, y0, rows, 0, out);
            return;
        }
        const uint64_t zEnd = uint64_t(z0) + depth, yEnd = uint64_t(y0) + rows;
        const std::array<uint32_t, 3>& c = m_scale.chunkSize;
        for (uint32_t layer = z0 / c[2]; uint64_t(layer) * c[2] < zEnd; ++layer)
            for (uint32_t gy = y0 / c[1]; uint64_t(gy) * c[1] < yEnd; ++gy) {
                const uint32_t za = std::max(z0, layer * c[2]), zb = uint32_t(std::min<uint64_t>(zEnd, uint64_t(layer + 1) * c[2]));
                const uint32_t ya = std::max(y0, gy * c[1]), yb = uint32_t(std::min<uint64_t>(yEnd, uint64_t(gy + 1) * c[1]));
                int64_t run = -1; // where the current run of chunks without a file starts
                for (uint32_t gx = 0; gx <= chunksAlong(0); ++gx) {
                    bool background = false;
                    if (gx < chunksAlong(0)) {
                        // No name there at all (chunkFile's "none"): one stat a name, no path check.
                        background = true;
                        for (const std::string& name : chunkNames(chunkBox(gx, gy, layer)))
                            background = background && notRegularFile(m_chunkDir + "/" + name) == "missing";
                    }
                    if (background && run < 0) run = int64_t(gx) * c[0];
                    if (!background && run >= 0) {
                        const uint32_t xb = uint32_t(std::min<uint64_t>(m_info.dim[0], uint64_t(gx) * c[0]));
                        out.push_back({{{uint32_t(run), ya, za}}, {{xb, yb, zb}}, 0});
                        run = -1;
                    }
                }
            }
    }

private:
    /// Chunk (x, y) of `layer`: its voxel box relative to the volume, and its extent.
    struct Box {
        std::array<uint32_t, 3> lo{}, extent{};
    };
    Box chunkBox(uint32_t gx, uint32_t gy, uint32_t layer) const {
        const std::array<uint32_t, 3> g{{gx, gy, layer}};
        Box b;
        for (size_t i = 0; i < 3; ++i) {
            b.lo[i] = g[i] * m_scale.chunkSize[i];
            b.extent[i] = std::min(m_scale.chunkSize[i], m_info.dim[i] - b.lo[i]);
        }
        return b;
    }

    uint32_t chunksAlong(size_t axis) const {
        return uint32_t((uint64_t(m_info.dim[axis]) + m_scale.chunkSize[axis] - 1) / m_scale.chunkSize[axis]);
    }

    /// `<begin>-<end>`: the voxel range of chunk `g` along `axis` in chunk names (voxel_offset
    /// added, clipped at the volume's end; offsets and extents are bounded so nothing overflows).
    std::string rangeName(size_t axis, uint32_t g) const {
        const uint32_t lo = g * m_scale.chunkSize[axis];
        const int64_t begin = m_scale.voxelOffset[axis] + lo;
        return std::to_string(begin) + "-" + std::to_string(begin + std::min(m_scale.chunkSize[axis], m_info.dim[axis] - lo));
    }

    /// Reads `text` as the range of a chunk along `axis` exactly as rangeName writes it.
    bool rangeIndex(const char* text, size_t length, size_t axis, uint32_t& out) const {
        int64_t begin = 0;
        const std::from_chars_result r = std::from_chars(text, text + length, begin);
        if (r.ec != std::errc() || r.ptr == text + length || *r.ptr != '-') return false;
        const int64_t lo = begin - m_scale.voxelOffset[axis]; // both within 2^40: no overflow
        if (lo < 0 || lo % m_scale.chunkSize[axis] != 0 || lo / m_scale.chunkSize[axis] >= chunksAlong(axis)) return false;
        out = uint32_t(lo / m_scale.chunkSize[axis]);
        return rangeName(axis, out).compare(0, std::string::npos, text, length) == 0;
    }

    /// Indexes `name` when it is a flat chunk name (`x_y_z` or `x_y_z.gz`).
    bool addFlat(const char* name) {
        size_t length = std::strlen(name);
        if (length > 3 && std::strcmp(name + length - 3, ".gz") == 0) length -= 3;
        std::array<uint32_t, 3> g{};
        const char* part = name;
        for (size_t axis = 0; axis < 3; ++axis) {
            const char* end = axis < 2 ? static_cast<const char*>(std::memchr(part, '_', size_t(name + length - part))) : name + length;
            if (!end || !rangeIndex(part, size_t(end - part), axis, g[axis])) return false;
            part = end + 1;
        }
        m_index.add(g[0], g[1], g[2]);
        return true;
    }

    /// Indexes the nested chunk names `<x>/<y>/<z>` below folder `<x>` (chunk gx along x).
    Status listNested(const std::string& xDir, uint32_t gx) {
        Status inner;
        Status s = listFolder(xDir, [&](const char* yName) {
            uint32_t gy = 0;
            if (!rangeIndex(yName, std::strlen(yName), 1, gy)) return true;
            inner = listFolder(xDir + "/" + yName, [&](const char* zName) {
                uint32_t gz = 0;
                if (rangeIndex(zName, std::strlen(zName), 2, gz)) m_index.add(gx, gy, gz);
                return true;
            });
            return inner.isOk();
        });
        return s ? inner : s;
    }

    /// Voxels [lz0, lz1) of every chunk of `layer` into out (a slab starting at z = lz0). With the
    /// index, rows of chunks some of which have no file are zeroed a row of voxels at a time and
    /// only the chunks with a file are read; without it, each chunk is looked up by name.
    Status decodeInto(uint32_t layer, uint32_t lz0, uint32_t lz1, uint64_t* out) {
        const uint64_t W = m_info.dim[0], H = m_info.dim[1];
        for (uint32_t gy = 0; gy < chunksAlong(1); ++gy) {
            if (!m_index.complete()) {
                for (uint32_t gx = 0; gx < chunksAlong(0); ++gx)
                    if (Status s = decodeAndCopy(chunkBox(gx, gy, layer), lz0, lz1, out); !s) return s;
                continue;
            }
            const ChunkIndex::Range row = m_index.row(gy, layer);
            if (uint64_t(row.second - row.first) < chunksAlong(0)) {
                const Box b = chunkBox(0, gy, layer);
                for (uint32_t z = lz0; z < lz1; ++z) {
                    uint64_t* first = out + W * (b.lo[1] + H * (z - lz0));
                    std::fill(first, first + W * b.extent[1], 0);
                }
            }
            for (const ChunkIndex::Position* p = row.first; p != row.second; ++p)
                if (Status s = decodeAndCopy(chunkBox(p->x, gy, layer), lz0, lz1, out); !s) return s;
        }
        return Status::ok();
    }

    /// Slices [lz0, lz1) of chunk `b` into out (a slab starting at z = lz0).
    Status decodeAndCopy(const Box& b, uint32_t lz0, uint32_t lz1, uint64_t* out) {
        const uint64_t W = m_info.dim[0], H = m_info.dim[1];
        if (Status s = decodeChunk(b); !s) return s;
        for (uint32_t z = lz0; z < lz1; ++z)
            for (uint32_t y = 0; y < b.extent[1]; ++y) {
                const uint64_t* from = m_chunk.data() + uint64_t(b.extent[0]) * (y + uint64_t(b.extent[1]) * (z - b.lo[2]));
                std::copy(from, from + b.extent[0], out + b.lo[0] + W * ((b.lo[1] + y) + H * (z - lz0)));
            }
        return Status::ok();
    }

    /// The layer from the cache (decoding it first when another one is cached).
    Status copyFromLayer(uint32_t layer, uint32_t lz0, uint32_t lz1, uint64_t* out) {
        const uint64_t plane = uint64_t(m_info.dim[0]) * m_info.dim[1];
        const uint32_t top = layer * m_scale.chunkSize[2];
        if (Status s = holdLayer(layer); !s) return s;
        std::copy(m_layer.begin() + plane * (lz0 - top), m_layer.begin() + plane * (lz1 - top), out);
        return Status::ok();
    }

    /// Makes m_layer hold chunk layer `layer`, decoded (when another one is held).
    Status holdLayer(uint32_t layer) {
        if (m_layerIndex == int64_t(layer)) return Status::ok();
        const uint64_t plane = uint64_t(m_info.dim[0]) * m_info.dim[1];
        const uint32_t top = layer * m_scale.chunkSize[2];
        m_layerIndex = -1;
        const uint32_t depth = std::min(m_scale.chunkSize[2], m_info.dim[2] - top);
        if (Status s = resizeOrFail(m_layer, size_t(plane * depth), m_chunkDir); !s) return s;
        if (Status s = decodeInto(layer, top, top + depth, m_layer.data()); !s) return s;
        m_layerIndex = layer;
        return Status::ok();
    }

    /// The chunk's file name(s): flat, gzip, nested. Empty when none exists (background). A name
    /// that is there but no regular file (a dangling link, a FIFO, a folder) is an error, not
    /// background: that would silently read as zeros (and a FIFO would block). A chunk that is a
    /// symbolic link out of the dataset is refused as the scale key would be (a raw chunk of the
    /// right size would copy any file into the output).
    /// The names a chunk's file may have, relative to the scale's folder: flat, gzip, nested.
    std::array<std::string, 3> chunkNames(const Box& b) const {
        std::array<std::string, 3> range;
        for (size_t i = 0; i < 3; ++i) range[i] = rangeName(i, b.lo[i] / m_scale.chunkSize[i]);
        const std::string flat = range[0] + "_" + range[1] + "_" + range[2];
        return {flat, flat + ".gz", range[0] + "/" + range[1] + "/" + range[2]};
    }

    Result<std::string> chunkFile(const Box& b) const {
        for (const std::string& name : chunkNames(b)) {
            const std::string candidate = m_chunkDir + "/" + name;
            const std::string kind = notRegularFile(candidate);
            if (kind == "missing") continue;
            if (!kind.empty()) return fail(candidate, "chunk is " + kind + ", not a regular file");
            if (!m_allowOutside)
                if (Result<std::string> inside =
                        resolveInside({m_scale.key + "/" + name, m_root, "chunk", "the dataset's folder"}, false);
                    !inside)
                    return Status(inside.status()).prefix(candidate);
            return candidate;
        }
        return std::string();
    }

    /// Reads and decodes one chunk into m_chunk (extent voxels, x fastest).
    Status decodeChunk(const Box& b) {
        const uint64_t voxels = uint64_t(b.extent[0]) * b.extent[1] * b.extent[2]; // <= the open-time chunk
        if (Status s = resizeOrFail(m_chunk, size_t(voxels), m_chunkDir); !s) return s;
        Result<std::string> named = chunkFile(b);
        if (!named) return named.status();
        const std::string& file = *named;
        if (file.empty()) {
            std::fill(m_chunk.begin(), m_chunk.end(), 0);
            return Status::ok();
        }
        const bool raw = m_scale.encoding == PrecomputedScale::Encoding::Raw;
        const uint64_t rawBytes = voxels * typeBytes(m_info.type);
        // A raw chunk's size is known; a plain file of another size is reported without reading it.
        if (raw && !endsWithNoCase(file, ".gz")) {
            Result<uint64_t> size = fileSize(file);
            if (!size) return size.status();
            if (*size != rawBytes)
                return fail(file, "raw chunk has " + std::to_string(*size) + " bytes, expected " +
                                      std::to_string(rawBytes) + " (" + chunkText(b.extent) + " voxels of " +
                                      labelTypeName(m_info.type) + ")");
        }
        const uint64_t bound = raw ? rawBytes + 1 : compressedSegmentationBound(m_info.type, b.extent, m_scale.blockSize);
        std::vector<uint8_t> bytes; // freed once decoded: not held between calls
        const uint64_t limit = std::min(bound, m_maxFileBytes);
        if (Status s = endsWithNoCase(file, ".gz") ? inflateChunkFile(file, limit, bytes) : readBoundedFile(file, limit, bytes); !s)
            return s;
        const Status s = raw ? decodeRawChunk(bytes.data(), bytes.size(), m_info.type, b.extent, m_chunk.data())
                             : decodeCompressedSegmentation(bytes.data(), bytes.size(), m_info.type, b.extent,
                                                            m_scale.blockSize, m_chunk.data());
        if (!s) return fail(file, s.message());
        return Status::ok();
    }

    void describe() {
        const PrecomputedScale& s = m_scale;
        m_info.dim = s.size;
        m_info.type = m_meta.type;
        for (size_t i = 0; i < 3; ++i) {
            m_info.geometry.spacing[i] = s.resolution[i];
            m_info.geometry.origin[i] = double(s.voxelOffset[i]) * s.resolution[i];
        }
        m_info.format = "precomputed";
        m_info.detail = "scale " + s.key + ", chunks " + chunkText(s.chunkSize) + ", " + encodingText(s) + ", " +
                        labelTypeName(m_info.type);
    }

    static std::string chunkText(const std::array<uint32_t, 3>& e) {
        return std::to_string(e[0]) + "x" + std::to_string(e[1]) + "x" + std::to_string(e[2]);
    }

    std::string m_root;
    std::string m_chunkDir;
    bool m_allowOutside;
    PrecomputedInfo m_meta;
    PrecomputedScale m_scale;
    bool m_cacheLayers;
    uint64_t m_maxFileBytes; ///< the most bytes a chunk file may hold (inflated), from the working-memory bound
    std::vector<uint64_t> m_chunk; ///< one decoded chunk
    std::vector<uint64_t> m_layer; ///< the decoded chunk layer m_layerIndex (when caching)
    int64_t m_layerIndex = -1;
    ChunkIndex m_index;            ///< the chunks that have a file (when complete())
};

} // namespace

bool claimsPrecomputed(const std::string& path) {
    const PrecomputedPath p = splitPath(path);
    // An `info` that is there but no file (a FIFO, a link to a device) is claimed, to be refused
    // by name (openPrecomputed), not taken for a TIFF folder without slices.
    return isDir(p.dir) && (isFile(p.dir + "/info") || existsButNotRegular(p.dir + "/info"));
}

Result<std::unique_ptr<InputSource>> openPrecomputed(const std::string& path, const InputOptions& options) {
    const PrecomputedPath p = splitPath(path);
    const std::string infoPath = p.dir + "/info";
    if (Status s = regularFile(infoPath); !s) return s;
    Result<std::vector<uint8_t>> text = readFile(infoPath, kMaxMetadataBytes);
    if (!text) return text.status();
    Result<PrecomputedInfo> info = parsePrecomputedInfo(text->data(), text->size());
    if (!info) return fail(infoPath, info.message());
    Result<size_t> index = selectScale(infoPath, *info, p.selector);
    if (!index) return index.status();
    const PrecomputedScale& scale = info->scales[*index];
    if (Status s = checkPrecomputedScale(*info, scale); !s) return fail(infoPath, s.message());
    Result<std::string> named =
        resolveInside({scale.key, p.dir, "scale key", "the dataset's folder"}, options.allowOutsidePaths);
    if (!named) return Status(named.status()).prefix(infoPath);
    const std::string chunkDir = *named;
    if (!isDir(chunkDir))
        return fail(infoPath, "the chunk folder of scale " + quotedText(scale.key) + " (" + chunkDir + ") does not exist");

    // Working memory: one decoded chunk and one chunk file always (the file at most its
    // encoding's worst case, capped at what the bound leaves); the chunk layer too when it fits.
    std::array<uint64_t, 3> chunk{};
    std::array<uint32_t, 3> chunk32{};
    for (size_t i = 0; i < 3; ++i) chunk32[i] = uint32_t(chunk[i] = std::min(scale.chunkSize[i], scale.size[i]));
    const uint64_t chunkBytes = mulSaturate(product3(chunk[0], chunk[1], chunk[2]), 8);
    const uint64_t layerBytes = mulSaturate(product3(scale.size[0], scale.size[1], chunk[2]), 8);
    if (chunkBytes >= options.maxWorkingBytes)
        return fail(infoPath, "a decoded " + dimText(chunk) + " chunk needs " +
                                  (chunkBytes == kSaturated ? std::string("more than 2^64") : std::to_string(chunkBytes)) +
                                  " bytes and its file more, beyond the working memory limit of " +
                                  std::to_string(options.maxWorkingBytes));
    const uint64_t worstFile = scale.encoding == PrecomputedScale::Encoding::Raw
                                   ? chunkBytes / 8 * typeBytes(info->type) + 1
                                   : compressedSegmentationBound(info->type, chunk32, scale.blockSize);
    const uint64_t maxFileBytes = std::min(worstFile, options.maxWorkingBytes - chunkBytes);
    const uint64_t left = options.maxWorkingBytes - chunkBytes - maxFileBytes;
    const bool cacheLayers = layerBytes <= left;

    auto source = std::make_unique<PrecomputedSource>(p.dir, chunkDir, options.allowOutsidePaths, std::move(*info), *index,
                                                      cacheLayers, maxFileBytes);
    // The chunk index takes what the chunk, its file and the layer leave.
    if (Status s = source->listChunks(left - (cacheLayers ? layerBytes : 0)); !s) return s;
    return std::unique_ptr<InputSource>(std::move(source));
}

} // namespace inputs
} // namespace csgv
