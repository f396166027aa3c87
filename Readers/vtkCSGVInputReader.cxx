// SPDX-License-Identifier: MIT
#include "vtkCSGVInputReader.h"

#include "CSGVHeldValue.h"

#include "CSGVAdapter.h"
#include "CSGVFileSeries.h"
#include "CSGVInputCache.h"
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
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <thread>

vtkStandardNewMacro(vtkCSGVInputReader);
csgvHeldSetter(vtkCSGVInputReader, BrickSize, int, 8, 128)
csgvHeldSetter(vtkCSGVInputReader, DecodeThreshold, vtkIdType, 0, VTK_ID_MAX)
csgvHeldSetter(vtkCSGVInputReader, Level, int, 0, 7)

using csgvvtk::InputLocation;

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
  std::string FailureText; ///< the last failure reported (ReportFailure), "" when none
  /// FileNames as set (AddFileName); what is read is chosen in ChooseInputs.
  csgvvtk::FileSeries FileNames;
  /// The inputs of the last RequestInformation (FileName alone, or FileNames) and, for a time
  /// series, the step whose file Location and Cache describe.
  std::vector<std::string> Inputs;
  int Step = 0;
  int StepExtent[6] = { 0, -1, 0, -1, 0, -1 }; ///< the extent PrepareInput announced for Step
  csgvvtk::StepShapes Shapes; ///< of a time series' files, for the extent of every step
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
    // The files the input names besides itself (an NRRD's data file, an HDF5 file's links) are
    // those the stamp lists, taken again now.
    const std::string identity = csgvvtk::cacheIdentity(this->Cache);
    const std::string stamp = csgvvtk::readStamp(this->Cache + ".stamp");
    return !identity.empty() &&
      stamp == this->Stamp + csgvvtk::namedFilesState(csgvvtk::namedFilesIn(stamp)) + identity &&
      this->Reader->CanReadFile(this->Cache.c_str());
  }

  /// The input's stamp, computed at most once per update: RequestData reuses RequestInformation's
  /// when the reader and the stamped path's own stat are unchanged since.
  void UpdateStamp(vtkCSGVInputReader* self, bool forInformation)
  {
    const std::string top = csgvvtk::topLevelState(this->Location.Stamped);
    if (!forInformation && this->StampFromInformation && self->GetMTime() == this->StampMTime &&
      top == this->StampTopLevel && !top.empty())
    {
      this->StampFromInformation = false; // the next update walks again
      return;
    }
    this->Stamp = csgvvtk::currentStamp(
      this->Location, self->GetRelabel(), self->GetBrickSize(), self->GetAllowOutsidePaths() != 0);
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
  const InputLocation loc = csgvvtk::locateInput(fileName);
  const bool ownReader = csgv::endsWithNoCase(loc.Input, ".vraw") ||
    csgv::endsWithNoCase(loc.Input, ".vraw.gz") || csgv::endsWithNoCase(loc.Input, ".nii") ||
    csgv::endsWithNoCase(loc.Input, ".nii.gz");
  return loc.Error.empty() && !ownReader && csgv::isInputPath(loc.Input) ? 1 : 0;
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

} // namespace

void vtkCSGVInputReader::AddFileName(const char* fileName)
{
  this->Internals->FileNames.Add(fileName);
  this->Modified();
}

void vtkCSGVInputReader::RemoveAllFileNames()
{
  if (this->Internals->FileNames.Clear())
  {
    this->Modified();
  }
}

int vtkCSGVInputReader::GetNumberOfFileNames()
{
  return this->Internals->FileNames.Count();
}

const char* vtkCSGVInputReader::GetFileNameAt(int index)
{
  return this->Internals->FileNames.At(index);
}

