// SPDX-License-Identifier: MIT
#pragma once
/// @file InputCommon.h
/// @brief What the input formats share (private to Core/src/inputs): header text parsing in the
/// classic locale, bounded quoting of file text in messages, the memory budget, and the one
/// chunked voxel reader on InputStream that turns file bytes into full-width labels.

#include "csgv/base/FileUtil.h"
#include "csgv/base/Status.h"
#include "csgv/inputs/Inputs.h"

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace csgv {
namespace inputs {

// ---- the formats (one file each); Inputs.cpp's table dispatches on claimsX, in its order.
// claimsX: does the path have this format's form (suffix, `:/dataset`, folder layout)?
// openX: reads the header/metadata and returns a source (Inputs.h states the contract).
bool claimsVraw(const std::string& path);
Result<std::unique_ptr<InputSource>> openVraw(const std::string& path, const InputOptions& options);
bool claimsNrrd(const std::string& path);
Result<std::unique_ptr<InputSource>> openNrrd(const std::string& path, const InputOptions& options);
bool claimsNifti(const std::string& path);
Result<std::unique_ptr<InputSource>> openNifti(const std::string& path, const InputOptions& options);
bool claimsHdf5(const std::string& path);
Result<std::unique_ptr<InputSource>> openHdf5(const std::string& path, const InputOptions& options);
bool claimsZarr(const std::string& path);
Result<std::unique_ptr<InputSource>> openZarr(const std::string& path, const InputOptions& options);
bool claimsPrecomputed(const std::string& path);
Result<std::unique_ptr<InputSource>> openPrecomputed(const std::string& path, const InputOptions& options);
bool claimsTiff(const std::string& path);
Result<std::unique_ptr<InputSource>> openTiff(const std::string& path, const InputOptions& options);

// readNrrd and readNifti are public (Inputs.h).
Result<InputVolume> readVrawInput(const std::string& path, uint64_t maxBytes);
/// A whole volume already read, as a source (for formats not yet streamed).
Result<std::unique_ptr<InputSource>> sourceOf(Result<InputVolume> volume, const std::string& format);

// ---- messages and header text
Status fail(const std::string& path, const std::string& what);
std::string lower(std::string s);
bool endsWith(const std::string& s, const std::string& suffix);
std::string trim(const std::string& s);
/// Quotes text from a file for a message: bounded, with unprintable bytes escaped, so that a
/// binary file named as NRRD does not fill the message with garbage.
std::string quoted(const std::string& s, size_t maxChars = 60);
// Numbers in headers are parsed and printed in the classic locale: a host application may have
// set a locale whose decimal separator is a comma.
std::string formatDouble(double v);
bool parseDouble(const std::string& text, double& out);
bool parseInt64(const std::string& text, int64_t& out);
std::vector<std::string> splitWords(const std::string& s);

/// @brief Closes a C file on every return path.
class CFile {
public:
    explicit CFile(std::FILE* f) : m_file(f) {}
    ~CFile() {
        if (m_file) std::fclose(m_file);
    }
    CFile(const CFile&) = delete;
    CFile& operator=(const CFile&) = delete;
    std::FILE* get() const { return m_file; }

private:
    std::FILE* m_file;
};

// ---- voxels
unsigned typeBytes(LabelType type);
std::string dimText(const std::array<uint64_t, 3>& d);
/// Refuses volumes whose full-width values (8 bytes a voxel) exceed maxBytes, before anything
/// of that size is allocated.
Status checkBudget(const std::string& path, const std::array<uint64_t, 3>& d, uint64_t maxBytes);

/// @brief What readVoxels() got: the bytes the stream delivered, and the first voxel that is not
/// an integer label (reported by callers only when no byte was missing, so that a truncated
/// file is called truncated, as it always was).
struct VoxelRead {
    uint64_t bytes = 0;
    Status decode;
};

/// Reads `vol.voxelCount()` voxels of `vol.type` from `in` in chunks into `vol.values` (which
/// grows as bytes arrive, so a header that claims more than the file holds costs no allocation
/// of the claimed size). Fewer bytes than needed is not an error here: callers word it. An error
/// is the stream's (in.failure() says which step).
Result<VoxelRead> readVoxels(InputStream& in, InputVolume& vol, bool bigEndian, const std::string& path);

} // namespace inputs
} // namespace csgv
