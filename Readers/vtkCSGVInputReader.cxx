// SPDX-License-Identifier: MIT
#include "vtkCSGVInputReader.h"

#include "vtkCSGVReader.h"

#include "csgv/base/FileUtil.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Compress.h"
#include "csgv/inputs/Inputs.h"

#include <vtkCallbackCommand.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationDoubleVectorKey.h>
#include <vtkInformationIntegerKey.h>
#include <vtkInformationIntegerVectorKey.h>
#include <vtkInformationKey.h>
#include <vtkInformationVector.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fcntl.h>
#include <exception>
#include <filesystem>
#include <fstream>
#include <new>
#include <sstream>
#include <sys/stat.h>
#include <thread>
#include <unistd.h>

vtkStandardNewMacro(vtkCSGVInputReader);

namespace
{
namespace fs = std::filesystem;

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

bool isDirectory(const std::string& path)
{
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool exists(const std::string& path)
{
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
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

std::string lowered(std::string s)
{
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
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

InputLocation locate(const std::string& fileName)
{
  InputLocation loc;
  const std::string path = absolutePath(folderForDialogFile(fileName));
  loc.Input = path;
  loc.Display = fileName;
  loc.Stem = fs::path(path).filename().string();
  std::string inner; // the part of the input inside Stamped (an HDF5 dataset, a glob)
  if (exists(path))
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
    const std::string s = lowered(part.string());
    if (s.size() > 5 && s.compare(s.size() - 5, 5, ".zarr") == 0)
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

/// A file's name without a `.tif` / `.tiff` suffix.
std::string tiffStem(const std::string& path)
{
  std::string name = fs::path(path).filename().string();
  const std::string low = lowered(name);
  for (const char* suffix : { ".tif", ".tiff" })
  {
    const size_t n = std::char_traits<char>::length(suffix);
    if (low.size() > n && low.compare(low.size() - n, n, suffix) == 0)
    {
      name.resize(name.size() - n);
      break;
    }
  }
  return name;
}

/// An image stack of slice files: its cache is named after the first and the last slice,
/// `slice_0000.tif` .. `slice_0127.tif` -> `slice_0000-0127.csgv`, beside the first one (its own
/// folder: the stamp follows the slice files, not the folder, so the cache may live there).
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
  const std::string folder = fs::path(loc.Slices.front()).parent_path().string();
  loc.BesidePath = (folder.empty() ? std::string(".") : folder) + "/" + flattened(loc.Stem) + ".csgv";
  return loc;
}

/// Opens the input `loc` names: a stack of slices, or any form csgv::openInput takes. Core
/// returns errors as values; anything thrown still must not leave into ParaView.
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

/// 64-bit FNV-1a: a stable name for an input's cache in the shared cache folder.
std::string hashName(const std::string& s)
{
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s)
  {
    h = (h ^ c) * 1099511628211ull;
  }
  char hex[17];
  std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(h));
  return hex;
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

/// The cache path for `loc`, creating the cache folder when needed; "" with `error` set when no
/// place can be written.
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
  return absolutePath(dir) + "/" + (stem.empty() ? std::string() : stem + "-") + hashName(loc.Input) + ".csgv";
}

std::string jsonString(const std::string& s)
{
  std::string out = "\"";
  for (unsigned char c : s)
  {
    if (c == '"' || c == '\\')
    {
      out += '\\';
      out += char(c);
    }
    else if (c < 0x20)
    {
      char esc[8];
      std::snprintf(esc, sizeof(esc), "\\u%04x", c);
      out += esc;
    }
    else
    {
      out += char(c);
    }
  }
  return out + "\"";
}

int64_t mtimeNs(const struct stat& st)
{
  return int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

/// The stamp text that describes the input's current state and the encoding options; "" when the
/// input cannot be examined.
std::string currentStamp(const InputLocation& loc, int relabel, int brickSize)
{
  uint64_t files = 0, bytes = 0;
  int64_t newest = 0;
  struct stat st;
  std::string input = jsonString(loc.Input);
  if (!loc.Slices.empty())
  {
    // A stack: its slice files in order (a reordered or shorter list is another volume).
    input = "[";
    for (const std::string& slice : loc.Slices)
    {
      if (::stat(slice.c_str(), &st) != 0)
      {
        return std::string();
      }
      input += (files == 0 ? "\n    " : ",\n    ") + jsonString(slice);
      ++files;
      bytes += uint64_t(st.st_size);
      newest = std::max(newest, mtimeNs(st));
    }
    input += "\n  ]";
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
  std::ostringstream s;
  s << "{\n  \"input\": " << input << ",\n  \"relabel\": " << (relabel ? 1 : 0)
    << ",\n  \"brickSize\": " << brickSize << ",\n  \"files\": " << files << ",\n  \"bytes\": " << bytes
    << ",\n  \"newestMtimeNs\": " << newest << "\n}\n";
  return s.str();
}

/// The cache's own identity (inode, size, modification time) as the stamp's last line, after the
/// input's JSON state: a stamp vouches only for the very .csgv it was written for, so when two
/// writers race, a stamp never vouches for the other writer's file. "" when the cache is missing.
std::string cacheIdentity(const std::string& cache)
{
  struct stat st;
  if (::stat(cache.c_str(), &st) != 0)
  {
    return std::string();
  }
  std::ostringstream s;
  s << "cache: " << uint64_t(st.st_ino) << " " << uint64_t(st.st_size) << " " << mtimeNs(st) << "\n";
  return s.str();
}

/// What of the stamped file or folder a stat shows (no walk): enough to tell, between
/// RequestInformation and RequestData of one update, whether the walk must be done again.
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

std::string readText(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return in ? s.str() : std::string();
}

/// Writes the stamp through Core's AtomicFile (a temporary name unique to this process and call,
/// renamed into place), so a reader never sees half a stamp.
bool writeStamp(const std::string& path, const std::string& text)
{
  csgv::AtomicFile file;
  return file.open(path) && file.write(text.data(), text.size()) && file.commit();
}

} // namespace

/// @brief The internal `.csgv` reader and what RequestInformation found for RequestData.
class vtkCSGVInputReader::vtkInternals
{
public:
  vtkSmartPointer<vtkCSGVReader> Reader;
  vtkNew<vtkCallbackCommand> ProgressForwarder;
  /// Where reading the cached .csgv starts on the progress bar: its last tenth after compressing
  /// in this request, all of it when the cache was there already (it sat at 98% meanwhile).
  double ReadProgressFrom = 0.9;
  InputLocation Location;
  std::string Cache;
  std::string Stamp; ///< the input's state when RequestInformation looked
  /// For reusing RequestInformation's stamp in the RequestData of the same update (a folder's
  /// stamp walks every file): the reader's MTime and the stamped path's own stat then.
  bool StampFromInformation = false;
  vtkMTimeType StampMTime = 0;
  std::string StampTopLevel;
  bool Failed = true;
  /// FileNames as set (AddFileName); what is read is chosen in ChooseInputs.
  std::vector<std::string> FileNames;
  /// The inputs of the last RequestInformation (FileName alone, or FileNames) and, for a time
  /// series, the step whose file Location and Cache describe.
  std::vector<std::string> Inputs;
  int Step = 0;
  /// The reader's MTime and the input's stamp when RequestData last failed: the pipeline asks
  /// again for the extent it announced (an empty output does not cover it), and the same
  /// request must neither compress again nor report again.
  vtkMTimeType FailedMTime = 0;
  std::string FailedStamp;

  /// A fresh .csgv reader: the old one keys what it loaded by file time and size at one-second
  /// resolution, which a recompression within the same second could fool.
  void ResetReader()
  {
    this->Reader = vtkSmartPointer<vtkCSGVReader>::New();
    this->Reader->AddObserver(vtkCommand::ProgressEvent, this->ProgressForwarder);
  }

  /// The stamp matches the input and the cache it was written for (inode, size, mtime), and the
  /// cache starts like a .csgv (a cache overwritten or emptied by someone else is compressed
  /// again; deeper damage is reported when it is read).
  bool CacheIsValid() const
  {
    if (this->Stamp.empty())
    {
      return false;
    }
    const std::string identity = cacheIdentity(this->Cache);
    return !identity.empty() && readText(this->Cache + ".stamp") == this->Stamp + identity &&
      this->Reader->CanReadFile(this->Cache.c_str());
  }

  /// The input's stamp, computed at most once per update: RequestData reuses RequestInformation's
  /// when the reader and the stamped path's own stat are unchanged since.
  void UpdateStamp(vtkCSGVInputReader* self, bool forInformation)
  {
    const std::string top = topLevelState(this->Location.Stamped);
    if (!forInformation && this->StampFromInformation && self->GetMTime() == this->StampMTime &&
      top == this->StampTopLevel && !top.empty())
    {
      this->StampFromInformation = false; // the next update walks again
      return;
    }
    this->Stamp = currentStamp(this->Location, self->GetRelabel(), self->GetBrickSize());
    this->StampFromInformation = forInformation;
    this->StampMTime = self->GetMTime();
    this->StampTopLevel = top;
  }
};

vtkCSGVInputReader::vtkCSGVInputReader()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(0);
  // Reading the cached .csgv is the last tenth of the progress bar after compressing, else all.
  this->Internals->ProgressForwarder->SetClientData(this);
  this->Internals->ProgressForwarder->SetCallback(
    [](vtkObject* caller, unsigned long, void* clientData, void*) {
      auto* self = static_cast<vtkCSGVInputReader*>(clientData);
      const double from = self->Internals->ReadProgressFrom;
      self->UpdateProgress(from + (1.0 - from) * static_cast<vtkAlgorithm*>(caller)->GetProgress());
    });
  this->Internals->ResetReader();
}

vtkCSGVInputReader::~vtkCSGVInputReader()
{
  this->SetFileName(nullptr);
  this->SetCacheDirectory(nullptr);
  delete this->Internals;
}

const char* vtkCSGVInputReader::GetCachedFileName()
{
  return this->Internals->Cache.c_str();
}

int vtkCSGVInputReader::CanReadFile(const char* fileName)
{
  if (!fileName || !*fileName)
  {
    return 0;
  }
  const InputLocation loc = locate(fileName);
  return loc.Error.empty() && csgv::isInputPath(loc.Input) ? 1 : 0;
}

namespace
{
enum SeriesModes
{
  NoInput = 0,
  OneInput = 1,
  ImageStack = 2,
  TimeSeries = 3
};

/// The time step a request asks for: time values are the file indices 0, 1, ..., N - 1, and a
/// time between two of them shows the earlier file (as vtkFileSeriesReader does).
int requestedStep(vtkInformation* outInfo, int steps)
{
  if (!outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP()))
  {
    return 0;
  }
  const double t = outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP());
  if (!(t > 0.0)) // NaN too
  {
    return 0;
  }
  return int(std::min<double>(std::floor(t + 1e-9), double(steps - 1)));
}
} // namespace

