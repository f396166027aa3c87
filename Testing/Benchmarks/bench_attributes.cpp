// SPDX-License-Identifier: MIT
/// @file bench_attributes.cpp
/// @brief Prints the time to compute the per-label attributes (voxel count, surface area, bounding
/// box, centroid) from the compressed volume with 1 thread and with all threads, next to the time
/// to merely decode every brick, for the AAL atlas, synth:512x512x512 and a synthetic volume with
/// about half a million labels. Also times the derived-attribute path (SQLite in memory).
/// Usage: csgv_bench_attributes [--seconds S] [--aal PATH.nii.gz] [--synth WxHxD] [--many WxHxD]
///        [--brick B] [FILE.csgv...]

#include "csgv/attributes/Attributes.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/inputs/Inputs.h"
#include "csgv/inputs/Procedural.h"
#include "csgv/inputs/Relabel.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <omp.h>
#include <string>
#include <vector>

using namespace csgv;

namespace {

using Clock = std::chrono::steady_clock;

/// Best of repeated runs until minSeconds have elapsed (at least one run).
double bestSeconds(const std::function<bool()>& run, double minSeconds) {
    double best = 1e300, total = 0;
    do {
        const auto t0 = Clock::now();
        if (!run()) return -1;
        const double t = std::chrono::duration<double>(Clock::now() - t0).count();
        best = std::min(best, t);
        total += t;
    } while (total < minSeconds);
    return best;
}

void report(const std::string& name, const CompressedVolume& vol, const std::vector<int64_t>* idToLabel,
            double minSeconds) {
    const int all = omp_get_max_threads();
    std::vector<int> threadCounts = {1};
    if (all > 1) threadCounts.push_back(all);
    size_t labels = 0;
    for (int threads : threadCounts) {
        ComputeAttributesOptions o;
        o.threads = threads;
        o.idToLabel = idToLabel;
        std::string error;
        const double t = bestSeconds(
            [&] {
                Result<AttributeTable> r = computeAttributes(vol, o);
                if (!r) error = r.message();
                else labels = r->rowCount();
                return r.isOk();
            },
            minSeconds);
        const double d = bestSeconds(
            [&] {
                Status s = validateStreams(vol, threads);
                if (!s) error = s.message();
                return s.isOk();
            },
            minSeconds);
        if (!error.empty()) {
            std::fprintf(stderr, "%s: %s\n", name.c_str(), error.c_str());
            return;
        }
        std::printf("%-28s %12llu %9zu %6u %7d %10.3f %10.1f %10.3f %8.2f\n", name.c_str(),
                    (unsigned long long)vol.voxelCount(), labels, vol.brickSize, threads, t,
                    double(vol.voxelCount()) / t / 1e6, d, t / d);
    }
}

bool parseDims(const char* text, std::array<uint32_t, 3>& dim) {
    unsigned w = 0, h = 0, d = 0;
    if (std::sscanf(text, "%ux%ux%u", &w, &h, &d) != 3 || !w || !h || !d) return false;
    dim = {{w, h, d}};
    return true;
}

} // namespace

