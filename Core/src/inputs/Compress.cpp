// SPDX-License-Identifier: MIT
/// @file Compress.cpp
/// @brief compressToFile: input -> LabelSlabAdapter (optionally relabelled in two passes) ->
/// encodeToFile, then the sidecars and the final rename (memory: see Compress.h).
#include "csgv/inputs/Compress.h"
#include "csgv/attributes/AttributeDb.h"
#include "csgv/base/FileUtil.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Procedural.h"
#include "InputCommon.h"

#include <algorithm>
#include <sys/stat.h>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <new>
#include <optional>

namespace csgv {

namespace {

using inputs::endsWith;

std::string baseName(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

/// The folder `path` lies in ("." for a bare name).
std::string folderOf(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
}

double since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// @brief The procedural volume as an InputSource (uint32 values widened), so that `--relabel`
/// and verify treat `synth:` like any input. Memory: one uint32 copy of the last slab read.
class SynthInput : public InputSource {
public:
    explicit SynthInput(const SynthSpec& spec) : m_generator(spec) {
        m_info.dim = spec.dim;
        m_info.type = LabelType::U32;
        m_info.format = "synth";
        m_info.detail = "procedural Voronoi cells, cell size " + std::to_string(spec.cellSize) + ", seed " +
                        std::to_string(spec.seed);
    }
    Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) override {
        return readRows(z0, depth, 0, m_info.dim[1], out);
    }
    bool readsRows() const override { return true; }
    Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out) override {
        if (Status s = inputs::checkRows(m_info, z0, depth, y0, rows, "synth"); !s) return s;
        const size_t n = size_t(uint64_t(m_info.dim[0]) * rows * depth);
        m_labels.resize(n);
        if (Status s = m_generator.readRows(z0, depth, y0, rows, m_labels.data()); !s) return s;
        std::copy(m_labels.begin(), m_labels.end(), out);
        return Status::ok();
    }
    uint64_t workingBytes() const override { return m_labels.capacity() * sizeof(uint32_t); }

private:
    ProceduralSlabSource m_generator;
    std::vector<uint32_t> m_labels;
};

/// @brief Stage bookkeeping between encodeToFile's fractions and CompressOptions::progress:
/// maps a stage's own fraction into its share of the whole (of what was left at a restart, so
/// the whole never goes backwards) and remembers a cancel.
class Progress {
public:
    explicit Progress(const CompressProgress& callback) : m_callback(callback) {}
    /// Starts a stage covering [from, to] of the passes since the last restart (reported at its
    /// start, so rates can be measured from there); false once cancelled.
    bool stage(const char* name, double from, double to) {
        m_name = name;
        m_from = m_base + (1 - m_base) * from;
        m_to = m_base + (1 - m_base) * to;
        return report(0);
    }
    /// The passes that follow share what is left of [0, 1] from the last fraction reported.
    void restart() { m_base = m_last; }
    /// Reports the stage's own fraction; false once the callback asked to cancel.
    bool report(double stageFraction) {
        if (m_cancelled) return false;
        m_last = std::max(m_last, m_from + (m_to - m_from) * std::clamp(stageFraction, 0.0, 1.0));
        if (m_callback && !m_callback(m_last, m_name)) m_cancelled = true;
        return !m_cancelled;
    }
    bool cancelled() const { return m_cancelled; }

private:
    const CompressProgress& m_callback;
    const char* m_name = "";
    double m_from = 0, m_to = 1;
    double m_base = 0;   ///< where the passes since the last restart begin
    double m_last = 0;   ///< the last fraction reported
    bool m_cancelled = false;
};

/// Pass 1: every voxel of the source through the relabeller (which takes them in any order), in
/// reads of bounded size: sub-slabs of whole slices, or, where one slice at 8 bytes a voxel would
/// pass the scratch's bound and the source reads rows, bands of rows as deep as its chunks (so no
/// chunk is decoded twice, and a gzip source inflates each slab once).
Status observeAll(InputSource& source, StreamingRelabeller& relabeller, const CompressOptions& options,
                  Progress& progress, uint64_t& maxSourceWorking) {
    const auto& dim = source.info().dim;
    const uint64_t W = dim[0], slice = W * dim[1];
    const uint64_t budget = LabelSlabAdapter::kScratchBytes;
    // Long reads inside the source ask too (InputSource::setKeepGoing), for as long as this pass runs.
    double last = 0;
    source.setKeepGoing([&] { return progress.report(last); });
    struct Unset {
        InputSource& source;
        ~Unset() { source.setKeepGoing(nullptr); }
    } unset{source};
    const auto observed = [&](uint32_t z, uint32_t depth, uint32_t y, uint32_t rows) {
        maxSourceWorking = std::max(maxSourceWorking, source.workingBytes());
        last = std::max(last, (double(z) + double(depth) * double(y + rows) / double(dim[1])) / double(dim[2]));
        return progress.report(last) ? Status::ok() : Status::error("cancelled");
    };
    // What the source knows to be uniform is observed without reading (each box is first
    // visited at its lowest corner: positions grow with x, y and z); a read covered whole by
    // such boxes is skipped.
    std::vector<UniformBox> boxes;
    const auto knownUniform = [&](uint32_t z, uint32_t depth, uint32_t y, uint32_t rows) {
        if (!options.encode.useUniformBoxes) return false;
        source.uniformBoxes(z, depth, y, rows, boxes);
        uint64_t voxels = 0;
        for (const UniformBox& box : boxes) {
            relabeller.observeUniform(box);
            voxels += box.voxels();
        }
        return voxels == W * rows * depth;
    };
    std::vector<uint64_t> scratch;
    if (!source.readsRows() || slice * sizeof(uint64_t) <= budget) {
        // Bounded scratch (one slice at least), and at least 16 reads so progress moves.
        const uint32_t step = std::min(subSlabDepth(slice, dim[2]), std::max(1u, (dim[2] + 15) / 16));
        Status s = forEachSubSlab(0, dim[2], step, [&](uint32_t z, uint32_t depth) -> Status {
            if (!knownUniform(z, depth, 0, dim[1])) {
                scratch.resize(size_t(slice * step));
                if (Status r = source.readSlab(z, depth, scratch.data()); !r) return r;
                relabeller.observe(z, depth, scratch.data());
            }
            return observed(z, depth, 0, dim[1]);
        });
        return s ? relabeller.finish() : s;
    }
    uint32_t depth = std::clamp<uint32_t>(source.info().chunkDepth, 1, dim[2]);
    if (W * depth * sizeof(uint64_t) > budget) depth = 1;
    const uint32_t rows = uint32_t(std::clamp<uint64_t>(budget / (W * depth * sizeof(uint64_t)), 1, dim[1]));
    for (uint32_t z = 0; z < dim[2]; z += depth) {
        const uint32_t d = std::min(depth, dim[2] - z);
        for (uint32_t y = 0; y < dim[1]; y += rows) {
            const uint32_t r = std::min(rows, dim[1] - y);
            if (!knownUniform(z, d, y, r)) {
                scratch.resize(size_t(W * rows * depth));
                if (Status s = source.readRows(z, d, y, r, scratch.data()); !s) return s;
                relabeller.observeBox({0, y, z}, {dim[0], r, d}, scratch.data());
            }
            if (Status s = observed(z, d, y, r); !s) return s;
        }
    }
    return relabeller.finish();
}

/// Names the input in a message unless it already does.
Status named(Status s, const std::string& input) {
    if (!s && s.message().find(input) == std::string::npos) s.prefix(input);
    return s;
}

} // namespace


