// SPDX-License-Identifier: MIT
#include "CSGVFileSeries.h"

#include <vtkInformation.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include "csgv/codec/Decoder.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace csgvvtk
{

bool FileSeries::Clear()
{
  const bool had = !this->Names.empty();
  this->Names.clear();
  return had;
}

const char* FileSeries::At(int index) const
{
  return index >= 0 && index < this->Count() ? this->Names[size_t(index)].c_str() : nullptr;
}

bool FileSeries::Choose(const char* fileName, std::vector<std::string>& inputs, std::string& error) const
{
  inputs.clear();
  const std::string single = fileName ? fileName : "";
  for (const std::string& name : this->Names)
  {
    if (name.empty())
    {
      error = "FileNames has an empty entry";
      return false;
    }
  }
  if (!single.empty() && this->Names.size() == 1)
  {
    // OpenDataFile (and the file dialog) set FileNames to one file; a script that then sets
    // FileName means that file. Decided by the values, not by which was set last, so a state
    // file (which sets both, in its own order) reads what the session read.
    inputs = { single };
    return true;
  }
  if (!this->Names.empty() && !single.empty())
  {
    // A script that sets FileName on a reader the file dialog made (or the reverse) would
    // otherwise read one of the two silently.
    error = "both FileName ('" + single + "') and FileNames (" + std::to_string(this->Names.size()) +
      (this->Names.size() == 1 ? " file" : " files") + ", '" + this->Names[0] +
      "' first) are set; set only one of them";
    return false;
  }
  inputs = this->Names.empty() ? std::vector<std::string>{ single } : this->Names;
  if (inputs.size() == 1 && inputs[0].empty())
  {
    error = "no FileName set";
    inputs.clear();
    return false;
  }
  return true;
}

int RequestedStep(vtkInformation* outInfo, int steps)
{
  if (steps <= 1 || !outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP()))
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

bool TakeRequestedStep(vtkInformation* outInfo, int steps, int& step)
{
  const int requested = RequestedStep(outInfo, steps);
  const bool changed = requested != step;
  step = requested;
  return changed;
}

void AnnounceSteps(vtkInformation* outInfo, int steps)
{
  std::vector<double> times(size_t(std::max(steps, 0)));
  for (int i = 0; i < steps; ++i)
  {
    times[size_t(i)] = i;
  }
  const double range[2] = { 0.0, double(steps - 1) };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::TIME_STEPS(), times.data(), steps);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::TIME_RANGE(), range, 2);
  // Each step is a file with its own extent: the pipeline asks for it once the time is known.
  outInfo->Set(vtkStreamingDemandDrivenPipeline::TIME_DEPENDENT_INFORMATION(), 1);
  // Consumers downstream (ParaView's post filter, representations) keep the whole extent of the
  // step they saw last and ask it again before the reader can answer (the executive checks the
  // request against the new step's extent first): the reader takes any request and answers with
  // the step's whole extent in RequestUpdateExtent (AskWholeExtent).
  outInfo->Set(vtkStreamingDemandDrivenPipeline::UNRESTRICTED_UPDATE_EXTENT(), 1);
}

void ClearSteps(vtkInformation* outInfo)
{
  outInfo->Remove(vtkStreamingDemandDrivenPipeline::TIME_STEPS());
  outInfo->Remove(vtkStreamingDemandDrivenPipeline::TIME_RANGE());
  outInfo->Remove(vtkStreamingDemandDrivenPipeline::TIME_DEPENDENT_INFORMATION());
  outInfo->Remove(vtkStreamingDemandDrivenPipeline::UNRESTRICTED_UPDATE_EXTENT());
}

std::array<int, 6> LevelExtent(const std::array<uint32_t, 3>& dims, uint32_t lod)
{
  const std::array<uint32_t, 3> ld = csgv::lodDimensions(dims, lod);
  std::array<int, 6> extent{};
  for (int a = 0; a < 3; ++a)
  {
    // A header that lies about its size gives no negative extent.
    extent[size_t(2 * a + 1)] = int(std::min<uint32_t>(ld[size_t(a)], uint32_t(std::numeric_limits<int>::max())));
  }
  return extent;
}

void HoldStep(int whole[6], const std::array<uint32_t, 3>& dims, uint32_t lod)
{
  const std::array<int, 6> step = LevelExtent(dims, lod);
  for (int a = 0; a < 3; ++a)
  {
    whole[2 * a] = 0;
    whole[2 * a + 1] = std::max(whole[2 * a + 1], step[size_t(2 * a + 1)]);
  }
}

bool StepShapes::Get(const std::string& path, const Reader& read, StepShape& shape, const std::string& options,
  const std::string& stamped)
{
  struct stat st;
  if (::stat((stamped.empty() ? path : stamped).c_str(), &st) != 0)
  {
    this->Files.erase(path);
    return false;
  }
  Known& known = this->Files[path];
  const int64_t modified = int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
  if (known.Size != int64_t(st.st_size) || known.Modified != modified || known.Options != options)
  {
    known.Size = int64_t(st.st_size);
    known.Modified = modified;
    known.Options = options;
    known.Shape = StepShape{};
    known.Read = read(path, known.Shape);
  }
  shape = known.Shape;
  return known.Read;
}

void AskWholeExtent(vtkInformation* outInfo)
{
  int whole[6];
  outInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), whole, 6);
  // The executive unites each request with the extents requested before in the same cycle
  // (COMBINED_UPDATE_EXTENT): one made for another step would bring its extent back.
  if (outInfo->Has(vtkStreamingDemandDrivenPipeline::COMBINED_UPDATE_EXTENT()))
  {
    static const int empty[6] = { 0, -1, 0, -1, 0, -1 };
    outInfo->Set(vtkStreamingDemandDrivenPipeline::COMBINED_UPDATE_EXTENT(), empty, 6);
  }
}

} // namespace csgvvtk