void vtkCSGVInputReader::AddFileName(const char* fileName)
{
  this->Internals->FileNames.emplace_back(fileName ? fileName : "");
  this->Modified();
}

void vtkCSGVInputReader::RemoveAllFileNames()
{
  if (!this->Internals->FileNames.empty())
  {
    this->Internals->FileNames.clear();
    this->Modified();
  }
}

int vtkCSGVInputReader::GetNumberOfFileNames()
{
  return static_cast<int>(this->Internals->FileNames.size());
}

const char* vtkCSGVInputReader::GetFileNameAt(int index)
{
  const std::vector<std::string>& names = this->Internals->FileNames;
  return index >= 0 && index < static_cast<int>(names.size()) ? names[size_t(index)].c_str() : nullptr;
}

bool vtkCSGVInputReader::ChooseInputs(std::string& error)
{
  vtkInternals& in = *this->Internals;
  in.Inputs.clear();
  const std::string single = this->FileName ? this->FileName : "";
  for (const std::string& name : in.FileNames)
  {
    if (name.empty())
    {
      error = "FileNames has an empty entry";
      return false;
    }
  }
  if (!in.FileNames.empty() && !single.empty() &&
    !(in.FileNames.size() == 1 && in.FileNames[0] == single))
  {
    // A script that sets FileName on a reader the file dialog made (or the reverse) would
    // otherwise read one of the two silently.
    error = "both FileName ('" + single + "') and FileNames (" + std::to_string(in.FileNames.size()) +
      (in.FileNames.size() == 1 ? " file" : " files") + ", '" + in.FileNames[0] +
      "' first) are set; set only one of them";
    return false;
  }
  in.Inputs = in.FileNames.empty() ? std::vector<std::string>{ single } : in.FileNames;
  if (in.Inputs.size() == 1)
  {
    if (in.Inputs[0].empty())
    {
      error = "no FileName set";
      return false;
    }
    this->SeriesMode = OneInput;
    return true;
  }
  if (!this->ReadAsImageStack)
  {
    this->SeriesMode = TimeSeries;
    return true;
  }
  // What the first file is decides, as a user would: a 2D TIFF is a slice of a stack, anything
  // with depth (a multi-page TIFF, HDF5, NRRD...) is a volume of its own, one per time step.
  const InputLocation first = locate(in.Inputs[0]);
  if (!first.Error.empty())
  {
    error = first.Error;
    return false;
  }
  csgv::InputOptions options;
  options.allowOutsidePaths = this->AllowOutsidePaths != 0;
  csgv::Result<std::unique_ptr<csgv::InputSource>> source = openSource(first, options);
  if (!source)
  {
    error = source.message();
    return false;
  }
  const csgv::InputInfo& info = (*source)->info();
  this->SeriesMode = info.format == "TIFF" && info.dim[2] == 1 ? ImageStack : TimeSeries;
  return true;
}