bool vtkCSGVInputReader::ChooseInputs(std::string& error)
{
  vtkInternals& in = *this->Internals;
  if (!in.FileNames.Choose(this->FileName, in.Inputs, error))
  {
    return false;
  }
  if (in.Inputs.size() == 1)
  {
    this->SeriesMode = OneInput;
    return true;
  }
  if (!this->ReadAsImageStack)
  {
    this->SeriesMode = TimeSeries;
    return true;
  }
  // What the first file is decides, as a user would: a 2D TIFF is a slice of a stack, anything
  // with depth (a multi-page TIFF, HDF5, NRRD...) is a volume of its own, one per time step. A
  // first file that cannot be read leaves it to the next that can (the bad one is then named when
  // its slice or step is read), so one bad file does not hide a whole series.
  csgv::InputOptions options;
  options.allowOutsidePaths = this->AllowOutsidePaths != 0;
  std::string firstError;
  for (const std::string& input : in.Inputs)
  {
    const InputLocation where = csgvvtk::locateInput(input);
    csgv::Result<std::unique_ptr<csgv::InputSource>> source = where.Error.empty()
      ? csgvvtk::openSource(where, options)
      : csgv::Result<std::unique_ptr<csgv::InputSource>>(csgv::Status::error(where.Error));
    if (!source)
    {
      if (firstError.empty())
      {
        firstError = source.message();
      }
      continue;
    }
    const csgv::InputInfo& info = (*source)->info();
    this->SeriesMode = info.format == "TIFF" && info.dim[2] == 1 ? ImageStack : TimeSeries;
    return true;
  }
  error = firstError;
  return false;
}

int vtkCSGVInputReader::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkInternals& in = *this->Internals;
  in.Failed = true;
  in.FailureText.clear();
  in.Cache.clear();
  this->SeriesMode = NoInput;
  // Errors are reported once here; the pipeline goes on with an empty extent and RequestData
  // leaves an empty output (as vtkCSGVReader does).
  const int empty[6] = { 0, -1, 0, -1, 0, -1 };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), empty, 6);
  csgvvtk::ClearSteps(outInfo);
  std::string error;
  if (!this->ChooseInputs(error))
  {
    this->SeriesMode = NoInput;
    this->ReportFailure(csgvvtk::inParaViewWords(error));
    return 1;
  }
  in.Step = 0;
  if (this->SeriesMode == TimeSeries)
  {
    const int steps = static_cast<int>(in.Inputs.size());
    csgvvtk::AnnounceSteps(outInfo, steps);
    in.Step = csgvvtk::RequestedStep(outInfo, steps);
  }
  this->PrepareInput(outInfo);
  if (this->SeriesMode == TimeSeries)
  {
    this->AnnounceEveryStep(outInfo);
  }
  return 1;
}

void vtkCSGVInputReader::AnnounceEveryStep(vtkInformation* outInfo)
{
  // Consumers downstream (ParaView's post filter, every representation) keep the whole extent
  // they see here and ask for it again at every step, cropping what a larger step gives to it
  // (found by an attack pass on .csgv series). They see the extent that holds every step (the
  // inputs' headers); each step's output has its own (SwitchStep).
  vtkInternals& in = *this->Internals;
  int whole[6];
  outInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  csgv::InputOptions options;
  options.allowOutsidePaths = this->AllowOutsidePaths != 0;
  csgvvtk::InputLocation location;
  const auto readHeader = [&options, &location](const std::string&, csgvvtk::StepShape& shape) {
    if (!location.Error.empty())
    {
      return false;
    }
    csgv::Result<std::unique_ptr<csgv::InputSource>> source = csgvvtk::openSource(location, options);
    if (source)
    {
      shape.Dims = (*source)->info().dim;
    }
    return source.isOk();
  };
  const uint32_t levels = csgv::levelCount(static_cast<uint32_t>(this->BrickSize));
  const uint32_t lod = std::min<uint32_t>(static_cast<uint32_t>(this->Level), levels - 1);
  for (size_t i = 0; i < in.Inputs.size(); ++i)
  {
    if (int(i) == in.Step)
    {
      continue; // described already
    }
    location = csgvvtk::locateInput(in.Inputs[i]);
    csgvvtk::StepShape shape;
    if (in.Shapes.Get(in.Inputs[i], readHeader, shape, options.allowOutsidePaths ? "outside paths" : "",
          location.Stamped))
    {
      csgvvtk::HoldStep(whole, shape.Dims, lod);
    }
  }
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole, 6);
}

