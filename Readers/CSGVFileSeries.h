// SPDX-License-Identifier: MIT
/**
 * @file CSGVFileSeries.h
 * @brief A reader's FileName and FileNames, and the time series FileNames makes (private to
 * Readers/; used by vtkCSGVReader and vtkCSGVInputReader).
 *
 * Why FileNames: ParaView's file dialog groups `s_0.csgv` ... `s_9.csgv` into one entry and
 * hands the whole group to a repeatable (`repeat_command`) property only; any other reader gets
 * the first file, silently. FileName stays for scripts and state files. A FileName set beside a
 * FileNames of one file (OpenDataFile's, then `r.FileName = other` in a script) is read; beside a
 * series of several it is an error, never one of the two read silently.
 *
 * Time steps are the file indices 0, 1, ..., N - 1; a time between two shows the earlier file
 * (as vtkFileSeriesReader does). Another step is another file, possibly of another extent: it is
 * announced when the pipeline asks for time-dependent information (the requested time is known
 * then), and every request is answered with the step's whole extent (AskWholeExtent).
 */
#ifndef CSGVFileSeries_h
#define CSGVFileSeries_h

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

class vtkInformation;

namespace csgvvtk
{

/// @brief FileNames as set, in order.
class FileSeries
{
public:
  void Add(const char* fileName) { this->Names.emplace_back(fileName ? fileName : ""); }
  /// True when there was something to remove (the reader is then Modified).
  bool Clear();
  int Count() const { return static_cast<int>(this->Names.size()); }
  /// Entry `index` (null outside [0, Count())).
  const char* At(int index) const;
  const std::vector<std::string>& All() const { return this->Names; }

  /// What is read: FileName alone (also beside a FileNames of one file), or FileNames. False with
  /// `error` when FileName is set beside several FileNames, an entry is empty, or nothing is set.
  bool Choose(const char* fileName, std::vector<std::string>& inputs, std::string& error) const;

private:
  std::vector<std::string> Names;
};

/// The time step a request asks for, in [0, steps).
int RequestedStep(vtkInformation* outInfo, int steps);

/// The step a request asks for becomes `step`; true when it changed (the reader then announces
/// the new step's file, before AskWholeExtent).
bool TakeRequestedStep(vtkInformation* outInfo, int steps, int& step);

/// Publishes time steps 0 .. steps - 1, their range, and that the information (the extent)
/// depends on the time (the reader answers REQUEST_TIME_DEPENDENT_INFORMATION).
void AnnounceSteps(vtkInformation* outInfo, int steps);

/// Removes what AnnounceSteps published.
void ClearSteps(vtkInformation* outInfo);

/// The point extent of a volume of `dims` cells at level `lod` (held within an int's range).
std::array<int, 6> LevelExtent(const std::array<uint32_t, 3>& dims, uint32_t lod);

/// Widens `whole` (a point extent, possibly empty) to hold LevelExtent(dims, lod). A series
/// announces at RequestInformation the extent that holds every step: consumers keep the extent
/// they see then and crop any step to it.
void HoldStep(int whole[6], const std::array<uint32_t, 3>& dims, uint32_t lod);

/// What a series needs of a step's file to announce its extent.
struct StepShape
{
  std::array<uint32_t, 3> Dims{}; ///< cells at level 0
  uint32_t Levels = 0;            ///< levels of detail the file holds (0: the reader's own count)
};

/// @brief The shapes of a series' files, read once per version of each file (its size and
/// modification time): RequestInformation runs at every change of a reader's property, and
/// reading every step's header each time would read the series again and again.
class StepShapes
{
public:
  /// Reads a file's shape; false when it cannot (its step says why when it is shown).
  using Reader = std::function<bool(const std::string& path, StepShape& shape)>;
  /// Whether `path`'s shape is known, reading it with `read` for a new version of the file or
  /// other reading options (`options`: a text that differs when the answer may, such as whether
  /// files outside the input's folder may be read: a refusal is not kept once they may).
  /// `stamped`: the file or folder whose version stands for the input's (InputLocation::Stamped:
  /// `path` less a dataset suffix such as ":/labels"), else `path` itself.
  bool Get(const std::string& path, const Reader& read, StepShape& shape, const std::string& options = std::string(),
    const std::string& stamped = std::string());

private:
  struct Known
  {
    int64_t Size = -1, Modified = 0;
    std::string Options;
    bool Read = false;
    StepShape Shape;
  };
  std::map<std::string, Known> Files;
};

/// A series reader's update extent is the current step's whole extent, whatever was asked.
/// Consumers downstream (ParaView's post filter, representations, filters) keep the extent of the
/// step they saw when they last asked for information and ask it again at other steps: a larger
/// one is outside this step's extent, a smaller one would crop it. Pieces (MPI) are asked by
/// number, not by extent, and stay as they are.
void AskWholeExtent(vtkInformation* outInfo);

} // namespace csgvvtk

#endif