int vtkCSGVInputReader::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkInternals& in = *this->Internals;
  in.Failed = true;
  in.Cache.clear();
  this->SeriesMode = NoInput;
  // Errors are reported once here; the pipeline goes on with an empty extent and RequestData
  // leaves an empty output (as vtkCSGVReader does).
  const int empty[6] = { 0, -1, 0, -1, 0, -1 };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), empty, 6);
  outInfo->Remove(vtkStreamingDemandDrivenPipeline::TIME_STEPS());
  outInfo->Remove(vtkStreamingDemandDrivenPipeline::TIME_RANGE());
  std::string error;
  if (!this->ChooseInputs(error))
  {
    this->SeriesMode = NoInput;
    vtkErrorMacro(<< error);
    return 1;
  }
  in.Step = 0;
  if (this->SeriesMode == TimeSeries)
  {
    const int steps = static_cast<int>(in.Inputs.size());
    std::vector<double> times(in.Inputs.size());
    for (int i = 0; i < steps; ++i)
    {
      times[size_t(i)] = i;
    }
    const double range[2] = { 0.0, double(steps - 1) };
    outInfo->Set(vtkStreamingDemandDrivenPipeline::TIME_STEPS(), times.data(), steps);
    outInfo->Set(vtkStreamingDemandDrivenPipeline::TIME_RANGE(), range, 2);
    in.Step = requestedStep(outInfo, steps);
  }
  this->PrepareInput(outInfo);
  return 1;
}

