// SPDX-License-Identifier: MIT
/// @file Hdf5.cpp
/// @brief `FILE.h5[:/group/dataset]` (also `.hdf5`) through libhdf5's C API, streamed slab by
/// slab with hyperslab selections.
///
/// - Dataset: the one named after `:`, or else the file's only 3D integer dataset (every group
///   is walked; none or several is an error, several listing their paths).
/// - Axes (z, y, x), x last. Extra axes of size 1 are allowed (4D/5D): leading ones are dropped
///   first (`(1, z, y, x)`), then trailing ones (ilastik's channel, `(z, y, x, 1)`).
/// - Types: u8..u64 and i8..i64 (read as the matching native type, HDF5 converting the byte
///   order, then widened; signed sign-extended); float32/float64 when every voxel read holds an
///   integer (else an error naming the voxel). Other classes (string, compound, enum, half
///   floats...) are rejected. Any filter the linked libhdf5 can decode (gzip, shuffle,
///   fletcher32, szip when built in, plugins on HDF5_PLUGIN_PATH); a missing one is named when
///   the file is opened.
/// - Geometry, from the dataset's attributes, each 3 numbers in (z, y, x) order (or one per file
///   axis): spacing from `element_size_um` (Fiji, ilastik), `resolution` (CREMI) or `spacing`;
///   origin (centre of voxel 0) from `offset` (CREMI) or `origin`. Spacing 1 and origin 0 when
///   absent; an attribute of another shape or with a non-positive spacing is ignored and the
///   detail line says so.
/// - Chunks whose filters are gzip and/or shuffle (nearly all label volumes), on standard types,
///   are read raw (H5Dread_chunk) and decoded here (Storage::ownDecoding): the stored size is
///   checked against what deflate can need for one chunk before it is read, inflating stops at the
///   chunk's size (a crafted chunk that inflates further is an error naming it, where libhdf5's own
///   deflate filter grows its buffer until the stream ends: 1 MB reached 1 GB), and chunks never
///   written (H5Dget_chunk_info_by_coord; none at all: H5Dget_num_chunks) are the fill value
///   without any read.
/// - Fill values: voxels never written are the dataset's fill value (converted to the label type
///   as libhdf5 converts it; 0 when none is defined) on every path. libhdf5 itself leaves them
///   as the caller's buffer held them when the fill time is "never" or no fill value is defined,
///   so readNative fills the buffer first. uniformBoxes lists the chunks never written (one
///   index lookup each; the whole region when no chunk was written, or contiguous storage never
///   allocated) as boxes of the fill value, which the encoder writes as constant bricks without
///   reading them: a volume of fill values compresses in time per chunk and brick, not per voxel.
/// - Working memory: decoded chunks are cached by us at their native width, within the budget
///   libhdf5's cache would have: one layer of chunks along z when that fits
///   InputOptions::maxWorkingBytes, so that chunks deeper than the caller's slab are not decoded
///   again for the next slab, else one chunk; bands of rows as deep as whole chunk layers (the
///   encoder reads them so, InputInfo::chunkDepth) keep only the chunks one band touches. Plus one
///   chunk's stored bytes and its decoding (twice the chunk at most) while a chunk is decoded.
///   Other datasets (contiguous, compact, other filters) are read by libhdf5 straight into the
///   caller's buffer at their native width and widened there in place (back to front), with its
///   chunk cache sized as above (the dataset is reopened when the access changes between slabs and
///   bands); its nbit and scaleoffset decoders write into a buffer of one chunk, and before it
///   decodes a pipeline with gzip or szip the chunks a read touches are checked by us
///   (precheckChunks: gzip inflated within a chunk and a KiB, what szip's header states). NOT
///   bounded: plugin filters allocate what they choose (only their names are checked: every
///   filter must be available). Chunks larger than the limit are refused. libhdf5 also keeps a
///   type-conversion buffer (1 MiB) and its metadata cache (a few MiB).
/// - External storage (raw data in other files) must lie in the HDF5 file's folder unless
///   InputOptions::allowOutsidePaths; relative names are resolved there (checkStorageFiles). So
///   must the files external links lead to (checked by libhdf5's callback before it opens one,
///   for every link a name crosses) and the sources of virtual datasets, nested ones included
///   (checkDatasetFiles): in every place libhdf5 may look for them, each must be a regular file (a
///   FIFO would block for good). A FIFO that libhdf5 opens before any check can see it (sources
///   named by a pattern) blocks the metadata probe's child, which is then ended (blockedOnFifo).
/// - Errors: HDF5's error printer is silenced around every call and its own message (the error
///   stack, walked) goes into the Status text; also at exit (see silenceShutdownOnce). Every
///   handle is closed on every path.
/// - Threads: Debian's libhdf5 is built without thread safety, so every call into it here holds
///   one process-wide mutex (sources may be used from different threads).
#include "InputCommon.h"

#include "csgv/base/Cancel.h"
#include "csgv/base/Checked.h"
#include "csgv/inputs/PathGuard.h"

#include <hdf5.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <list>
#include <map>
#include <set>
#include <mutex>
#include <type_traits>
#include <utility>
#include <vector>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace csgv {
namespace inputs {

namespace {

// ------------------------------------------------------------------------------------------------
// libhdf5 plumbing: the lock, the silenced error printer, its messages, handles that close.
// ------------------------------------------------------------------------------------------------

std::mutex& hdf5Mutex() {
    static std::mutex m;
    return m;
}

/// libhdf5 1.10 keeps some state behind after failing on certain damaged files (an object header
/// it cannot open, a bad end-of-file address) and, when its error printer is on as the process
/// exits, complains "infinite loop closing library" from its own exit handler, outside any call
/// we wrap. Ours, registered after libhdf5 has registered its own (so run before it), turns the
/// printer off for that moment only.
void silenceShutdownOnce() {
    static std::once_flag once;
    std::call_once(once, [] { std::atexit([] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }); });
}

/// @brief Holds the library lock and keeps HDF5 from printing its error stack to stderr for as
/// long as it lives (the printer is restored afterwards, for host applications that want it).
class Hdf5Scope {
public:
    Hdf5Scope() : m_lock(hdf5Mutex()) {
        H5Eget_auto2(H5E_DEFAULT, &m_func, &m_data); // initialises libhdf5 (and its exit handler) first
        H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
        silenceShutdownOnce();
    }
    ~Hdf5Scope() { H5Eset_auto2(H5E_DEFAULT, m_func, m_data); }
    Hdf5Scope(const Hdf5Scope&) = delete;
    Hdf5Scope& operator=(const Hdf5Scope&) = delete;

private:
    std::lock_guard<std::mutex> m_lock;
    H5E_auto2_t m_func = nullptr;
    void* m_data = nullptr;
};

herr_t collectError(unsigned, const H5E_error2_t* err, void* data) {
    auto* lines = static_cast<std::vector<std::string>*>(data);
    // The plugin search that follows a missing filter only says that the search failed.
    if (err->desc && *err->desc && err->maj_num != H5E_PLUGIN) lines->push_back(err->desc);
    return 0;
}

/// HDF5's words for the call that just failed: the outermost description and the innermost
/// one (the cause), e.g. "unable to open file: file signature not found".
std::string hdf5Message() {
    std::vector<std::string> lines;
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collectError, &lines);
    H5Eclear2(H5E_DEFAULT);
    if (lines.empty()) return "HDF5 gave no reason";
    if (lines.size() == 1 || lines.front() == lines.back()) return lines.front();
    return lines.front() + ": " + lines.back();
}

/// @brief One HDF5 identifier, closed with its own close function on every path.
class Handle {
public:
    Handle() = default;
    Handle(hid_t id, herr_t (*close)(hid_t)) : m_id(id), m_close(close) {}
    ~Handle() { reset(); }
    Handle(Handle&& o) noexcept : m_id(std::exchange(o.m_id, H5I_INVALID_HID)), m_close(o.m_close) {}
    Handle& operator=(Handle&& o) noexcept {
        if (this != &o) {
            reset();
            m_id = std::exchange(o.m_id, H5I_INVALID_HID);
            m_close = o.m_close;
        }
        return *this;
    }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;

    hid_t get() const { return m_id; }
    bool valid() const { return m_id >= 0; }
    void reset() {
        if (m_id >= 0 && m_close) m_close(m_id);
        m_id = H5I_INVALID_HID;
    }

private:
    hid_t m_id = H5I_INVALID_HID;
    herr_t (*m_close)(hid_t) = nullptr;
};

// ------------------------------------------------------------------------------------------------
// Names, paths and messages
// ------------------------------------------------------------------------------------------------

/// `FILE.h5` or `FILE.h5:/dataset` split into the file and the dataset path ("" when none).
struct Hdf5Path {
    std::string file;
    std::string dataset;
};

Hdf5Path splitPath(const std::string& path) {
    const std::string low = lower(path);
    for (const char* suffix : {".h5:/", ".hdf5:/"}) {
        const size_t at = low.find(suffix);
        if (at != std::string::npos) {
            const size_t colon = at + std::strlen(suffix) - 2;
            return {path.substr(0, colon), path.substr(colon + 1)};
        }
    }
    return {path, ""};
}

std::string shapeText(const std::vector<hsize_t>& dims) {
    std::string s;
    for (size_t i = 0; i < dims.size(); ++i) s += (i ? "x" : "") + std::to_string(dims[i]);
    return s.empty() ? "scalar" : s;
}

std::string listText(const std::vector<std::string>& names, size_t most = 10) {
    std::string s;
    for (size_t i = 0; i < names.size() && i < most; ++i) s += (i ? ", " : "") + names[i];
    if (names.size() > most) s += " and " + std::to_string(names.size() - most) + " more";
    return s;
}

const char* classText(H5T_class_t c) {
    switch (c) {
    case H5T_INTEGER: return "integer";
    case H5T_FLOAT: return "float";
    case H5T_TIME: return "time";
    case H5T_STRING: return "string";
    case H5T_BITFIELD: return "bitfield";
    case H5T_OPAQUE: return "opaque";
    case H5T_COMPOUND: return "compound";
    case H5T_REFERENCE: return "reference";
    case H5T_ENUM: return "enum";
    case H5T_VLEN: return "variable-length";
    case H5T_ARRAY: return "array";
    default: return "unknown";
    }
}

std::string filterName(H5Z_filter_t id, const char* stored) {
    switch (id) {
    case H5Z_FILTER_DEFLATE: return "gzip";
    case H5Z_FILTER_SHUFFLE: return "shuffle";
    case H5Z_FILTER_FLETCHER32: return "fletcher32";
    case H5Z_FILTER_SZIP: return "szip";
    case H5Z_FILTER_NBIT: return "nbit";
    case H5Z_FILTER_SCALEOFFSET: return "scaleoffset";
    default: break;
    }
    if (stored && *stored) return stored;
    return "filter " + std::to_string(id);
}

// ------------------------------------------------------------------------------------------------
// What a dataset holds: its label type and which file axes are z, y, x.
// ------------------------------------------------------------------------------------------------

/// @brief The voxel type of a dataset and the native type HDF5 converts it to for us.
struct VoxelType {
    LabelType type = LabelType::U32;
    hid_t memType = H5I_INVALID_HID; ///< a predefined native type (never closed)
};