vtkTypeBool vtkCSGVInputReader::ProcessRequest(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  if (request->Has(vtkStreamingDemandDrivenPipeline::REQUEST_TIME_DEPENDENT_INFORMATION()))
  {
    this->SwitchStep(outputVector->GetInformationObject(0));
    return 1;
  }
  return this->Superclass::ProcessRequest(request, inputVector, outputVector);
}

int vtkCSGVInputReader::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  this->SwitchStep(outputVector->GetInformationObject(0));
  return 1;
}

void vtkCSGVInputReader::SwitchStep(vtkInformation* outInfo)
{
  vtkInternals& in = *this->Internals;
  if (this->SeriesMode != TimeSeries)
  {
    return;
  }
  // Another time step is another file: announce its extent, as vtkFileSeriesReader does.
  if (csgvvtk::TakeRequestedStep(outInfo, static_cast<int>(in.Inputs.size()), in.Step))
  {
    this->PrepareInput(outInfo);
  }
  else
  {
    // The step's own extent, not the one of every step that RequestInformation announced.
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), in.StepExtent, 6);
  }
  csgvvtk::AskWholeExtent(outInfo);
}

void vtkCSGVInputReader::PrepareInput(vtkInformation* outInfo)
{
  vtkInternals& in = *this->Internals;
  in.Failed = true;
  in.Cache.clear();
  const int empty[6] = { 0, -1, 0, -1, 0, -1 };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), empty, 6);
  std::copy(empty, empty + 6, in.StepExtent);
  in.Location = this->SeriesMode == ImageStack ? csgvvtk::locateStack(in.Inputs)
                                               : csgvvtk::locateInput(in.Inputs[size_t(in.Step)]);
  if (!in.Location.Error.empty())
  {
    this->ReportFailure(in.Location.Error);
    return;
  }
  std::string error;
  in.Cache = csgvvtk::chooseCache(in.Location, this->CacheDirectory ? this->CacheDirectory : "", error);
  if (in.Cache.empty())
  {
    this->ReportFailure(in.Location.Display + ": " + error);
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
    outInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), in.StepExtent);
    in.Failed = false;
    return;
  }

  // Not compressed yet: the input's header gives what the .csgv will say (Core writes the
  // input's centre-origin geometry as corner-origin metadata, and a brick size of 2^n gives
  // n + 1 levels).
  csgv::InputOptions inputOptions;
  inputOptions.allowOutsidePaths = this->AllowOutsidePaths != 0;
  csgv::Result<std::unique_ptr<csgv::InputSource>> source = csgvvtk::openSource(in.Location, inputOptions);
  if (!source)
  {
    if (this->SeriesMode == ImageStack)
    {
      this->ReportFailure(csgvvtk::inParaViewWords(source.message()) + " (the " + std::to_string(in.Inputs.size()) +
        " files were read as the slices of one volume; with ReadAsImageStack off each file is one time step)");
    }
    else
    {
      this->ReportFailure(csgvvtk::inParaViewWords(source.message()));
    }
    return;
  }
  const csgv::InputInfo& info = (*source)->info();
  const csgv::Geometry geometry = csgv::cellGeometryFromPointGeometry(info.geometry);
  const uint32_t levels = csgv::levelCount(static_cast<uint32_t>(this->BrickSize));
  const uint32_t lod = std::min<uint32_t>(static_cast<uint32_t>(this->Level), levels - 1);
  const std::array<int, 6> extent = csgvvtk::LevelExtent(info.dim, lod);
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
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent.data(), 6);
  outInfo->Set(vtkDataObject::SPACING(), spacing, 3);
  outInfo->Set(vtkDataObject::ORIGIN(), geometry.origin.data(), 3);
  outInfo->Set(vtkDataObject::DIRECTION(), geometry.direction.data(), 9);
  outInfo->Set(vtkCSGVReader::CSGV_DIMENSIONS(), dims, 3);
  outInfo->Set(vtkCSGVReader::CSGV_LEVELS(), int(levels));
  outInfo->Set(vtkCSGVReader::CSGV_GEOMETRY(), geometry15, 15);
  outInfo->Set(vtkAlgorithm::CAN_PRODUCE_SUB_EXTENT(), 1);
  std::copy(extent.begin(), extent.end(), in.StepExtent);
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
    this->SwitchStep(outInfo);
    // Every output says which step it is, failed ones too (an output without a time would be
    // asked for again at every render).
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), double(in.Step));
  }
  if (in.Failed)
  {
    csgvvtk::markReadError(output->GetFieldData(), in.FailureText);
    return 1; // RequestInformation reported why
  }
  // The input may have changed since RequestInformation (ParaView's Reload re-runs both).
  in.UpdateStamp(this, false);
  if (in.Stamp.empty())
  {
    this->ReportFailure(
      "cannot examine '" + (in.Location.Slices.empty() ? in.Location.Stamped : in.Location.Display) + "'");
    csgvvtk::markReadError(output->GetFieldData(), in.FailureText);
    return 1;
  }
  if (this->GetMTime() == in.FailedMTime && in.Stamp == in.FailedStamp)
  {
    csgvvtk::markReadError(output->GetFieldData(), in.FailureText);
    return 1; // this very request failed and was reported; it is retried once something changes
  }
  this->UpdateProgress(0.0);
  const bool compress = !in.CacheIsValid();
  in.ReadProgressFrom = compress ? 0.9 : 0.0;
  if (compress && !this->Compress())
  {
    this->RememberFailure();
    csgvvtk::markReadError(output->GetFieldData(), in.FailureText);
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
    this->ReportFailure("cannot read the cached '" + in.Cache + "'; it will be compressed again");
    std::remove((in.Cache + ".stamp").c_str());
    this->RememberFailure();
    csgvvtk::markReadError(output->GetFieldData(), in.FailureText);
    return 1;
  }
  output->ShallowCopy(in.Reader->GetOutput());
  if (in.Location.Slices.empty())
  {
    // An atlas's label names beside it (MRIcron's `aal.nii.txt`): the representation reads them
    // as attributes (names in Segmentation Pick and the legend) without Load attributes.
    csgvvtk::setAttributeSidecar(output->GetFieldData(), csgvvtk::labelTableBeside(in.Location.Input));
  }
  if (this->SeriesMode == TimeSeries)
  {
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), double(in.Step));
  }
  this->UpdateProgress(1.0);
  return 1;
}

