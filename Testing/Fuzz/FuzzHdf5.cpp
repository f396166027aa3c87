// SPDX-License-Identifier: MIT
/// @file FuzzHdf5.cpp
/// @brief Fuzz entry point over the HDF5 input (Core/src/inputs/Hdf5.cpp, through libhdf5): the
/// input becomes `fuzz.h5`, opened with openInput() under a small working-memory limit and read
/// slice by slice and in bands of rows (readSlices, FuzzFiles.h). libhdf5 itself is not what is
/// under test (its own parser has known bugs on damaged files, README.md); our wrapper is: the
/// dataset search, axes, types, storage and cache choice, geometry attributes and the reads.
///
/// Input framing, by the first byte:
///   bits 0-1: the path: `fuzz.h5` (the file's one 3D integer dataset), `fuzz.h5:/data`,
///             `fuzz.h5:/g/labels`, `fuzz.h5:/` (the root group);
///   bits 2-3: InputOptions::maxWorkingBytes: 4 KiB, 64 KiB, 1 MiB or 64 MiB.
/// The rest is the file. Every failure must name the path opened.

#include "FuzzFiles.h"

using namespace csgv;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const uint8_t mode = data[0];
    static const uint64_t kBudgets[] = {uint64_t(4) << 10, uint64_t(64) << 10, uint64_t(1) << 20, uint64_t(64) << 20};
    static const char* kDatasets[] = {"", ":/data", ":/g/labels", ":/"};
    InputOptions options;
    options.maxWorkingBytes = kBudgets[(mode >> 2) & 3];

    const std::string file = fuzz::scratchDir() + "/fuzz.h5";
    fuzz::writeFile(file, data + 1, size - 1);
    const std::string path = file + kDatasets[mode & 3];

    Result<std::unique_ptr<InputSource>> source = openInput(path, options);
    if (!source) {
        fuzz::require(fuzz::namesPath(source.message(), file));
        return 0;
    }
    fuzz::require((*source)->info().format == "HDF5");
    fuzz::readSlices(**source, path);
    return 0;
}
