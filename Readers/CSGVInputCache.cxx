// SPDX-License-Identifier: MIT
#include "CSGVInputCache.h"

#include "csgv/base/FileUtil.h"
#include "csgv/base/Hash.h"
#include "csgv/inputs/PathGuard.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <fcntl.h>
#include <filesystem>
#include <new>
#include <sys/stat.h>
#include <unistd.h>

namespace csgvvtk
{
namespace
{
namespace fs = std::filesystem;

/// Largest stamp read back: a stack of 100,000 slices lists about 10 MB of names.
constexpr uint64_t kMaxStampBytes = uint64_t(64) << 20;

bool exists(const std::string& path)
{
  std::error_code ec;
  return fs::exists(path, ec);
}

bool isDirectory(const std::string& path)
{
  std::error_code ec;
  return fs::is_directory(path, ec);
}

std::string absolutePath(const std::string& path)
{
  std::error_code ec;
  fs::path p = fs::absolute(fs::path(path), ec);
  if (ec)
  {
    p = fs::path(path);
  }
  std::string s = p.lexically_normal().string();
  while (s.size() > 1 && s.back() == '/')
  {
    s.pop_back(); // "DIR/" and "DIR" are the same input and must share one cache
  }
  return s;
}

/// True when `name` ends with `suffix` (lowercase) and has more before it.
bool hasSuffix(const std::string& name, const char* suffix)
{
  return name.size() > std::char_traits<char>::length(suffix) && csgv::endsWithNoCase(name, suffix);
}

/// A path inside a container as part of a file name: "/labels/0" -> "labels_0".
std::string flattened(const std::string& inner)
{
  std::string out;
  for (char c : inner)
  {
    const bool keep = std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_';
    if (!keep && (out.empty() || out.back() == '_'))
    {
      continue;
    }
    out += keep ? c : '_';
  }
  while (!out.empty() && out.back() == '_')
  {
    out.pop_back();
  }
  return out;
}

/// ParaView's file dialog opens files: a Zarr metadata file stands for its folder, a precomputed
/// `info` file for its folder.
std::string folderForDialogFile(const std::string& path)
{
  const fs::path p(path);
  const std::string name = p.filename().string();
  if ((name == ".zarray" || name == ".zgroup" || name == ".zattrs" || name == "info") &&
    !isDirectory(path))
  {
    const std::string parent = p.parent_path().string();
    return parent.empty() ? std::string(".") : parent;
  }
  return path;
}

/// A file's name without a `.tif` / `.tiff` suffix.
std::string tiffStem(const std::string& path)
{
  std::string name = fs::path(path).filename().string();
  for (const char* suffix : { ".tif", ".tiff" })
  {
    if (hasSuffix(name, suffix))
    {
      name.resize(name.size() - std::char_traits<char>::length(suffix));
      break;
    }
  }
  return name;
}

/// True when a file can be created in `dir` by this process (as its effective user; a mode
/// check would be wrong for root and for ACLs).
bool canCreateIn(const std::string& dir)
{
  const std::string probe = dir + "/.csgv-probe-" + std::to_string(::getpid());
  const int fd = ::open(probe.c_str(), O_CREAT | O_EXCL | O_WRONLY, 0600);
  if (fd < 0)
  {
    return false;
  }
  ::close(fd);
  ::unlink(probe.c_str());
  return true;
}

std::string defaultCacheRoot()
{
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  if (xdg && xdg[0] == '/')
  {
    return std::string(xdg) + "/csgv-paraview";
  }
  const char* home = std::getenv("HOME");
  if (home && *home)
  {
    return std::string(home) + "/.cache/csgv-paraview";
  }
  return std::string();
}

int64_t mtimeNs(const struct stat& st)
{
  return int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

} // namespace

InputLocation locateInput(const std::string& fileName)
{
  InputLocation loc;
  // A Neuroglancer precomputed scale, `DIR[/info]#N` or `#KEY` (as the csgv tool takes it): the
  // part before '#' exists, the whole name does not.
  std::string scale;
  std::string named = fileName;
  const size_t hash = fileName.rfind('#');
  if (hash != std::string::npos && hash > 0 && !exists(absolutePath(fileName)) &&
    exists(absolutePath(folderForDialogFile(fileName.substr(0, hash)))))
  {
    scale = fileName.substr(hash);
    named = fileName.substr(0, hash);
  }
  const std::string path = absolutePath(folderForDialogFile(named));
  loc.Input = path + scale;
  loc.Display = fileName;
  loc.Stem = fs::path(path).filename().string();
  std::string inner = scale; // the part of the input inside Stamped (an HDF5 dataset, a glob, a scale)
  if (!scale.empty())
  {
    loc.Stamped = path;
  }
  else if (exists(path))
  {
    loc.Stamped = path;
  }
  else if (path.find_first_of("*?[") != std::string::npos)
  {
    const fs::path p(path);
    loc.Stamped = p.parent_path().string();
    inner = p.filename().string();
  }
  else
  {
    const size_t colon = path.rfind(':');
    if (colon != std::string::npos && colon > 0 && exists(path.substr(0, colon)))
    {
      loc.Stamped = path.substr(0, colon);
      inner = path.substr(colon + 1);
    }
  }
  if (loc.Stamped.empty() || !exists(loc.Stamped))
  {
    loc.Error = "cannot open '" + fileName + "': no such file or folder";
    return loc;
  }
  // Beside a Zarr store rather than inside it (a store is one dataset to its users).
  std::string container = loc.Stamped;
  fs::path walked;
  for (const fs::path& part : fs::path(loc.Stamped))
  {
    walked /= part;
    if (hasSuffix(part.string(), ".zarr"))
    {
      container = walked.string();
      const std::string rel = fs::path(loc.Stamped).lexically_relative(walked).string();
      if (rel != "." && !rel.empty())
      {
        inner = inner.empty() ? rel : rel + "/" + inner;
      }
      break;
    }
  }
  const std::string suffix = flattened(inner);
  loc.BesidePath = container + (suffix.empty() ? std::string() : "_" + suffix) + ".csgv";
  return loc;
}

InputLocation locateStack(const std::vector<std::string>& files)
{
  InputLocation loc;
  for (const std::string& f : files)
  {
    loc.Slices.push_back(absolutePath(f));
    loc.Input += (loc.Input.empty() ? "" : "\n") + loc.Slices.back();
  }
  loc.Display = csgv::sliceListName(loc.Slices);
  const std::string first = tiffStem(loc.Slices.front());
  const std::string last = tiffStem(loc.Slices.back());
  // The common beginning of the two names, not cut inside a run of digits (the slice number).
  size_t common = 0;
  while (common < first.size() && common < last.size() && first[common] == last[common])
  {
    ++common;
  }
  while (common > 0 && std::isdigit(static_cast<unsigned char>(first[common - 1])))
  {
    --common;
  }
  const std::string rest = last.substr(common);
  loc.Stem = first + "-" + (rest.empty() ? std::string("stack") : rest);
  // Its own folder: the stamp follows the slice files, not the folder, so the cache may live there.
  const std::string folder = fs::path(loc.Slices.front()).parent_path().string();
  loc.BesidePath = (folder.empty() ? std::string(".") : folder) + "/" + flattened(loc.Stem) + ".csgv";
  return loc;
}

csgv::Result<std::unique_ptr<csgv::InputSource>> openSource(
  const InputLocation& loc, const csgv::InputOptions& options)
{
  try
  {
    return loc.Slices.empty() ? csgv::openInput(loc.Input, options)
                              : csgv::openTiffSlices(loc.Slices, options);
  }
  catch (const std::bad_alloc&)
  {
    return csgv::Status::error("out of memory while opening '" + loc.Display + "'");
  }
  catch (...)
  {
    return csgv::Status::error("opening '" + loc.Display + "' failed unexpectedly");
  }
}

std::string chooseCache(const InputLocation& loc, const std::string& cacheDirectory, std::string& error)
{
  std::string dir = cacheDirectory;
  if (dir.empty())
  {
    const std::string besideDir = fs::path(loc.BesidePath).parent_path().string();
    if (canCreateIn(besideDir))
    {
      return loc.BesidePath;
    }
    dir = defaultCacheRoot();
    if (dir.empty())
    {
      error = "'" + besideDir + "' is not writable and neither XDG_CACHE_HOME nor HOME is set";
      return std::string();
    }
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!canCreateIn(dir))
  {
    error = "cannot write the cache folder '" + dir + "'";
    return std::string();
  }
  const std::string stem = flattened(loc.Stem);
  return absolutePath(dir) + "/" + (stem.empty() ? std::string() : stem + "-") +
    csgv::fnv1a64Hex(loc.Input) + ".csgv";
}

std::string currentStamp(const InputLocation& loc, int relabel, int brickSize, bool allowOutside)
{
  uint64_t files = 0, bytes = 0;
  int64_t newest = 0;
  struct stat st;
  nlohmann::ordered_json input = loc.Input;
  if (!loc.Slices.empty())
  {
    // A stack: its slice files in order (a reordered or shorter list is another volume).
    input = nlohmann::ordered_json::array();
    for (const std::string& slice : loc.Slices)
    {
      if (::stat(slice.c_str(), &st) != 0)
      {
        return std::string();
      }
      input.push_back(slice);
      ++files;
      bytes += uint64_t(st.st_size);
      newest = std::max(newest, mtimeNs(st));
    }
  }
  else if (::stat(loc.Stamped.c_str(), &st) != 0)
  {
    return std::string();
  }
  else if (S_ISDIR(st.st_mode))
  {
    // Folders (Zarr, precomputed, TIFF slices): any chunk added, removed or rewritten changes the
    // count, the total size or the newest modification time.
    std::error_code ec;
    for (fs::recursive_directory_iterator it(loc.Stamped, fs::directory_options::skip_permission_denied, ec), end;
         !ec && it != end; it.increment(ec))
    {
      struct stat fst;
      if (::stat(it->path().c_str(), &fst) == 0 && S_ISREG(fst.st_mode))
      {
        ++files;
        bytes += uint64_t(fst.st_size);
        newest = std::max(newest, mtimeNs(fst));
      }
    }
    if (ec)
    {
      return std::string();
    }
  }
  else
  {
    files = 1;
    bytes = uint64_t(st.st_size);
    newest = mtimeNs(st);
  }
  nlohmann::ordered_json stamp = { { "input", std::move(input) }, { "relabel", relabel ? 1 : 0 },
    { "brickSize", brickSize }, { "files", files }, { "bytes", bytes }, { "newestMtimeNs", newest } };
  if (allowOutside)
  {
    // A cache made with files outside the input's folder allowed is not one without: reading it
    // would show what the reader now refuses. Absent when off, so older caches stay valid.
    stamp["allowOutsidePaths"] = 1;
  }
  // Paths are bytes; JSON text is UTF-8, so invalid sequences become U+FFFD (as in .csgv.json).
  return stamp.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

std::string cacheIdentity(const std::string& cache)
{
  struct stat st;
  if (::stat(cache.c_str(), &st) != 0)
  {
    return std::string();
  }
  return "cache: " + std::to_string(uint64_t(st.st_ino)) + " " + std::to_string(uint64_t(st.st_size)) +
    " " + std::to_string(mtimeNs(st)) + "\n";
}

std::string topLevelState(const std::string& path)
{
  struct stat st;
  if (::stat(path.c_str(), &st) != 0)
  {
    return std::string();
  }
  return std::to_string(uint64_t(st.st_ino)) + " " + std::to_string(uint64_t(st.st_size)) + " " +
    std::to_string(mtimeNs(st));
}

namespace
{
/// A path as one token of printable ASCII that gives back its exact bytes (names are bytes: a
/// JSON string would turn invalid UTF-8 into U+FFFD, a name that does not exist).
std::string percentEncoded(const std::string& path)
{
  static const char hex[] = "0123456789ABCDEF";
  std::string out;
  for (const unsigned char c : path)
  {
    if (c > 0x20 && c < 0x7f && c != '%')
    {
      out += char(c);
    }
    else
    {
      out += '%';
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

bool percentDecoded(const std::string& token, std::string& out)
{
  out.clear();
  for (size_t i = 0; i < token.size(); ++i)
  {
    if (token[i] != '%')
    {
      out += token[i];
      continue;
    }
    if (i + 2 >= token.size())
    {
      return false;
    }
    const std::string two = token.substr(i + 1, 2);
    if (!std::isxdigit(static_cast<unsigned char>(two[0])) ||
      !std::isxdigit(static_cast<unsigned char>(two[1])))
    {
      return false;
    }
    out += char(std::stoi(two, nullptr, 16));
    i += 2;
  }
  return true;
}
} // namespace

std::string namedFilesState(const std::vector<std::string>& files)
{
  // The count first: a stamp without it (one written before inputs named files, or cut by hand)
  // or without some of its lines never matches, so the input is compressed again.
  std::string text = "named files: " + std::to_string(files.size()) + "\n";
  for (const std::string& file : files)
  {
    const std::string state = topLevelState(file);
    text += "named: " + (state.empty() ? std::string("missing") : state) + " " + percentEncoded(file) + "\n";
  }
  return text;
}

std::vector<std::string> namedFilesIn(const std::string& stamp)
{
  std::vector<std::string> files;
  for (size_t at = stamp.find("\nnamed: "); at != std::string::npos; at = stamp.find("\nnamed: ", at + 1))
  {
    const size_t end = stamp.find('\n', at + 1);
    const size_t space = stamp.rfind(' ', end);
    std::string path;
    if (end != std::string::npos && space != std::string::npos && space > at &&
      percentDecoded(stamp.substr(space + 1, end - space - 1), path))
    {
      files.push_back(path);
    }
  }
  return files;
}

std::string inParaViewWords(const std::string& coreMessage)
{
  std::string text = coreMessage;
  const std::string hint = csgv::inputs::kAllowOutsideHint;
  for (size_t at = text.find(hint); at != std::string::npos; at = text.find(hint, at + 1))
  {
    text.replace(at, hint.size(), "turn on the reader's Allow Outside Paths property (advanced) to read it");
  }
  return text;
}

std::string readStamp(const std::string& path)
{
  csgv::Result<std::vector<uint8_t>> bytes = csgv::readFile(path, kMaxStampBytes);
  return bytes ? std::string(bytes->begin(), bytes->end()) : std::string();
}

bool writeStamp(const std::string& path, const std::string& text)
{
  csgv::AtomicFile file;
  return file.open(path) && file.write(text.data(), text.size()) && file.commit();
}

} // namespace csgvvtk