/// The label type of an HDF5 datatype, or why it cannot hold labels.
Result<VoxelType> voxelTypeOf(hid_t fileType) {
    const H5T_class_t cls = H5Tget_class(fileType);
    const size_t size = H5Tget_size(fileType);
    if (cls == H5T_INTEGER) {
        const bool sgn = H5Tget_sign(fileType) == H5T_SGN_2;
        switch (size) {
        case 1: return sgn ? VoxelType{LabelType::I8, H5T_NATIVE_INT8} : VoxelType{LabelType::U8, H5T_NATIVE_UINT8};
        case 2: return sgn ? VoxelType{LabelType::I16, H5T_NATIVE_INT16} : VoxelType{LabelType::U16, H5T_NATIVE_UINT16};
        case 4: return sgn ? VoxelType{LabelType::I32, H5T_NATIVE_INT32} : VoxelType{LabelType::U32, H5T_NATIVE_UINT32};
        case 8: return sgn ? VoxelType{LabelType::I64, H5T_NATIVE_INT64} : VoxelType{LabelType::U64, H5T_NATIVE_UINT64};
        default: break;
        }
    } else if (cls == H5T_FLOAT) {
        if (size == 4) return VoxelType{LabelType::F32, H5T_NATIVE_FLOAT};
        if (size == 8) return VoxelType{LabelType::F64, H5T_NATIVE_DOUBLE};
    }
    return Status::error("has datatype " + std::string(classText(cls)) + " of " + std::to_string(size) +
                         " bytes; labels must be integers of 1, 2, 4 or 8 bytes (or float32/float64 holding integers)");
}

/// @brief Where the spatial axes are in the file's axes.
struct Axes {
    std::vector<hsize_t> dims; ///< the file's shape
    int zAxis = 0;             ///< file axis of z; y and x follow it
};

/// The dataset's shape as (z, y, x) axes, or why it is not a 3D volume.
Result<Axes> axesOf(hid_t space) {
    if (H5Sget_simple_extent_type(space) != H5S_SIMPLE) return Status::error("is a scalar or has no data space");
    const int rank = H5Sget_simple_extent_ndims(space);
    if (rank < 0) return Status::error("has an unreadable shape");
    Axes a;
    a.dims.resize(size_t(rank));
    if (rank > 0) H5Sget_simple_extent_dims(space, a.dims.data(), nullptr);
    if (rank < 3 || rank > 5)
        return Status::error("is " + std::to_string(rank) + "D (shape " + shapeText(a.dims) +
                             "); labels need 3 axes (z, y, x), or 4 or 5 with the extra ones of size 1");
    int extra = rank - 3;
    while (extra > 0 && a.dims[size_t(a.zAxis)] == 1) ++a.zAxis, --extra;
    for (int i = 0; i < extra; ++i)
        if (a.dims[size_t(rank - 1 - i)] != 1)
            return Status::error("is " + std::to_string(rank) + "D (shape " + shapeText(a.dims) +
                                 "); the axes beyond (z, y, x) must have size 1");
    for (int i = 0; i < 3; ++i) {
        const hsize_t n = a.dims[size_t(a.zAxis + i)];
        if (n == 0) return Status::error("is empty (shape " + shapeText(a.dims) + ")");
        if (n > 0xFFFFFFFFu) return Status::error("has an axis longer than 2^32 - 1 (shape " + shapeText(a.dims) + ")");
    }
    return a;
}

/// Why auto-picking passes over a dataset, "" when it takes it (integer voxels on (z, y, x)
/// axes): its shape's problem, its type's, or that floats are read only when named.
std::string passedOver(hid_t dataset) {
    Handle type(H5Dget_type(dataset), H5Tclose);
    Handle space(H5Dget_space(dataset), H5Sclose);
    if (!type.valid() || !space.valid()) return "cannot be read";
    const Result<Axes> axes = axesOf(space.get());
    // The problem itself, without the rule after it ("is 2D (shape 3x4)").
    auto first = [](const std::string& m) { return m.substr(0, m.find(';')); };
    if (!axes) return first(axes.message());
    const Result<VoxelType> voxel = voxelTypeOf(type.get());
    if (!voxel) return first(voxel.message());
    if (H5Tget_class(type.get()) != H5T_INTEGER)
        return "holds floats (shape " + shapeText(axes->dims) + "; read only when named, where they hold integers)";
    return "";
}

// ------------------------------------------------------------------------------------------------
// Files an HDF5 file names: external links, virtual dataset sources, external storage
// ------------------------------------------------------------------------------------------------

namespace fs = std::filesystem;

/// @brief Where the files an HDF5 file names may lie, and what the external-link callback found.
/// Its address is kept by libhdf5 in every access list made here, and by every dataset opened
/// with one (a virtual dataset opens its sources with its own copy when read): it lives as long
/// as the file's handles (Hdf5Source owns it).
struct FileRules {
    fs::path folder;              ///< the named HDF5 file's folder (canonical)
    bool allowOutside = false;    ///< InputOptions::allowOutsidePaths
    std::string refused;          ///< why the callback refused an external link ("" when it did not)
    std::set<std::pair<std::string, std::string>> checkedSources; ///< (file, dataset) of checked virtual sources
    std::set<std::string> named;  ///< every file found for a name (canonical): InputInfo::namedFiles
    /// Virtual source file names already checked, by the folder they were named from and the
    /// name, with the file found (a dataset may take a million mappings from one file).
    std::map<std::string, fs::path> checkedNames;
};

FileRules rulesFor(const std::string& file, const InputOptions& options) {
    std::error_code ec;
    FileRules rules;
    rules.folder = fs::weakly_canonical(fs::absolute(fs::path(file), ec).parent_path(), ec);
    rules.allowOutside = options.allowOutsidePaths;
    return rules;
}

/// The prefixes of an environment variable libhdf5 reads (HDF5_EXT_PREFIX, HDF5_VDS_PREFIX,
/// HDF5_EXTFILE_PREFIX: colon-separated), `${ORIGIN}` expanded to the folder of the file that holds
/// the name, as libhdf5 expands it.
std::vector<fs::path> envPrefixes(const char* envVariable, const fs::path& holderFolder) {
    std::vector<fs::path> out;
    const char* env = std::getenv(envVariable);
    if (!env) return out;
    const std::string prefixes(env), origin = "${ORIGIN}";
    for (size_t at = 0; at <= prefixes.size();) {
        const size_t colon = std::min(prefixes.find(':', at), prefixes.size());
        std::string prefix = prefixes.substr(at, colon - at);
        if (prefix.compare(0, origin.size(), origin) == 0) prefix = holderFolder.string() + prefix.substr(origin.size());
        if (!prefix.empty()) out.emplace_back(prefix);
        at = colon + 1;
    }
    return out;
}

/// The places libhdf5 may look for a file an external link or a virtual dataset names
/// (H5Lcreate_external, H5Pset_virtual): an absolute name itself; then, for a relative name (or an
/// absolute one's last component), each prefix in the environment variable, the folder of the
/// file that holds the name, and the name as it stands (the working directory). libhdf5 takes the
/// first place it can open, and goes on past one it cannot (a file that is no valid HDF5 file),
/// so every place that exists must pass checkNamedFile, not only the first.
std::vector<fs::path> searchOrder(const std::string& stored, const fs::path& holderFolder, const char* envVariable) {
    std::vector<fs::path> places;
    fs::path name(stored);
    if (name.is_absolute()) {
        places.push_back(name);
        name = name.filename();
    }
    for (const fs::path& prefix : envPrefixes(envVariable, holderFolder)) places.push_back(prefix / name);
    places.push_back(holderFolder / name);
    places.push_back(name);
    return places;
}

/// The rule for a file an HDF5 file names (`what` says which, e.g. "an external link in '/'
/// leads to '/d' in"): every place of `places` that exists must be a regular file (a FIFO would
/// block the read for good, a device never end) and lie in the named file's folder unless
/// allowed. Every one, because which of them libhdf5 opens depends on which it can open. Where
/// none exists the name dangles (libhdf5 says so, or reads a virtual dataset's fill value): the
/// places are recorded all the same, so a cache of the volume goes stale when one appears.
Status checkNamedFile(FileRules& rules, const std::string& stored, const std::vector<fs::path>& places,
                      const std::string& what) {
    std::error_code ec;
    bool found = false;
    for (const fs::path& place : places) {
        const fs::file_status status = fs::status(place, ec);
        if (!fs::exists(status)) continue;
        found = true;
        const fs::path resolved = fs::weakly_canonical(fs::absolute(place, ec), ec);
        const std::string names = what + " " + quotedText(stored, 200) + " (" + resolved.string() + ")";
        if (!fs::is_regular_file(status)) return Status::error(names + ", which is not a regular file");
        if (!rules.allowOutside && (ec || !liesInside(resolved, rules.folder)))
            return Status::error(names + ", outside the HDF5 file's folder " + rules.folder.string() + "; " +
                                 kAllowOutsideHint);
        rules.named.insert(resolved.string());
    }
    if (!found)
        for (const fs::path& place : places) rules.named.insert(fs::absolute(place, ec).lexically_normal().string());
    return Status::ok();
}

/// libhdf5's external-link callback: runs before the target file is opened, for every external
/// link any name traverses (the last component or one on the way).
herr_t checkExternalLink(const char* parentFile, const char* parentGroup, const char* childFile, const char* childObject,
                         unsigned*, hid_t, void* data) {
    auto* rules = static_cast<FileRules*>(data);
    std::error_code ec;
    const fs::path holder = fs::absolute(fs::path(parentFile), ec).parent_path();
    const Status s = checkNamedFile(*rules, childFile, searchOrder(childFile, holder, "HDF5_EXT_PREFIX"),
                                    "an external link in " + quotedText(parentGroup, 200) + " leads to " +
                                        quotedText(childObject, 200) + " in");
    if (s) return 0;
    rules->refused = s.message();
    return -1;
}

/// A link access list (or one of its subclasses: group and dataset access) that checks every
/// external link it traverses with the rules.
Handle linkAccess(FileRules& rules, hid_t cls = H5P_LINK_ACCESS) {
    Handle lapl(H5Pcreate(cls), H5Pclose);
    if (lapl.valid() && H5Pset_elink_cb(lapl.get(), checkExternalLink, &rules) < 0) lapl.reset();
    return lapl;
}

/// The dataset access list of every open here: external links checked, and external storage
/// named relatively lies beside the HDF5 file that holds the dataset (libhdf5 would look in the
/// working directory), where checkStorageFiles looks. libhdf5 refuses to open a dataset already
/// open with another prefix, so every dataset is opened with this one, never through H5Oopen
/// (which uses the default prefix).
Handle datasetAccess(FileRules& rules) {
    Handle dapl = linkAccess(rules, H5P_DATASET_ACCESS);
    if (dapl.valid() && H5Pset_efile_prefix(dapl.get(), "${ORIGIN}") < 0) dapl.reset();
    return dapl;
}

/// The error of a call that failed: the external-link callback's refusal when it refused (taken,
/// so the next call starts clean), else libhdf5's words (after `words` and a colon, when given).
std::string failure(FileRules& rules, const std::string& words) {
    if (rules.refused.empty()) return words.empty() ? hdf5Message() : words + ": " + hdf5Message();
    H5Eclear2(H5E_DEFAULT);
    return std::exchange(rules.refused, std::string());
}

/// The name of the file that holds an open object (the one an external link led to, if any).
std::string holderOf(hid_t object) {
    const ssize_t n = H5Fget_name(object, nullptr, 0);
    if (n <= 0) return "";
    std::string name(size_t(n) + 1, '\0');
    H5Fget_name(object, name.data(), name.size());
    name.resize(size_t(n));
    return name;
}