std::string voxelText(uint64_t index, const std::array<uint32_t, 3>& dim, uint32_t z0) {
    return voxelText(index, dim[0], 0, dim[1], z0);
}

std::string voxelText(uint64_t index, uint32_t width, uint32_t y0, uint32_t rows, uint32_t z0) {
    const uint64_t x = index % width, y = y0 + (index / width) % rows, z = z0 + index / (uint64_t(width) * rows);
    return "(" + std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) + ")";
}

std::string inputSourceName(const std::string& input) {
    if (isSynthName(input)) return input;
    std::string s = input;
    while (s.size() > 1 && s.back() == '/') s.pop_back();
    // Where the file or folder's own name ends and a selector inside it begins: an HDF5 dataset,
    // a Zarr array path, a precomputed scale, or the pattern of a glob.
    const std::string low = inputs::lower(s);
    size_t cut = s.size();
    for (const char* sel : {".h5:", ".hdf5:", ".zarr/"}) {
        const size_t at = low.find(sel);
        if (at != std::string::npos) cut = std::min(cut, at + std::strlen(sel) - 1);
    }
    cut = std::min(cut, s.find('#'));
    const size_t lastSlash = s.find_last_of('/');
    if (s.find_first_of("*?[", lastSlash == std::string::npos ? 0 : lastSlash) != std::string::npos &&
        lastSlash != std::string::npos)
        cut = std::min(cut, lastSlash);
    std::string file = s.substr(0, cut);
    if (endsWith(file, "/info") && file.size() > 5) file.resize(file.size() - 5); // a precomputed folder's info
    return baseName(file) + s.substr(cut);
}

