// SPDX-License-Identifier: MIT
/**
 * @file CSGVInputCache.h
 * @brief Where vtkCSGVInputReader's inputs live and where their cached `.csgv` goes, and the
 * stamp that says whether a cache still matches its input (private to Readers/; the rules are
 * vtkCSGVInputReader.h's "Cache" section). No VTK here: the reader translates, this decides.
 */
#ifndef CSGVInputCache_h
#define CSGVInputCache_h

#include "csgv/base/Status.h"
#include "csgv/inputs/Inputs.h"

#include <memory>
#include <string>
#include <vector>

namespace csgvvtk
{

/// @brief Where an input lives on disk and where its cache goes.
struct InputLocation
{
  std::string Input;      ///< what csgv::openInput gets (absolute); a stack's slices, one a line
  std::string Stamped;    ///< the file or folder whose state the stamp records ("" for a stack)
  std::vector<std::string> Slices; ///< an image stack's slice files in z order (absolute), or none
  std::string Display;    ///< the input in messages: as the user named it, or a stack's ends
  std::string Stem;       ///< the cache's name stem in a shared cache folder
  std::string BesidePath; ///< the cache beside the input (`.csgv` included)
  std::string Error;      ///< why the input cannot be located ("" when it can)
};

/// One input in any form csgv::openInput takes; a Zarr metadata file or a precomputed `info`
/// file stands for its folder (ParaView's file dialog opens files).
InputLocation locateInput(const std::string& fileName);

/// An image stack of slice files: its cache is named after the first and the last slice,
/// `slice_0000.tif` .. `slice_0127.tif` -> `slice_0000-0127.csgv`, beside the first one.
InputLocation locateStack(const std::vector<std::string>& files);

/// Opens the input `loc` names: a stack of slices, or any form csgv::openInput takes. Core
/// returns errors as values; anything thrown is turned into one too.
csgv::Result<std::unique_ptr<csgv::InputSource>> openSource(
  const InputLocation& loc, const csgv::InputOptions& options);

/// The cache path for `loc`, creating the cache folder when needed; "" with `error` set when no
/// place can be written.
std::string chooseCache(const InputLocation& loc, const std::string& cacheDirectory, std::string& error);

/// The stamp text (JSON) that describes the input's current state and the encoding options; ""
/// when the input cannot be examined.
std::string currentStamp(const InputLocation& loc, int relabel, int brickSize, bool allowOutside);

/// The cache's own identity (inode, size, modification time) as the stamp's last line, after the
/// input's JSON state: a stamp vouches only for the very .csgv it was written for, so when two
/// writers race, a stamp never vouches for the other writer's file. "" when the cache is missing.
std::string cacheIdentity(const std::string& cache);

/// What of the stamped file or folder a stat shows (no walk): enough to tell, between
/// RequestInformation and RequestData of one update, whether the walk must be done again.
std::string topLevelState(const std::string& path);

/// The state of the files an input names besides itself (csgv::InputInfo::namedFiles: an NRRD's
/// data file, an HDF5 file's external links, storage and virtual sources), one line each, for the
/// stamp: `named files: N`, then `named: INODE SIZE MTIME PATH` (or `named: missing PATH`) for
/// each, the path percent-encoded (its exact bytes, in one token of printable ASCII).
std::string namedFilesState(const std::vector<std::string>& files);

/// The files a stamp's `named:` lines list (none for a stamp without any, or a damaged line: the
/// stamp then no longer matches and the input is compressed again).
std::vector<std::string> namedFilesIn(const std::string& stamp);

/// Core's message in ParaView's words: the refusal of a path outside its dataset names the
/// reader's Allow Outside Paths property instead of `--allow-outside-paths`.
std::string inParaViewWords(const std::string& coreMessage);

/// The text of a stamp file ("" when it is missing or unreadable).
std::string readStamp(const std::string& path);

/// Writes a stamp through Core's AtomicFile, so a reader never sees half a stamp.
bool writeStamp(const std::string& path, const std::string& text);

} // namespace csgvvtk

#endif