int vtkCSGVInputReader::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInternals& in = *this->Internals;
  if (this->SeriesMode != TimeSeries)
  {
    return 1;
  }
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  const int step = requestedStep(outInfo, static_cast<int>(in.Inputs.size()));
  if (step == in.Step)
  {
    return 1;
  }
  // Another time step is another file: announce its extent (as vtkFileSeriesReader does), and
  // ask it whole when the extent asked of the previous file does not fit it.
  in.Step = step;
  this->PrepareInput(outInfo);
  int whole[6], ext[6];
  outInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext);
  bool inside = true;
  for (int a = 0; a < 3; ++a)
  {
    inside = inside && ext[2 * a] >= whole[2 * a] && ext[2 * a + 1] <= whole[2 * a + 1];
  }
  if (!inside)
  {
    outInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), whole, 6);
  }
  return 1;
}

void vtkCSGVInputReader::PrepareInput(vtkInformation* outInfo)
{
  vtkInternals& in = *this->Internals;
  in.Failed = true;
  in.Cache.clear();
  const int empty[6] = { 0, -1, 0, -1, 0, -1 };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), empty, 6);
  in.Location = this->SeriesMode == ImageStack ? locateStack(in.Inputs)
                                               : locate(in.Inputs[size_t(in.Step)]);
  if (!in.Location.Error.empty())
  {
    vtkErrorMacro(<< in.Location.Error);
    return;
  }
  std::string error;
  in.Cache = chooseCache(in.Location, this->CacheDirectory ? this->CacheDirectory : "", error);
  if (in.Cache.empty())
  {
    vtkErrorMacro(<< in.Location.Display << ": " << error);
    return;
  }
  in.UpdateStamp(this, true);

  if (in.CacheIsValid())
  {
    // The .csgv knows everything; report exactly what vtkCSGVReader reports.
    in.Reader->SetFileName(in.Cache.c_str());
    in.Reader->SetLevel(this->Level);
    in.Reader->UpdateInformation();
    vtkInformation* cached = in.Reader->GetOutputInformation(0);
    for (vtkInformationKey* key :
      { static_cast<vtkInformationKey*>(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()),
        static_cast<vtkInformationKey*>(vtkDataObject::SPACING()),
        static_cast<vtkInformationKey*>(vtkDataObject::ORIGIN()),
        static_cast<vtkInformationKey*>(vtkDataObject::DIRECTION()),
        static_cast<vtkInformationKey*>(vtkCSGVReader::CSGV_DIMENSIONS()),
        static_cast<vtkInformationKey*>(vtkCSGVReader::CSGV_LEVELS()),
        static_cast<vtkInformationKey*>(vtkCSGVReader::CSGV_GEOMETRY()) })
    {
      outInfo->CopyEntry(cached, key);
    }
    // Sub-extents, as before the cache exists (the cached .csgv is read whole by one reader).
    outInfo->Set(vtkAlgorithm::CAN_PRODUCE_SUB_EXTENT(), 1);
    in.Failed = false;
    return;
  }

  // Not compressed yet: the input's header gives what the .csgv will say (Core writes the
  // input's centre-origin geometry as corner-origin metadata, and a brick size of 2^n gives
  // n + 1 levels).
  csgv::InputOptions inputOptions;
  inputOptions.allowOutsidePaths = this->AllowOutsidePaths != 0;
  csgv::Result<std::unique_ptr<csgv::InputSource>> source = openSource(in.Location, inputOptions);
  if (!source)
  {
    if (this->SeriesMode == ImageStack)
    {
      vtkErrorMacro(<< source.message() << " (the " << in.Inputs.size()
                    << " files were read as the slices of one volume; with ReadAsImageStack off each"
                       " file is one time step)");
    }
    else
    {
      vtkErrorMacro(<< source.message());
    }
    return;
  }
  const csgv::InputInfo& info = (*source)->info();
  const csgv::Geometry geometry = csgv::cellGeometryFromPointGeometry(info.geometry);
  const uint32_t levels = csgv::levelCount(static_cast<uint32_t>(this->BrickSize));
  const uint32_t lod = std::min<uint32_t>(static_cast<uint32_t>(this->Level), levels - 1);
  const std::array<uint32_t, 3> ld = csgv::lodDimensions(info.dim, lod);
  const int extent[6] = { 0, int(ld[0]), 0, int(ld[1]), 0, int(ld[2]) };
  double spacing[3];
  double geometry15[15];
  for (int a = 0; a < 3; ++a)
  {
    spacing[a] = geometry.spacing[a] * double(uint64_t(1) << lod);
    geometry15[a] = geometry.spacing[a];
    geometry15[3 + a] = geometry.origin[a];
  }
  std::copy(geometry.direction.begin(), geometry.direction.end(), geometry15 + 6);
  const int dims[3] = { int(info.dim[0]), int(info.dim[1]), int(info.dim[2]) };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  outInfo->Set(vtkDataObject::SPACING(), spacing, 3);
  outInfo->Set(vtkDataObject::ORIGIN(), geometry.origin.data(), 3);
  outInfo->Set(vtkDataObject::DIRECTION(), geometry.direction.data(), 9);
  outInfo->Set(vtkCSGVReader::CSGV_DIMENSIONS(), dims, 3);
  outInfo->Set(vtkCSGVReader::CSGV_LEVELS(), int(levels));
  outInfo->Set(vtkCSGVReader::CSGV_GEOMETRY(), geometry15, 15);
  outInfo->Set(vtkAlgorithm::CAN_PRODUCE_SUB_EXTENT(), 1);
  in.Failed = false;
}

