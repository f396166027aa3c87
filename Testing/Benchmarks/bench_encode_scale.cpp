// SPDX-License-Identifier: MIT
/// @file bench_encode_scale.cpp
/// @brief Issue 12's scale demonstration: encodes a procedural `synth:WxHxD` volume straight to a
/// `.csgv` file with encodeToFile (bounded memory) and prints wall time, throughput, bits per
/// voxel and peak RSS. A benchmark, never a test.
/// Usage: csgv_bench_encode_scale synth:4096x4096x4096 OUT.csgv [--held-mib M]

#include "csgv/codec/Encoder.h"
#include "csgv/inputs/Procedural.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <sys/resource.h>

using namespace csgv;

namespace {
double peakRssMiB() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_maxrss) / 1024.0;
}
} // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: csgv_bench_encode_scale synth:WxHxD OUT.csgv [--held-mib M]\n");
        return 1;
    }
    Result<SynthSpec> spec = parseSynthSpec(argv[1]);
    if (!spec) {
        std::fprintf(stderr, "error: %s\n", spec.message().c_str());
        return 1;
    }
    EncodeToFileOptions fo;
    if (argc == 5 && !std::strcmp(argv[3], "--held-mib")) fo.heldSymbolBytes = uint64_t(std::atoll(argv[4])) << 20;
    const auto t0 = std::chrono::steady_clock::now();
    int lastPercent = -1;
    fo.progress = [&](double f) {
        const int p = int(f * 100);
        if (p / 5 != lastPercent / 5) {
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            std::fprintf(stderr, "%3d %% after %.0f s, peak RSS %.0f MiB\n", p, s, peakRssMiB());
            lastPercent = p;
        }
        return true;
    };
    ProceduralSlabSource src(*spec);
    uint64_t bytes = 0;
    const Status s = encodeToFile(src, EncodeOptions{}, argv[2], fo, &bytes);
    if (!s) {
        std::fprintf(stderr, "error: %s\n", s.message().c_str());
        return 1;
    }
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double voxels = double(spec->dim[0]) * spec->dim[1] * spec->dim[2];
    std::printf("volume: %s\nvoxels: %.0f\nuint32_bytes_gib: %.1f\noutput_bytes: %llu\nbits_per_voxel: %.4f\n"
                "wall_seconds: %.1f\nmvoxels_per_second: %.1f\npeak_rss_mib: %.0f\n",
                argv[1], voxels, voxels * 4 / double(1ull << 30), (unsigned long long)bytes, bytes * 8.0 / voxels, secs,
                voxels / secs / 1e6, peakRssMiB());
    return 0;
}