/// External storage (raw data in other files, H5Pset_external) may name any file: each must be a
/// regular file in the named HDF5 file's folder unless allowed (checkNamedFile). A relative name
/// is found beside the file that holds the dataset when we open it (datasetAccess), but in the
/// working directory when libhdf5 opens a virtual dataset's source, and under HDF5_EXTFILE_PREFIX
/// when that is set: each of those places is checked.
Status checkStorageFiles(hid_t dataset, hid_t dcpl, FileRules& rules, const std::string& name) {
    const int count = H5Pget_external_count(dcpl);
    std::error_code ec;
    const fs::path holder = fs::absolute(fs::path(holderOf(dataset)), ec).parent_path();
    for (int i = 0; i < count; ++i) {
        char stored[4096] = {0};
        off_t offset = 0;
        hsize_t size = 0;
        if (H5Pget_external(dcpl, unsigned(i), sizeof stored, stored, &offset, &size) < 0)
            return Status::error("cannot read external file " + std::to_string(i) + " of " + name + ": " + hdf5Message());
        const fs::path named(stored);
        std::vector<fs::path> places;
        if (named.is_absolute()) places.push_back(named);
        else {
            places = envPrefixes("HDF5_EXTFILE_PREFIX", holder);
            for (fs::path& prefix : places) prefix /= named;
            places.push_back(holder / named);
            places.push_back(named);
        }
        if (Status s = checkNamedFile(rules, stored, places, "dataset " + name + " keeps its data in the external file"); !s)
            return s;
    }
    return Status::ok();
}

/// How deep virtual datasets may take their voxels from other virtual datasets.
constexpr int kMostVirtualDepth = 8;

/// A virtual dataset reads its voxels from source datasets, in its own file (".") or others,
/// which libhdf5 opens when the voxels are read: each source file must pass checkNamedFile, and
/// each source (opened here with the rules, so external links on its path are checked too) the
/// same checks as the dataset, nested virtual datasets included. Sources named by a pattern
/// (printf form, for unlimited dimensions) cannot be checked one by one: refused unless allowed.
Status checkDatasetFiles(hid_t dataset, FileRules& rules, const std::string& name, int depth = 0) {
    Handle dcpl(H5Dget_create_plist(dataset), H5Pclose);
    if (!dcpl.valid()) return Status::error("cannot read the storage of " + name + ": " + hdf5Message());
    if (Status s = checkStorageFiles(dataset, dcpl.get(), rules, name); !s) return s;
    if (H5Pget_layout(dcpl.get()) != H5D_VIRTUAL) return Status::ok();
    if (depth >= kMostVirtualDepth)
        return Status::error("virtual dataset " + name + " takes voxels from virtual datasets nested more than " +
                             std::to_string(kMostVirtualDepth) + " deep");
    size_t count = 0;
    if (H5Pget_virtual_count(dcpl.get(), &count) < 0)
        return Status::error("cannot read the sources of virtual dataset " + name + ": " + hdf5Message());
    std::error_code ec;
    const std::string holderName = holderOf(dataset);
    const fs::path holder = fs::absolute(fs::path(holderName), ec).parent_path();
    auto text = [&](ssize_t (*get)(hid_t, size_t, char*, size_t), size_t i) {
        const ssize_t n = get(dcpl.get(), i, nullptr, 0);
        std::string s(n > 0 ? size_t(n) + 1 : 1, '\0');
        if (n > 0) get(dcpl.get(), i, s.data(), s.size());
        s.resize(n > 0 ? size_t(n) : 0);
        return s;
    };
    for (size_t i = 0; i < count; ++i) {
        if (cancelRequested()) return Status::error("cancelled");
        const std::string file = text(H5Pget_virtual_filename, i), source = text(H5Pget_virtual_dsetname, i);
        const std::string what = "virtual dataset " + name + " takes voxels from " + quotedText(source, 200) + " in";
        if (file.empty()) return Status::error("cannot read source " + std::to_string(i) + " of virtual dataset " + name);
        const bool pattern = file.find('%') != std::string::npos || source.find('%') != std::string::npos;
        if (pattern && !rules.allowOutside)
            return Status::error("virtual dataset " + name + " names its sources by a pattern (" + quotedText(file, 200) +
                                 ", " + quotedText(source, 200) + "), which libhdf5 opens without our checks; " +
                                 kAllowOutsideHint);
        fs::path sourceFile = holderName; // where libhdf5 finds the source's file
        if (file != ".") {
            const auto [known, added] = rules.checkedNames.emplace(holder.string() + "\n" + file, fs::path());
            if (added) {
                const std::vector<fs::path> places = searchOrder(file, holder, "HDF5_VDS_PREFIX");
                if (Status s = checkNamedFile(rules, file, places, what); !s) return s;
                for (const fs::path& place : places)
                    if (fs::exists(place, ec)) {
                        known->second = place;
                        break;
                    }
            }
            if (known->second.empty()) continue; // no such file: libhdf5 reads the fill value
            sourceFile = known->second;
        }
        if (pattern) continue;
        // The source itself: its external links, storage and sources. Each once (a dataset that
        // is its own source, or a thousand mappings from one source).
        const std::string key = fs::weakly_canonical(fs::absolute(sourceFile, ec), ec).string();
        if (!rules.checkedSources.insert({key, source}).second) continue;
        Handle opened(file == "." ? H5Iget_file_id(dataset) : H5Fopen(sourceFile.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT),
                      H5Fclose);
        if (!opened.valid()) {
            H5Eclear2(H5E_DEFAULT);
            continue; // libhdf5 fills what it cannot read from a missing source with the fill value
        }
        Handle d(H5Dopen2(opened.get(), source.c_str(), datasetAccess(rules).get()), H5Dclose);
        if (!d.valid()) {
            if (!rules.refused.empty()) return Status::error("the source " + quotedText(source, 200) + " of virtual dataset " + name + ": " +
                                     failure(rules, ""));
            H5Eclear2(H5E_DEFAULT);
            continue;
        }
        if (Status s = checkDatasetFiles(d.get(), rules, key + ":" + source, depth + 1); !s) return s;
    }
    return Status::ok();
}

// ------------------------------------------------------------------------------------------------
// Finding the dataset
// ------------------------------------------------------------------------------------------------

/// @brief What a walk over a group found.
struct WalkState {
    std::string prefix;               ///< path of the group walked, ending in '/'
    std::vector<std::string> volumes; ///< 3D integer datasets
    std::vector<std::string> broken;  ///< objects HDF5 could not open (damaged headers)
    std::vector<std::string> passed;  ///< other datasets, each with why it is not a candidate
    FileRules* rules = nullptr;
    bool cancelled = false;           ///< stopped by a cancel request
};

/// One link of a walk. The object is opened by the address the link holds: by its name (the path
/// from the walk's group) each lookup would cross every group on the way, and a chain of 1000
/// nested groups took 11 s. libhdf5 refuses to open by address a dataset that is open elsewhere
/// in the process with our access list (another reader of the same file): then by name, with it.
herr_t visitLink(hid_t group, const char* name, const H5L_info_t* info, void* data) {
    auto* state = static_cast<WalkState*>(data);
    if (cancelRequested()) {
        state->cancelled = true;
        return 1; // stops the walk
    }
    if (info->type == H5L_TYPE_EXTERNAL) {
        // A dataset behind an external link is a candidate as a named one is, by the same rules
        // (the link's callback); one the rules refuse is passed over with the reason.
        H5O_info_t target{};
        if (H5Oget_info_by_name2(group, name, &target, H5O_INFO_BASIC, linkAccess(*state->rules).get()) < 0) {
            state->passed.push_back(state->prefix + name + " is an external link, " +
                                    (state->rules->refused.empty() ? "which leads to nothing that opens"
                                                                   : "and " + failure(*state->rules, "")));
            H5Eclear2(H5E_DEFAULT);
            return 0;
        }
        if (target.type != H5O_TYPE_DATASET) return 0;
        Handle linked(H5Dopen2(group, name, datasetAccess(*state->rules).get()), H5Dclose);
        if (!linked.valid()) state->broken.push_back(state->prefix + name);
        else if (const std::string why = passedOver(linked.get()); why.empty()) state->volumes.push_back(state->prefix + name);
        else state->passed.push_back(state->prefix + name + " " + why);
        H5Eclear2(H5E_DEFAULT);
        return 0;
    }
    if (info->type != H5L_TYPE_HARD) return 0; // soft links name objects the walk meets as hard links
    Handle object(H5Oopen_by_addr(group, info->u.address), H5Oclose);
    if (!object.valid()) {
        H5Eclear2(H5E_DEFAULT);
        H5O_info_t named{};
        if (H5Oget_info_by_name2(group, name, &named, H5O_INFO_BASIC, H5P_DEFAULT) < 0 || named.type != H5O_TYPE_DATASET) {
            state->broken.push_back(state->prefix + name);
            return 0;
        }
        object = Handle(H5Dopen2(group, name, datasetAccess(*state->rules).get()), H5Dclose);
        if (!object.valid()) {
            state->broken.push_back(state->prefix + name);
            return 0;
        }
    }
    if (H5Iget_type(object.get()) != H5I_DATASET) return 0;
    if (const std::string why = passedOver(object.get()); why.empty()) state->volumes.push_back(state->prefix + name);
    else state->passed.push_back(state->prefix + name + " " + why);
    return 0;
}

/// The 3D integer datasets under a group (every depth).
WalkState walkGroup(hid_t group, const std::string& groupPath, FileRules& rules) {
    WalkState state;
    state.rules = &rules;
    state.prefix = groupPath.empty() || groupPath.back() != '/' ? groupPath + "/" : groupPath;
    H5Lvisit(group, H5_INDEX_NAME, H5_ITER_INC, visitLink, &state);
    H5Eclear2(H5E_DEFAULT);
    return state;
}

std::string brokenText(const WalkState& walk) {
    return walk.broken.empty() ? "" : " (HDF5 could not open " + listText(walk.broken) + ")";
}

/// The datasets a walk passed over and why ("" when none): what a user who expected one of them
/// needs to read.
std::string passedText(const WalkState& walk) {
    return walk.passed.empty() ? "" : "; passed over: " + listText(walk.passed, 4);
}

/// The dataset to read: the one named, or the file's only 3D integer dataset.
Result<std::pair<Handle, std::string>> findDataset(hid_t file, const std::string& named, FileRules& rules) {
    if (named.empty()) {
        const WalkState walk = walkGroup(file, "/", rules);
        if (walk.cancelled) return Status::error("cancelled while searching the file's datasets");
        const std::vector<std::string>& volumes = walk.volumes;
        if (volumes.empty())
            return Status::error("holds no 3D integer dataset" + brokenText(walk) + passedText(walk) +
                                 "; name one as FILE.h5:/group/dataset");
        if (volumes.size() > 1)
            return Status::error("holds several 3D integer datasets (" + listText(volumes) +
                                 "); name one as FILE.h5:/group/dataset");
        Handle d(H5Dopen2(file, volumes[0].c_str(), datasetAccess(rules).get()), H5Dclose);
        if (!d.valid()) return Status::error("cannot open dataset " + volumes[0] + ": " + hdf5Message());
        return std::make_pair(std::move(d), volumes[0]);
    }
    // Every call that follows the name checks the external links it crosses (linkAccess).
    const Handle lapl = linkAccess(rules);
    H5O_info_t object{};
    if (H5Oget_info_by_name2(file, named.c_str(), &object, H5O_INFO_BASIC, lapl.get()) < 0) {
        if (!rules.refused.empty()) return Status::error(failure(rules, ""));
        // libhdf5's words for what a reader of the object meets: those of opening it (it fails
        // before any dataset is opened, so the default prefix conflicts with nothing).
        H5Eclear2(H5E_DEFAULT);
        Handle opened(H5Oopen(file, named.c_str(), lapl.get()), H5Oclose);
        const std::string why = opened.valid() ? "its header cannot be read" : failure(rules, "");
        // A link that exists but whose object does not open is a damaged file, not a wrong name.
        if (H5Lexists(file, named.c_str(), lapl.get()) > 0) return Status::error("cannot open " + named + ": " + why);
        H5Eclear2(H5E_DEFAULT);
        rules.refused.clear();
        return Status::error("no dataset " + named + " in the file (" + why + ")");
    }
    if (object.type == H5O_TYPE_GROUP) {
        Handle group(H5Gopen2(file, named.c_str(), linkAccess(rules, H5P_GROUP_ACCESS).get()), H5Gclose);
        if (!group.valid()) return Status::error(failure(rules, "cannot open " + named));
        const WalkState inside = walkGroup(group.get(), named, rules);
        return Status::error(named + " is a group, not a dataset" +
                             (inside.volumes.empty() ? "; it holds no 3D integer dataset" + passedText(inside)
                                                     : "; its 3D integer datasets: " + listText(inside.volumes)) +
                             brokenText(inside));
    }
    if (object.type != H5O_TYPE_DATASET) return Status::error(named + " is a named datatype, not a dataset");
    Handle d(H5Dopen2(file, named.c_str(), datasetAccess(rules).get()), H5Dclose);
    if (!d.valid()) return Status::error(failure(rules, "cannot open dataset " + named));
    return std::make_pair(std::move(d), named);
}

