// SPDX-License-Identifier: MIT
/// @file bench_decode.cpp
/// @brief Prints CPU decode throughput (Mvoxel/s) of `.csgv` files at full resolution and at
/// every coarser level, with 1 thread and with all threads, measured in one run.
/// Usage: csgv_bench_decode [--seconds S] [--mapped] FILE.csgv...
/// --mapped decodes from the memory-mapped file (openCsgvMapped: words at addresses of 1 modulo
/// 4) instead of a copy read into aligned memory.

#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"

#include <chrono>
#include <cstdio>
#include <cstring>
#include <omp.h>
#include <string>
#include <vector>

using namespace csgv;

namespace {
/// Median-free, simple: repeats until minSeconds elapsed and reports the mean rate.
double rate(const CsgvFile& f, uint32_t lod, int threads, double minSeconds) {
    const auto dims = lodDimensions(f.volume.dim, lod);
    const double voxels = double(dims[0]) * dims[1] * dims[2];
    const auto t0 = std::chrono::steady_clock::now();
    int reps = 0;
    double t = 0;
    do {
        Result<LabelVolume> v = decodeVolume(f.volume, lod, f.decodeOptions(threads));
        if (!v) {
            std::fprintf(stderr, "error: %s\n", v.message().c_str());
            return 0;
        }
        ++reps;
        t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    } while (t < minSeconds);
    return voxels * reps / t / 1e6;
}
} // namespace

int main(int argc, char** argv) {
    double seconds = 0.5;
    std::vector<std::string> files;
    bool mapped = false;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--seconds") && i + 1 < argc) seconds = std::atof(argv[++i]);
        else if (!std::strcmp(argv[i], "--mapped")) mapped = true;
        else files.emplace_back(argv[i]);
    }
    if (files.empty()) {
        std::fprintf(stderr, "usage: csgv_bench_decode [--seconds S] [--mapped] FILE.csgv...\n");
        return 1;
    }
    const int all = omp_get_max_threads();
    std::printf("%-40s %5s %8s %10s %12s %12s %8s\n", "file", "lod", "voxels", "bits/vox", "Mvox/s 1thr",
                ("Mvox/s " + std::to_string(all) + "thr").c_str(), "speedup");
    for (const std::string& path : files) {
        Result<CsgvFile> f = mapped ? openCsgvMapped(path) : openCsgv(path);
        if (!f) {
            std::fprintf(stderr, "error: %s\n", f.message().c_str());
            return 1;
        }
        const std::string name = path.substr(path.find_last_of('/') + 1);
        const double bpv = double(f->volume.serializedSize()) * 8 / double(f->volume.voxelCount());
        for (uint32_t lod = 0; lod < f->volume.levels(); ++lod) {
            const auto d = lodDimensions(f->volume.dim, lod);
            const double one = rate(*f, lod, 1, seconds);
            const double many = rate(*f, lod, all, seconds);
            std::printf("%-40s %5u %8llu %10.4f %12.1f %12.1f %8.2f\n", name.c_str(), lod,
                        (unsigned long long)(uint64_t(d[0]) * d[1] * d[2]), bpv, one, many, many / one);
            if (lod == 0 && files.size() > 1) break; // full resolution only when comparing many files
        }
    }
    return 0;
}
