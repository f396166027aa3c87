// SPDX-License-Identifier: MIT
#pragma once
/// @file PathGuard.h
/// @brief The one check on files that a dataset names inside itself (a precomputed scale key, an
/// OME-Zarr dataset path or label name, NRRD's `data file:`, HDF5 external storage): a dataset
/// handed to us must not make us read files elsewhere on the machine (`../../home/u/.ssh/id_rsa`),
/// so what it names must lie inside the dataset's own folder unless the user allows otherwise
/// (InputOptions::allowOutsidePaths, `csgv --allow-outside-paths`). And the one way to open such
/// a file for reading that never blocks: a FIFO named as a data file would wait for a writer
/// forever.

#include "csgv/base/FileUtil.h"
#include "csgv/base/Status.h"

#include <filesystem>
#include <string>

namespace csgv {
namespace inputs {

/// @brief A file or folder that a dataset names, and where it must stay.
struct NamedPath {
    std::string named;      ///< as the dataset writes it: relative to `folder`, or absolute
    std::string folder;     ///< the folder it is relative to and must stay inside ("" is ".")
    std::string what;       ///< for the message: "data file", "scale key", "multiscale dataset path"
    std::string folderRole; ///< for the message: "the header's folder", "the group's folder"
};

/// The words every refusal of a path outside its dataset ends with, so that a host can put its own
/// (ParaView: the reader's Allow Outside Paths property) in their place.
inline constexpr const char* kAllowOutsideHint = "pass --allow-outside-paths to read it";

/// The path to open for `p.named`: `p.folder/p.named`, or `p.named` itself when absolute. An error
/// when it lies outside `p.folder` and `allowOutside` is not set; both are resolved first, `.` and
/// `..` and symbolic links included (the named path as far as it exists: what does not exist
/// cannot be opened anyway). The message reads "<what> '<named>' lies outside <folderRole>
/// '<resolved folder>' (pass --allow-outside-paths to read it)"; callers prefix the dataset.
Result<std::string> resolveInside(const NamedPath& p, bool allowOutside);

/// True when `inner` is `outer` or lies below it (both resolved: absolute, symbolic links of
/// their existing part followed), compared component by component, so that `/data/set2` does not
/// count as inside `/data/set`.
bool liesInside(const std::filesystem::path& inner, const std::filesystem::path& outer);

/// What a path is when it is not a regular file (FileUtil's, named here too for the inputs).
using csgv::notRegularFile;

/// Opens `path` read-only (close-on-exec) without ever blocking: a FIFO or device is refused with
/// what it is ("is a FIFO (named pipe), not a regular file"), as is anything else but a regular
/// file. Returns the descriptor (the caller closes it); an error's message is only the reason.
Result<int> openRegularFile(const std::string& path);

} // namespace inputs
} // namespace csgv