uint32_t subSlabDepth(uint64_t sliceVoxels, uint32_t depth, uint64_t maxBytes) {
    const uint64_t slices = maxBytes / std::max<uint64_t>(1, sliceVoxels * sizeof(uint64_t));
    return uint32_t(std::max<uint64_t>(1, std::min<uint64_t>(slices, std::max<uint32_t>(depth, 1))));
}

LabelSlabAdapter::LabelSlabAdapter(InputSource& source, const StreamingRelabeller* relabeller, uint64_t maxScratchBytes)
    : m_source(source), m_relabeller(relabeller), m_maxScratchBytes(maxScratchBytes) {}

LabelSlabAdapter::~LabelSlabAdapter() {
    if (m_onRead) m_source.setKeepGoing(nullptr);
}

void LabelSlabAdapter::onRead(std::function<bool(double fraction)> callback) {
    m_onRead = std::move(callback);
    m_source.setKeepGoing(m_onRead ? std::function<bool()>([this] { return m_onRead(m_lastRead); }) : nullptr);
}

Status LabelSlabAdapter::readSlab(uint32_t z0, uint32_t depth, uint32_t* out) {
    return readRegion(z0, depth, 0, m_source.info().dim[1], out);
}

Status LabelSlabAdapter::readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint32_t* out) {
    return readRegion(z0, depth, y0, rows, out);
}

void LabelSlabAdapter::uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows,
                                    std::vector<UniformBox>& out) {
    m_source.uniformBoxes(z0, depth, y0, rows, out);
    size_t kept = 0;
    for (const UniformBox& box : out) {
        uint32_t label = 0;
        if (m_relabeller ? !m_relabeller->toIds(&box.value, 1, &label) : !labelFitsFormat(box.value)) continue;
        out[kept] = box;
        out[kept++].value = m_relabeller ? label : box.value;
    }
    out.resize(kept);
}

