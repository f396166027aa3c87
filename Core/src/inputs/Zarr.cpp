// SPDX-License-Identifier: MIT
/// @file Zarr.cpp
/// @brief Zarr v2 arrays and OME-Zarr multiscale images and label groups (`DIR.zarr[/path]`),
/// read chunk by chunk. The path names an array (a folder with `.zarray`), an OME multiscale
/// group (its first, full-resolution dataset is read) or an OME `labels` group (its first label
/// image). Metadata parsing and chunk decoding are in ZarrFormat.cpp. The paths that metadata
/// name (a multiscale dataset's `path`, a label image's name) must lie inside the group that names
/// them, and chunk files inside the folder the user named, unless InputOptions::allowOutsidePaths
/// (PathGuard.h); a chunk name that is there but no regular file is an error, not fill_value.
///
/// Working memory: when one layer of chunks (every chunk sharing a z chunk index) fits
/// InputOptions::maxWorkingBytes, the decoded chunks of the current layer are kept, so a chunk
/// deeper than the caller's slab is decoded once; otherwise each request decodes the chunks it
/// touches one at a time (one decoded chunk). Either way, plus one compressed chunk file (at most
/// the decoded chunk size + 1/16 + 4 KiB: a larger file is refused, not read). Chunks with no file
/// are fill_value and are listed as uniform boxes, so a volume of them compresses per brick, not
/// per voxel (uniformBoxes).
///
/// Which chunks have a file is learnt by listing the array's folder once when it is opened (with
/// dimension_separator "/", the nested folders of the names that can be chunk keys), into a
/// ChunkIndex (InputCommon.h): a chunk not listed is fill_value without a stat of its name, so
/// time goes with the chunk files, not with the chunk names the grid declares (a 1024^3 array of
/// 1-voxel chunks and no file took an hour). The layer cache then holds a slot for each chunk of
/// a layer that has a file. A folder with more chunk files than the index holds (its bound is in
/// ChunkIndex) is read as before, a stat a chunk, unless that would mean far more names than files.
#include "InputCommon.h"

#include "csgv/base/Checked.h"
#include "csgv/inputs/PathGuard.h"
#include "csgv/inputs/ZarrFormat.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>