int main(int argc, char** argv) {
    double seconds = 1.0;
    std::string aal = "/usr/share/mricron/templates/aal.nii.gz";
    std::array<uint32_t, 3> synth{{512, 512, 512}}, many{{256, 256, 256}};
    uint32_t brick = 32;
    std::vector<std::string> files;
    for (int i = 1; i < argc; ++i) {
        const bool more = i + 1 < argc;
        if (!std::strcmp(argv[i], "--seconds") && more) seconds = std::atof(argv[++i]);
        else if (!std::strcmp(argv[i], "--aal") && more) aal = argv[++i];
        else if (!std::strcmp(argv[i], "--synth") && more && parseDims(argv[i + 1], synth)) ++i;
        else if (!std::strcmp(argv[i], "--many") && more && parseDims(argv[i + 1], many)) ++i;
        else if (!std::strcmp(argv[i], "--brick") && more) brick = uint32_t(std::atoi(argv[++i]));
        else if (argv[i][0] == '-') {
            std::fprintf(stderr, "usage: csgv_bench_attributes [--seconds S] [--aal PATH.nii.gz] [--synth WxHxD] "
                                 "[--many WxHxD] [--brick B] [FILE.csgv...]\n");
            return 1;
        } else files.emplace_back(argv[i]);
    }
    std::printf("computed attributes (voxel count, surface area, bounding box, centroid); best of runs over %.1f s\n",
                seconds);
    std::printf("%-28s %12s %9s %6s %7s %10s %10s %10s %8s\n", "volume", "voxels", "labels", "brick", "threads",
                "attr s", "Mvox/s", "decode s", "attr/dec");
    EncodeOptions enc;
    enc.brickSize = brick;

    if (!aal.empty()) {
        Result<InputVolume> in = readNifti(aal);
        if (!in) {
            std::fprintf(stderr, "skipping the AAL atlas: %s\n", in.message().c_str());
        } else {
            LabelMapping mapping;
            Result<LabelVolume> labels = prepareLabels(*in, brick, false, mapping);
            Result<CompressedVolume> vol = labels ? encodeVolume(*labels, enc) : Result<CompressedVolume>(labels.status());
            if (!vol) {
                std::fprintf(stderr, "AAL: %s\n", vol.message().c_str());
                return 1;
            }
            report("aal.nii.gz", *vol, nullptr, seconds);

            // The derived-attribute path on its region table, when installed beside it.
            const std::string table = aal.substr(0, aal.size() - 3) + ".txt";
            Result<AttributeTable> t = readCsv(table);
            if (t) {
                const double d = bestSeconds(
                    [&] {
                        AttributeTable copy = *t;
                        return addDerivedAttribute(copy, "hemisphere",
                                                   "CASE WHEN name LIKE '%\\_L' ESCAPE '\\' THEN 0 "
                                                   "WHEN name LIKE '%\\_R' ESCAPE '\\' THEN 1 END")
                            .isOk();
                    },
                    seconds / 4);
                std::printf("  derived 'hemisphere' over %zu regions of %s: %.3f ms\n", t->rowCount(), table.c_str(),
                            d * 1e3);
            }
        }
    }
    struct SynthCase {
        std::array<uint32_t, 3> dim;
        uint32_t cell;
    };
    for (const SynthCase& c : {SynthCase{synth, 24}, SynthCase{many, 3}}) {
        SynthSpec spec;
        spec.dim = c.dim;
        spec.cellSize = c.cell;
        ProceduralSlabSource source(spec);
        const auto t0 = Clock::now();
        Result<CompressedVolume> vol = encodeVolume(source, enc);
        if (!vol) {
            std::fprintf(stderr, "synth: %s\n", vol.message().c_str());
            return 1;
        }
        const double encodeSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
        const std::string name = "synth:" + std::to_string(c.dim[0]) + "x" + std::to_string(c.dim[1]) + "x" +
                                 std::to_string(c.dim[2]) + " cell " + std::to_string(c.cell);
        std::fprintf(stderr, "(%s encoded in %.1f s)\n", name.c_str(), encodeSeconds);
        report(name, *vol, nullptr, seconds);
        if (c.cell == 3) { // the derived path over many labels
            Result<AttributeTable> t = computeAttributes(*vol);
            if (t) {
                const auto d0 = Clock::now();
                AttributeTable copy = *t;
                Status s = addDerivedAttribute(copy, "compactness", "surface_area / voxel_count");
                const double d = std::chrono::duration<double>(Clock::now() - d0).count();
                std::printf("  derived 'surface_area / voxel_count' over %zu labels: %.3f s%s\n", t->rowCount(), d,
                            s ? "" : (" (" + s.message() + ")").c_str());
            }
        }
    }
    for (const std::string& path : files) {
        Result<CsgvFile> f = openCsgv(path);
        if (!f) {
            std::fprintf(stderr, "error: %s\n", f.message().c_str());
            return 1;
        }
        report(path.substr(path.find_last_of('/') + 1), f->volume,
               f->hasAttributes ? &f->attributes.labels : nullptr, seconds);
    }
    return 0;
}