Status LabelSlabAdapter::readRegion(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint32_t* out) {
    const auto& dim = m_source.info().dim;
    const uint64_t W = dim[0];
    const bool whole = y0 == 0 && rows == dim[1];
    // Sub-reads within the scratch: a slab by slices; a band by rows at its full depth (so that a
    // chunked source still sees bands of whole chunk layers), by slices too when one row is too much.
    uint32_t stepRows = rows, stepDepth = depth;
    if (whole) {
        stepDepth = subSlabDepth(W * rows, depth, m_maxScratchBytes);
    } else {
        const uint64_t rowBytes = W * std::max(depth, 1u) * sizeof(uint64_t);
        stepRows = uint32_t(std::clamp<uint64_t>(m_maxScratchBytes / rowBytes, 1, std::max(rows, 1u)));
        if (stepRows == 1 && rowBytes > m_maxScratchBytes) stepDepth = subSlabDepth(W, depth, m_maxScratchBytes);
    }
    m_scratch.resize(size_t(W * stepRows * stepDepth));
    for (uint32_t z = z0; z < z0 + depth; z += stepDepth) {
        const uint32_t d = std::min(stepDepth, z0 + depth - z);
        for (uint32_t y = y0; y < y0 + rows; y += stepRows) {
            const uint32_t r = std::min(stepRows, y0 + rows - y);
            Status read = whole ? m_source.readSlab(z, d, m_scratch.data()) : m_source.readRows(z, d, y, r, m_scratch.data());
            if (!read) return read;
            m_maxSourceWorking = std::max(m_maxSourceWorking, m_source.workingBytes());
            // Slices before the region, then this region's share by the rows done (the
            // encoder reads a region's rows for all its slices at once).
            const double done = (double(z0) + double(z - z0 + d) * double(y + r) / double(dim[1])) / double(dim[2]);
            m_lastRead = std::max(m_lastRead, std::min(done, 1.0));
            if (m_onRead && !m_onRead(m_lastRead)) return Status::error("cancelled");
            const uint64_t piece = W * r;
            const auto where = [&](uint64_t i) { return voxelText(i, dim[0], y, r, z); };
            for (uint32_t k = 0; k < d; ++k) {
                const uint64_t* src = m_scratch.data() + piece * k;
                uint32_t* dst = out + W * ((uint64_t(z - z0 + k) * rows) + (y - y0));
                if (m_relabeller) {
                    size_t miss = 0;
                    if (m_relabeller->toIds(src, size_t(piece), dst, &miss)) continue;
                    const uint64_t v = src[miss];
                    const std::string label =
                        isSignedType(m_source.info().type) ? std::to_string(int64_t(v)) : std::to_string(v);
                    return Status::error("the input changed during compression (label " + label + " at voxel " +
                                         where(piece * k + miss) + " was not there in the first pass)");
                }
                // One branch-free pass in shifts and ors, which SSE2 vectorises (a quarter of a
                // fill-only volume's time went to a loop that stopped at the first misfit); the
                // misfit is looked up after. Nonzero for values above 32 bits or 0xFFFFFFFF
                // (labelFitsFormat's rule).
                uint64_t misfits = 0;
                for (uint64_t i = 0; i < piece; ++i) {
                    misfits |= (src[i] >> 32) | (((src[i] & 0xFFFFFFFFu) + 1) >> 32);
                    dst[i] = uint32_t(src[i]);
                }
                if (misfits) {
                    const uint64_t i = uint64_t(std::find_if_not(src, src + piece, labelFitsFormat) - src);
                    m_misfit = true;
                    return Status::error("voxel " + where(piece * k + i) + " holds a label that does not fit the format");
                }
            }
        }
    }
    return Status::ok();
}

Result<std::unique_ptr<InputSource>> openCompressInput(const std::string& input, const InputOptions& options) {
    if (!isSynthName(input)) return openInput(input, options);
    Result<SynthSpec> spec = parseSynthSpec(input);
    if (!spec) return spec.status();
    return std::unique_ptr<InputSource>(std::make_unique<SynthInput>(*spec));
}

namespace {

/// Whether a volume's set (the volume, its `.csgv.json` and `_csgv.db3`) may replace what its
/// names hold (replaceableOutput): a folder in the way would fail its rename after the others were
/// done, and a device, FIFO or link would be replaced by a file.
Status replaceableSet(const std::string& output) {
    for (const std::string& p : {output, metadataPathFor(output), attributeDbPathFor(output)})
        if (Status s = replaceableOutput(p); !s) return s;
    return Status::ok();
}

} // namespace