namespace csgv {
namespace inputs {

namespace fs = std::filesystem;

namespace {

std::string stripSlashes(std::string p) {
    while (p.size() > 1 && p.back() == '/') p.pop_back();
    return p;
}

/// Reads a whole small file (metadata), refusing large ones.
Result<std::string> readText(const std::string& path) {
    Result<std::vector<uint8_t>> bytes = readFile(path, kMaxMetadataBytes);
    if (!bytes) return bytes.status();
    return std::string(bytes->begin(), bytes->end());
}

Result<ZarrAttrs> readAttrs(const std::string& dir) {
    const std::string p = dir + "/.zattrs";
    if (!isFile(p)) return ZarrAttrs();
    Result<std::string> text = readText(p);
    if (!text) return text.status();
    Result<ZarrAttrs> a = parseZattrs(*text);
    if (!a) return fail(p, a.message());
    return a;
}

/// The path of `dir` inside its `.zarr` root, for details ("labels/cells/0").
std::string relativeName(const std::string& dir) {
    const std::string l = lower(dir);
    const size_t at = l.rfind(".zarr/");
    if (at != std::string::npos) return dir.substr(at + 6);
    return fs::path(dir).filename().string();
}

/// @brief What a path resolved to: the array folder, and the OME multiscale metadata that
/// places it (none for a bare array).
struct Resolved {
    std::string arrayDir;
    ZarrAttrs multiscale;     ///< of the group holding the array; hasMultiscales false when none
    int level = -1;           ///< index of the array in multiscale.datasets; -1 when none
    std::string what;         ///< detail prefix ("label image cells (first of 2): ")
};

/// The array a multiscale group's `level` names (inside the group unless allowOutside).
Result<Resolved> levelOf(const std::string& group, ZarrAttrs attrs, size_t level, const std::string& what,
                         bool allowOutside) {
    Resolved r;
    Result<std::string> named =
        resolveInside({attrs.datasets[level].path, group, "multiscale dataset path", "the group's folder"}, allowOutside);
    if (!named) return Status(named.status()).prefix(group);
    r.arrayDir = *named;
    if (!isFile(r.arrayDir + "/.zarray"))
        return fail(group, "multiscale dataset " + quotedText(attrs.datasets[level].path) + " has no .zarray");
    r.multiscale = std::move(attrs);
    r.level = int(level);
    r.what = what;
    return r;
}

/// Names the Zarr things inside a folder that is neither an array nor an OME group.
std::string describeFolder(const std::string& dir, const ZarrAttrs& attrs) {
    std::string found = isFile(dir + "/.zgroup") ? "a group (.zgroup)" : "no .zarray or .zgroup";
    // A metadata name that is there but no file (a FIFO, a link to a device) is said as such.
    for (const char* meta : {"/.zarray", "/.zgroup", "/.zattrs"}) {
        const std::string kind = notRegularFile(dir + meta);
        if (!kind.empty() && kind != "missing") found += " ('" + dir + meta + "' is " + kind + ", not a file)";
    }
    if (isFile(dir + "/.zattrs")) found += attrs.hasLabels ? ", .zattrs with an empty labels list" : ", .zattrs without multiscales or labels";
    std::vector<std::string> children;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end && children.size() < 8; it.increment(ec))
        if (isFile(it->path().string() + "/.zarray") || isFile(it->path().string() + "/.zgroup"))
            children.push_back(it->path().filename().string());
    std::sort(children.begin(), children.end());
    if (!children.empty()) {
        found += "; it holds";
        for (const std::string& c : children) found += " " + quotedText(c);
        found += " (name one in the path)";
    }
    return found;
}

/// What `path` names; the paths that metadata name (a multiscale dataset, a label image) must lie
/// inside the group that names them unless allowOutside.
Result<Resolved> resolve(const std::string& path, bool allowOutside) {
    const std::string dir = stripSlashes(path);
    if (isFile(dir + "/.zarray")) {
        // An array: a level of an OME multiscale group when its parent says so.
        Resolved r;
        r.arrayDir = dir;
        const fs::path p(dir);
        Result<ZarrAttrs> parent = readAttrs(p.parent_path().string());
        if (parent && parent->hasMultiscales)
            for (size_t i = 0; i < parent->datasets.size(); ++i)
                if (parent->datasets[i].path == p.filename().string()) {
                    r.multiscale = std::move(*parent);
                    r.level = int(i);
                    break;
                }
        return r;
    }
    if (!isDir(dir)) return fail(dir, "no such Zarr folder");
    Result<ZarrAttrs> attrs = readAttrs(dir);
    if (!attrs) return attrs.status();
    if (attrs->hasMultiscales) return levelOf(dir, std::move(*attrs), 0, "", allowOutside);
    if (attrs->hasLabels && !attrs->labels.empty()) {
        const std::string name = attrs->labels[0];
        Result<std::string> named = resolveInside({name, dir, "label image", "the labels group's folder"}, allowOutside);
        if (!named) return Status(named.status()).prefix(dir);
        const std::string image = *named;
        Result<ZarrAttrs> imageAttrs = readAttrs(image);
        if (!imageAttrs) return imageAttrs.status();
        if (!imageAttrs->hasMultiscales) return fail(image, "label image has no multiscales in its .zattrs");
        const std::string what = "label image " + quotedText(name) + " (first of " + std::to_string(attrs->labels.size()) + "): ";
        return levelOf(image, std::move(*imageAttrs), 0, what, allowOutside);
    }
    return fail(dir, "not a Zarr array or OME-Zarr image: found " + describeFolder(dir, *attrs));
}

/// @brief Reads a Zarr v2 array's z slabs chunk by chunk (see the file's @brief for memory).
class ZarrSource : public InputSource {
public:
    Status open(const std::string& path, const InputOptions& options);
    Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) override;
    /// Rows for about their share of a slice's cost when the layer is cached: each chunk is then
    /// decoded once for all the bands of rows that read it (a sparse array is read a band at a
    /// time, not a slab of whole slices at a time). Otherwise whole slices, as chunk by chunk.
    bool readsRows() const override { return m_cacheLayer; }
    Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) override;
    uint64_t workingBytes() const override;
    /// Chunks with no file at all are fill_value (when it is an integer label): boxes found in the
    /// chunk index, merged along x, y and z (ChunkIndex::absentBoxes), or, when the folder held too
    /// many files to index, one box per run along x found with a stat a chunk.
    void uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, std::vector<UniformBox>& out) override;

