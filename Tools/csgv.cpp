// SPDX-License-Identifier: MIT
/// @file csgv.cpp
/// @brief The `csgv` command-line tool: info, decompress, extract, verify. Exit 0 on success, 1 with one
/// message on stderr for any user or data error; no input may end it with a signal.

#include "csgv/inputs/Compress.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Extract.h"
#include "csgv/codec/Mesh.h"
#include "csgv/codec/LabelVolume.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Procedural.h"
#include "csgv/base/FileUtil.h"
#include "CommandLine.h"
#include "Interrupt.h"
#ifdef CSGV_HAVE_RENDER
#include "RenderCommand.h"
#endif

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>
#include <omp.h>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <unistd.h>
#include <vector>
#include <zlib.h>
#include <zstd.h>

using namespace csgv;

namespace {

/// The usage text; the input forms come from the format table, so a new reader shows up here.
std::string usage() {
    const std::string inputs = "synth:WxHxD[:seed], " + supportedInputForms();
#ifdef CSGV_HAVE_RENDER
    const std::string shadings = shadingChoices();
#else
    const std::string shadings = "MODE";
#endif
    return "usage: csgv <command> [options]\n"
           "  info IN.csgv [--stats] [--check] [--threads N]\n"
           "      key: value lines describing the file; --stats decodes it and prints label statistics,\n"
           "      --check decodes every brick and reports the first stream error\n"
           "  info INPUT\n"
           "      an input's format, dimensions, type, spacing, origin and label count (labels_counted:\n"
           "      exact up to 2^24 voxels, otherwise an estimate from 16 evenly spaced slices)\n"
           "  decompress IN.csgv OUT.vraw|OUT.nrrd [--level L] [--threads N]\n"
           "      level 0 = full resolution, 1 = half, ...; original labels when a _csgv.db3 is beside IN\n"
           "  extract IN.csgv OUT.nrrd|OUT.vti|OUT.vraw --labels L1,L2,... | --query SQL [--mask] [--level L]\n"
           "          [--box x0,y0,z0,x1,y1,z1] [--max-labels N] [--max-output-mib M] [--threads N]\n"
           "      the selected labels (original labels; --query: an SQL condition over the _csgv.db3's\n"
           "      columns) as a label image (others 0) or a uint8 mask (--mask), cropped to their bounding\n"
           "      box, decoding only the bricks whose palettes hold one; --box in full-resolution voxels,\n"
           "      half-open; NRRD origin and spacing overlay the volume; limits: 1000000 labels, 4096 MiB\n"
           "  extract IN.csgv OUT.obj|OUT.ply|OUT.stl|OUT.vtp --labels L1,L2,... | --query SQL [--level L] [--box ...]\n"
           "      voxel-face surfaces of the selected labels in world coordinates, each label extracted on\n"
           "      its own (OBJ: a group label_L per label; PLY: a label per face; STL: no labels)\n"
           "  verify IN.csgv SOURCE [--threads N]\n"
           "      SOURCE: any input below; compared slab by slab; exit 0 only if every voxel and every\n"
           "      coarse level matches SOURCE (through the attribute database when there is one)\n"
           "  compress IN OUT.csgv [--brick-size N] [--encoding nibble|rans1|rans2] [--ops default|all|LETTERS]\n"
           "           [--threads N] [--relabel] [--quiet]\n"
           "      writes OUT.csgv.json (geometry) and OUT_csgv.db3 when labels are relabelled; progress on\n"
           "      stderr unless --quiet; letters p x y z n l d s\n"
           "  tile IN.csgv OUT.csgv --times X,Y,Z [--max-output-mib M] [--quiet]\n"
           "      IN repeated X x Y x Z times, its bricks copied as stored (dimensions must be whole\n"
           "      bricks): a volume larger than memory in the time it takes to write it (benchmarks)\n"
           "  bench IN [--threads N] [--brick-size N] [--encoding E] [--ops O]\n"
           "      bits/voxel, encode and decode Mvoxel/s, and zstd -19 / gzip -9 of the raw uint32 labels\n"
           "  render IN.csgv OUT.png [--size WxH] [--eye x,y,z] [--center x,y,z] [--up x,y,z]\n"
           "         [--fov-y DEG | --parallel-scale S] [--shading " + shadings + "] [--frames N]\n"
           "         [--no-jitter] [--finest] [--labels-out FILE] [--materials FILE.json]\n"
           "         [--orbit N | --camera-path FILE] [--camera volcanite] [--frames-per-view N [--compare-converged]]\n"
           "         [--video PATTERN]\n"
           "         [--cache-mib M] [--device-memory-mib M] [--host-memory-mib M] [--cache-paletting]\n"
           "         [--subsampling 1|2|4|8] [--lod-bias B] [--decode auto|gpu|host] [--decode-steps N|all|auto]\n"
           "         [--prefetch-voxels N|auto] [--blend B] [--no-denoise] [--tone-mapping] [--background r,g,b]\n"
           "         [--attributes FILE.csv|.txt|.db3]... [--computed-attributes] [--derive NAME=SQL]...\n"
           "      renders on the GPU (CSGV_VULKAN_DEVICE picks the device); --frames N: samples per pixel;\n"
           "      prints each frame's time, the median, the time to the first full frame, device memory\n"
           "         --video PATTERN: an image per view; one %d or %0Nd (view number), %% for a percent sign\n"
           "         --camera-path FILE: a pose a line, ex ey ez cx cy cz ux uy uz fovy (degrees), # comments\n"
           "         --camera volcanite: Volcanite 0.6's default orbital pose (1.5 x the largest side, elevation\n"
           "         0.5 rad, azimuth 4.0 rad, up +z, fov 59.4 degrees); --orbit turns it about the up axis\n"
           "         --frames-per-view N: exactly N frames a pose, converged or not (1: a moving camera)\n"
           "         --compare-converged: also renders each pose until converged (a second renderer, every\n"
           "         decoder step, not timed) and prints the share of pixels the view's last frame shows as\n"
           "         that image does, and of its previews (pixels without samples), per view and the median\n"
           "         --decode-steps N: GPU decoding gives each brick N steps a frame, going on in the next\n"
           "         frames (auto: 512 on GPUs, all on CPU devices; all: every brick ends in its frame)\n"
           "         --prefetch-voxels N: a new cache decodes every visible brick at the first frame when they\n"
           "         hold at most N voxels (auto: 2^23 decoded on the host, 2^24 on the GPU; 0: never)\n"
           "         --host-memory-mib M: a rANS two-table encoding larger than M (0: half the available\n"
           "         memory) keeps its coarse levels in memory and reads the finest level from the file\n"
           "  inputs (IN, SOURCE, INPUT): " + inputs + "\n"
           "  --allow-outside-paths: read files an input names outside its own folder (NRRD data files,\n"
           "      precomputed scales, OME-Zarr paths, HDF5 external storage); refused by default\n"
           "  Ctrl-C, SIGTERM, SIGHUP or SIGPIPE ends any command within a second with exit status 130 and no partial\n"
           "  output; outputs appear only when complete, and replace an existing set all at once\n";
}

struct Args {
    std::vector<std::string> positional;
    bool stats = false;
    bool check = false;
    bool relabel = false;
    bool quiet = false;
    InputOptions input;
    uint32_t level = 0;
    int threads = 0;
    EncodeOptions encode;
    // extract
    bool mask = false;
    bool hasLabels = false;
    std::vector<int64_t> labels;
    std::string query;
    bool hasQuery = false;
    bool hasBox = false;
    Box box;
    uint64_t maxLabels = kDefaultMaxExtractLabels;
    uint64_t maxOutputMiB = 4096;
    // tile
    bool hasTimes = false;
    std::array<uint32_t, 3> times{{1, 1, 1}};
};

int fail(const std::string& message) { return interrupt::failed(message); }

bool parseUnsigned(const std::string& s, uint64_t max, uint64_t& out) {
    if (s.empty() || s.size() > 19 || s.find_first_not_of("0123456789") != std::string::npos) return false;
    out = std::stoull(s);
    return out <= max;
}

Status parseArgs(int argc, char** argv, Args& a) {
    for (int i = 2; i < argc; ++i)
        if (!*argv[i]) return Status::error("empty argument");
    // Every command accepts the same options (those it does not use are ignored), as always.
    CLI::App app;
    configureCommand(app);
    app.add_flag("--stats", a.stats);
    app.add_flag("--check", a.check);
    app.add_flag("--relabel", a.relabel);
    app.add_flag("--quiet", a.quiet);
    app.add_flag("--mask", a.mask);
    app.add_flag("--allow-outside-paths", a.input.allowOutsidePaths);
    app.add_option("files", a.positional);
    ValueOptions values(app);
    const auto small = [&values](const char* name, uint64_t max, auto set) {
        values.add(name, [name, max, set](const std::string& v) {
            uint64_t n = 0;
            if (!parseUnsigned(v, max, n))
                return Status::error(std::string("option ") + name + " expects a small non-negative integer, not '" +
                                     v + "'");
            set(n);
            return Status::ok();
        });
    };
    small("--level", 31, [&a](uint64_t n) { a.level = uint32_t(n); });
    small("--threads", 1024, [&a](uint64_t n) { a.threads = int(n); });
    small("--brick-size", 1024, [&a](uint64_t n) { a.encode.brickSize = uint32_t(n); });
    small("--max-output-mib", uint64_t(1) << 40, [&a](uint64_t n) { a.maxOutputMiB = n; });
    values.add("--max-labels", [&a](const std::string& v) {
        if (!parseUnsigned(v, uint64_t(1) << 32, a.maxLabels) || a.maxLabels == 0)
            return Status::error("option --max-labels expects a positive integer, not '" + v + "'");
        return Status::ok();
    });
    values.add("--labels", [&a](const std::string& v) {
        // Comma-separated integers: negative and unsigned 64-bit labels as their int64 bits.
        a.labels.clear();
        a.hasLabels = true;
        size_t at = 0;
        while (at <= v.size()) {
            const size_t comma = std::min(v.find(',', at), v.size());
            const std::string item = v.substr(at, comma - at);
            const bool negative = !item.empty() && item[0] == '-';
            const std::string digits = negative ? item.substr(1) : item;
            uint64_t n = 0;
            const bool ok = !digits.empty() && digits.size() <= 20 && digits.find_first_not_of("0123456789") == std::string::npos &&
                            (digits.size() < 20 || digits <= "18446744073709551615");
            if (ok) n = std::stoull(digits);
            if (!ok || (negative && n > uint64_t(1) << 63))
                return Status::error("--labels expects comma-separated integer labels, not '" + item + "' in '" + v + "'");
            a.labels.push_back(negative ? int64_t(0 - n) : int64_t(n));
            at = comma + 1;
        }
        return Status::ok();
    });
    values.add("--query", [&a](const std::string& v) {
        a.query = v;
        a.hasQuery = true;
        return Status::ok();
    });
    values.add("--box", [&a](const std::string& v) {
        uint64_t n[6];
        size_t at = 0;
        for (int i = 0; i < 6; ++i) {
            const size_t comma = i < 5 ? v.find(',', at) : v.size();
            if (comma == std::string::npos || !parseUnsigned(v.substr(at, comma - at), 0xFFFFFFFFu, n[i]))
                return Status::error("--box expects six non-negative integers x0,y0,z0,x1,y1,z1, not '" + v + "'");
            at = comma + 1;
        }
        if (at != v.size() + 1)
            return Status::error("--box expects six non-negative integers x0,y0,z0,x1,y1,z1, not '" + v + "'");
        for (int c = 0; c < 3; ++c) {
            a.box.min[c] = uint32_t(n[c]);
            a.box.max[c] = uint32_t(n[c + 3]);
        }
        a.hasBox = true;
        return Status::ok();
    });
    values.add("--times", [&a](const std::string& v) {
        uint64_t n[3];
        size_t at = 0;
        for (int i = 0; i < 3; ++i) {
            const size_t comma = i < 2 ? v.find(',', at) : v.size();
            if (comma == std::string::npos || !parseUnsigned(v.substr(at, comma - at), 1024, n[i]) || n[i] == 0)
                return Status::error("--times expects three repeat counts X,Y,Z from 1 to 1024, not '" + v + "'");
            at = comma + 1;
        }
        for (int c = 0; c < 3; ++c) a.times[c] = uint32_t(n[c]);
        a.hasTimes = true;
        return Status::ok();
    });
    values.add("--encoding", [&a](const std::string& v) {
        if (v == "nibble" || v == "0") a.encode.encoding = kEncodingNibble;
        else if (v == "rans1" || v == "1") a.encode.encoding = kEncodingRans1;
        else if (v == "rans2" || v == "2") a.encode.encoding = kEncodingRans2;
        else return Status::error("--encoding expects nibble, rans1 or rans2, not '" + v + "'");
        return Status::ok();
    });
    values.add("--ops", [&a](const std::string& v) {
        Result<uint32_t> m = parseOperationMask(v);
        if (!m) return Status::error("--ops: " + m.message());
        a.encode.opMask = *m;
        return Status::ok();
    });
    if (Status s = parseCommand(app, argc, argv); !s) return s;
    return values.convert();
}

double seconds(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Distinct values of an input: every voxel when the volume is small (exact), otherwise those of
/// kLabelSampleSlices evenly spaced slices (a lower bound). Memory is bounded whatever the input:
/// values are read kLabelReadVoxels at a time (sub-slabs, or bands of rows of a slice wider than
/// that: a 20000 x 20000 slice read whole took 3.2 GB; inputs that read whole slices only give
/// a slice of at most kLabelSliceVoxels), a slice larger than kLabelSliceVoxels is sampled by
/// kLabelSampleBands evenly spaced bands of rows (an input that reads whole slices only is then
/// not counted), and the set stops growing at kMaxCountedLabels.
struct LabelCount {
    uint64_t count = 0;
    bool exact = false;
    bool capped = false;      ///< the set reached kMaxCountedLabels: count is a lower bound
    bool skipped = false;     ///< slices too large to sample and the input reads whole slices only
    uint32_t slicesRead = 0;
    uint32_t bandRows = 0;    ///< rows per band when slices were sampled by bands (0: whole slices)
};
constexpr uint64_t kExactLabelVoxels = uint64_t(1) << 24;
constexpr uint32_t kLabelSampleSlices = 16;
constexpr uint64_t kLabelReadVoxels = uint64_t(1) << 21;   // 16 MiB of values at once
constexpr uint64_t kLabelSliceVoxels = uint64_t(1) << 25;  // larger slices are sampled by bands
constexpr uint32_t kLabelSampleBands = 4;
constexpr size_t kMaxCountedLabels = size_t(1) << 21;      // about 100 MB of set

Result<LabelCount> countLabels(InputSource& src) {
    const auto& dim = src.info().dim;
    const uint64_t W = dim[0], H = dim[1], slice = W * H;
    LabelCount c;
    // Exact only by voxel count: a few huge slices read whole would fill the set as surely.
    c.exact = src.info().voxelCount() <= kExactLabelVoxels;
    std::unordered_set<uint64_t> seen;
    std::vector<uint64_t> buf;
    auto add = [&](size_t n) {
        uint64_t last = n ? ~buf[0] : 0;
        for (size_t i = 0; i < n && !c.capped; ++i)
            if (buf[i] != last) {
                seen.insert(last = buf[i]);
                c.capped = seen.size() >= kMaxCountedLabels;
            }
    };
    // Rows [y0, y0 + rows) of slice z, in reads of at most kLabelReadVoxels (at least one row);
    // an input that reads whole slices only gives the slice (at most kLabelSliceVoxels here).
    auto addRows = [&](uint32_t z, uint32_t y0, uint32_t rows) -> Status {
        if (!src.readsRows()) {
            buf.resize(size_t(slice));
            if (Status s = src.readSlab(z, 1, buf.data()); !s) return s;
            add(buf.size());
            return Status::ok();
        }
        const uint32_t step = uint32_t(std::clamp<uint64_t>(kLabelReadVoxels / std::max<uint64_t>(W, 1), 1, rows));
        buf.resize(size_t(W * step));
        for (uint32_t y = y0; y < y0 + rows && !c.capped; y += step) {
            const uint32_t r = std::min(step, y0 + rows - y);
            if (Status s = src.readRows(z, 1, y, r, buf.data()); !s) return s;
            add(size_t(W * r));
        }
        return Status::ok();
    };
    if (c.exact) {
        const uint32_t step = std::max(1u, uint32_t(std::min<uint64_t>(dim[2], kLabelReadVoxels / std::max<uint64_t>(slice, 1))));
        for (uint32_t z = 0; z < dim[2] && !c.capped; z += step) {
            const uint32_t d = std::min(step, dim[2] - z);
            if (slice <= kLabelReadVoxels || !src.readsRows()) {
                buf.resize(size_t(slice * d));
                if (Status s = src.readSlab(z, d, buf.data()); !s) return s;
                add(buf.size());
            } else if (Status s = addRows(z, 0, dim[1]); !s) {
                return s;
            }
            c.slicesRead += d;
        }
    } else {
        const bool bands = slice > kLabelSliceVoxels;
        if (bands && (!src.readsRows() || W > kLabelReadVoxels)) {
            c.skipped = true;
            return c;
        }
        const uint32_t n = std::min(kLabelSampleSlices, dim[2]);
        const uint32_t bandCount = bands ? std::min<uint32_t>(kLabelSampleBands, dim[1]) : 1;
        c.bandRows = bands ? uint32_t(std::max<uint64_t>(1, kLabelSliceVoxels / kLabelSampleBands / W)) : 0;
        for (uint32_t i = 0; i < n && !c.capped; ++i) {
            const uint32_t z = uint32_t((2 * uint64_t(i) + 1) * dim[2] / (2 * n));
            for (uint32_t b = 0; b < bandCount && !c.capped; ++b) {
                const uint32_t rows = bands ? std::min<uint32_t>(c.bandRows, dim[1]) : dim[1];
                const uint32_t y0 = bands ? uint32_t((2 * uint64_t(b) + 1) * (H - rows) / (2 * bandCount)) : 0;
                if (Status s = addRows(z, y0, rows); !s) return s;
            }
            ++c.slicesRead;
        }
    }
    c.count = seen.size();
    return c;
}

int cmdInfoInput(const Args& a) {
    const std::string& path = a.positional[0];
    if (a.stats || a.check)
        return fail(std::string(a.stats ? "--stats" : "--check") + " applies to a .csgv file; " + path +
                    " is an input (compress it first, or drop the option)");
    Result<std::unique_ptr<InputSource>> src = openCompressInput(path, a.input);
    if (!src) return fail(src.message());
    const InputInfo& info = (*src)->info();
    const Geometry& g = info.geometry;
    Result<LabelCount> labels = countLabels(**src);
    if (!labels) return fail(labels.message());
    std::printf("file: %s\n", interrupt::oneLine(path.c_str()).c_str());
    std::printf("format: %s\n", info.format.c_str());
    if (!info.detail.empty()) std::printf("detail: %s\n", interrupt::oneLine(info.detail.c_str()).c_str());
    std::printf("dimensions: %u %u %u\n", info.dim[0], info.dim[1], info.dim[2]);
    std::printf("voxels: %llu\n", (unsigned long long)info.voxelCount());
    std::printf("type: %s\n", labelTypeName(info.type));
    std::printf("spacing: %g %g %g\n", g.spacing[0], g.spacing[1], g.spacing[2]);
    std::printf("origin: %g %g %g\n", g.origin[0], g.origin[1], g.origin[2]);
    // Every line is `key: value` with a value a script can read: the count, then how it was got.
    if (labels->skipped) {
        std::printf("labels_counted: none (slices of %llu voxels are sampled by rows, and this input reads whole "
                    "slices only)\n",
                    (unsigned long long)(uint64_t(info.dim[0]) * info.dim[1]));
        return 0;
    }
    std::printf("labels: %llu\n", (unsigned long long)labels->count);
    if (labels->capped) std::printf("labels_counted: at least (counting stops at %zu labels)\n", kMaxCountedLabels);
    else if (labels->exact) std::printf("labels_counted: exact\n");
    else if (labels->bandRows)
        std::printf("labels_counted: estimate (%u slices, %u bands of %u rows each)\n", labels->slicesRead,
                    std::min<uint32_t>(kLabelSampleBands, info.dim[1]), std::min(labels->bandRows, info.dim[1]));
    else std::printf("labels_counted: estimate (%u slices)\n", labels->slicesRead);
    return 0;
}

int cmdInfo(const Args& a) {
    if (a.positional.size() != 1) return fail("info expects one file: csgv info IN.csgv|INPUT");
    if (!endsWithNoCase(a.positional[0], ".csgv") && (isSynthName(a.positional[0]) || isInputPath(a.positional[0])))
        return cmdInfoInput(a);
    Result<CsgvFile> f = openCsgvMapped(a.positional[0]);
    if (!f) return fail(f.message());
    const CompressedVolume& v = f->volume;
    const uint64_t bytes = v.serializedSize();
    const auto g = v.brickGrid();
    uint64_t words = 0;
    for (const auto& arr : v.arrays) words += arr.size();
    std::printf("file: %s\n", interrupt::oneLine(a.positional[0].c_str()).c_str());
    std::printf("version: %04u\n", v.version);
    std::printf("dimensions: %u %u %u\n", v.dim[0], v.dim[1], v.dim[2]);
    std::printf("voxels: %llu\n", (unsigned long long)v.voxelCount());
    std::printf("brick_size: %u\n", v.brickSize);
    std::printf("levels: %u\n", v.levels());
    std::printf("bricks: %llu\n", (unsigned long long)v.brickCount());
    std::printf("brick_grid: %u %u %u\n", g[0], g[1], g[2]);
    std::printf("encoding: %s\n", encodingName(v.encoding));
    std::printf("encoding_mode: %d\n", v.encoding);
    std::printf("operation_mask: 0x%x\n", v.opMask);
    std::printf("operations: %s\n", operationLetters(v.opMask).c_str());
    std::printf("max_palette: %u\n", v.maxPalette);
    std::printf("random_access: %d\n", v.randomAccess ? 1 : 0);
    std::printf("encoding_arrays: %zu\n", v.arrays.size());
    std::printf("encoding_words: %llu\n", (unsigned long long)words);
    std::printf("bytes: %llu\n", (unsigned long long)bytes);
    std::printf("bits_per_voxel: %.4f\n", double(bytes) * 8.0 / double(v.voxelCount()));
    if (f->hasAttributes) {
        std::string cols;
        for (const auto& c : f->attributes.columns) cols += (cols.empty() ? "" : ", ") + c.name;
        std::printf("attribute_database: %s\n", interrupt::oneLine(f->attributes.path.c_str()).c_str());
        std::printf("attribute_labels: %zu\n", f->attributes.labels.size());
        std::printf("attribute_columns: %s\n", interrupt::oneLine(cols.c_str()).c_str());
    }
    if (a.check) {
        const auto t0 = std::chrono::steady_clock::now();
        Status s = validateStreams(v, a.threads);
        if (!s) return fail(a.positional[0] + ": " + s.message());
        // The header's largest palette is the largest brick palette (readers size buffers by it).
        uint32_t largest = 0;
        for (uint64_t i = 0; i < v.brickCount(); ++i) largest = std::max(largest, v.brick(i).words[v.levels()]);
        if (largest != v.maxPalette)
            return fail(a.positional[0] + ": the header says the largest palette holds " + std::to_string(v.maxPalette) +
                        " labels, but the largest brick palette holds " + std::to_string(largest));
        std::printf("check: ok (%llu bricks, %.3f s)\n", (unsigned long long)v.brickCount(), seconds(t0));
    }
    if (a.stats) {
        const auto t0 = std::chrono::steady_clock::now();
        Result<LabelVolume> vol = decodeVolume(v, 0, f->decodeOptions(a.threads));
        const double t = seconds(t0);
        if (!vol) return fail(a.positional[0] + ": " + vol.message());
        std::unordered_map<uint32_t, uint64_t> counts;
        for (uint32_t l : vol->labels) ++counts[l];
        std::vector<std::pair<uint64_t, uint32_t>> bySize;
        bySize.reserve(counts.size());
        for (const auto& kv : counts) bySize.emplace_back(kv.second, kv.first);
        std::sort(bySize.begin(), bySize.end(), [](const auto& x, const auto& y) {
            return x.first != y.first ? x.first > y.first : x.second < y.second;
        });
        uint32_t lo = ~0u, hi = 0;
        for (const auto& kv : counts) {
            lo = std::min(lo, kv.first);
            hi = std::max(hi, kv.first);
        }
        std::printf("decode_seconds: %.4f\n", t);
        std::printf("decode_mvoxels_per_second: %.1f\n", double(v.voxelCount()) / t / 1e6);
        std::printf("distinct_labels: %zu\n", counts.size());
        std::printf("label_range: %u %u\n", lo, hi);
        std::printf("background_fraction: %.4f\n", counts.count(0) ? double(counts[0]) / double(v.voxelCount()) : 0.0);
        std::printf("largest_labels:");
        for (size_t i = 0; i < bySize.size() && i < 5; ++i)
            std::printf(" %u(%llu)", bySize[i].second, (unsigned long long)bySize[i].first);
        std::printf("\n");
    }
    return 0;
}

int cmdDecompress(const Args& a) {
    if (a.positional.size() != 2) return fail("decompress expects: csgv decompress IN.csgv OUT.vraw|OUT.nrrd [--level L]");
    const std::string& out = a.positional[1];
    const bool nrrd = endsWithNoCase(out, ".nrrd");
    if (!nrrd && !endsWithNoCase(out, ".vraw")) return fail("output '" + out + "' must end in .vraw or .nrrd");
    Result<CsgvFile> f = openCsgvMapped(a.positional[0]);
    if (!f) return fail(f.message());
    if (f->wideLabels && !nrrd)
        return fail(a.positional[0] + ": the original labels do not fit uint32 (" + f->metadata.originalType +
                    "); decompress to .nrrd instead");
    Result<LabelVolume> vol = decodeVolume(f->volume, a.level, f->decodeOptions(a.threads));
    if (!vol) return fail(a.positional[0] + ": " + vol.message());
    if (!nrrd) {
        Status w = writeVraw(out, *vol);
        return w ? 0 : fail(w.message());
    }
    // Coarse nodes cover 2^level voxels: scale the spacing, then centre the origin on node 0.
    Geometry g = f->metadata.geometry;
    for (double& sp : g.spacing) sp *= double(1u << a.level);
    g = pointGeometryFromCellGeometry(g);
    Status w;
    if (f->wideLabels) {
        std::vector<int64_t> wide(vol->labels.size());
        for (size_t i = 0; i < wide.size(); ++i) wide[i] = f->originalLabel(vol->labels[i]);
        w = writeNrrd(out, vol->dim, f->attributes.labelsUnsigned64 ? "uint64" : "int64", wide.data(), 8, g);
    } else {
        w = writeNrrd(out, *vol, g);
    }
    return w ? 0 : fail(w.message());
}

/// `extract` to a surface mesh: label by label into the writer, which commits at the end.
int extractMesh(const CsgvFile& f, const ExtractOptions& o, const Args& a, const std::string& in, const std::string& out,
                MeshFormat format, std::chrono::steady_clock::time_point t0) {
    MeshFileWriter writer;
    if (Status st = writer.open(out, format, o.labels); !st) return fail(st.message());
    Result<MeshSummary> r = extractMeshes(f, o, writer);
    if (!r) return fail(in + ": " + r.message());
    if (cancelRequested()) return fail("interrupted");
    if (r->labelsWithVoxels == 0)
        return fail("no voxel of the " + std::to_string(r->labelsSelected) + " selected labels lies " +
                    (a.hasBox ? "in the box" : "in the volume") + " at level " + std::to_string(a.level) +
                    "; nothing written");
    if (Status st = writer.commit(); !st) return fail(st.message());
    std::printf("output: %s\n", interrupt::oneLine(out.c_str()).c_str());
    std::printf("type: mesh %s\n", format == MeshFormat::Obj ? "obj" : format == MeshFormat::Ply ? "ply" : format == MeshFormat::Vtp ? "vtp" : "stl");
    std::printf("level: %u\n", a.level);
    std::printf("labels: %llu\n", (unsigned long long)r->labelsSelected);
    std::printf("labels_with_voxels: %llu\n", (unsigned long long)r->labelsWithVoxels);
    std::printf("bricks_total: %llu\n", (unsigned long long)r->bricksTotal);
    std::printf("bricks_decoded: %llu\n", (unsigned long long)r->bricksDecoded);
    std::printf("voxels: %llu\n", (unsigned long long)r->voxels);
    std::printf("vertices: %llu\n", (unsigned long long)r->vertices);
    std::printf("faces: %llu\n", (unsigned long long)r->quads);
    std::printf("triangles: %llu\n", (unsigned long long)(2 * r->quads));
    std::printf("seconds: %.3f\n", seconds(t0));
    std::printf("peak_memory_mib: %.1f\n", peakRssMiB());
    return 0;
}

int cmdExtract(const Args& a) {
    if (a.positional.size() != 2)
        return fail("extract expects: csgv extract IN.csgv OUT.nrrd|OUT.vti|OUT.vraw|OUT.obj|OUT.ply|OUT.stl|OUT.vtp --labels L1,L2,... | --query SQL [options]");
    const std::string& in = a.positional[0];
    const std::string& out = a.positional[1];
    const bool vti = endsWithNoCase(out, ".vti"), nrrd = endsWithNoCase(out, ".nrrd");
    MeshFormat meshFormat = MeshFormat::Obj;
    const bool mesh = meshFormatFor(out, meshFormat);
    if (!nrrd && !vti && !mesh && !endsWithNoCase(out, ".vraw"))
        return fail("output '" + out + "' must end in .vraw, .nrrd, .vti, .obj, .ply, .stl or .vtp");
    if (mesh && a.mask) return fail("--mask is for label images (.nrrd, .vti, .vraw); a mesh output (" + out + ") takes no --mask");
    if (a.hasLabels == a.hasQuery)
        return fail(a.hasLabels ? "extract takes --labels or --query, not both"
                                : "extract needs a selection: --labels L1,L2,... or --query SQL");
    const auto t0 = std::chrono::steady_clock::now();
    Result<CsgvFile> f = openCsgvMapped(in);
    if (!f) return fail(f.message());
    if (f->wideLabels && !a.mask && !nrrd && !vti && !mesh)
        return fail(in + ": the original labels do not fit uint32 (" + f->metadata.originalType +
                    "); extract to .nrrd or .vti or extract a --mask instead");
    ExtractOptions o;
    o.mask = a.mask;
    o.lod = a.level;
    o.hasBox = a.hasBox;
    o.box = a.box;
    o.maxLabels = a.maxLabels;
    o.maxOutputBytes = a.maxOutputMiB << 20;
    o.threads = a.threads;
    o.progress = [](double) { return !cancelRequested(); };
    if (a.hasQuery) {
        Result<std::vector<int64_t>> q = labelsMatchingQuery(*f, a.query);
        if (!q) return fail(in + ": " + q.message());
        if (q->empty()) return fail("the query selects no label of " + f->attributes.path + "; nothing written");
        o.labels = std::move(*q);
    } else {
        o.labels = a.labels;
    }
    if (mesh) return extractMesh(*f, o, a, in, out, meshFormat, t0);
    Result<ExtractResult> r = extractLabels(*f, o);
    if (!r) return fail(in + ": " + r.message());
    if (cancelRequested()) return fail("interrupted");
    if (r->empty())
        return fail("no voxel of the " + std::to_string(r->labelsSelected) + " selected labels lies " +
                    (a.hasBox ? "in the box" : "in the volume") + " at level " + std::to_string(a.level) + " (" +
                    std::to_string(r->bricksDecoded) + " of " + std::to_string(r->bricksTotal) +
                    " bricks decoded); nothing written");
    // Node (0,0,0) of the output is node `offset` of the level image: the corner geometry moves
    // there, then NRRD takes the centre of the first node, as decompress writes it.
    const Geometry g = pointGeometryFromCellGeometry(extractGeometry(f->metadata.geometry, a.level, r->offset));
    // VTK's image data: cells at their place in the level image (the level's corner geometry).
    const Geometry level = extractGeometry(f->metadata.geometry, a.level, {0, 0, 0});
    Status w;
    const bool wide = f->wideLabels && !a.mask;
    const std::vector<int64_t> original = wide ? originalLabels(*r, *f) : std::vector<int64_t>();
    const bool u64 = f->attributes.labelsUnsigned64;
    if (vti && a.mask) {
        w = writeVti(out, r->offset, r->dim, "UInt8", "Mask", r->mask.data(), 1, level);
    } else if (vti) {
        w = wide ? writeVti(out, r->offset, r->dim, u64 ? "UInt64" : "Int64", "Label", original.data(), 8, level)
                 : writeVti(out, r->offset, r->dim, "UInt32", "Label", r->labels.data(), 4, level);
    } else if (a.mask) {
        w = nrrd ? writeNrrd(out, r->dim, "uint8", r->mask.data(), 1, g) : writeVrawUint8(out, r->dim, r->mask.data());
    } else if (wide) {
        w = writeNrrd(out, r->dim, u64 ? "uint64" : "int64", original.data(), 8, g);
    } else {
        LabelVolume v;
        v.dim = r->dim;
        v.labels = std::move(r->labels);
        w = nrrd ? writeNrrd(out, v, g) : writeVraw(out, v);
    }
    if (!w) return fail(w.message());
    std::printf("output: %s\n", interrupt::oneLine(out.c_str()).c_str());
    std::printf("type: %s\n", a.mask ? "mask uint8" : "labels");
    std::printf("level: %u\n", a.level);
    std::printf("labels: %llu\n", (unsigned long long)r->labelsSelected);
    std::printf("labels_found: %llu\n", (unsigned long long)r->labelsFound);
    std::printf("bricks_total: %llu\n", (unsigned long long)r->bricksTotal);
    std::printf("bricks_in_box: %llu\n", (unsigned long long)r->bricksInBox);
    std::printf("bricks_decoded: %llu\n", (unsigned long long)r->bricksDecoded);
    std::printf("bricks_with_voxels: %llu\n", (unsigned long long)r->bricksWithVoxels);
    std::printf("voxels: %llu\n", (unsigned long long)r->voxels);
    std::printf("box: %u %u %u %u %u %u\n", r->offset[0], r->offset[1], r->offset[2], r->offset[0] + r->dim[0],
                r->offset[1] + r->dim[1], r->offset[2] + r->dim[2]);
    std::printf("dimensions: %u %u %u\n", r->dim[0], r->dim[1], r->dim[2]);
    std::printf("seconds: %.3f\n", seconds(t0));
    std::printf("peak_memory_mib: %.1f\n", peakRssMiB());
    return 0;
}

/// @brief Level 0 of a .csgv against any input, slab by slab: the source's values become the
/// file's ids (through its attribute database when it has one) and are compared with the decoded
/// brick-deep slab. Memory: one decoded slab (W * H * brickSize * 4) + one source sub-slab.
int verifyLevel0(const CsgvFile& f, InputSource& src, const std::string& csgvPath, const std::string& srcPath, int threads) {
    const CompressedVolume& v = f.volume;
    std::unordered_map<int64_t, uint32_t> idOf;
    if (f.hasAttributes)
        for (size_t id = 0; id < f.attributes.labels.size(); ++id) idOf.emplace(f.attributes.labels[id], uint32_t(id));
    auto show = [&](uint32_t l) { return f.hasAttributes ? std::to_string(f.originalLabel(l)) : std::to_string(l); };
    DecodeOptions plain;
    plain.threads = threads;
    const uint64_t slice = uint64_t(v.dim[0]) * v.dim[1];
    std::vector<uint64_t> values;
    for (uint32_t z0 = 0; z0 < v.dim[2]; z0 += v.brickSize) {
        const uint32_t depth = std::min(v.brickSize, v.dim[2] - z0);
        Result<LabelVolume> got = decodeRegion(v, 0, Box{{0, 0, z0}, {v.dim[0], v.dim[1], z0 + depth}}, plain);
        if (!got) return fail(csgvPath + ": " + got.message());
        Status s = forEachSubSlab(z0, depth, subSlabDepth(slice, depth), [&](uint32_t z, uint32_t d) -> Status {
            values.resize(size_t(slice * d));
            if (Status r = src.readSlab(z, d, values.data()); !r) return r;
            const uint32_t* ids = got->labels.data() + slice * (z - z0);
            for (size_t i = 0; i < values.size(); ++i) {
                uint32_t expected = 0;
                if (f.hasAttributes) {
                    auto it = idOf.find(int64_t(values[i]));
                    if (it == idOf.end())
                        return Status::error("voxel " + voxelText(i, v.dim, z) + " of " + srcPath + " holds label " +
                                             std::to_string(int64_t(values[i])) +
                                             ", which the attribute database lacks");
                    expected = it->second;
                } else if (!labelFitsFormat(values[i])) {
                    return Status::error("voxel " + voxelText(i, v.dim, z) + " of " + srcPath +
                                         " holds a label that does not fit the format, and " + csgvPath +
                                         " has no attribute database mapping it");
                } else {
                    expected = uint32_t(values[i]);
                }
                if (ids[i] != expected)
                    return Status::error("level 0, voxel " + voxelText(i, v.dim, z) + " decodes to " + show(ids[i]) +
                                         ", expected " + show(expected));
            }
            return Status::ok();
        });
        if (!s) return fail(s.message());
    }
    std::printf("level 0: %u x %u x %u match\n", v.dim[0], v.dim[1], v.dim[2]);
    return 0;
}

/// @brief Each coarse level against the coarsening of the level above it, slab by slab (the
/// coarse-label rule only looks at the 2x2x2 children, so even-aligned slabs coarsen alone). With
/// level 0 equal to the source this is the same as coarsening the source level by level.
int verifyCoarseLevels(const CsgvFile& f, const std::string& csgvPath, int threads) {
    const CompressedVolume& v = f.volume;
    auto show = [&](uint32_t l) { return f.hasAttributes ? std::to_string(f.originalLabel(l)) : std::to_string(l); };
    DecodeOptions plain;
    plain.threads = threads;
    for (uint32_t lod = 1; lod < v.levels(); ++lod) {
        const auto fine = lodDimensions(v.dim, lod - 1), coarse = lodDimensions(v.dim, lod);
        const uint32_t step = std::max(1u, v.brickSize >> lod);
        for (uint32_t cz = 0; cz < coarse[2]; cz += step) {
            const uint32_t cd = std::min(step, coarse[2] - cz);
            Result<LabelVolume> above = decodeRegion(
                v, lod - 1, Box{{0, 0, 2 * cz}, {fine[0], fine[1], std::min(fine[2], 2 * (cz + cd))}}, plain);
            if (!above) return fail(csgvPath + ": " + above.message());
            Result<LabelVolume> got = decodeRegion(v, lod, Box{{0, 0, cz}, {coarse[0], coarse[1], cz + cd}}, plain);
            if (!got) return fail(csgvPath + ": " + got.message());
            const LabelVolume expected = coarsenLabels(*above);
            for (size_t i = 0; i < expected.labels.size(); ++i)
                if (got->labels[i] != expected.labels[i])
                    return fail("level " + std::to_string(lod) + ", voxel " + voxelText(i, coarse, cz) + " decodes to " +
                                show(got->labels[i]) + ", expected " + show(expected.labels[i]));
        }
        std::printf("level %u: %u x %u x %u match\n", lod, coarse[0], coarse[1], coarse[2]);
    }
    return 0;
}

int cmdVerify(const Args& a) {
    if (a.positional.size() != 2) return fail("verify expects: csgv verify IN.csgv SOURCE");
    Result<CsgvFile> f = openCsgvMapped(a.positional[0]);
    if (!f) return fail(f.message());
    Result<std::unique_ptr<InputSource>> src = openCompressInput(a.positional[1], a.input);
    if (!src) return fail(src.message());
    const CompressedVolume& v = f->volume;
    const auto& sd = (*src)->info().dim;
    if (sd != v.dim)
        return fail("dimensions differ: " + a.positional[0] + " is " + std::to_string(v.dim[0]) + " " +
                    std::to_string(v.dim[1]) + " " + std::to_string(v.dim[2]) + ", " + a.positional[1] + " is " +
                    std::to_string(sd[0]) + " " + std::to_string(sd[1]) + " " + std::to_string(sd[2]));
    // Compared in the file's own label space: ids when a database maps them (the coarse-label rule
    // does not depend on label values, only on equality and child order), labels otherwise.
    if (int rc = verifyLevel0(*f, **src, a.positional[0], a.positional[1], a.threads); rc != 0) return rc;
    src->reset(); // the source is not needed for the coarse levels
    if (int rc = verifyCoarseLevels(*f, a.positional[0], a.threads); rc != 0) return rc;
    std::printf("verified: %u levels\n", v.levels());
    return 0;
}

/// @brief Compression progress on stderr: percentage, stage and rate. On a terminal one line
/// rewritten with \r at most 4 times a second; otherwise one line per 10% (and per stage change),
/// so logs stay short.
class ProgressPrinter {
public:
    explicit ProgressPrinter(const CompressReport& report) : m_report(report), m_tty(isatty(2) != 0) {}
    bool operator()(double fraction, const char* stage) {
        const auto now = std::chrono::steady_clock::now();
        if (m_stage != stage) {
            // The stage's own share of the whole, for its rate: relabelling has kRelabellingShare of
            // what is left when it starts, encoding the rest (Compress.h).
            m_stage = stage;
            m_stageStart = now;
            m_stageFrom = fraction;
            m_stageTo = m_stage == "relabelling" ? fraction + (1 - fraction) * kRelabellingShare : 1.0;
            m_nextDecile = int(fraction * 10) + 1;
            print(fraction, now);
            return true;
        }
        const bool due = m_tty ? std::chrono::duration<double>(now - m_lastPrint).count() >= 0.25
                               : fraction * 10 >= m_nextDecile;
        if (due || (fraction >= 1.0 && !m_printedEnd)) print(fraction, now);
        return true;
    }
    /// Ends the rewritten terminal line.
    void finish() {
        if (m_tty && m_printed) std::fputc('\n', stderr);
    }

private:
    void print(double fraction, std::chrono::steady_clock::time_point now) {
        const double dt = std::chrono::duration<double>(now - m_stageStart).count();
        const double stageDone = (fraction - m_stageFrom) / std::max(1e-9, m_stageTo - m_stageFrom);
        // A stage's first report comes as it starts: no rate yet.
        char rate[48] = "";
        if (dt > 1e-3 && stageDone > 0)
            std::snprintf(rate, sizeof rate, " %.1f Mvoxels/s", stageDone * double(m_report.voxels) / dt / 1e6);
        std::fprintf(stderr, m_tty ? "\rprogress: %5.1f%% %s%s        " : "progress: %.1f%% %s%s\n", fraction * 100,
                     m_stage.c_str(), rate);
        std::fflush(stderr);
        m_lastPrint = now;
        m_printed = true;
        m_printedEnd = fraction >= 1.0;
        while (m_nextDecile <= int(fraction * 10)) ++m_nextDecile;
    }

    const CompressReport& m_report;
    bool m_tty;
    std::string m_stage;
    std::chrono::steady_clock::time_point m_stageStart, m_lastPrint;
    double m_stageFrom = 0, m_stageTo = 1;
    int m_nextDecile = 1;
    bool m_printed = false, m_printedEnd = false;
};

int cmdCompress(const Args& a) {
    if (a.positional.size() != 2) return fail("compress expects: csgv compress IN OUT.csgv [options]");
    CompressOptions o;
    o.encode = a.encode;
    o.encode.threads = a.threads;
    o.relabel = a.relabel;
    o.input = a.input;
    CompressReport r;
    ProgressPrinter printer(r);
    o.progress = [&printer, &a](double f, const char* stage) {
        if (cancelRequested()) return false; // Ctrl-C: compressToFile removes its temporaries
        return a.quiet || printer(f, stage);
    };
    const auto t0 = std::chrono::steady_clock::now();
    Status s = compressToFile(a.positional[0], a.positional[1], o, &r);
    printer.finish();
    if (!s) return fail(s.message());
    const double t = seconds(t0);
    const double voxels = double(r.voxels);
    std::printf("output: %s\n", interrupt::oneLine(a.positional[1].c_str()).c_str());
    std::printf("input_format: %s\n", r.inputFormat.c_str());
    std::printf("dimensions: %u %u %u\n", r.dim[0], r.dim[1], r.dim[2]);
    std::printf("bytes: %llu\n", (unsigned long long)r.outputBytes);
    std::printf("bits_per_voxel: %.4f\n", double(r.outputBytes) * 8 / voxels);
    std::printf("original_type: %s\n", r.originalType.c_str());
    std::printf("relabelled: %s\n", r.relabelled ? "yes" : "no");
    if (r.relabelled) std::printf("labels: %llu\n", (unsigned long long)r.labelCount);
    std::printf("passes: %d%s\n", r.passes, r.restarted ? " (a label did not fit: restarted with relabelling)" : "");
    std::printf("seconds: %.3f (open %.3f, relabel %.3f, encode %.3f, write %.3f)\n", t, r.readSeconds,
                r.relabelSeconds, r.encodeSeconds, r.writeSeconds);
    std::printf("encode_mvoxels_per_second: %.1f\n", voxels / r.encodeSeconds / 1e6);
    std::printf("mvoxels_per_second: %.1f\n", r.mvoxelsPerSecond);
    std::printf("working_memory_mib: %.1f (estimate: encoder slab, scratch, source, label map)\n",
                double(r.workingBytes) / double(1 << 20));
    std::printf("peak_memory_mib: %.1f\n", peakRssMiB());
    return 0;
}

int cmdTile(const Args& a) {
    if (a.positional.size() != 2 || !a.hasTimes) return fail("tile expects: csgv tile IN.csgv OUT.csgv --times X,Y,Z");
    Result<CompressedVolume> src = readCsgvMapped(a.positional[0]);
    if (!src) return fail(src.message());
    Limits limits;
    limits.maxOutputBytes = a.maxOutputMiB << 20;
    const auto t0 = std::chrono::steady_clock::now();
    int shown = -1;
    Status s = writeTiledCsgv(a.positional[1], *src, a.times, limits, [&](double f) {
        if (cancelRequested()) return false; // Ctrl-C: the temporary goes, OUT stays as it was
        if (!a.quiet && int(f * 20) != shown) {
            shown = int(f * 20);
            std::fprintf(stderr, "\rtiling: %3d%%", shown * 5);
        }
        return true;
    });
    if (!a.quiet) std::fprintf(stderr, "\n");
    if (!s) return fail(s.message());
    Result<CompressedVolume> out = readCsgvHeader(a.positional[1]);
    if (!out) return fail(out.message());
    std::printf("output: %s\n", interrupt::oneLine(a.positional[1].c_str()).c_str());
    std::printf("dimensions: %u %u %u\n", out->dim[0], out->dim[1], out->dim[2]);
    std::printf("bricks: %llu\n", (unsigned long long)out->brickCount());
    const Result<uint64_t> bytes = fileSize(a.positional[1]);
    std::printf("bytes: %llu\n", (unsigned long long)(bytes ? *bytes : 0));
    std::printf("seconds: %.3f\n", seconds(t0));
    std::printf("peak_memory_mib: %.1f\n", peakRssMiB());
    return 0;
}

/// Repeats fn until at least minSeconds have passed; returns seconds per run.
template <typename Fn>
double timeIt(Fn fn, double minSeconds = 1.0) {
    const auto t0 = std::chrono::steady_clock::now();
    int reps = 0;
    double t = 0;
    do {
        if (!fn()) return -1;
        ++reps;
        t = seconds(t0);
    } while (t < minSeconds);
    return t / reps;
}

int cmdBench(const Args& a) {
    if (a.positional.size() != 1) return fail("bench expects: csgv bench IN [options]");
    const std::string& in = a.positional[0];
    // The labels in memory, as the encoder sees them (relabelled when they must be).
    LabelVolume labels;
    if (isSynthName(in)) {
        Result<SynthSpec> spec = parseSynthSpec(in);
        if (!spec) return fail(spec.message());
        Result<LabelVolume> v = generateVolume(*spec);
        if (!v) return fail(v.message());
        labels = std::move(*v);
    } else {
        Result<InputVolume> v = readInput(in);
        if (!v) return fail(v.message());
        LabelMapping m;
        Result<LabelVolume> l = prepareLabels(*v, a.encode.brickSize, a.relabel, m);
        if (!l) return fail(l.message());
        labels = std::move(*l);
    }
    EncodeOptions o = a.encode;
    o.threads = a.threads;
    const int threads = a.threads > 0 ? a.threads : omp_get_max_threads();
    const double voxels = double(labels.voxelCount());
    const double rawBytes = voxels * 4;
    Result<CompressedVolume> enc = Status::error("not run");
    const double tEnc = timeIt([&] { enc = encodeVolume(labels, o); return enc.isOk(); });
    if (!enc) return fail(enc.message());
    Status dst;
    const double tDec = timeIt([&] {
        Result<LabelVolume> d = decodeVolume(*enc, 0, DecodeOptions{threads, uint64_t(64) << 30, nullptr});
        if (!d) dst = d.status();
        else if (d->labels != labels.labels) dst = Status::error("decoded volume differs from the input");
        return d.isOk() && dst.isOk();
    });
    if (!dst) return fail(dst.message());
    std::printf("input: %s\n", interrupt::oneLine(in.c_str()).c_str());
    std::printf("dimensions: %u %u %u\n", labels.dim[0], labels.dim[1], labels.dim[2]);
    std::printf("threads: %d\n", threads);
    std::printf("settings: brick %u, %s, ops %s\n", o.brickSize, encodingName(o.encoding), operationLetters(o.opMask).c_str());
    std::printf("csgv_bytes: %llu\n", (unsigned long long)enc->serializedSize());
    std::printf("csgv_bits_per_voxel: %.4f\n", double(enc->serializedSize()) * 8 / voxels);
    std::printf("csgv_encode_mvoxels_per_second: %.1f\n", voxels / tEnc / 1e6);
    std::printf("csgv_decode_mvoxels_per_second: %.1f\n", voxels / tDec / 1e6);
    std::fflush(stdout);

    // zstd -19 (multi-threaded where libzstd allows) and gzip -9 of the raw little-endian labels.
    std::vector<uint8_t> z(ZSTD_compressBound(size_t(rawBytes)));
    size_t zsize = 0;
    const double tZ = timeIt([&] {
        ZSTD_CCtx* c = ZSTD_createCCtx();
        ZSTD_CCtx_setParameter(c, ZSTD_c_compressionLevel, 19);
        ZSTD_CCtx_setParameter(c, ZSTD_c_nbWorkers, threads);
        zsize = ZSTD_compress2(c, z.data(), z.size(), labels.labels.data(), size_t(rawBytes));
        ZSTD_freeCCtx(c);
        return !ZSTD_isError(zsize);
    }, 0.0);
    if (tZ < 0) return fail("zstd failed");
    std::vector<uint32_t> back(labels.labels.size());
    const double tZd = timeIt([&] { return ZSTD_decompress(back.data(), size_t(rawBytes), z.data(), zsize) == size_t(rawBytes); });
    std::printf("zstd19_bits_per_voxel: %.4f\n", double(zsize) * 8 / voxels);
    std::printf("zstd19_compress_mvoxels_per_second: %.1f\n", voxels / tZ / 1e6);
    std::printf("zstd19_decompress_mvoxels_per_second: %.1f\n", voxels / tZd / 1e6);
    std::fflush(stdout);
    uLongf gsize = compressBound(uLong(rawBytes));
    std::vector<uint8_t> g(gsize);
    const double tG = timeIt([&] {
        gsize = compressBound(uLong(rawBytes));
        return compress2(g.data(), &gsize, reinterpret_cast<const Bytef*>(labels.labels.data()), uLong(rawBytes), 9) == Z_OK;
    }, 0.0);
    const double tGd = timeIt([&] {
        uLongf n = uLongf(rawBytes);
        return uncompress(reinterpret_cast<Bytef*>(back.data()), &n, g.data(), gsize) == Z_OK;
    });
    std::printf("gzip9_bits_per_voxel: %.4f\n", double(gsize) * 8 / voxels);
    std::printf("gzip9_compress_mvoxels_per_second: %.1f\n", voxels / tG / 1e6);
    std::printf("gzip9_decompress_mvoxels_per_second: %.1f\n", voxels / tGd / 1e6);
    std::printf("peak_memory_mib: %.1f\n", peakRssMiB());
    return 0;
}

int run(int argc, char** argv) {
    if (argc < 2) {
        fail("no command given");
        std::fputs(usage().c_str(), stderr);
        return 1;
    }
    if (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
        std::fputs(usage().c_str(), stdout);
        return 0;
    }
    if (!std::strcmp(argv[1], "render")) {
#ifdef CSGV_HAVE_RENDER
        return cmdRender(argc, argv);
#else
        return fail("this csgv was built without VulkanBackend (CSGV_BUILD_VULKAN=OFF): render is not available");
#endif
    }
    Args a;
    Status s = parseArgs(argc, argv, a);
    if (!s) return fail(s.message());
    const std::string cmd = argv[1];
    if (cmd == "info") return cmdInfo(a);
    if (cmd == "decompress") return cmdDecompress(a);
    if (cmd == "extract") return cmdExtract(a);
    if (cmd == "verify") return cmdVerify(a);
    if (cmd == "compress") return cmdCompress(a);
    if (cmd == "bench") return cmdBench(a);
    if (cmd == "tile") return cmdTile(a);
    return fail("unknown command '" + cmd + "' (try csgv --help)");
}

} // namespace

/// "'compress' of 'IN'": what ran, for the messages of failures that carry no context.
std::string whatRan(int argc, char** argv) {
    std::string w = argc > 1 ? std::string("'") + argv[1] + "'" : std::string("csgv");
    for (int i = 2; i < argc; ++i)
        if (argv[i][0] != '-') return w + " of '" + argv[i] + "'";
    return w;
}

/// The limit an allocation ran into, for the out-of-memory message: the address-space limit when
/// one is set (ulimit -v, prlimit --as), else the memory the system has free.
std::string memoryLimitText() {
    struct rlimit rl {};
    if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY)
        return "its address-space limit is " + std::to_string(uint64_t(rl.rlim_cur) >> 20) + " MiB";
    const long pages = sysconf(_SC_AVPHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    return std::to_string((uint64_t(pages) * uint64_t(page)) >> 20) + " MiB of memory are free";
}

int main(int argc, char** argv) {
    interrupt::Guard guard; // Ctrl-C: exit 130 within a second, no partial output (Interrupt.h)
    int rc = 1;
    try {
        rc = run(argc, argv);
    } catch (const std::bad_alloc&) {
        rc = fail(whatRan(argc, argv) + " needs more memory than this process may use (out of memory; " +
                  memoryLimitText() + ")");
    } catch (const std::exception& e) {
        rc = fail(whatRan(argc, argv) + ": " + e.what());
    }
    if (rc != 0 && interrupt::Guard::interrupted()) {
        interrupt::reportOnce(interrupt::stoppedLine());
        return kInterruptedExit;
    }
    return rc;
}