Status publishVolumeFiles(const std::string& output, const std::string& volumeTmp, const VolumeMetadata& md,
                          const LabelMapping& mapping) {
    const std::string db = attributeDbPathFor(output), mdPath = metadataPathFor(output);
    if (Status s = replaceableSet(output); !s) return s;
    // Every new file complete under a temporary name first: a full disk or any write error
    // strikes here, before anything of the old set is touched.
    const std::string dbTmp = temporaryNameFor(db), mdTmp = temporaryNameFor(mdPath);
    auto dropNew = [&] {
        for (const std::string* p : {&dbTmp, &mdTmp})
            if (fileExists(*p)) std::remove(p->c_str());
    };
    VolumeMetadata written = md;
    written.relabelled = mapping.relabelled;
    if (mapping.relabelled) {
        if (Status s = writeAttributeDb(dbTmp, md.dim, mapping.originalBits, isSignedType(mapping.type)); !s) {
            dropNew();
            return Status::error(renamedInMessage(s.message(), dbTmp, db));
        }
    }
    if (Status s = writeMetadata(mdTmp, written); !s) {
        dropNew();
        return Status::error(renamedInMessage(s.message(), mdTmp, mdPath));
    }
    // Then the renames, sidecars first and the volume last. Each file of the old set is moved
    // aside before its replacement comes in (a stale database of an earlier relabelling goes
    // without one), so a rename that fails (a folder changed under us) puts the old set back
    // whole; the old files go once the volume is in place.
    struct Move {
        std::string from, to, aside; // from empty: `to` is removed (the stale database)
        bool asideDone = false, moved = false;
    };
    std::vector<Move> moves;
    // No interrupt between the renames (an interrupt watchdog waits for this, FileUtil.h).
    std::optional<PublishingHold> publishing;
    publishing.emplace();
    std::optional<FolderLocks> folder; // another process publishing a set of these names waits
    folder.emplace(std::vector<std::string>{output});
    if (Status s = interruptedBeforePublishing(); !s) {
        dropNew();
        return s;
    }
    moves.push_back({mdTmp, mdPath, {}});
    if (mapping.relabelled) moves.push_back({dbTmp, db, {}});
    else if (fileExists(db)) moves.push_back({{}, db, {}});
    moves.push_back({volumeTmp, output, {}});
    Status s;
    for (Move& m : moves) {
        if (!m.from.empty()) keepModeOf(m.to, m.from);
        if (fileExists(m.to)) {
            m.aside = temporaryNameFor(m.to) + "-old";
            if (std::rename(m.to.c_str(), m.aside.c_str()) != 0) {
                s = Status::error("cannot replace '" + m.to + "': " + errnoText());
                break;
            }
            m.asideDone = true;
        }
        if (!m.from.empty()) {
            if (std::rename(m.from.c_str(), m.to.c_str()) != 0) {
                s = Status::error("cannot rename '" + m.from + "' to '" + m.to + "': " + errnoText());
                break;
            }
            m.moved = true;
        }
    }
    if (!s) {
        std::string stranded; // old files that could not be put back, named in the error
        for (auto m = moves.rbegin(); m != moves.rend(); ++m) {
            if (m->moved) std::rename(m->to.c_str(), m->from.c_str()); // the caller's volume stays its own
            if (m->asideDone && std::rename(m->aside.c_str(), m->to.c_str()) != 0)
                stranded += "; the old '" + m->to + "' is at '" + m->aside + "'";
        }
        dropNew();
        return Status::error(s.message() + stranded);
    }
    // The old files go after the hold: removing a large one may take long, and an interrupt
    // meanwhile finds the lock free and removes what is left of them. Registered only now that
    // the set is in (an old file a failed set could not put back stays where its error says).
    for (const Move& m : moves)
        if (m.asideDone) registerTemporary(m.aside);
    folder.reset();
    publishing.reset();
    for (const Move& m : moves)
        if (m.asideDone) std::remove(m.aside.c_str());
    return Status::ok();
}

Status writeVolumeFiles(const std::string& output, const CompressedVolume& volume, const VolumeMetadata& md,
                        const LabelMapping& mapping) {
    if (Status s = replaceableSet(output); !s) return s;
    const std::string tmp = temporaryNameFor(output); // no .csgv at its end: nothing offers it as a volume
    Status s = writeCsgv(tmp, volume);
    if (s) s = publishVolumeFiles(output, tmp, md, mapping);
    if (s) return s;
    if (fileExists(tmp)) std::remove(tmp.c_str());
    // The user named the output, not its temporaries ('<output>.tmp-...' up to the closing quote:
    // writeCsgv's own temporary is named after this one).
    std::string message = s.message();
    const std::string prefix = output + ".tmp-";
    for (size_t at = message.find(prefix); at != std::string::npos; at = message.find(prefix, at + output.size())) {
        const size_t end = message.find('\'', at + prefix.size()); // a quote in the path is no end
        message.replace(at, (end == std::string::npos ? message.size() : end) - at, output);
    }
    return Status::error(message);
}