private:
    /// One decoded chunk of the cached layer (or the scratch chunk).
    struct Chunk {
        uint64_t layer = ~uint64_t(0); ///< the z chunk index this slot holds a chunk of
        bool loaded = false;
        bool missing = false; ///< no file: fill_value everywhere
        std::vector<uint8_t> bytes;
    };

    Status readArray(const Resolved& r);
    Status findAxes(const Resolved& r);
    void placeInSpace(const Resolved& r);
    Status planMemory(const InputOptions& options);
    Status listChunks(uint64_t budgetBytes);
    Status listLevel(const std::string& dir, size_t axis, std::array<uint32_t, 3>& at);
    Status listFlat();
    bool chunkIndexOf(const char* text, size_t length, size_t axis, uint32_t& out) const;
    void place(size_t axis, uint32_t index, std::array<uint32_t, 3>& at) const;
    std::string chunkPath(uint64_t iz, uint64_t iy, uint64_t ix) const;
    Status load(uint64_t iz, uint64_t iy, uint64_t ix, Chunk& chunk);
    /// Chunk (ix, iy, iz), decoded; `slot` is its place in the layer cache.
    Result<Chunk*> chunkAt(uint64_t iz, uint64_t iy, uint64_t ix, size_t slot);
    /// Rows [y0, y1) of the slices from z0 on, into out[x + W * ((y - y0) + (y1 - y0) * (z - z0))].
    struct Target {
        uint32_t z0, y0, y1;
        uint64_t* out;
    };
    Status readRegion(const Target& t, uint32_t depth);
    Status readRow(uint64_t iz, uint64_t iy, const ChunkIndex::Position* layerFirst, const Target& t, uint32_t zs, uint32_t ze);
    Status readRowByName(uint64_t iz, uint64_t iy, const Target& t, uint32_t zs, uint32_t ze);
    void fillRows(uint64_t iy, const Target& t, uint32_t zs, uint32_t ze) const;
    Status copyChunk(const Chunk& chunk, uint64_t iz, uint64_t iy, uint64_t ix, const Target& t, uint32_t zs, uint32_t ze) const;

    std::string m_dir;
    /// Chunk files must lie inside the folder the user named (m_root; m_dir as seen from it)
    /// unless options allow otherwise: a chunk that links out would copy any file into the output.
    std::string m_root, m_dirFromRoot;
    bool m_allowOutside = false;
    ZarrArray m_array;
    int m_axis[3] = {-1, -1, -1};     ///< array axis of x, y, z (-1: z absent, a 2D image)
    uint64_t m_chunk[3] = {1, 1, 1};  ///< chunk extent along x, y, z
    uint64_t m_stride[3] = {0, 0, 0}; ///< element stride inside a chunk along x, y, z
    uint64_t m_grid[3] = {1, 1, 1};   ///< chunks along x, y, z
    uint64_t m_maxFileBytes = 0;
    ChunkIndex m_index;               ///< the chunks that have a file (when complete())
    bool m_cacheLayer = false;
    /// The decoded chunks of one layer: a slot for each chunk of a layer that has a file (its
    /// place among the layer's chunks in m_index), or m_grid[0] * m_grid[1] when not indexed.
    std::vector<Chunk> m_layer;
    Chunk m_scratch;
    std::vector<uint8_t> m_file;      ///< compressed bytes of the chunk being decoded
};

Status ZarrSource::readArray(const Resolved& r) {
    m_dir = r.arrayDir;
    const std::string meta = m_dir + "/.zarray";
    Result<std::string> text = readText(meta);
    if (!text) return text.status();
    Result<ZarrArray> a = parseZarray(*text);
    if (!a) return fail(meta, a.message());
    m_array = std::move(*a);
    return Status::ok();
}