int vtkCSGVInputReader::RequestData(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkImageData* output = vtkImageData::GetData(outInfo);
  if (!output)
  {
    return 0;
  }
  output->Initialize();
  vtkInternals& in = *this->Internals;
  this->Compressed = 0;
  if (this->SeriesMode == TimeSeries)
  {
    // RequestUpdateExtent has switched to the requested step's file; a request that came
    // without one (it should not) switches here.
    const int step = requestedStep(outInfo, static_cast<int>(in.Inputs.size()));
    if (step != in.Step)
    {
      in.Step = step;
      this->PrepareInput(outInfo);
    }
    // Every output says which step it is, failed ones too (an output without a time would be
    // asked for again at every render).
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), double(in.Step));
  }
  if (in.Failed)
  {
    return 1; // RequestInformation reported why
  }
  // The input may have changed since RequestInformation (ParaView's Reload re-runs both).
  in.UpdateStamp(this, false);
  if (in.Stamp.empty())
  {
    vtkErrorMacro(<< "cannot examine '"
                  << (in.Location.Slices.empty() ? in.Location.Stamped : in.Location.Display) << "'");
    return 1;
  }
  if (this->GetMTime() == in.FailedMTime && in.Stamp == in.FailedStamp)
  {
    return 1; // this very request failed and was reported; it is retried once something changes
  }
  this->UpdateProgress(0.0);
  const bool compress = !in.CacheIsValid();
  in.ReadProgressFrom = compress ? 0.9 : 0.0;
  if (compress && !this->Compress())
  {
    this->RememberFailure();
    return 1;
  }
  in.Reader->SetFileName(in.Cache.c_str());
  in.Reader->SetLevel(this->Level);
  in.Reader->SetDecodeLabels(this->DecodeLabels);
  in.Reader->SetDecodeThreshold(this->DecodeThreshold);
  in.Reader->UpdateInformation();
  int whole[6], ext[6];
  in.Reader->GetOutputInformation(0)->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext);
  bool inside = whole[0] <= whole[1];
  for (int a = 0; a < 3 && inside; ++a)
  {
    inside = ext[2 * a] >= whole[2 * a] && ext[2 * a + 1] <= whole[2 * a + 1];
  }
  if (!inside)
  {
    // The .csgv disagrees with what the header promised (it should not): give it whole.
    vtkWarningMacro(<< "'" << in.Cache << "' has another extent than '" << in.Location.Display << "' announced");
    std::copy(whole, whole + 6, ext);
  }
  if (whole[0] > whole[1] || !in.Reader->UpdateExtent(ext) ||
    in.Reader->GetOutput()->GetNumberOfPoints() == 0)
  {
    // vtkCSGVReader said why; a broken cache must not be trusted next time.
    vtkErrorMacro(<< "cannot read the cached '" << in.Cache << "'; it will be compressed again");
    std::remove((in.Cache + ".stamp").c_str());
    this->RememberFailure();
    return 1;
  }
  output->ShallowCopy(in.Reader->GetOutput());
  if (this->SeriesMode == TimeSeries)
  {
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), double(in.Step));
  }
  this->UpdateProgress(1.0);
  return 1;
}