namespace {

/// The share of encodeToFile's fractions that its first pass (reading and encoding the labels)
/// takes: it reports 0.8 * (slabs done) / slabs (Encoder.cpp). Reads report within that share,
/// never ahead of what the encoder reports once their slab is done.
constexpr double kEncoderReadShare = 0.8;

/// Progress and cancellation between the encoder's own reports (LabelSlabAdapter::onRead).
void reportReads(LabelSlabAdapter& adapter, Progress& progress) {
    adapter.onRead([&progress](double f) { return progress.report(kEncoderReadShare * f); });
}

/// One encoding pass of `slabs` into `path`, its fractions reported through `progress`.
Status encodePass(SlabSource& slabs, const CompressOptions& options, const std::string& path, Progress& progress,
                  uint64_t& outputBytes) {
    EncodeToFileOptions fo;
    fo.maxOutputBytes = options.maxOutputBytes;
    fo.maxIndexBytes = options.maxIndexBytes;
    fo.progress = [&progress](double f) { return progress.report(f); };
    return encodeToFile(slabs, options.encode, path, fo, &outputBytes);
}

/// Removes the file at `path` if there is one (cleanup after errors; failures are harmless).
void removeIfThere(const std::string& path) {
    if (fileExists(path)) std::remove(path.c_str());
}

/// @brief One compression's state between its steps (open, encode, publish).
struct Job {
    const std::string& input;
    const CompressOptions& options;
    CompressReport& rep;
    std::string tmp;           ///< the encoded volume before its final rename
    Progress progress;
    bool synth = false;
    std::unique_ptr<InputSource> owned;
    InputSource* source = nullptr;
    VolumeMetadata md;
    LabelMapping mapping;
    uint64_t outputBytes = 0;
    bool published = false;    ///< the volume was renamed into place
    const std::string& output;

    Job(const std::string& in, const std::string& out, const CompressOptions& o, CompressReport& r)
        : input(in), options(o), rep(r), tmp(temporaryNameFor(out)), progress(o.progress), output(out) {
        registerTemporary(tmp);
    }
    /// Whatever ends the job (an error, an exception unwinding), no temporary volume is left.
    ~Job() {
        if (!published) removeIfThere(tmp);
    }
    Job(const Job&) = delete;
    Job& operator=(const Job&) = delete;

    /// Cleans up after an error and says what happened (a cancel says so).
    Status failed(Status s) {
        removeIfThere(tmp);
        if (progress.cancelled()) return Status::error("compression of '" + input + "' cancelled");
        // The user named the output, not its temporary (encodeToFile's messages name the latter).
        return named(Status::error(renamedInMessage(s.message(), tmp, output)), input);
    }

    /// Opens the input (unless a source is given) and fills what is known before any voxel is read.
    Status open(InputSource* given) {
        synth = !given && isSynthName(input);
        if (given) {
            source = given;
        } else {
            // A source's scratch file goes where the encoder's go: beside the output.
            InputOptions inputOptions = options.input;
            if (inputOptions.scratchDirectory.empty()) inputOptions.scratchDirectory = folderOf(output);
            Result<std::unique_ptr<InputSource>> opened = openCompressInput(input, inputOptions);
            if (!opened) return opened.status();
            owned = std::move(*opened);
            source = owned.get();
        }
        const InputInfo& info = source->info();
        md.source = inputSourceName(input);
        md.dim = info.dim;
        if (!synth) {
            md.geometry = cellGeometryFromPointGeometry(info.geometry);
            md.originalType = labelTypeName(info.type);
        }
        mapping.type = info.type;
        rep.dim = info.dim;
        rep.voxels = info.voxelCount();
        rep.inputFormat = info.format;
        rep.namedFiles = info.namedFiles;
        return Status::ok();
    }

    /// One pass keeping the labels; sets `misfit` (and fails) at the first label that does not fit.
    Status encodeKeepingLabels(bool& misfit) {
        if (!progress.stage("encoding", 0, 1)) return Status::error("cancelled");
        rep.passes = 1;
        if (synth) {
            // The generator's labels always fit: no adapter, no scratch.
            ProceduralSlabSource generator(*parseSynthSpec(input));
            rep.workingBytes = encoderBandBytes(generator, options.encode.brickSize);
            return encodePass(generator, options, tmp, progress, outputBytes);
        }
        LabelSlabAdapter adapter(*source, nullptr);
        reportReads(adapter, progress);
        Status s = encodePass(adapter, options, tmp, progress, outputBytes);
        rep.workingBytes = encoderBandBytes(adapter, options.encode.brickSize) + adapter.scratchBytes() +
                           adapter.maxSourceWorkingBytes();
        misfit = !s && adapter.misfit() && !progress.cancelled();
        return s;
    }