Status ZarrSource::findAxes(const Resolved& r) {
    const size_t n = m_array.shape.size();
    const std::vector<std::string>& names = r.multiscale.axes;
    if (!names.empty() && names.size() != n)
        return fail(m_dir, "the OME axes list " + std::to_string(names.size()) + " axes but the array has " + std::to_string(n));
    if (names.empty()) {
        m_axis[0] = int(n) - 1;
        m_axis[1] = int(n) - 2;
        m_axis[2] = n >= 3 ? int(n) - 3 : -1;
    } else {
        for (size_t i = 0; i < n; ++i) {
            const std::string a = lower(names[i]);
            if (a == "x") m_axis[0] = int(i);
            else if (a == "y") m_axis[1] = int(i);
            else if (a == "z") m_axis[2] = int(i);
        }
        if (m_axis[0] < 0 || m_axis[1] < 0) return fail(m_dir, "the OME axes have no x and y");
    }
    for (size_t i = 0; i < n; ++i) {
        if (int(i) == m_axis[0] || int(i) == m_axis[1] || int(i) == m_axis[2]) continue;
        if (m_array.shape[i] != 1) {
            const std::string name = names.empty() ? "axis " + std::to_string(i) : "axis " + quotedText(names[i]);
            return fail(m_dir, name + " has size " + std::to_string(m_array.shape[i]) +
                                   "; only single-channel, single-timepoint images are label volumes");
        }
    }
    // Strides of each array axis inside a (full-size) chunk, C or F order.
    std::vector<uint64_t> stride(n, 1);
    if (m_array.fortranOrder)
        for (size_t i = 1; i < n; ++i) stride[i] = stride[i - 1] * m_array.chunks[i - 1];
    else
        for (size_t i = n - 1; i-- > 0;) stride[i] = stride[i + 1] * m_array.chunks[i + 1];
    for (int k = 0; k < 3; ++k) {
        const uint64_t extent = m_axis[k] < 0 ? 1 : m_array.shape[size_t(m_axis[k])];
        if (extent == 0 || extent > UINT32_MAX)
            return fail(m_dir, "array extent " + std::to_string(extent) + " along " + "xyz"[k] + " is not a volume extent (1 to 2^32-1)");
        m_info.dim[size_t(k)] = uint32_t(extent);
        m_chunk[k] = m_axis[k] < 0 ? 1 : m_array.chunks[size_t(m_axis[k])];
        m_stride[k] = m_axis[k] < 0 ? 0 : stride[size_t(m_axis[k])];
        m_grid[k] = (extent + m_chunk[k] - 1) / m_chunk[k];
    }
    return Status::ok();
}

void ZarrSource::placeInSpace(const Resolved& r) {
    if (r.level < 0) return;
    const OmeDataset& level = r.multiscale.datasets[size_t(r.level)];
    const size_t n = m_array.shape.size();
    auto pick = [n](const std::vector<double>& v, int axis, double otherwise) {
        return axis >= 0 && v.size() == n ? v[size_t(axis)] : otherwise;
    };
    for (int k = 0; k < 3; ++k) {
        const double gs = pick(r.multiscale.globalScale, m_axis[k], 1.0);
        const double gt = pick(r.multiscale.globalTranslation, m_axis[k], 0.0);
        m_info.geometry.spacing[size_t(k)] = gs * pick(level.scale, m_axis[k], 1.0);
        m_info.geometry.origin[size_t(k)] = gs * pick(level.translation, m_axis[k], 0.0) + gt;
    }
}

Status ZarrSource::planMemory(const InputOptions& options) {
    const uint64_t chunkBytes = m_array.chunkBytes(); // at most 2 GiB (parseZarray): no sum wraps
    m_maxFileBytes = chunkBytes + chunkBytes / 16 + 4096;
    const uint64_t budget = options.maxWorkingBytes;
    if (chunkBytes + m_maxFileBytes > budget)
        return fail(m_dir, "a chunk of " + std::to_string(chunkBytes) + " bytes does not fit the working memory bound of " +
                               std::to_string(budget) + " bytes");
    // The index takes what one decoded chunk and its file leave; the layer cache what is left then.
    if (Status s = listChunks(budget - chunkBytes - m_maxFileBytes); !s) return s;
    const uint64_t slots = m_index.complete() ? m_index.largestLayer() : mulSaturate(m_grid[0], m_grid[1]);
    const uint64_t layerBytes = mulSaturate(slots, chunkBytes + sizeof(Chunk));
    m_cacheLayer = layerBytes <= budget - m_maxFileBytes - m_index.bytes();
    if (m_cacheLayer) return resizeOrFail(m_layer, size_t(slots), m_dir);
    return Status::ok();
}