void vtkCSGVInputReader::RememberFailure()
{
  // A cancellation leaves AbortExecute set; clearing it (which bumps the MTime) comes first so
  // that the remembered MTime is the one the repeated request will carry.
  this->SetAbortExecute(0);
  this->Internals->FailedMTime = this->GetMTime();
  this->Internals->FailedStamp = this->Internals->Stamp;
}

bool vtkCSGVInputReader::Compress()
{
  vtkInternals& in = *this->Internals;
  // A stamp that outlives a failed compression could vouch for sidecars of another input state.
  std::remove((in.Cache + ".stamp").c_str());
  const std::thread::id pipelineThread = std::this_thread::get_id();
  csgv::CompressOptions options;
  options.encode.brickSize = static_cast<uint32_t>(this->BrickSize);
  options.relabel = this->Relabel != 0;
  options.input.allowOutsidePaths = this->AllowOutsidePaths != 0;
  options.progress = [this, pipelineThread](double fraction, const char*) {
    // VTK events belong to the pipeline's thread; workers only look at the abort flag.
    if (std::this_thread::get_id() == pipelineThread)
    {
      this->UpdateProgress(0.9 * std::min(std::max(fraction, 0.0), 1.0));
    }
    return !this->GetAbortExecute();
  };
  // A progress observer may abort before Core reports any progress.
  if (this->GetAbortExecute())
  {
    vtkErrorMacro(<< "compressing '" << in.Location.Display << "' was cancelled");
    return false;
  }
  csgv::CompressReport report;
  csgv::Status status;
  if (in.Location.Slices.empty())
  {
    try
    {
      status = csgv::compressToFile(in.Location.Input, in.Cache, options, &report);
    }
    catch (...)
    {
      // compressToFile returns its errors; this is the last guard of the ParaView session.
      status = csgv::Status::error("compressing '" + in.Location.Input + "' failed unexpectedly");
    }
  }
  else
  {
    // A stack has no single name for compressToFile: open its slices and hand over the source
    // (its scratch files, if any, go where the encoder's do: beside the cache).
    csgv::InputOptions inputOptions = options.input;
    inputOptions.scratchDirectory = fs::path(in.Cache).parent_path().string();
    csgv::Result<std::unique_ptr<csgv::InputSource>> source = openSource(in.Location, inputOptions);
    status = source ? csgv::Status::ok() : source.status();
    try
    {
      if (source)
      {
        status = csgv::compressSourceToFile(**source, in.Location.Display, in.Cache, options, &report);
      }
    }
    catch (...)
    {
      status = csgv::Status::error("compressing '" + in.Location.Display + "' failed unexpectedly");
    }
  }
  if (!status)
  {
    vtkErrorMacro(<< status.message());
    return false;
  }
  if (this->GetAbortExecute())
  {
    // Finished before Core looked at the flag: the files are whole, so keep them, but say so.
    vtkWarningMacro(<< "compressing '" << in.Location.Display << "' finished before it could be cancelled");
  }
  // The stamp names the cache just written (before the new reader looks at it, so a concurrent
  // writer's later .csgv never matches it).
  const std::string identity = cacheIdentity(in.Cache);
  if (identity.empty() || !writeStamp(in.Cache + ".stamp", in.Stamp + identity))
  {
    vtkWarningMacro(<< "cannot write '" << in.Cache << ".stamp'; the input will be compressed again next time");
  }
  this->Compressed = 1;
  in.ResetReader();
  this->UpdateProgress(0.9);
  return true;
}

void vtkCSGVInputReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
  os << indent << "FileNames: " << this->Internals->FileNames.size() << "\n";
  for (const std::string& name : this->Internals->FileNames)
  {
    os << indent.GetNextIndent() << name << "\n";
  }
  os << indent << "ReadAsImageStack: " << this->ReadAsImageStack << "\n";
  os << indent << "SeriesMode: " << this->SeriesMode << "\n";
  os << indent << "Relabel: " << this->Relabel << "\n";
  os << indent << "AllowOutsidePaths: " << this->AllowOutsidePaths << "\n";
  os << indent << "BrickSize: " << this->BrickSize << "\n";
  os << indent << "CacheDirectory: " << (this->CacheDirectory ? this->CacheDirectory : "(default)") << "\n";
  os << indent << "DecodeLabels: " << this->DecodeLabels << "\n";
  os << indent << "DecodeThreshold: " << this->DecodeThreshold << "\n";
  os << indent << "Level: " << this->Level << "\n";
  os << indent << "CachedFileName: " << this->Internals->Cache << "\n";
}
