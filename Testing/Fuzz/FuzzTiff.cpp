// SPDX-License-Identifier: MIT
/// @file FuzzTiff.cpp
/// @brief Fuzz entry point over the TIFF input (Core/src/inputs/Tiff.cpp, through libtiff): the
/// input becomes one file or a folder of slice files, opened with openInput() under a small
/// working-memory limit and read slice by slice (readSlices, FuzzFiles.h).
///
/// Input framing, by the first byte:
///   bits 0-1: 0 or 1: the rest is one (multi-page) file `fuzz.tif`; 2: the rest, split at each
///             "SLICE" (at most 3 pieces), is a folder of slices `s1.tif`, `s2.tif`...  opened as
///             `DIR/`; 3: the same folder opened as the glob `DIR/s*.tif`;
///   bits 2-3: InputOptions::maxWorkingBytes: 4 KiB, 64 KiB, 1 MiB or 64 MiB;
///   bit 4:    with a folder of slices, open the slice files as an explicit list instead
///             (openTiffSlices, what ParaView's file dialog hands over), last one first.
/// Every failure must name the path opened; an opened source must keep InputSource's contract.

#include "FuzzFiles.h"

#include <cstring>

using namespace csgv;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const uint8_t mode = data[0];
    const uint8_t* rest = data + 1;
    const size_t restSize = size - 1;
    static const uint64_t kBudgets[] = {uint64_t(4) << 10, uint64_t(64) << 10, uint64_t(1) << 20, uint64_t(64) << 20};
    InputOptions options;
    options.maxWorkingBytes = kBudgets[(mode >> 2) & 3];

    const std::string dir = fuzz::freshDir("tiff");
    std::string path;
    std::vector<std::string> slices;
    if ((mode & 3) < 2) {
        path = dir + "/fuzz.tif";
        fuzz::writeFile(path, rest, restSize);
    } else {
        static const char kSeparator[] = "SLICE";
        const size_t sep = sizeof kSeparator - 1;
        size_t begin = 0;
        for (int slice = 1; slice <= 3; ++slice) {
            size_t end = restSize;
            if (slice < 3)
                for (size_t i = begin; i + sep <= restSize; ++i)
                    if (std::memcmp(rest + i, kSeparator, sep) == 0) {
                        end = i;
                        break;
                    }
            slices.insert(slices.begin(), dir + "/s" + std::to_string(slice) + ".tif");
            fuzz::writeFile(slices.front(), rest + begin, end - begin);
            if (end == restSize) break;
            begin = end + sep;
        }
        path = (mode & 3) == 2 ? dir + "/" : dir + "/s*.tif";
    }

    const bool list = (mode & 3) >= 2 && (mode & 16);
    if (list) path = sliceListName(slices);
    Result<std::unique_ptr<InputSource>> source = list ? openTiffSlices(slices, options) : openInput(path, options);
    if (!source) {
        fuzz::require(fuzz::namesPath(source.message(), path));
        return 0;
    }
    fuzz::require((*source)->info().format == "TIFF");
    fuzz::readSlices(**source, path);
    return 0;
}