/// Lists the chunk files into m_index: the array folder's names `i.j.k`, or with the separator
/// "/" the folders `i`, `i/j` and files `i/j/k`. Only names that are chunk keys of the grid as
/// chunkPath writes them count (and only such folders are listed), so a stray file costs nothing.
Status ZarrSource::listChunks(uint64_t budgetBytes) {
    m_index.start(budgetBytes);
    std::array<uint32_t, 3> at{{0, 0, 0}};
    Status s = m_array.separator == '/' ? listLevel(m_dir, 0, at) : listFlat();
    m_index.finish();
    if (!s) return s;
    return m_index.checkLookups(m_dir, product3(m_grid[0], m_grid[1], m_grid[2]));
}

Status ZarrSource::listFlat() {
    const size_t n = m_array.shape.size();
    return listFolder(m_dir, [&](const char* name) {
        std::array<uint32_t, 3> at{{0, 0, 0}};
        const char* part = name;
        for (size_t axis = 0; axis < n; ++axis) {
            const char* end = std::strchr(part, '.');
            if ((end == nullptr) != (axis + 1 == n)) return true; // too few or too many parts
            if (!end) end = part + std::strlen(part);
            uint32_t index = 0;
            if (!chunkIndexOf(part, size_t(end - part), axis, index)) return true;
            place(axis, index, at);
            part = end + 1;
        }
        m_index.add(at[0], at[1], at[2]);
        return true;
    });
}

Status ZarrSource::listLevel(const std::string& dir, size_t axis, std::array<uint32_t, 3>& at) {
    const bool last = axis + 1 == m_array.shape.size();
    Status inner; // a failure listing a folder below, which ends this listing too
    Status s = listFolder(dir, [&](const char* name) {
        uint32_t index = 0;
        if (!chunkIndexOf(name, std::strlen(name), axis, index)) return true;
        std::array<uint32_t, 3> here = at;
        place(axis, index, here);
        if (last) m_index.add(here[0], here[1], here[2]);
        else inner = listLevel(dir + "/" + name, axis + 1, here); // at most 5 folders open at once
        return inner.isOk();
    });
    return s ? inner : s;
}

/// Reads `text` as a chunk key's index along array axis `axis`: decimal as chunkPath writes it (no
/// sign, no leading zero) and inside the grid (0 along an axis that is not x, y or z).
bool ZarrSource::chunkIndexOf(const char* text, size_t length, size_t axis, uint32_t& out) const {
    if (length == 0 || length > 10 || (text[0] == '0' && length > 1)) return false;
    uint64_t v = 0;
    for (size_t i = 0; i < length; ++i) {
        if (text[i] < '0' || text[i] > '9') return false;
        v = v * 10 + uint64_t(text[i] - '0');
    }
    uint64_t bound = 1;
    for (int k = 0; k < 3; ++k)
        if (m_axis[k] == int(axis)) bound = m_grid[k];
    if (v >= bound) return false;
    out = uint32_t(v);
    return true;
}

/// Puts a chunk key's index along array axis `axis` into its grid position (x, y, z).
void ZarrSource::place(size_t axis, uint32_t index, std::array<uint32_t, 3>& at) const {
    for (int k = 0; k < 3; ++k)
        if (m_axis[k] == int(axis)) at[size_t(k)] = index;
}

Status ZarrSource::open(const std::string& path, const InputOptions& options) {
    Result<Resolved> r = resolve(path, options.allowOutsidePaths);
    if (!r) return r.status();
    m_allowOutside = options.allowOutsidePaths;
    m_root = stripSlashes(path);
    std::error_code ec;
    m_dirFromRoot = fs::path(r->arrayDir).lexically_normal().lexically_relative(fs::path(m_root).lexically_normal()).string();
    if (m_dirFromRoot.empty()) m_dirFromRoot = fs::absolute(r->arrayDir, ec).string();
    for (auto step : {&ZarrSource::readArray, &ZarrSource::findAxes})
        if (Status s = (this->*step)(*r); !s) return s;
    placeInSpace(*r);
    if (Status s = planMemory(options); !s) return s;
    m_info.type = m_array.type;
    m_info.format = "Zarr";
    std::string chunks;
    for (uint64_t c : m_array.chunks) chunks += (chunks.empty() ? "" : "x") + std::to_string(c);
    const std::string name = relativeName(m_dir);
    m_info.detail = r->what + "array " + (name.empty() ? std::string(".") : name) + ", chunks " + chunks + ", " +
                    m_array.compressorText + ", " + (m_array.fortranOrder ? "F" : "C") + " order";
    return Status::ok();
}

