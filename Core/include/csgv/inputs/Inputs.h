// SPDX-License-Identifier: MIT
#pragma once
/// @file Inputs.h
/// @brief Label volumes from files other than `.csgv`, read slab by slab (InputSource) so that no
/// step holds the whole decoded volume: Volcanite's `.vraw`, NRRD, NIfTI-1, HDF5, TIFF (one
/// multi-page file, a folder, a glob or an ordered list of slices), Zarr v2 / OME-Zarr and
/// Neuroglancer precomputed. Values are kept at full width (uint64, signed ones sign-extended) so that nothing
/// is truncated before relabelling. The format table (name, how a path is recognised, the
/// opener) is in Core/src/inputs/Inputs.cpp; each format is one file beside it.

#include "csgv/base/Checked.h"
#include "csgv/base/Geometry.h"
#include "csgv/base/Status.h"
#include "csgv/base/UniformBox.h"

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace csgv {

/// Voxel type of the input file.
enum class LabelType { U8, I8, U16, I16, U32, I32, U64, I64, F32, F64 };
/// "uint8", "int8", "uint16", "int16", "uint32", "int32", "uint64", "int64", "float32", "float64".
const char* labelTypeName(LabelType type);
bool isSignedType(LabelType type);

// Geometry of inputs (Geometry.h): `origin` is the centre of voxel (0,0,0), as in NRRD and NIfTI.

/// @brief A label volume at full width. Signed values are stored sign-extended (as int64 bits),
/// float values that hold integers are converted to those integers (int64 bits).
struct InputVolume {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    LabelType type = LabelType::U32;
    Geometry geometry; ///< origin: centre of voxel (0,0,0)
    std::vector<uint64_t> values; ///< x fastest

    uint64_t voxelCount() const { return uint64_t(dim[0]) * dim[1] * dim[2]; }
    /// True when the value of voxel i, read as the file's type, is negative.
    bool isNegative(size_t i) const { return isSignedType(type) && int64_t(values[i]) < 0; }
};

/// @brief What an input is, known after opening it and before reading any voxel.
struct InputInfo {
    std::array<uint32_t, 3> dim{{0, 0, 0}};
    LabelType type = LabelType::U32;
    Geometry geometry;  ///< origin: centre of voxel (0,0,0)
    std::string format; ///< "vraw", "NRRD", "NIfTI", "HDF5", "TIFF", "Zarr", "precomputed"
    std::string detail; ///< one line for `csgv info`: dataset path, chunk shape, compressor...
    /// Slices stored together (the z extent of a chunk; 1 for formats stored slice by slice):
    /// readers that read rows serve bands this deep from a small cache (see readRows).
    uint32_t chunkDepth = 1;
    /// Other files whose bytes make the volume, absolute: NRRD's data file, HDF5 external storage,
    /// the targets of external links followed and the sources of virtual datasets. A cache of the
    /// volume (vtkCSGVInputReader's stamp) is stale when one of them changes.
    std::vector<std::string> namedFiles;

    /// Saturates at kSaturated instead of wrapping; openInput refuses any input whose voxels
    /// would need 2^64 bytes or more at full width, so for an opened source it is exact.
    uint64_t voxelCount() const { return product3(dim[0], dim[1], dim[2]); }
};

/// @brief Options every input format takes.
struct InputOptions {
    /// Bound on the buffers a source keeps between readSlab calls (chunk or page caches), not
    /// counting the caller's slab. A source that cannot work within it says so when opened.
    uint64_t maxWorkingBytes = uint64_t(1) << 30;
    /// Files that a dataset names inside itself (a precomputed scale key, an OME-Zarr path, NRRD's
    /// `data file:`, HDF5 external storage) must lie inside the dataset's own folder unless this
    /// is set (`csgv --allow-outside-paths`); a refusal names the file it would have read.
    bool allowOutsidePaths = false;
    /// Where a source may put a scratch file (unlinked as soon as it is open, so nothing is left
    /// behind): a gzip source read in bands of rows keeps one inflated brick-deep slab there when
    /// it does not fit kSlabMemoryBytes. Empty: $TMPDIR, else /tmp. compressToFile sets the
    /// output's folder, where the encoder's own scratch files go.
    std::string scratchDirectory;
};

/// @brief A label volume read z-slab by z-slab at full width. Opened by openInput().
///
/// Contract (every format keeps it; the tests check it on each):
/// - readSlab(z0, depth, out) fills out[x + W * (y + H * (z - z0))] for z in [z0, z0 + depth)
///   with full-width values: unsigned types as they are, signed types sign-extended (int64 bits),
///   float types holding integers as those integers (int64 bits; a fraction, NaN or infinity is
///   an error naming the voxel).
/// - Slabs are usually requested in increasing z; any order must work (a request before the last
///   one may restart a sequential stream such as gzip). Reading the volume twice gives the same
///   values (relabelling reads it twice).
/// - Memory: the source holds at most InputOptions::maxWorkingBytes between calls; workingBytes()
///   reports what it holds.
/// - Errors name the file and what is wrong (truncated chunk, unsupported dtype...). A source
///   never crashes, never hangs and never allocates what a header merely claims.
class InputSource {
public:
    virtual ~InputSource() = default;
    const InputInfo& info() const { return m_info; }
    virtual Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) = 0;
    /// True when readRows reads part of a slice for about its share of a whole slice's cost
    /// (chunked and uncompressed files), so the encoder may read bands of rows and hold less.
    virtual bool readsRows() const { return false; }
    /// Rows [y0, y0 + rows) of slices [z0, z0 + depth): out[x + W * ((y - y0) + rows * (z - z0))],
    /// the values readSlab gives there, under the same contract. The default reads whole slices
    /// only. A chunked source read in bands of whole chunk layers (z0 and depth multiples of
    /// info().chunkDepth, or reaching the last slice) may keep just the chunks of one band.
    virtual Status readRows(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, uint64_t* out);
    /// Boxes of rows [y0, y0 + rows) of slices [z0, z0 + depth) (all of x) that hold one value
    /// each, known without reading a voxel: put in `out` (replacing what it held), disjoint,
    /// inside the region, each with the full-width value readRows gives there. Listing none is
    /// always right (the default: "don't know"); a source lists what it knows for about one
    /// lookup per chunk, never per voxel (HDF5: chunks never written are the fill value). A
    /// source that cannot tell (an error looking up a chunk) lists none; its read then says
    /// what is wrong. The encoder writes the bricks they cover without reading them
    /// (SlabSource::uniformBoxes), so a volume of fill values costs time per brick, not per voxel.
    virtual void uniformBoxes(uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows, std::vector<UniformBox>& out) {
        (void)z0, (void)depth, (void)y0, (void)rows;
        out.clear();
    }
    /// Bytes of caches held between calls (for reports and the memory tests).
    virtual uint64_t workingBytes() const { return 0; }
    /// Reads that take long inside one call (a gzip source inflating a slab before serving its
    /// first band of rows: seconds for a wide slab) call `keepGoing` every few MiB and fail with
    /// "cancelled" when it returns false, so that a cancel is seen within a fraction of a second.
    /// Empty (the default): never asked.
    void setKeepGoing(std::function<bool()> keepGoing) { m_keepGoing = std::move(keepGoing); }

protected:
    bool keepGoing() const { return !m_keepGoing || m_keepGoing(); }

    InputInfo m_info;
    std::function<bool()> m_keepGoing;
};