// ------------------------------------------------------------------------------------------------
// Layout, filters and the chunk cache
// ------------------------------------------------------------------------------------------------

/// @brief How a dataset is stored and the chunk cache chosen for it.
struct Storage {
    std::string detail;       ///< "chunks 8x10x7, filters shuffle+gzip" or "contiguous"
    bool chunked = false;
    bool contiguous = false;
    uint64_t chunkBytes = 0;
    uint64_t layerChunks = 0; ///< chunks one z range touches
    uint64_t rowChunks = 0;   ///< chunks one z range of one y range of chunks touches
    uint64_t yChunks = 0;     ///< chunks along y
    uint32_t chunkY = 1, chunkZ = 1; ///< the chunk's extent along y and z
    uint64_t hashSpan = 1;    ///< chunk-cache hash values one z layer spans (HDF5 packs chunk coordinates in bits)
    std::vector<hsize_t> chunk; ///< the chunk's shape in the file's axes
    uint32_t chunkX = 1;
    /// The filter pipeline in the order it was applied when writing.
    std::vector<H5Z_filter_t> filters;
    /// True when we read the chunks raw (H5Dread_chunk) and undo the filters ourselves, inflating
    /// into a buffer of exactly one chunk: every filter is gzip, shuffle or fletcher32 (else adding
    /// a checksum would hand a crafted gzip chunk back to libhdf5), the voxels a standard type and
    /// the chunk's axes beyond (z, y, x) of size 1. libhdf5's own deflate filter grows its output
    /// until the stream ends (a crafted chunk of 1 MB reached 1 GB), ours stops at the chunk's
    /// size. Other pipelines (szip, nbit, scaleoffset, plugins) stay with libhdf5 (the file's
    /// @brief says which of its decoders are bounded).
    bool ownDecoding = false;
    /// Not ownDecoding, but gzip or szip among the filters: chunks are checked before libhdf5
    /// decodes them (precheckChunks).
    bool precheck = false;
};

uint64_t bitsFor(uint64_t n) {
    uint64_t bits = 0;
    while ((uint64_t(1) << bits) < n) ++bits;
    return bits;
}

/// True for the integer and IEEE float types whose bytes decodeVoxels reads (any byte order):
/// raw chunks of other types (odd precisions, bit offsets) are left to libhdf5's conversion.
bool isStandardType(hid_t fileType) {
    for (hid_t t : {H5T_STD_U8LE, H5T_STD_U8BE, H5T_STD_I8LE, H5T_STD_I8BE, H5T_STD_U16LE, H5T_STD_U16BE,
                    H5T_STD_I16LE, H5T_STD_I16BE, H5T_STD_U32LE, H5T_STD_U32BE, H5T_STD_I32LE, H5T_STD_I32BE,
                    H5T_STD_U64LE, H5T_STD_U64BE, H5T_STD_I64LE, H5T_STD_I64BE, H5T_IEEE_F32LE, H5T_IEEE_F32BE,
                    H5T_IEEE_F64LE, H5T_IEEE_F64BE})
        if (H5Tequal(fileType, t) > 0) return true;
    return false;
}

/// The layout and filters, checking that every filter can be decoded here.
Result<Storage> storageOf(hid_t dataset, const Axes& axes, hid_t fileType, const std::string& name) {
    const size_t typeSize = H5Tget_size(fileType);
    Handle dcpl(H5Dget_create_plist(dataset), H5Pclose);
    if (!dcpl.valid()) return Status::error("cannot read the storage of " + name + ": " + hdf5Message());
    Storage s;
    const H5D_layout_t layout = H5Pget_layout(dcpl.get());
    if (layout != H5D_CHUNKED) {
        s.contiguous = layout == H5D_CONTIGUOUS;
        s.detail = layout == H5D_COMPACT ? "compact" : layout == H5D_VIRTUAL ? "virtual" : "contiguous";
        return s;
    }
    std::vector<hsize_t> chunk(axes.dims.size());
    if (H5Pget_chunk(dcpl.get(), int(chunk.size()), chunk.data()) != int(chunk.size()))
        return Status::error("cannot read the chunk shape of " + name + ": " + hdf5Message());
    s.chunked = true;
    s.chunkBytes = typeSize;
    s.layerChunks = 1;
    uint64_t layerBits = 0;
    for (size_t i = 0; i < chunk.size(); ++i) {
        if (chunk[i] == 0) return Status::error(name + " has a chunk axis of size 0");
        s.chunkBytes = mulSaturate(s.chunkBytes, chunk[i]);
        if (int(i) > axes.zAxis) { // the axes after z: one layer spans all their chunks
            const uint64_t n = (axes.dims[i] + chunk[i] - 1) / chunk[i];
            s.layerChunks = mulSaturate(s.layerChunks, n);
            layerBits += bitsFor(n + 1); // HDF5 rounds each axis's chunk count up to a power of two
            if (int(i) == axes.zAxis + 1) s.yChunks = n;
            else s.rowChunks = mulSaturate(std::max<uint64_t>(s.rowChunks, 1), n);
        }
    }
    s.chunkZ = uint32_t(std::min<hsize_t>(chunk[size_t(axes.zAxis)], 0xFFFFFFFFu));
    s.chunkY = uint32_t(std::min<hsize_t>(chunk[size_t(axes.zAxis) + 1], 0xFFFFFFFFu));
    s.chunkX = uint32_t(std::min<hsize_t>(chunk[size_t(axes.zAxis) + 2], 0xFFFFFFFFu));
    s.chunk = chunk;
    bool spatialOnly = true;
    for (size_t i = 0; i < chunk.size(); ++i)
        if ((int(i) < axes.zAxis || int(i) > axes.zAxis + 2) && chunk[i] != 1) spatialOnly = false;
    s.hashSpan = layerBits >= 40 ? kSaturated : uint64_t(1) << layerBits;
    const std::vector<hsize_t> spatial(chunk.begin() + axes.zAxis, chunk.begin() + axes.zAxis + 3);
    s.detail = "chunks " + shapeText(spatial);

    const int n = H5Pget_nfilters(dcpl.get());
    std::string filters;
    for (int i = 0; i < n; ++i) {
        unsigned flags = 0, config = 0;
        size_t values = 0;
        char stored[64] = {0};
        const H5Z_filter_t id = H5Pget_filter2(dcpl.get(), unsigned(i), &flags, &values, nullptr, sizeof stored, stored, &config);
        if (id < 0) return Status::error("cannot read the filters of " + name + ": " + hdf5Message());
        const std::string filter = filterName(id, stored);
        filters += (filters.empty() ? "" : "+") + filter;
        s.filters.push_back(id);
        unsigned info = 0;
        const bool decodes = H5Zfilter_avail(id) > 0 && H5Zget_filter_info(id, &info) >= 0 &&
                             (info & H5Z_FILTER_CONFIG_DECODE_ENABLED);
        H5Eclear2(H5E_DEFAULT);
        // Optional filters too: "optional" only lets a writer skip a filter that fails on a
        // chunk; chunks it did filter still need it to be read.
        if (!decodes)
            return Status::error("dataset " + name + " needs HDF5 filter '" + filter + "' (id " + std::to_string(id) +
                                 "), which this libhdf5 cannot decode (not built in, and no plugin for it on "
                                 "HDF5_PLUGIN_PATH)");
    }
    s.detail += filters.empty() ? ", no filters" : ", filters " + filters;
    s.ownDecoding = spatialOnly && isStandardType(fileType) &&
                    std::all_of(s.filters.begin(), s.filters.end(), [](H5Z_filter_t id) {
                        return id == H5Z_FILTER_DEFLATE || id == H5Z_FILTER_SHUFFLE || id == H5Z_FILTER_FLETCHER32;
                    });
    s.precheck = !s.ownDecoding && std::any_of(s.filters.begin(), s.filters.end(), [](H5Z_filter_t id) {
        return id == H5Z_FILTER_DEFLATE || id == H5Z_FILTER_SZIP;
    });
    return s;
}

uint64_t nextPrime(uint64_t n) {
    for (;; ++n) {
        bool prime = n >= 2;
        for (uint64_t d = 2; prime && d * d <= n; ++d) prime = n % d != 0;
        if (prime) return n;
    }
}

/// @brief The chunk cache of the dataset access property list.
struct ChunkCache {
    uint64_t bytes = 0;
    uint64_t slots = 521; // HDF5's default
    bool wholeLayer = false;
};

/// The cache for reads of slabs (bandDepth 0: every chunk of a z layer, when that fits), or for
/// bands of whole chunk layers `bandDepth` deep and `bandRows` tall read in order (the chunks one
/// band touches: no chunk is needed again once its band is done).
ChunkCache chooseCache(const Storage& s, uint64_t maxWorkingBytes, uint32_t bandDepth = 0, uint32_t bandRows = 0) {
    ChunkCache c;
    if (!s.chunked) return c;
    uint64_t layer = mulSaturate(s.layerChunks, s.chunkBytes);
    if (bandDepth > 0) {
        const uint64_t layers = (uint64_t(bandDepth) + s.chunkZ - 1) / s.chunkZ;
        const uint64_t rows = std::min<uint64_t>(s.yChunks, (uint64_t(bandRows) + s.chunkY - 1) / s.chunkY + 1);
        layer = std::min(mulSaturate(layers, layer),
                         mulSaturate(mulSaturate(layers, rows), mulSaturate(s.rowChunks, s.chunkBytes)));
    }
    if (layer <= maxWorkingBytes) {
        c.bytes = layer;
        c.wholeLayer = true;
        // A prime above the span of hash values of one layer: no two chunks of a layer share a slot,
        // so none evicts another before the layer is done. Bounded: slots cost 8 bytes each.
        c.slots = nextPrime(std::max<uint64_t>(521, std::min<uint64_t>(s.hashSpan, uint64_t(1) << 20) + 1));
    } else {
        c.bytes = s.chunkBytes;
    }
    return c;
}

// ------------------------------------------------------------------------------------------------
// Geometry from attributes
// ------------------------------------------------------------------------------------------------