std::string ZarrSource::chunkPath(uint64_t iz, uint64_t iy, uint64_t ix) const {
    std::string key;
    const uint64_t index[3] = {ix, iy, iz};
    for (size_t i = 0; i < m_array.shape.size(); ++i) {
        uint64_t v = 0;
        for (int k = 0; k < 3; ++k)
            if (m_axis[k] == int(i)) v = index[k];
        key += (i == 0 ? "" : std::string(1, m_array.separator)) + std::to_string(v);
    }
    return m_dir + "/" + key;
}

Status ZarrSource::load(uint64_t iz, uint64_t iy, uint64_t ix, Chunk& chunk) {
    const std::string p = chunkPath(iz, iy, ix);
    chunk.loaded = true;
    chunk.missing = false;
    // Only a chunk with no name at all was never written (fill_value everywhere): a dangling link
    // or a FIFO in its place is an error, not background (and a FIFO is never opened: it blocks).
    const std::string kind = notRegularFile(p);
    if (kind == "missing") {
        chunk.missing = true;
        chunk.bytes.clear();
        chunk.bytes.shrink_to_fit();
        return Status::ok();
    }
    if (!kind.empty()) {
        chunk.loaded = false;
        return fail(p, "chunk is " + kind + ", not a regular file");
    }
    if (!m_allowOutside) {
        const std::string key = p.substr(m_dir.size() + 1);
        Result<std::string> inside =
            resolveInside({m_dirFromRoot == "." ? key : m_dirFromRoot + "/" + key, m_root, "chunk", "the dataset's folder"}, false);
        if (!inside) {
            chunk.loaded = false;
            return Status(inside.status()).prefix(p);
        }
    }
    Result<int> fd = openRegularFile(p);
    CFile f(fd ? ::fdopen(*fd, "rb") : nullptr);
    if (!f.get()) {
        chunk.loaded = false;
        if (fd) ::close(*fd);
        return fail(p, "cannot open chunk: " + (fd ? std::string(std::strerror(errno)) : fd.message()));
    }
    std::error_code ec;
    const uint64_t size = fs::file_size(p, ec);
    if (ec || size > m_maxFileBytes) {
        chunk.loaded = false;
        return fail(p, ec ? "cannot size chunk file" : "chunk file of " + std::to_string(size) + " bytes is larger than any encoding of its " +
                                                            std::to_string(m_array.chunkBytes()) + " decoded bytes");
    }
    if (Status s = resizeOrFail(m_file, size_t(size), p); !s) {
        chunk.loaded = false;
        return s;
    }
    if (size && std::fread(m_file.data(), 1, size_t(size), f.get()) != size) {
        chunk.loaded = false;
        return fail(p, "read error or file shrank while reading the chunk");
    }
    Status s = decodeZarrChunk(m_array, m_file.data(), m_file.size(), chunk.bytes);
    if (!s) {
        chunk.loaded = false;
        return fail(p, s.message());
    }
    return Status::ok();
}

Result<ZarrSource::Chunk*> ZarrSource::chunkAt(uint64_t iz, uint64_t iy, uint64_t ix, size_t slot) {
    if (!m_cacheLayer) {
        if (Status s = load(iz, iy, ix, m_scratch); !s) return s;
        return &m_scratch;
    }
    Chunk& c = m_layer[slot];
    if (c.layer != iz) { // the slot held a chunk of another layer (its bytes are reused)
        c.layer = iz;
        c.loaded = false;
    }
    if (!c.loaded)
        if (Status s = load(iz, iy, ix, c); !s) return s;
    return &c;
}