    /// Two passes: first visiting positions, then the ids encoded.
    Status encodeRelabelled() {
        removeIfThere(tmp);
        progress.restart();
        StreamingRelabeller relabeller(source->info().dim, options.encode.brickSize);
        uint64_t sourceWorking = 0;
        if (!progress.stage("relabelling", 0, kRelabellingShare)) return Status::error("cancelled");
        const auto t0 = std::chrono::steady_clock::now();
        if (Status s = observeAll(*source, relabeller, options, progress, sourceWorking); !s) return s;
        rep.relabelSeconds = since(t0);
        rep.passes += 2;
        if (!progress.stage("encoding", kRelabellingShare, 1)) return Status::error("cancelled");
        LabelSlabAdapter adapter(*source, &relabeller);
        reportReads(adapter, progress);
        if (Status s = encodePass(adapter, options, tmp, progress, outputBytes); !s) return s;
        mapping.relabelled = true;
        mapping.originalBits = relabeller.originalBits();
        if (synth) md.originalType = labelTypeName(LabelType::U32);
        rep.workingBytes = std::max(rep.workingBytes, encoderBandBytes(adapter, options.encode.brickSize) +
                                                          adapter.scratchBytes() +
                                                          relabeller.memoryBytes() +
                                                          std::max(sourceWorking, adapter.maxSourceWorkingBytes()));
        return Status::ok();
    }

    Status publish(const std::string& output) {
        md.relabelled = mapping.relabelled;
        Status s = publishVolumeFiles(output, tmp, md, mapping);
        published = bool(s);
        return s;
    }
};

/// compressToFile from a given source or the input's name.
Status compress(InputSource* given, const std::string& input, const std::string& output,
                const CompressOptions& options, CompressReport* report) {
    CompressReport local;
    CompressReport& rep = report ? *report : local;
    rep = CompressReport{};
    if (Status s = checkEncodeOptions(options.encode); !s) return s;
    if (!endsWith(output, ".csgv")) return Status::error("output '" + output + "' must end in .csgv");
    // What the set would replace is checked before any work (and again when it is published).
    if (Status s = replaceableSet(output); !s) return s;
    const auto tStart = std::chrono::steady_clock::now();
    Job job(input, output, options, rep);
    if (Status s = job.open(given); !s) return s;
    rep.readSeconds = since(tStart);
    // An index that cannot fit is refused now, not after a relabelling pass or the first slabs.
    if (Status s = checkEncoderIndex(rep.dim, options.encode.brickSize, options.maxIndexBytes); !s)
        return job.failed(s);

    // Labels kept in one optimistic pass unless relabelling is asked for or a label does not fit.
    auto t0 = std::chrono::steady_clock::now();
    bool relabel = options.relabel;
    if (!relabel) {
        Status s = job.encodeKeepingLabels(rep.restarted);
        if (!s && !rep.restarted) return job.failed(s);
        relabel = rep.restarted;
    }
    if (relabel) {
        t0 = std::chrono::steady_clock::now();
        if (Status s = job.encodeRelabelled(); !s) return job.failed(s);
    }
    rep.encodeSeconds = since(t0) - rep.relabelSeconds;

    t0 = std::chrono::steady_clock::now();
    if (Status s = job.publish(output); !s) return job.failed(s);
    rep.writeSeconds = since(t0);
    rep.outputBytes = job.outputBytes;
    rep.relabelled = job.mapping.relabelled;
    rep.labelCount = job.mapping.originalBits.size();
    rep.originalType = job.md.originalType;
    const double total = since(tStart);
    rep.mvoxelsPerSecond = total > 0 ? double(rep.voxels) / total / 1e6 : 0;
    return Status::ok();
}

} // namespace

namespace {

/// compress() with errors as values across Core's boundary: an allocation failure (the label map,
/// the scratch, the encoder's tables) or any other exception becomes a message; the Job's
/// destructor has removed the temporary volume by then.
Status compressCatching(InputSource* given, const std::string& input, const std::string& output,
                        const CompressOptions& options, CompressReport* report) {
    try {
        return compress(given, input, output, options, report);
    } catch (const std::bad_alloc&) {
        return Status::error("out of memory while compressing '" + input + "' to '" + output + "'");
    } catch (const std::exception& e) {
        return Status::error("compressing '" + input + "' to '" + output + "' failed: " + e.what());
    }
}

} // namespace

Status compressToFile(const std::string& input, const std::string& output, const CompressOptions& options,
                      CompressReport* report) {
    return compressCatching(nullptr, input, output, options, report);
}

Status compressSourceToFile(InputSource& source, const std::string& name, const std::string& output,
                            const CompressOptions& options, CompressReport* report) {
    return compressCatching(&source, name, output, options, report);
}

} // namespace csgv