/// Three numbers (z, y, x) from a numeric attribute of 3 values or of one per file axis;
/// false when absent or of another shape.
bool readTriple(hid_t dataset, const char* name, const Axes& axes, std::array<double, 3>& zyx) {
    if (H5Aexists(dataset, name) <= 0) return false;
    Handle attr(H5Aopen(dataset, name, H5P_DEFAULT), H5Aclose);
    if (!attr.valid()) return false;
    Handle type(H5Aget_type(attr.get()), H5Tclose);
    Handle space(H5Aget_space(attr.get()), H5Sclose);
    if (!type.valid() || !space.valid()) return false;
    const H5T_class_t cls = H5Tget_class(type.get());
    if (cls != H5T_INTEGER && cls != H5T_FLOAT) return false;
    const hssize_t count = H5Sget_simple_extent_npoints(space.get());
    if (count != 3 && count != hssize_t(axes.dims.size())) return false;
    std::vector<double> values(static_cast<size_t>(count));
    if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, values.data()) < 0) return false;
    const size_t first = count == 3 ? 0 : size_t(axes.zAxis);
    for (int i = 0; i < 3; ++i) zyx[size_t(i)] = values[first + size_t(i)];
    return true;
}

/// Spacing and origin from the first attribute of each kind that is present; `notes` says which
/// were used or ignored (for the detail line).
Geometry geometryOf(hid_t dataset, const Axes& axes, std::string& notes) {
    Geometry g;
    const auto valid = [](const std::array<double, 3>& v, bool positive) {
        for (double x : v)
            if (!std::isfinite(x) || (positive && x <= 0)) return false;
        return true;
    };
    for (bool spacing : {true, false}) {
        const auto names = spacing ? std::vector<const char*>{"element_size_um", "resolution", "spacing"}
                                   : std::vector<const char*>{"offset", "origin"};
        for (const char* name : names) {
            std::array<double, 3> zyx{};
            const bool present = H5Aexists(dataset, name) > 0;
            if (!present) continue;
            if (!readTriple(dataset, name, axes, zyx) || !valid(zyx, spacing)) {
                notes += std::string(", attribute ") + name + " ignored (not 3 " + (spacing ? "positive " : "") +
                         "numbers)";
                continue;
            }
            (spacing ? g.spacing : g.origin) = {zyx[2], zyx[1], zyx[0]};
            notes += std::string(spacing ? ", spacing from " : ", origin from ") + name;
            break;
        }
    }
    H5Eclear2(H5E_DEFAULT);
    return g;
}

// ------------------------------------------------------------------------------------------------
// Values: native width in the caller's buffer, widened in place
// ------------------------------------------------------------------------------------------------

/// Widens `n` values of T packed at the start of `out` to 64 bits, back to front: value i is read
/// from bytes below 8 * i + 8 before out[i] overwrites them, and no value below i lies there.
template <typename T>
void widenInPlace(uint64_t* out, size_t n) {
    static_assert(sizeof(T) < 8, "8-byte integers are already full width");
    const unsigned char* bytes = reinterpret_cast<const unsigned char*>(out);
    for (size_t i = n; i-- > 0;) {
        T v;
        std::memcpy(&v, bytes + i * sizeof(T), sizeof(T));
        out[i] = std::is_signed<T>::value ? uint64_t(int64_t(v)) : uint64_t(v);
    }
}

/// The first of `n` floats of type F packed at the start of `out` that is not an integer label,
/// or n when all are.
template <typename F>
size_t firstNonInteger(const uint64_t* out, size_t n, double& bad) {
    const unsigned char* bytes = reinterpret_cast<const unsigned char*>(out);
    for (size_t i = 0; i < n; ++i) {
        F v;
        std::memcpy(&v, bytes + i * sizeof(F), sizeof(F));
        int64_t iv;
        if (!floatToInt64(double(v), iv)) {
            bad = double(v);
            return i;
        }
    }
    return n;
}

/// Floats already checked to hold integers, to int64 bits in place (back to front as above).
template <typename F>
void floatsToIntegersInPlace(uint64_t* out, size_t n) {
    const unsigned char* bytes = reinterpret_cast<const unsigned char*>(out);
    for (size_t i = n; i-- > 0;) {
        F v;
        std::memcpy(&v, bytes + i * sizeof(F), sizeof(F));
        out[i] = uint64_t(int64_t(v));
    }
}

// ------------------------------------------------------------------------------------------------
// The source
// ------------------------------------------------------------------------------------------------

/// @brief The label of voxels whose chunk was never written (the dataset's fill value).
struct FillValue {
    uint64_t label = 0;
    std::string bad; ///< non-empty: why the fill value is no label (a float with a fraction)
    bool defined = false; ///< a fill value is defined (by the writer or libhdf5's default 0)
    /// libhdf5 leaves the caller's buffer as it was where storage was never written (fill time
    /// "never", or no fill value defined): readNative fills it with `native` first, so that those
    /// voxels are the fill value on every path, never what the buffer held before.
    bool leftByLibhdf5 = false;
    std::vector<uint8_t> native; ///< the fill value as one voxel of the read's memory type
};

/// @brief What openHdf5 learns about a dataset before reading it.
struct Description {
    InputInfo info;
    VoxelType voxel;
    Axes axes;
    Storage storage;
    bool bigEndian = false; ///< the file's byte order (for chunks we decode ourselves)
    FillValue fill;
    /// Chunks written to the file: none means every voxel is the fill value, known without a
    /// query per chunk (a 1.4 KB file may declare 65536^3 voxels in 2^30 chunks).
    hsize_t writtenChunks = 0;
    /// Contiguous storage never allocated (nothing written, no external file): every voxel is the
    /// fill value too.
    bool unallocated = false;
};

/// zlib's compressBound: the most bytes deflate can store `n` bytes in. A stored chunk larger than
/// that (with every filter applied) is no chunk this dataset's writer made.
uint64_t deflateBound(uint64_t n) { return n + (n >> 12) + (n >> 14) + (n >> 25) + 13; }

/// Inflates a zlib stream (HDF5's deflate filter) into `want` bytes (at most `want` unless
/// `exact`); a stream that holds more (or, exact, fewer) is an error, and no more than `want` + 1
/// bytes are ever produced.
Status inflateChunk(const std::vector<uint8_t>& in, uint64_t want, std::vector<uint8_t>& out, bool exact = true) {
    if (Status s = resizeOrFail(out, size_t(want) + 1, "chunk"); !s) return s;
    z_stream z{};
    if (inflateInit(&z) != Z_OK) return Status::error("cannot start zlib");
    z.next_in = const_cast<Bytef*>(in.data());
    z.avail_in = uInt(in.size()); // at most deflateBound(chunk bytes): checked by the caller
    uint64_t got = 0;
    int ret = Z_OK;
    while (ret == Z_OK && got < want + 1) {
        const uint64_t room = std::min<uint64_t>(want + 1 - got, uint64_t(1) << 30);
        z.next_out = out.data() + got;
        z.avail_out = uInt(room);
        ret = inflate(&z, Z_NO_FLUSH);
        got += room - z.avail_out;
        if (ret == Z_BUF_ERROR && z.avail_in == 0) break;
    }
    const std::string why = z.msg ? z.msg : "";
    inflateEnd(&z);
    if (got > want)
        return Status::error(exact ? "gzip data inflate to more than the chunk's " + std::to_string(want) + " bytes"
                                   : "gzip data inflate to more than " + std::to_string(want) +
                                         " bytes (a chunk's and a KiB of filter headers)");
    if (ret != Z_STREAM_END && ret != Z_OK && ret != Z_BUF_ERROR)
        return Status::error("gzip data are corrupt (" + (why.empty() ? "zlib error " + std::to_string(ret) : why) + ")");
    if (exact && got < want)
        return Status::error("gzip data inflate to " + std::to_string(got) + " bytes, less than the chunk's " +
                             std::to_string(want));
    out.resize(size_t(got));
    return Status::ok();
}

/// HDF5's Fletcher-32 (H5_checksum_fletcher32): 16-bit big-endian words, sums folded every 360.
uint32_t fletcher32(const uint8_t* data, size_t bytes) {
    uint32_t sum1 = 0, sum2 = 0;
    for (size_t words = bytes / 2; words > 0;) {
        const size_t n = std::min<size_t>(words, 360);
        words -= n;
        for (size_t i = 0; i < n; ++i, data += 2) {
            sum1 += (uint32_t(data[0]) << 8) | data[1];
            sum2 += sum1;
        }
        sum1 = (sum1 & 0xffff) + (sum1 >> 16);
        sum2 = (sum2 & 0xffff) + (sum2 >> 16);
    }
    if (bytes % 2) {
        sum1 += uint32_t(*data) << 8;
        sum2 += sum1;
        sum1 = (sum1 & 0xffff) + (sum1 >> 16);
        sum2 = (sum2 & 0xffff) + (sum2 >> 16);
    }
    sum1 = (sum1 & 0xffff) + (sum1 >> 16);
    sum2 = (sum2 & 0xffff) + (sum2 >> 16);
    return (sum2 << 16) | sum1;
}

/// Undoes HDF5's fletcher32 filter: checks and drops the checksum after the data (little-endian;
/// files of HDF5 before 1.6.3 stored it with its 16-bit halves' bytes swapped, accepted too).
Status checkFletcher32(std::vector<uint8_t>& data) {
    if (data.size() < 4) return Status::error("fletcher32 data of " + std::to_string(data.size()) + " bytes hold no checksum");
    const size_t n = data.size() - 4;
    const uint32_t sum = fletcher32(data.data(), n);
    const uint8_t* c = data.data() + n;
    const uint32_t stored = uint32_t(c[0]) | uint32_t(c[1]) << 8 | uint32_t(c[2]) << 16 | uint32_t(c[3]) << 24;
    const uint32_t swapped = uint32_t(c[1]) | uint32_t(c[0]) << 8 | uint32_t(c[3]) << 16 | uint32_t(c[2]) << 24;
    if (stored != sum && swapped != sum)
        return Status::error("its fletcher32 checksum does not match (stored " + std::to_string(stored) +
                             ", computed " + std::to_string(sum) + ")");
    data.resize(n);
    return Status::ok();
}

/// Undoes HDF5's shuffle filter: byte j of element i was stored at j * count + i; bytes after
/// the last whole element were stored as they are.
void unshuffle(const std::vector<uint8_t>& in, size_t elementBytes, std::vector<uint8_t>& out) {
    out.resize(in.size());
    const size_t count = elementBytes ? in.size() / elementBytes : 0;
    for (size_t j = 0; j < elementBytes; ++j)
        for (size_t i = 0; i < count; ++i) out[i * elementBytes + j] = in[j * count + i];
    std::copy(in.begin() + std::ptrdiff_t(count * elementBytes), in.end(),
              out.begin() + std::ptrdiff_t(count * elementBytes));
}

Result<Handle> reopenWithCache(hid_t file, const std::string& name, const ChunkCache& cache, FileRules& rules);

/// @brief One HDF5 dataset read slab by slab (see the file's @brief for the memory bound).
class Hdf5Source : public InputSource {
public:
    Hdf5Source(std::string path, std::string name, std::unique_ptr<FileRules> rules, Handle file, Handle dataset,
               Description what, uint64_t cacheBytes, uint64_t maxWorkingBytes)
        : m_path(std::move(path)), m_name(std::move(name)), m_rules(std::move(rules)), m_file(std::move(file)),
          m_dataset(std::move(dataset)),
          m_type(what.voxel), m_axes(std::move(what.axes)), m_storage(std::move(what.storage)),
          m_cacheBytes(cacheBytes), m_maxWorking(maxWorkingBytes), m_bigEndian(what.bigEndian),
          m_fill(std::move(what.fill)), m_writtenChunks(what.writtenChunks), m_unallocated(what.unallocated) {
        m_info = std::move(what.info);
        if (m_storage.ownDecoding && m_writtenChunks == 0) m_cacheBytes = 0;
    }