Status ZarrSource::copyChunk(const Chunk& chunk, uint64_t iz, uint64_t iy, uint64_t ix, const Target& t, uint32_t zs,
                             uint32_t ze) const {
    const uint64_t W = m_info.dim[0], H = m_info.dim[1];
    const uint64_t x0 = ix * m_chunk[0], x1 = std::min<uint64_t>(W, x0 + m_chunk[0]);
    const uint64_t cy0 = iy * m_chunk[1];
    const uint64_t y0 = std::max<uint64_t>(cy0, t.y0), y1 = std::min<uint64_t>({H, cy0 + m_chunk[1], t.y1});
    const uint64_t cz0 = iz * m_chunk[2];
    for (uint64_t z = zs; z < ze; ++z)
        for (uint64_t y = y0; y < y1; ++y) {
            uint64_t* row = t.out + W * ((y - t.y0) + (t.y1 - t.y0) * (z - t.z0));
            if (chunk.missing) {
                if (!m_array.fillIsLabel)
                    return fail(chunkPath(iz, iy, ix), "chunk file is missing and the array's fill_value is not an integer label");
                std::fill(row + x0, row + x1, m_array.fill);
                continue;
            }
            const uint64_t base = (z - cz0) * m_stride[2] + (y - cy0) * m_stride[1];
            double bad = 0;
            for (uint64_t x = x0; x < x1; ++x)
                if (!zarrElement(m_array, chunk.bytes.data(), base + (x - x0) * m_stride[0], row[x], &bad))
                    return fail(chunkPath(iz, iy, ix), "voxel (" + std::to_string(x) + ", " + std::to_string(y) + ", " +
                                                           std::to_string(z) + ") " + notAnIntegerLabel(bad));
        }
    return Status::ok();
}

Status ZarrSource::readSlab(uint32_t z0, uint32_t depth, uint64_t* out) {
    if (Status s = checkSlab(m_info, z0, depth, m_dir); !s) return s;
    return readRegion({z0, 0, m_info.dim[1], out}, depth);
}

Status ZarrSource::readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) {
    if (Status s = checkRows(m_info, z0, depth, y0, rows, m_dir); !s) return s;
    return readRegion({z0, y0, y0 + rows, out}, depth);
}

Status ZarrSource::readRegion(const Target& t, uint32_t depth) {
    if (depth == 0 || t.y1 == t.y0) return Status::ok();
    const uint64_t zEnd = uint64_t(t.z0) + depth;
    for (uint64_t iz = t.z0 / m_chunk[2]; iz * m_chunk[2] < zEnd; ++iz) {
        const uint32_t zs = uint32_t(std::max<uint64_t>(t.z0, iz * m_chunk[2]));
        const uint32_t ze = uint32_t(std::min<uint64_t>(zEnd, (iz + 1) * m_chunk[2]));
        const ChunkIndex::Position* layerFirst = m_index.layer(uint32_t(iz)).first;
        for (uint64_t iy = t.y0 / m_chunk[1]; iy * m_chunk[1] < t.y1; ++iy) {
            Status s = m_index.complete() ? readRow(iz, iy, layerFirst, t, zs, ze) : readRowByName(iz, iy, t, zs, ze);
            if (!s) return s;
        }
    }
    return Status::ok();
}

/// Slices [zs, ze) of the chunks of row (iy, iz) into the target, knowing from the index which
/// have a file: the others are fill_value, written a row of voxels at a time.
Status ZarrSource::readRow(uint64_t iz, uint64_t iy, const ChunkIndex::Position* layerFirst, const Target& t, uint32_t zs,
                           uint32_t ze) {
    const ChunkIndex::Range row = m_index.row(uint32_t(iy), uint32_t(iz));
    const auto copy = [&](const ChunkIndex::Position* p) -> Status {
        Result<Chunk*> c = chunkAt(iz, iy, p->x, size_t(p - layerFirst));
        if (!c) return c.status();
        return copyChunk(**c, iz, iy, p->x, t, zs, ze);
    };
    if (uint64_t(row.second - row.first) < m_grid[0]) {
        uint64_t missing = 0; // the first chunk of the row without a file
        for (const ChunkIndex::Position* p = row.first; p != row.second && p->x == missing; ++p) ++missing;
        if (!m_array.fillIsLabel) {
            for (const ChunkIndex::Position* p = row.first; p != row.second && p->x < missing; ++p)
                if (Status s = copy(p); !s) return s; // errors in x order, as chunk by chunk
            return fail(chunkPath(iz, iy, missing), "chunk file is missing and the array's fill_value is not an integer label");
        }
        fillRows(iy, t, zs, ze);
    }
    for (const ChunkIndex::Position* p = row.first; p != row.second; ++p)
        if (Status s = copy(p); !s) return s;
    return Status::ok();
}

