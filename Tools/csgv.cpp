// SPDX-License-Identifier: MIT
/// @file csgv.cpp
/// @brief The `csgv` command-line tool: info, decompress, verify. Exit 0 on success, 1 with one
/// message on stderr for any user or data error; no input may end it with a signal.

#include "csgv/inputs/Compress.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/LabelVolume.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Procedural.h"
#include "CommandLine.h"
#ifdef CSGV_HAVE_RENDER
#include "RenderCommand.h"
#endif

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>
#include <omp.h>
#include <string>
#include <unordered_map>
#include <sys/resource.h>
#include <vector>
#include <zlib.h>
#include <zstd.h>

using namespace csgv;

namespace {

const char* kUsage =
    "usage: csgv <command> [options]\n"
    "  info IN.csgv [--stats] [--check] [--threads N]\n"
    "      key: value lines describing the file; --stats decodes it and prints label statistics,\n"
    "      --check decodes every brick and reports the first stream error\n"
    "  decompress IN.csgv OUT.vraw|OUT.nrrd [--level L] [--threads N]\n"
    "      level 0 = full resolution, 1 = half, ...; original labels when a _csgv.db3 is beside IN\n"
    "  verify IN.csgv SOURCE [--threads N]\n"
    "      SOURCE: .vraw[.gz], .nrrd, .nhdr, .nii[.gz]; exit 0 only if every voxel and every\n"
    "      coarse level matches SOURCE (through the attribute database when there is one)\n"
    "  compress IN OUT.csgv [--brick-size N] [--encoding nibble|rans1|rans2] [--ops default|all|LETTERS]\n"
    "           [--threads N] [--relabel]\n"
    "      IN: synth:WxHxD[:seed], .vraw[.gz], .nrrd, .nhdr, .nii[.gz]; letters p x y z n l d s;\n"
    "      writes OUT.json (geometry) and OUT's _csgv.db3 when labels are relabelled\n"
    "  bench IN [--threads N] [--brick-size N] [--encoding E] [--ops O]\n"
    "      bits/voxel, encode and decode Mvoxel/s, and zstd -19 / gzip -9 of the raw uint32 labels\n"
    "  render IN.csgv OUT.png [--size WxH] [--eye x,y,z] [--center x,y,z] [--up x,y,z]\n"
    "         [--fov-y DEG | --parallel-scale S] [--shading local|shadow|ao|pt] [--frames N]\n"
    "         [--no-jitter] [--finest] [--labels-out FILE] [--materials FILE.json]\n"
    "         [--video PATTERN --orbit N] [--cache-mib M] [--cache-paletting]\n"
    "         [--subsampling 1|2|4|8] [--lod-bias B]\n"
    "         [--blend B] [--no-denoise] [--tone-mapping] [--background r,g,b]\n"
    "         [--attributes FILE.csv|.txt|.db3]... [--computed-attributes] [--derive NAME=SQL]...\n"
    "      renders on the GPU (CSGV_VULKAN_DEVICE picks the device); --frames N: samples per pixel;\n"
    "      prints each frame's time, the median, the time to the first full frame, device memory\n";

struct Args {
    std::vector<std::string> positional;
    bool stats = false;
    bool check = false;
    bool relabel = false;
    uint32_t level = 0;
    int threads = 0;
    EncodeOptions encode;
};

int fail(const std::string& message) {
    std::fprintf(stderr, "csgv: error: %s\n", message.c_str());
    return 1;
}

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

bool endsWith(const std::string& s, const char* suffix) {
    const size_t n = std::strlen(suffix);
    return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

double seconds(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int cmdInfo(const Args& a) {
    if (a.positional.size() != 1) return fail("info expects one file: csgv info IN.csgv");
    Result<CsgvFile> f = openCsgv(a.positional[0]);
    if (!f) return fail(f.message());
    const CompressedVolume& v = f->volume;
    const uint64_t bytes = v.serializedSize();
    const auto g = v.brickGrid();
    uint64_t words = 0;
    for (const auto& arr : v.arrays) words += arr.size();
    std::printf("file: %s\n", a.positional[0].c_str());
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
        std::printf("attribute_database: %s\n", f->attributes.path.c_str());
        std::printf("attribute_labels: %zu\n", f->attributes.labels.size());
        std::printf("attribute_columns: %s\n", cols.c_str());
    }
    if (a.check) {
        const auto t0 = std::chrono::steady_clock::now();
        Status s = validateStreams(v, a.threads);
        if (!s) return fail(a.positional[0] + ": " + s.message());
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
    const bool nrrd = endsWith(out, ".nrrd");
    if (!nrrd && !endsWith(out, ".vraw")) return fail("output '" + out + "' must end in .vraw or .nrrd");
    Result<CsgvFile> f = openCsgv(a.positional[0]);
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

int cmdVerify(const Args& a) {
    if (a.positional.size() != 2) return fail("verify expects: csgv verify IN.csgv SOURCE");
    Result<CsgvFile> f = openCsgv(a.positional[0]);
    if (!f) return fail(f.message());
    Result<InputVolume> src = readInput(a.positional[1]);
    if (!src) return fail(src.message());
    const CompressedVolume& v = f->volume;
    if (src->dim != v.dim)
        return fail("dimensions differ: " + a.positional[0] + " is " + std::to_string(v.dim[0]) + " " +
                    std::to_string(v.dim[1]) + " " + std::to_string(v.dim[2]) + ", " + a.positional[1] + " is " +
                    std::to_string(src->dim[0]) + " " + std::to_string(src->dim[1]) + " " + std::to_string(src->dim[2]));
    // Compare in the file's own label space: ids when a database maps them (the coarse-label rule
    // does not depend on label values, only on equality and child order), labels otherwise.
    LabelVolume expected;
    expected.dim = src->dim;
    expected.labels.resize(src->values.size());
    DecodeOptions plain;
    plain.threads = a.threads;
    if (f->hasAttributes) {
        std::unordered_map<int64_t, uint32_t> idOf;
        for (size_t id = 0; id < f->attributes.labels.size(); ++id) idOf.emplace(f->attributes.labels[id], uint32_t(id));
        for (size_t i = 0; i < src->values.size(); ++i) {
            auto it = idOf.find(int64_t(src->values[i]));
            if (it == idOf.end())
                return fail("voxel " + std::to_string(i) + " of " + a.positional[1] + " holds label " +
                            std::to_string(int64_t(src->values[i])) + ", which the attribute database lacks");
            expected.labels[i] = it->second;
        }
    } else {
        for (size_t i = 0; i < src->values.size(); ++i) {
            if (src->isNegative(i) || src->values[i] >= kInvalidLabel)
                return fail("voxel " + std::to_string(i) + " of " + a.positional[1] +
                            " holds a label that does not fit the format, and " + a.positional[0] +
                            " has no attribute database mapping it");
            expected.labels[i] = uint32_t(src->values[i]);
        }
    }
    src = InputVolume{};
    for (uint32_t lod = 0; lod < v.levels(); ++lod) {
        if (lod > 0) expected = coarsenLabels(expected);
        Result<LabelVolume> got = decodeVolume(v, lod, plain);
        if (!got) return fail(a.positional[0] + ": " + got.message());
        for (size_t i = 0; i < expected.labels.size(); ++i) {
            if (got->labels[i] != expected.labels[i]) {
                const uint64_t x = i % expected.dim[0], y = (i / expected.dim[0]) % expected.dim[1],
                               z = i / (uint64_t(expected.dim[0]) * expected.dim[1]);
                auto show = [&](uint32_t l) {
                    return f->hasAttributes ? std::to_string(f->originalLabel(l)) : std::to_string(l);
                };
                return fail("level " + std::to_string(lod) + ", voxel (" + std::to_string(x) + ", " +
                            std::to_string(y) + ", " + std::to_string(z) + ") decodes to " + show(got->labels[i]) +
                            ", expected " + show(expected.labels[i]));
            }
        }
        std::printf("level %u: %u x %u x %u match\n", lod, expected.dim[0], expected.dim[1], expected.dim[2]);
    }
    std::printf("verified: %u levels\n", v.levels());
    return 0;
}

double peakRssMiB() {
    struct rusage ru {};
    getrusage(RUSAGE_SELF, &ru);
    return double(ru.ru_maxrss) / 1024.0;
}

int cmdCompress(const Args& a) {
    if (a.positional.size() != 2) return fail("compress expects: csgv compress IN OUT.csgv [options]");
    CompressOptions o;
    o.encode = a.encode;
    o.encode.threads = a.threads;
    o.relabel = a.relabel;
    CompressReport r;
    const auto t0 = std::chrono::steady_clock::now();
    Status s = compressToFile(a.positional[0], a.positional[1], o, &r);
    if (!s) return fail(s.message());
    const double t = seconds(t0);
    const double voxels = double(r.dim[0]) * r.dim[1] * r.dim[2];
    std::printf("output: %s\n", a.positional[1].c_str());
    std::printf("dimensions: %u %u %u\n", r.dim[0], r.dim[1], r.dim[2]);
    std::printf("bytes: %llu\n", (unsigned long long)r.outputBytes);
    std::printf("bits_per_voxel: %.4f\n", double(r.outputBytes) * 8 / voxels);
    std::printf("original_type: %s\n", r.originalType.c_str());
    std::printf("relabelled: %s\n", r.relabelled ? "yes" : "no");
    if (r.relabelled) std::printf("labels: %llu\n", (unsigned long long)r.labelCount);
    std::printf("streamed: %s\n", r.streamed ? "yes" : "no");
    std::printf("seconds: %.3f (read %.3f, encode %.3f, write %.3f)\n", t, r.readSeconds, r.encodeSeconds, r.writeSeconds);
    std::printf("encode_mvoxels_per_second: %.1f\n", voxels / r.encodeSeconds / 1e6);
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
    std::printf("input: %s\n", in.c_str());
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
        std::fputs(kUsage, stderr);
        return 1;
    }
    if (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
        std::fputs(kUsage, stdout);
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
    if (cmd == "verify") return cmdVerify(a);
    if (cmd == "compress") return cmdCompress(a);
    if (cmd == "bench") return cmdBench(a);
    return fail("unknown command '" + cmd + "' (try csgv --help)");
}

} // namespace

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const std::bad_alloc&) {
        return fail("out of memory");
    } catch (const std::exception& e) {
        return fail(e.what());
    }
}
