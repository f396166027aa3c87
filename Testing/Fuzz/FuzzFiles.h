// SPDX-License-Identifier: MIT
#pragma once
/// @file FuzzFiles.h
/// @brief For targets whose parser reads files, not bytes: one scratch folder per process (under
/// $TMPDIR, removed at exit), files written into it from the fuzz input, and the checks every
/// InputSource target shares (open, then read slab by slab within a bound, twice where cheap).

#include "csgv/inputs/Inputs.h"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace fuzz {

/// Aborts (the fuzzer's finding) when `condition` is false, saying which check failed.
inline void require(bool condition, int line = 0, const char* text = nullptr) {
    if (condition) return;
    if (text) std::fprintf(stderr, "fuzz check failed (line %d): %s\n", line, text);
    std::abort();
}
#define FUZZ_REQUIRE(c) ::fuzz::require((c), __LINE__, #c)

/// The process's scratch folder (created on first use, removed at exit).
inline const std::string& scratchDir() {
    // Never destroyed: the exit handler that removes the folder runs after static destructors.
    static const std::string* dir = [] {
        const char* tmp = std::getenv("TMPDIR");
        auto* pattern = new std::string(std::string(tmp && *tmp ? tmp : "/tmp") + "/csgv-fuzz-XXXXXX");
        if (!mkdtemp(pattern->data())) std::abort();
        std::atexit([] {
            std::error_code ec;
            std::filesystem::remove_all(scratchDir(), ec);
        });
        return pattern;
    }();
    return *dir;
}

/// An empty folder `name` inside the scratch folder (emptied if it exists).
inline std::string freshDir(const std::string& name) {
    const std::string dir = scratchDir() + "/" + name;
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
    std::filesystem::create_directories(dir, ec);
    require(!ec);
    return dir;
}

/// Writes bytes to `path` (replacing it).
inline void writeFile(const std::string& path, const uint8_t* data, size_t size) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
    out.close();
    require(bool(out));
}

/// True when a failure's message names `path` and says something after it.
inline bool namesPath(const std::string& message, const std::string& path) {
    return message.size() > path.size() + 2 && message.find(path) != std::string::npos;
}

/// Reads an opened source slice by slice (at most `maxSlices`, each slice at most `maxSliceVoxels`
/// voxels), then slice 0 again, which must give the same values (InputSource's contract: any
/// order, same values). A failed read must name `path`.
inline void readSlices(csgv::InputSource& source, const std::string& path, uint64_t maxSliceVoxels = uint64_t(1) << 20,
                       uint32_t maxSlices = 16) {
    const csgv::InputInfo& info = source.info();
    FUZZ_REQUIRE(info.dim[0] > 0 && info.dim[1] > 0 && info.dim[2] > 0 && !info.format.empty());
    const uint64_t slice = uint64_t(info.dim[0]) * info.dim[1];
    if (slice > maxSliceVoxels) return;
    std::vector<uint64_t> first(slice), buffer(slice);
    bool firstRead = false;
    for (uint32_t z = 0; z < info.dim[2] && z < maxSlices; ++z) {
        csgv::Status s = source.readSlab(z, 1, z == 0 ? first.data() : buffer.data());
        if (!s) {
            FUZZ_REQUIRE(namesPath(s.message(), path));
            return;
        }
        if (z == 0) firstRead = true;
    }
    if (firstRead) {
        csgv::Status s = source.readSlab(0, 1, buffer.data());
        FUZZ_REQUIRE(s.isOk() || namesPath(s.message(), path));
        if (s) FUZZ_REQUIRE(buffer == first);
    }
    // The boxes the source says hold one value (HDF5: chunks never written): inside the first
    // slice's region, disjoint, and what the read gave there.
    if (firstRead) {
        std::vector<csgv::UniformBox> boxes;
        source.uniformBoxes(0, 1, 0, info.dim[1], boxes);
        std::vector<uint8_t> covered(slice, 0);
        for (const csgv::UniformBox& b : boxes) {
            FUZZ_REQUIRE(b.lo[2] == 0 && b.hi[2] == 1 && b.hi[0] <= info.dim[0] && b.hi[1] <= info.dim[1]);
            for (uint32_t y = b.lo[1]; y < b.hi[1]; ++y)
                for (uint32_t x = b.lo[0]; x < b.hi[0]; ++x) {
                    const uint64_t i = uint64_t(y) * info.dim[0] + x;
                    FUZZ_REQUIRE(!covered[i] && first[i] == b.value);
                    covered[i] = 1;
                }
        }
    }
    // Bands of rows, where the source reads them cheaply (chunked formats).
    if (source.readsRows() && info.dim[1] > 1) {
        const uint32_t rows = (info.dim[1] + 1) / 2;
        csgv::Status s = source.readRows(0, 1, info.dim[1] - rows, rows, buffer.data());
        FUZZ_REQUIRE(s.isOk() || namesPath(s.message(), path));
        if (s && firstRead)
            for (uint64_t i = 0; i < uint64_t(rows) * info.dim[0]; ++i)
                FUZZ_REQUIRE(buffer[i] == first[uint64_t(info.dim[1] - rows) * info.dim[0] + i]);
    }
}

} // namespace fuzz