    ~Hdf5Source() override {
        Hdf5Scope scope;
        m_dataset.reset();
        m_file.reset();
    }

    Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) override {
        return readRows(z0, depth, 0, m_info.dim[1], out);
    }

    /// A hyperslab of rows costs its chunks only: bands of rows are as cheap as slices.
    bool readsRows() const override { return true; }
    Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) override {
        if (Status s = checkRows(m_info, z0, depth, y0, rows, m_path); !s) return s;
        if (depth == 0 || rows == 0) return Status::ok();
        Hdf5Scope scope;
        if (Status s = fitCache(z0, depth, rows); !s) return s;
        if (m_storage.ownDecoding) {
            Status s = readChunks(z0, depth, y0, rows, out);
            if (!s) return fail(m_path, "cannot read z " + std::to_string(z0) + ".." + std::to_string(z0 + depth - 1) +
                                            ": " + s.message());
            return s;
        }
        if (m_storage.precheck) {
            Status s = precheckChunks(z0, depth, y0, rows);
            if (!s) return fail(m_path, "cannot read z " + std::to_string(z0) + ".." + std::to_string(z0 + depth - 1) +
                                            ": " + s.message());
        }
        if (Status s = readNative(z0, depth, y0, rows, out); !s) return s;
        return widen(z0, y0, rows, size_t(uint64_t(m_info.dim[0]) * rows * depth), out);
    }

    /// Chunks never written are the fill value (readChunks serves them so; libhdf5 does for the
    /// pipelines it decodes, readNative seeing to it when libhdf5 would leave them alone): one
    /// index lookup per chunk of the region (none when no chunk was written), runs along x
    /// merged into one box. None when the fill value is no label (a float with a fraction: the
    /// read names the voxel) or a lookup fails (the read says why).
    void uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, std::vector<UniformBox>& out) override {
        out.clear();
        if (!checkRows(m_info, z0, depth, y0, rows, m_path) || depth == 0 || rows == 0 || !m_fill.bad.empty()) return;
        const uint32_t W = m_info.dim[0], zEnd = z0 + depth, yEnd = y0 + rows;
        if (m_unallocated || (m_storage.chunked && m_writtenChunks == 0)) {
            out.push_back({{{0, y0, z0}}, {{W, yEnd, zEnd}}, m_fill.label});
            return;
        }
        if (!m_storage.chunked) return;
        const uint64_t cz = m_storage.chunkZ, cy = m_storage.chunkY, cx = m_storage.chunkX;
        Hdf5Scope scope;
        for (uint64_t kz = z0 / cz; kz * cz < zEnd; ++kz)
            for (uint64_t ky = y0 / cy; ky * cy < yEnd; ++ky) {
                const uint32_t za = uint32_t(std::max<uint64_t>(z0, kz * cz)), zb = uint32_t(std::min<uint64_t>(zEnd, (kz + 1) * cz));
                const uint32_t ya = uint32_t(std::max<uint64_t>(y0, ky * cy)), yb = uint32_t(std::min<uint64_t>(yEnd, (ky + 1) * cy));
                uint64_t run = ~uint64_t(0); // where the current run of unwritten chunks starts
                for (uint64_t kx = 0; kx * cx < W; ++kx) {
                    Result<bool> written = chunkWritten({kz, ky, kx});
                    if (!written) {
                        H5Eclear2(H5E_DEFAULT);
                        out.clear();
                        return;
                    }
                    if (!*written && run == ~uint64_t(0)) run = kx * cx;
                    if (*written && run != ~uint64_t(0)) {
                        out.push_back({{{uint32_t(run), ya, za}}, {{uint32_t(kx * cx), yb, zb}}, m_fill.label});
                        run = ~uint64_t(0);
                    }
                }
                if (run != ~uint64_t(0)) out.push_back({{{uint32_t(run), ya, za}}, {{W, yb, zb}}, m_fill.label});
            }
    }

    uint64_t workingBytes() const override { return m_cacheBytes; }