/// True when `path` names an input that openInput() recognises by its form (suffix, `FILE.h5:/dataset`,
/// a `.zarr` folder, a precomputed folder with an `info` file, a TIFF folder or glob); says
/// nothing about whether the file is valid. `.csgv` and `synth:` are not inputs here.
bool isInputPath(const std::string& path);
/// Opens an input by its form (see isInputPath); reads its header/metadata only.
Result<std::unique_ptr<InputSource>> openInput(const std::string& path, const InputOptions& options = {});
/// The recognised forms, for messages and `--help`: "`.vraw`, ..., `DIR.zarr[/path]`, ...".
std::string supportedInputForms();

/// TIFF slice files as one volume in the order given, file i at z = i (not sorted: the caller's
/// order is the volume's): what ParaView's file dialog hands over for a series `slice_0000.tif`,
/// `slice_0001.tif`, ... As for a folder of slices, each file must be a single-page TIFF with the
/// first one's width, height and sample type, and a name that is no regular file (a dangling link,
/// a FIFO) is refused; the message names the slice that differs. Messages start with
/// sliceListName(files).
Result<std::unique_ptr<InputSource>> openTiffSlices(const std::vector<std::string>& files,
                                                    const InputOptions& options = {});
/// A list of slices by its ends, "DIR/first.tif .. last.tif" (the last one's folder too when it
/// differs from the first's), for messages and a volume's metadata.
std::string sliceListName(const std::vector<std::string>& files);

/// Reads a whole input into memory (small volumes, tests, the ParaView NIfTI reader). `maxBytes`
/// bounds the values in memory (8 bytes a voxel) and is checked before allocating.
Result<InputVolume> readInput(const std::string& path, uint64_t maxBytes = uint64_t(16) << 30);
/// Reads all of an opened source into memory (same budget rule).
Result<InputVolume> readAll(InputSource& source, const std::string& path, uint64_t maxBytes = uint64_t(16) << 30);
/// NRRD (`.nrrd` attached, `.nhdr` detached; encodings raw and gzip; endian little or big).
Result<InputVolume> readNrrd(const std::string& path, uint64_t maxBytes = uint64_t(16) << 30);
/// NIfTI-1 single file (`.nii`, `.nii.gz`), 3D (or 4D with one volume); scl_slope/inter must be
/// identity (a scaled label volume is an error).
Result<InputVolume> readNifti(const std::string& path, uint64_t maxBytes = uint64_t(16) << 30);

} // namespace csgv