/// The same without an index: each chunk looked up by name (load).
Status ZarrSource::readRowByName(uint64_t iz, uint64_t iy, const Target& t, uint32_t zs, uint32_t ze) {
    for (uint64_t ix = 0; ix < m_grid[0]; ++ix) {
        Result<Chunk*> c = chunkAt(iz, iy, ix, size_t(iy * m_grid[0] + ix));
        if (!c) return c.status();
        if (Status s = copyChunk(**c, iz, iy, ix, t, zs, ze); !s) return s;
    }
    return Status::ok();
}

/// fill_value over the whole width of the target's rows in chunk row iy, slices [zs, ze).
void ZarrSource::fillRows(uint64_t iy, const Target& t, uint32_t zs, uint32_t ze) const {
    const uint64_t W = m_info.dim[0];
    const uint64_t y0 = std::max<uint64_t>(t.y0, iy * m_chunk[1]), y1 = std::min<uint64_t>(t.y1, (iy + 1) * m_chunk[1]);
    for (uint64_t z = zs; z < ze; ++z) {
        uint64_t* first = t.out + W * ((y0 - t.y0) + (t.y1 - t.y0) * (z - t.z0));
        std::fill(first, first + W * (y1 - y0), m_array.fill);
    }
}

void ZarrSource::uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, std::vector<UniformBox>& out) {
    out.clear();
    if (!checkRows(m_info, z0, depth, y0, rows, m_dir) || depth == 0 || rows == 0 || !m_array.fillIsLabel) return;
    if (m_index.complete()) {
        m_index.absentBoxes({{m_chunk[0], m_chunk[1], m_chunk[2]}}, m_info.dim, z0, depth, y0, rows, m_array.fill, out);
        return;
    }
    const uint64_t W = m_info.dim[0], zEnd = uint64_t(z0) + depth, yEnd = uint64_t(y0) + rows;
    for (uint64_t iz = z0 / m_chunk[2]; iz * m_chunk[2] < zEnd; ++iz)
        for (uint64_t iy = y0 / m_chunk[1]; iy * m_chunk[1] < yEnd; ++iy) {
            const uint32_t za = uint32_t(std::max<uint64_t>(z0, iz * m_chunk[2]));
            const uint32_t zb = uint32_t(std::min<uint64_t>(zEnd, (iz + 1) * m_chunk[2]));
            const uint32_t ya = uint32_t(std::max<uint64_t>(y0, iy * m_chunk[1]));
            const uint32_t yb = uint32_t(std::min<uint64_t>(yEnd, (iy + 1) * m_chunk[1]));
            uint64_t run = ~uint64_t(0); // where the current run of missing chunks starts
            for (uint64_t ix = 0; ix <= m_grid[0]; ++ix) {
                // Only a name that is not there at all is fill_value (load() refuses the rest).
                const bool missing = ix < m_grid[0] && notRegularFile(chunkPath(iz, iy, ix)) == "missing";
                if (missing && run == ~uint64_t(0)) run = ix * m_chunk[0];
                if (!missing && run != ~uint64_t(0)) {
                    out.push_back({{{uint32_t(run), ya, za}}, {{uint32_t(std::min(W, ix * m_chunk[0])), yb, zb}}, m_array.fill});
                    run = ~uint64_t(0);
                }
            }
        }
}

uint64_t ZarrSource::workingBytes() const {
    uint64_t bytes = m_scratch.bytes.capacity() + m_file.capacity() + m_layer.capacity() * sizeof(Chunk) + m_index.bytes();
    for (const Chunk& c : m_layer) bytes += c.bytes.capacity();
    return bytes;
}

} // namespace

bool claimsZarr(const std::string& path) {
    const std::string l = lower(stripSlashes(path));
    if (endsWith(l, ".zarr") || l.find(".zarr/") != std::string::npos) return true;
    const std::string dir = stripSlashes(path);
    return isFile(dir + "/.zarray") || (isFile(dir + "/.zgroup") && isFile(dir + "/.zattrs"));
}

Result<std::unique_ptr<InputSource>> openZarr(const std::string& path, const InputOptions& options) {
    auto source = std::make_unique<ZarrSource>();
    if (Status s = source->open(path, options); !s) return s;
    return std::unique_ptr<InputSource>(std::move(source));
}

} // namespace inputs
} // namespace csgv