private:
    /// @brief A chunk we decoded (its voxels at the file's width and byte order), or a chunk never
    /// written (fill: no bytes).
    struct Chunk {
        std::vector<uint8_t> bytes;
        bool fill = false;
        std::list<std::array<uint64_t, 3>>::iterator use;
    };
    /// Chunks the cache keeps (only written ones): as many as m_cacheBytes holds, as libhdf5's
    /// cache would, and, where chunks are tiny (1 byte each) and an entry's map and list nodes
    /// (about 128 bytes) would dominate, no more than the working-memory limit holds with them.
    uint64_t chunkLimit() const {
        const uint64_t c = m_storage.chunkBytes;
        return std::max<uint64_t>(1, std::min(m_cacheBytes / c, m_maxWorking / (c + 128)));
    }

    /// Rows [y0, y0 + rows) of slices [z0, z0 + depth) from the chunks they touch, each decoded by
    /// us (decodeChunk) or known unwritten and served as the fill value without reading.
    Status readChunks(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) {
        const uint64_t W = m_info.dim[0];
        const uint64_t cz = m_storage.chunkZ, cy = m_storage.chunkY, cx = m_storage.chunkX;
        const unsigned width = typeBytes(m_type.type);
        const uint64_t zEnd = uint64_t(z0) + depth, yEnd = uint64_t(y0) + rows;
        if (m_writtenChunks == 0 && m_fill.bad.empty()) { // one fill, not one per chunk row
            std::fill(out, out + W * rows * depth, m_fill.label);
            return Status::ok();
        }
        for (uint64_t kz = z0 / cz; kz * cz < zEnd; ++kz)
            for (uint64_t ky = y0 / cy; ky * cy < yEnd; ++ky)
                for (uint64_t kx = 0; kx * cx < W; ++kx) {
                    Result<const Chunk*> chunk = chunkAt({kz, ky, kx});
                    if (!chunk) return chunk.status();
                    const uint64_t za = std::max<uint64_t>(z0, kz * cz), zb = std::min(zEnd, (kz + 1) * cz);
                    const uint64_t ya = std::max<uint64_t>(y0, ky * cy), yb = std::min(yEnd, (ky + 1) * cy);
                    const uint64_t xa = kx * cx, n = std::min(W, xa + cx) - xa;
                    if ((*chunk)->fill && !m_fill.bad.empty())
                        return Status::error("voxel (x " + std::to_string(xa) + ", y " + std::to_string(ya) + ", z " +
                                             std::to_string(za) + ") lies in a chunk never written, and the fill value " +
                                             m_fill.bad);
                    for (uint64_t z = za; z < zb; ++z)
                        for (uint64_t y = ya; y < yb; ++y) {
                            uint64_t* dst = out + xa + W * ((y - y0) + uint64_t(rows) * (z - z0));
                            if ((*chunk)->fill) {
                                std::fill(dst, dst + n, m_fill.label);
                                continue;
                            }
                            const uint8_t* src = (*chunk)->bytes.data() + (((z - kz * cz) * cy + (y - ky * cy)) * cx) * width;
                            double bad = 0;
                            const size_t i = widenSamples(src, m_type.type, m_bigEndian, dst, size_t(n), bad);
                            if (i < n)
                                return Status::error("voxel (x " + std::to_string(xa + i) + ", y " + std::to_string(y) +
                                                     ", z " + std::to_string(z) + ") " + notAnIntegerLabel(bad) + " (" +
                                                     labelTypeName(m_type.type) + " voxels must hold integers within int64)");
                        }
                }
        return Status::ok();
    }

    /// The chunk at chunk coordinates (z, y, x), from the cache or decoded; the least recently
    /// used chunks are dropped to keep the cache within m_cacheBytes (at least one chunk).
    Result<const Chunk*> chunkAt(const std::array<uint64_t, 3>& at) {
        auto found = m_chunks.find(at);
        if (found != m_chunks.end()) {
            m_lru.splice(m_lru.end(), m_lru, found->second.use);
            return &found->second;
        }
        if (m_writtenChunks == 0) return &m_unwritten; // nothing to look up, nothing to keep
        Chunk c;
        if (Status s = decodeChunk(at, c); !s) return s;
        // Unwritten chunks are not kept: looking one up again costs less than an entry (a map
        // node each) for every chunk of a sparse volume.
        if (c.fill) return &m_unwritten;
        while (!m_lru.empty() && m_chunks.size() + 1 > chunkLimit()) dropOldest();
        m_lru.push_back(at);
        c.use = std::prev(m_lru.end());
        return &m_chunks.emplace(at, std::move(c)).first->second;
    }

    void dropOldest() {
        auto victim = m_chunks.find(m_lru.front());
        m_chunks.erase(victim);
        m_lru.pop_front();
    }

    /// One chunk's stored bytes as H5Dread_chunk gives them, or none when it was never written.
    struct RawChunk {
        bool written = false;
        std::string where;           ///< "the chunk at (x, y, z)", for messages
        uint64_t stored = 0;
        uint32_t filterMask = 0;     ///< bit i set: the writer skipped filter i for this chunk
        std::vector<uint8_t> data;
    };

    /// The file offset of the chunk at chunk coordinates (z, y, x), in the file's axes.
    std::vector<hsize_t> chunkOffset(const std::array<uint64_t, 3>& at) const {
        std::vector<hsize_t> offset(m_storage.chunk.size(), 0);
        const size_t z = size_t(m_axes.zAxis);
        offset[z] = at[0] * m_storage.chunkZ;
        offset[z + 1] = at[1] * m_storage.chunkY;
        offset[z + 2] = at[2] * m_storage.chunkX;
        return offset;
    }

    /// Whether the chunk at chunk coordinates (z, y, x) was written (an index lookup, no read).
    Result<bool> chunkWritten(const std::array<uint64_t, 3>& at) {
        const std::vector<hsize_t> offset = chunkOffset(at);
        unsigned mask = 0;
        haddr_t addr = HADDR_UNDEF;
        hsize_t stored = 0;
        if (H5Dget_chunk_info_by_coord(m_dataset.get(), offset.data(), &mask, &addr, &stored) < 0)
            return Status::error(hdf5Message());
        return addr != HADDR_UNDEF;
    }

    /// Reads chunk `at` raw, refusing (naming it) stored bytes beyond what any filter of a chunk
    /// can need: deflate's bound, a fletcher32 checksum, and a KiB of filter headers.
    Status readRawChunk(const std::array<uint64_t, 3>& at, RawChunk& raw) {
        const std::vector<hsize_t> offset = chunkOffset(at);
        const size_t z = size_t(m_axes.zAxis);
        raw.where = "the chunk at (x " + std::to_string(offset[z + 2]) + ", y " + std::to_string(offset[z + 1]) +
                    ", z " + std::to_string(offset[z]) + ")";
        unsigned mask = 0;
        haddr_t addr = HADDR_UNDEF;
        hsize_t stored = 0;
        if (H5Dget_chunk_info_by_coord(m_dataset.get(), offset.data(), &mask, &addr, &stored) < 0)
            return Status::error("cannot find " + raw.where + ": " + hdf5Message());
        raw.written = addr != HADDR_UNDEF;
        if (!raw.written) return Status::ok();
        raw.stored = stored;
        const uint64_t limit = deflateBound(m_storage.chunkBytes) + 4 + (m_storage.ownDecoding ? 0 : 1024);
        if (stored > limit)
            return Status::error(raw.where + " stores " + std::to_string(stored) + " bytes, more than the " +
                                 std::to_string(limit) + " a chunk of " + std::to_string(m_storage.chunkBytes) +
                                 " bytes can need");
        if (Status s = resizeOrFail(raw.data, size_t(stored), m_path); !s) return s;
        if (H5Dread_chunk(m_dataset.get(), H5P_DEFAULT, offset.data(), &raw.filterMask, raw.data.data()) < 0)
            return Status::error("cannot read " + raw.where + ": " + hdf5Message());
        return Status::ok();
    }

    /// Undoes the filters of `raw`, last applied first, while they are ours (fletcher32, gzip,
    /// shuffle), each into a buffer of bounded size: inflating stops at `limit` bytes (exactly
    /// the chunk's size when every filter is ours). Stops before any other filter, which it
    /// returns the index of (+ 1; 0 when all were undone).
    Result<size_t> undoOurFilters(RawChunk& raw, uint64_t limit, bool exact) {
        std::vector<uint8_t> next;
        for (size_t i = m_storage.filters.size(); i-- > 0;) {
            if (i < 32 && (raw.filterMask >> i) & 1u) continue; // the writer skipped it for this chunk
            const H5Z_filter_t id = m_storage.filters[i];
            Status s;
            if (id == H5Z_FILTER_FLETCHER32) {
                s = checkFletcher32(raw.data);
            } else if (id == H5Z_FILTER_DEFLATE) {
                s = inflateChunk(raw.data, limit, next, exact);
                raw.data.swap(next);
            } else if (id == H5Z_FILTER_SHUFFLE) {
                unshuffle(raw.data, typeBytes(m_type.type), next);
                raw.data.swap(next);
            } else {
                return i + 1;
            }
            if (!s) return Status::error(raw.where + " (" + std::to_string(raw.stored) + " bytes stored): " + s.message());
        }
        return size_t(0);
    }

    /// Before libhdf5 decodes chunks of a pipeline that is not all ours (Storage::ownDecoding), the
    /// chunks a read touches are checked the way we would decode them, as far as the filters are
    /// ours: a gzip stream may not inflate past the chunk (and a KiB of filter headers), an szip
    /// block may not state more than the chunk (libhdf5 allocates what its first four bytes say).
    /// This reads and inflates those chunks twice, for pipelines that are rare among labels.
    Status precheckChunks(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows) {
        const uint64_t cz = m_storage.chunkZ, cy = m_storage.chunkY, cx = m_storage.chunkX;
        for (uint64_t kz = z0 / cz; kz * cz < uint64_t(z0) + depth; ++kz)
            for (uint64_t ky = y0 / cy; ky * cy < uint64_t(y0) + rows; ++ky)
                for (uint64_t kx = 0; kx * cx < m_info.dim[0]; ++kx) {
                    RawChunk raw;
                    if (Status s = readRawChunk({kz, ky, kx}, raw); !s) return s;
                    if (!raw.written) continue;
                    Result<size_t> stopped = undoOurFilters(raw, m_storage.chunkBytes + 1024, false);
                    if (!stopped) return stopped.status();
                    if (*stopped == 0 || m_storage.filters[*stopped - 1] != H5Z_FILTER_SZIP) continue;
                    if (raw.data.size() < 4)
                        return Status::error(raw.where + " holds " + std::to_string(raw.data.size()) +
                                             " bytes of szip data, too few for their header");
                    const uint8_t* b = raw.data.data();
                    const uint64_t states = uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
                    if (states > m_storage.chunkBytes + 1024)
                        return Status::error(raw.where + " (" + std::to_string(raw.stored) + " bytes stored): szip data " +
                                             "state " + std::to_string(states) + " bytes, more than the chunk's " +
                                             std::to_string(m_storage.chunkBytes));
                }
        return Status::ok();
    }

    /// Decodes one chunk ourselves (Storage::ownDecoding): read raw, filters undone into exactly
    /// the chunk's size. A chunk never written is marked fill, unread.
    Status decodeChunk(const std::array<uint64_t, 3>& at, Chunk& c) {
        RawChunk raw;
        if (Status s = readRawChunk(at, raw); !s) return s;
        if (!raw.written) {
            c.fill = true;
            return Status::ok();
        }
        Result<size_t> stopped = undoOurFilters(raw, m_storage.chunkBytes, true);
        if (!stopped) return stopped.status();
        if (raw.data.size() != m_storage.chunkBytes)
            return Status::error(raw.where + " holds " + std::to_string(raw.data.size()) +
                                 " bytes once decoded, not the " + std::to_string(m_storage.chunkBytes) + " of a chunk");
        c.bytes = std::move(raw.data);
        return Status::ok();
    }

    /// Bands of whole chunk layers, read in order, need only the chunks of one band; anything else
    /// gets the layer cache. The cache is fixed when the dataset is opened, so a change of access
    /// reopens it (rarely: the relabelling pass reads slabs, the encoder bands).
    Status fitCache(uint32_t z0, uint32_t depth, uint32_t rows) {
        const uint32_t cz = m_storage.chunkZ;
        const bool bands = m_storage.chunked && rows < m_info.dim[1] && z0 % cz == 0 &&
                           (depth % cz == 0 || uint64_t(z0) + depth == m_info.dim[2]);
        const ChunkCache want = bands ? chooseCache(m_storage, m_maxWorking, depth, rows)
                                      : chooseCache(m_storage, m_maxWorking);
        if (bands == m_bandCache && (!bands || want.bytes <= m_cacheBytes)) return Status::ok();
        if (m_storage.ownDecoding) { // our own cache (chunkAt): no reopening
            m_cacheBytes = m_writtenChunks > 0 ? want.bytes : 0;
            m_bandCache = bands;
            while (!m_lru.empty() && m_chunks.size() > chunkLimit()) dropOldest();
            return Status::ok();
        }
        m_dataset.reset();
        Result<Handle> reopened = reopenWithCache(m_file.get(), m_name, want, *m_rules);
        if (!reopened) return fail(m_path, reopened.message());
        m_dataset = std::move(*reopened);
        m_cacheBytes = want.bytes;
        m_bandCache = bands;
        return Status::ok();
    }

    /// The region's voxels at their native width, packed at the start of `out`.
    Status readNative(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) {
        const size_t rank = m_axes.dims.size();
        std::vector<hsize_t> start(rank, 0), count(rank, 1);
        const size_t z = size_t(m_axes.zAxis);
        start[z] = z0;
        count[z] = depth;
        start[z + 1] = y0;
        count[z + 1] = rows;
        count[z + 2] = m_info.dim[0];
        if (m_fill.leftByLibhdf5) { // what libhdf5 leaves alone is the fill value, not the buffer's past
            const size_t w = m_fill.native.size(), n = size_t(uint64_t(m_info.dim[0]) * rows * depth);
            auto* bytes = reinterpret_cast<uint8_t*>(out);
            for (size_t i = 0; i < n; ++i) std::memcpy(bytes + i * w, m_fill.native.data(), w);
        }
        // The memory space has the selection's shape: HDF5 then maps chunks to memory by blocks
        // (a 1D memory space made it map element by element, at a fifth of the speed).
        Handle fileSpace(H5Dget_space(m_dataset.get()), H5Sclose);
        Handle memSpace(H5Screate_simple(int(rank), count.data(), nullptr), H5Sclose);
        if (!fileSpace.valid() || !memSpace.valid() ||
            H5Sselect_hyperslab(fileSpace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0 ||
            H5Dread(m_dataset.get(), m_type.memType, memSpace.get(), fileSpace.get(), H5P_DEFAULT, out) < 0)
            return fail(m_path, "cannot read z " + std::to_string(z0) + ".." + std::to_string(z0 + depth - 1) + ": " +
                                    hdf5Message());
        return Status::ok();
    }

    Status widen(uint32_t z0, uint32_t y0, uint32_t rows, size_t n, uint64_t* out) const {
        switch (m_type.type) {
        case LabelType::U8: widenInPlace<uint8_t>(out, n); break;
        case LabelType::I8: widenInPlace<int8_t>(out, n); break;
        case LabelType::U16: widenInPlace<uint16_t>(out, n); break;
        case LabelType::I16: widenInPlace<int16_t>(out, n); break;
        case LabelType::U32: widenInPlace<uint32_t>(out, n); break;
        case LabelType::I32: widenInPlace<int32_t>(out, n); break;
        case LabelType::U64:
        case LabelType::I64: break;
        case LabelType::F32: return floatsToIntegers<float>(z0, y0, rows, n, out);
        case LabelType::F64: return floatsToIntegers<double>(z0, y0, rows, n, out);
        }
        return Status::ok();
    }

    template <typename F>
    Status floatsToIntegers(uint32_t z0, uint32_t y0, uint32_t rows, size_t n, uint64_t* out) const {
        double bad = 0;
        const size_t i = firstNonInteger<F>(out, n, bad);
        if (i < n) {
            const uint64_t w = m_info.dim[0], h = rows;
            return fail(m_path, "voxel (x " + std::to_string(i % w) + ", y " + std::to_string(y0 + i / w % h) + ", z " +
                                    std::to_string(z0 + i / (w * h)) + ") " + notAnIntegerLabel(bad) + " (" +
                                    labelTypeName(m_type.type) +
                                    " voxels must hold integers within int64)");
        }
        floatsToIntegersInPlace<F>(out, n);
        return Status::ok();
    }

    std::string m_path;
    std::string m_name; ///< the dataset's path in the file
    /// Kept by libhdf5 in the access lists of the handles below: declared first, destroyed last.
    std::unique_ptr<FileRules> m_rules;
    Handle m_file;
    Handle m_dataset;
    VoxelType m_type;
    Axes m_axes;
    Storage m_storage;
    uint64_t m_cacheBytes = 0;
    uint64_t m_maxWorking = 0;
    bool m_bandCache = false; ///< the cache holds one band's chunks, not a layer's
    bool m_bigEndian = false;
    FillValue m_fill;
    hsize_t m_writtenChunks = 0;
    bool m_unallocated = false;
    // Chunks we decoded (Storage::ownDecoding), least recently used first in m_lru.
    std::map<std::array<uint64_t, 3>, Chunk> m_chunks;
    std::list<std::array<uint64_t, 3>> m_lru;
    Chunk m_unwritten{{}, true, {}}; ///< every chunk never written (not kept in m_chunks)
};

/// The file opened read-only, after checking that it is an HDF5 file at all.
Result<Handle> openFile(const std::string& file) {
    std::error_code ec;
    const auto status = std::filesystem::status(file, ec);
    if (!std::filesystem::exists(status)) return Status::error("no such file");
    if (std::filesystem::is_directory(status)) return Status::error("is a directory, not an HDF5 file");
    const htri_t isHdf5 = H5Fis_hdf5(file.c_str());
    if (isHdf5 == 0) return Status::error("not an HDF5 file (no HDF5 signature)");
    if (isHdf5 < 0) return Status::error("cannot open: " + hdf5Message());
    Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) return Status::error("cannot open: " + hdf5Message());
    return Result<Handle>(std::move(f));
}

/// Reopens the dataset with the chunk cache chosen for it.
Result<Handle> reopenWithCache(hid_t file, const std::string& name, const ChunkCache& cache, FileRules& rules) {
    Handle dapl = datasetAccess(rules);
    // w0 below 1: HDF5 evicts chunks read completely first and, when those do not free enough,
    // partly read ones; at w0 = 1 it never evicts a partly read chunk and the cache outgrows
    // its size (it did, by a whole layer, in our measurements).
    if (!dapl.valid() || H5Pset_chunk_cache(dapl.get(), size_t(cache.slots), size_t(cache.bytes), 0.75) < 0)
        return Status::error("cannot set the chunk cache: " + hdf5Message());
    Handle d(H5Dopen2(file, name.c_str(), dapl.get()), H5Dclose);
    if (!d.valid()) return Status::error(failure(rules, "cannot open dataset " + name));
    return Result<Handle>(std::move(d));
}