void vtkCSGVInputReader::ReportFailure(const std::string& message)
{
  vtkErrorMacro(<< message);
  this->Internals->FailureText = message;
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
    this->ReportFailure("compressing '" + in.Location.Display + "' was cancelled");
    return false;
  }
  csgv::CompressReport report;
  csgv::Status status;
  csgv::removeTemporariesOnSignals(); // Ctrl-C in pvbatch or the GUI leaves no half cache
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
    inputOptions.scratchDirectory = std::filesystem::path(in.Cache).parent_path().string();
    csgv::Result<std::unique_ptr<csgv::InputSource>> source = csgvvtk::openSource(in.Location, inputOptions);
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
    this->ReportFailure(csgvvtk::inParaViewWords(status.message()));
    return false;
  }
  if (this->GetAbortExecute())
  {
    // Finished before Core looked at the flag: the files are whole, so keep them, but say so.
    vtkWarningMacro(<< "compressing '" << in.Location.Display << "' finished before it could be cancelled");
  }
  // The stamp names the cache just written (before the new reader looks at it, so a concurrent
  // writer's later .csgv never matches it).
  const std::string identity = csgvvtk::cacheIdentity(in.Cache);
  if (identity.empty() ||
    !csgvvtk::writeStamp(in.Cache + ".stamp", in.Stamp + csgvvtk::namedFilesState(report.namedFiles) + identity))
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
  os << indent << "FileNames: " << this->Internals->FileNames.Count() << "\n";
  for (const std::string& name : this->Internals->FileNames.All())
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