/// The dataset's fill value as a label (0 where none is defined), and whether libhdf5 leaves
/// voxels never written alone when it reads them: with fill time "never" (checked: a buffer
/// filled with 99 beforehand still holds 99 there), or without a defined fill value.
FillValue fillValueOf(hid_t dataset, const VoxelType& voxel) {
    const LabelType type = voxel.type;
    FillValue f;
    f.native.assign(H5Tget_size(voxel.memType), 0);
    Handle dcpl(H5Dget_create_plist(dataset), H5Pclose);
    H5D_fill_value_t defined = H5D_FILL_VALUE_UNDEFINED;
    H5D_fill_time_t time = H5D_FILL_TIME_IFSET;
    if (!dcpl.valid() || H5Pfill_value_defined(dcpl.get(), &defined) < 0 || defined == H5D_FILL_VALUE_UNDEFINED) {
        H5Eclear2(H5E_DEFAULT);
        f.leftByLibhdf5 = true;
        return f;
    }
    f.defined = true;
    f.leftByLibhdf5 = H5Pget_fill_time(dcpl.get(), &time) >= 0 && time == H5D_FILL_TIME_NEVER;
    if (H5Pget_fill_value(dcpl.get(), voxel.memType, f.native.data()) < 0) std::fill(f.native.begin(), f.native.end(), 0);
    if (type == LabelType::F32 || type == LabelType::F64) {
        double v = 0;
        int64_t iv = 0;
        if (H5Pget_fill_value(dcpl.get(), H5T_NATIVE_DOUBLE, &v) >= 0 && floatToInt64(v, iv)) f.label = uint64_t(iv);
        else f.bad = notAnIntegerLabel(v);
    } else if (isSignedType(type)) {
        int64_t v = 0;
        if (H5Pget_fill_value(dcpl.get(), H5T_NATIVE_INT64, &v) >= 0) f.label = uint64_t(v);
    } else {
        uint64_t v = 0;
        if (H5Pget_fill_value(dcpl.get(), H5T_NATIVE_UINT64, &v) >= 0) f.label = v;
    }
    H5Eclear2(H5E_DEFAULT);
    return f;
}

/// Everything about the dataset but its cache: type, axes, storage, geometry.
Result<Description> describe(hid_t dataset, const std::string& name, const InputOptions& options, FileRules& rules) {
    Handle type(H5Dget_type(dataset), H5Tclose);
    Handle space(H5Dget_space(dataset), H5Sclose);
    if (!type.valid() || !space.valid()) return Status::error("cannot read dataset " + name + ": " + hdf5Message());
    Description d;
    Result<VoxelType> voxel = voxelTypeOf(type.get());
    if (!voxel) return Status::error("dataset " + name + " " + voxel.message());
    Result<Axes> axes = axesOf(space.get());
    if (!axes) return Status::error("dataset " + name + " " + axes.message());
    Result<Storage> storage = storageOf(dataset, *axes, type.get(), name);
    if (!storage) return storage.status();
    if (storage->chunked && storage->chunkBytes > options.maxWorkingBytes)
        return Status::error("dataset " + name + " has chunks of " + std::to_string(storage->chunkBytes) +
                             " bytes, more than the working-memory limit of " + std::to_string(options.maxWorkingBytes));
    if (Status s = checkDatasetFiles(dataset, rules, name); !s) return s;
    d.voxel = *voxel;
    d.axes = std::move(*axes);
    d.storage = std::move(*storage);
    d.bigEndian = H5Tget_order(type.get()) == H5T_ORDER_BE;
    d.fill = fillValueOf(dataset, d.voxel);
    if (d.storage.chunked) {
        if (H5Dget_num_chunks(dataset, space.get(), &d.writtenChunks) < 0)
            return Status::error("cannot count the chunks of " + name + ": " + hdf5Message());
        if (d.writtenChunks == 0) d.storage.detail += ", no chunk written (every voxel is the fill value)";
    } else if (d.storage.contiguous && d.fill.defined) {
        // libhdf5 refuses to read unallocated storage without a defined fill value: not uniform then.
        H5D_space_status_t status = H5D_SPACE_STATUS_ERROR;
        Handle dcpl(H5Dget_create_plist(dataset), H5Pclose);
        d.unallocated = dcpl.valid() && H5Pget_external_count(dcpl.get()) == 0 &&
                        H5Dget_space_status(dataset, &status) >= 0 && status == H5D_SPACE_STATUS_NOT_ALLOCATED;
        H5Eclear2(H5E_DEFAULT);
        if (d.unallocated) d.storage.detail += ", never written (every voxel is the fill value)";
    }

    const std::vector<hsize_t>& dims = d.axes.dims;
    const size_t z = size_t(d.axes.zAxis);
    d.info.dim = {uint32_t(dims[z + 2]), uint32_t(dims[z + 1]), uint32_t(dims[z])};
    d.info.type = d.voxel.type;
    d.info.format = "HDF5";
    // With no chunk written there is nothing to decode once per band: bands one slab deep halve
    // the encoder's band (and the time between its reads, when a cancel is noticed) on a volume
    // whose chunks are deeper than its bricks.
    d.info.chunkDepth = d.storage.chunked && d.writtenChunks > 0 ? d.storage.chunkZ : 1;
    std::string notes;
    d.info.geometry = geometryOf(dataset, d.axes, notes);
    d.info.detail = "dataset " + name + ", " + d.storage.detail + notes;
    d.info.namedFiles.assign(rules.named.begin(), rules.named.end());
    return d;
}

} // namespace

bool claimsHdf5(const std::string& path) {
    const std::string low = lower(path);
    return endsWith(low, ".h5") || endsWith(low, ".hdf5") || low.find(".h5:/") != std::string::npos ||
           low.find(".hdf5:/") != std::string::npos;
}

/// libhdf5 1.10.8 (Debian 12) crashes inside itself on some damaged files (Testing/Fuzz/README.md:
/// a local heap that claims 2^62 bytes is copied into the null pointer its failed allocation
/// returned). No check of ours sees that coming, and the crash would take the whole process, a
/// ParaView session, down. So the metadata walk that opening does (the file, the dataset search,
/// the description) runs first in a child process, and a child that dies of a signal marks a file
/// this libhdf5 cannot read safely. A child that cannot be started, or does not end within
/// kProbeSeconds, proves nothing: the open goes on here as it always did.
constexpr int kProbeSeconds = 20;

/// True when the process sleeps in the kernel on a FIFO: waiting for its other end to open it, or
/// for bytes (what Linux's /proc/PID/wchan names those waits). Where /proc hides the wait, only
/// kProbeSeconds is left.
bool blockedOnFifo(pid_t pid) {
    std::FILE* f = std::fopen(("/proc/" + std::to_string(pid) + "/wchan").c_str(), "r");
    if (!f) return false;
    char wait[64] = {0};
    const size_t n = std::fread(wait, 1, sizeof wait - 1, f);
    std::fclose(f);
    const std::string w(wait, n);
    return w == "wait_for_partner" || w == "fifo_open" || w == "pipe_read" || w == "pipe_wait" ||
           w == "pipe_wait_readable";
}

Status probeMetadataInChild(const Hdf5Path& where, const InputOptions& options) {
    pid_t pid = -1;
    {
        // No other thread is inside libhdf5 while its state is copied into the child; the child's
        // copy of the lock is released by this scope's end there too (one thread, the same one).
        std::lock_guard<std::mutex> lock(hdf5Mutex());
        pid = ::fork();
    }
    if (pid < 0) return Status::ok();
    if (pid == 0) {
        // A host's crash handlers (a stack printer that exits with a status) would hide the
        // signal: the child dies of it as a plain process does.
        for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) std::signal(sig, SIG_DFL);
        const struct rlimit noCore {0, 0};
        ::setrlimit(RLIMIT_CORE, &noCore); // a crash here is expected: no core file beside the user's data
        {
            Hdf5Scope scope;
            Result<Handle> file = openFile(where.file);
            if (file) {
                FileRules rules = rulesFor(where.file, options);
                Result<std::pair<Handle, std::string>> found = findDataset(file->get(), where.dataset, rules);
                if (found) (void)describe(found->first.get(), found->second, options, rules);
            }
        }
        ::_exit(0); // errors are the parent's to find and word; no exit handlers, no stdio flush
    }
    const auto start = std::chrono::steady_clock::now();
    const auto until = start + std::chrono::seconds(kProbeSeconds);
    int status = 0;
    for (int polls = 0;; ++polls) {
        const pid_t r = ::waitpid(pid, &status, WNOHANG);
        if (r == pid) break;
        if (r < 0) return Status::ok(); // reaped by the host's own SIGCHLD handling
        // libhdf5 opens some files before any check of ours can see them (the sources of a
        // virtual dataset named by a pattern, when the dataset is opened): a FIFO among them
        // would block the open here for good.
        if (polls % 50 == 49 && blockedOnFifo(pid)) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            return Status::error("libhdf5 blocked on a FIFO (named pipe) the file names (an external link, a virtual "
                                 "dataset's source or external storage) while reading the file's metadata in a separate "
                                 "process: the file is not opened");
        }
        if (std::chrono::steady_clock::now() > until || cancelRequested()) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            return Status::ok();
        }
        ::usleep(1000);
    }
    // The child ends with status 0 whatever it found; anything else is libhdf5 ending it.
    if (WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) != 0))
        return Status::error(std::string("libhdf5 crashed (") +
                             (WIFSIGNALED(status) ? ::strsignal(WTERMSIG(status))
                                                  : "exit status " + std::to_string(WEXITSTATUS(status))) +
                             ") reading the file's metadata in a separate process: the file is damaged in a way this "
                             "libhdf5 does not survive, so it is not opened");
    return Status::ok();
}

Result<std::unique_ptr<InputSource>> openHdf5(const std::string& path, const InputOptions& options) {
    const Hdf5Path where = splitPath(path);
    if (Status s = probeMetadataInChild(where, options); !s) return fail(path, s.message());
    std::unique_ptr<Hdf5Source> source;
    {
        Hdf5Scope scope;
        Result<Handle> file = openFile(where.file);
        if (!file) return fail(path, file.message());
        auto rules = std::make_unique<FileRules>(rulesFor(where.file, options));
        Result<std::pair<Handle, std::string>> found = findDataset(file->get(), where.dataset, *rules);
        if (!found) return fail(path, found.message());
        const std::string name = found->second;
        Result<Description> what = describe(found->first.get(), name, options, *rules);
        if (!what) return fail(path, what.message());
        // The chunk cache is fixed when a dataset is first opened (later opens share it).
        found->first.reset();
        const ChunkCache cache = chooseCache(what->storage, options.maxWorkingBytes);
        // Chunks we decode ourselves are cached by us: libhdf5 keeps none of them.
        Result<Handle> dataset =
            reopenWithCache(file->get(), name, what->storage.ownDecoding ? ChunkCache{0, 521, false} : cache, *rules);
        if (!dataset) return fail(path, dataset.message());
        source = std::make_unique<Hdf5Source>(path, name, std::move(rules), std::move(*file), std::move(*dataset), std::move(*what),
                                              cache.bytes, options.maxWorkingBytes);
    }
    return std::unique_ptr<InputSource>(std::move(source));
}

} // namespace inputs
} // namespace csgv
