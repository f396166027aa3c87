// SPDX-License-Identifier: MIT
#include "vtkCSGVNIfTIReader.h"

#include "CSGVAdapter.h"

#include "csgv/base/FileUtil.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Inputs.h"

#include <vtkAOSDataArrayTemplate.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkNIFTIImageHeader.h>
#include <vtkNIFTIImageReader.h>
#include <vtkObjectFactory.h>
#include <vtkCellData.h>
#include <vtkPointData.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <memory>
#include <new>
#include <vector>

vtkStandardNewMacro(vtkCSGVNIfTIReader);

/// @brief The last file's source. RequestInformation opens it (its header only: nothing
/// proportional to what a header claims is allocated there) and RequestData reads it band by band
/// into an array of the file's own type, so memory is the output plus a bounded band.
class vtkCSGVNIfTIReader::vtkInternals
{
public:
  std::string Path;
  std::unique_ptr<csgv::InputSource> Source;
  std::string Failure; ///< why RequestInformation refused the file ("" when it did not)

  /// Set when the file is not a label volume and VTK's reader reads it instead.
  vtkSmartPointer<vtkNIFTIImageReader> Intensity;
  double IntensityOrigin[3] = { 0, 0, 0 };
  double IntensityDirection[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };

  /// True for Core's refusals that mean "a valid NIfTI, but not labels".
  static bool NotALabelVolume(const std::string& message)
  {
    return message.find("which is not an integer label") != std::string::npos ||
      message.find("scaled data") != std::string::npos;
  }

  /// Opens the file with VTK's reader; geometry from the sform (code > 0), else the qform, as
  /// Core's reader chooses. VTK's matrices already map its (possibly slice-flipped) data.
  bool OpenIntensity(const char* path)
  {
    this->Intensity = vtkSmartPointer<vtkNIFTIImageReader>::New();
    this->Intensity->SetFileName(path);
    this->Intensity->UpdateInformation();
    vtkNIFTIImageHeader* header = this->Intensity->GetNIFTIHeader();
    if (!header)
    {
      this->Intensity = nullptr;
      return false;
    }
    vtkMatrix4x4* m = nullptr;
    if (header->GetSFormCode() > 0)
    {
      m = this->Intensity->GetSFormMatrix();
    }
    if (!m && header->GetQFormCode() > 0)
    {
      m = this->Intensity->GetQFormMatrix();
    }
    for (int r = 0; r < 3; ++r)
    {
      this->IntensityOrigin[r] = m ? m->GetElement(r, 3) : 0.0;
      for (int c = 0; c < 3; ++c)
      {
        this->IntensityDirection[3 * r + c] = m ? m->GetElement(r, c) : (r == c ? 1.0 : 0.0);
      }
    }
    return true;
  }
};

vtkCSGVNIfTIReader::vtkCSGVNIfTIReader()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(0);
}

vtkCSGVNIfTIReader::~vtkCSGVNIfTIReader()
{
  this->SetFileName(nullptr);
  delete this->Internals;
}

bool vtkCSGVNIfTIReader::IsNIfTIFile(const char* fileName)
{
  if (!fileName)
  {
    return false;
  }
  const std::string path(fileName);
  if (csgv::existsButNotRegular(path))
  {
    return false; // a FIFO would block File > Open, a device never end: regular files only
  }
  const size_t n = path.size();
  if (n > 7 && path.compare(n - 7, 7, ".nii.gz") == 0)
  {
    return true;
  }
  if (n < 4 || path.compare(n - 4, 4, ".nii") != 0)
  {
    return false;
  }
  std::ifstream in(path, std::ios::binary);
  char header[348];
  if (!in.read(header, sizeof(header)))
  {
    return false;
  }
  // sizeof_hdr 348 (either byte order) and the single-file magic "n+1".
  int32_t size;
  std::memcpy(&size, header, 4);
  const bool sizeOk = size == 348 || size == 0x5C010000;
  return sizeOk && std::memcmp(header + 344, "n+1", 4) == 0;
}

bool vtkCSGVNIfTIReader::IsImageHeader(const char* fileName)
{
  // VTK's reader reads (and for .nii.gz decompresses) only the header here.
  vtkNew<vtkNIFTIImageReader> reader;
  if (!reader->CanReadFile(fileName))
  {
    return false; // the label reader reports what is wrong with it
  }
  reader->SetFileName(fileName);
  reader->UpdateInformation();
  vtkNIFTIImageHeader* header = reader->GetNIFTIHeader();
  if (!header || header->GetIntentCode() == vtkNIFTIImageHeader::IntentLabel)
  {
    return false;
  }
  const int type = header->GetDataType();
  const bool floats = type == vtkNIFTIImageHeader::TypeFloat32 ||
    type == vtkNIFTIImageHeader::TypeFloat64 || type == vtkNIFTIImageHeader::TypeFloat128;
  const double slope = header->GetSclSlope();
  const bool scaled = (slope != 0.0 && slope != 1.0) || header->GetSclInter() != 0.0;
  return floats || scaled;
}

int vtkCSGVNIfTIReader::CanReadFile(const char* fileName)
{
  return IsNIfTIFile(fileName) && IsImageHeader(fileName) == bool(this->ExpectImages) ? 1 : 0;
}

namespace
{
/// Bytes of 64-bit values one band of rows holds at most while the output is filled.
constexpr uint64_t kBandBytes = uint64_t(64) << 20;

/// Calls `band(z, y0, rows, values)` for bands of whole rows of every slice, front to back,
/// holding at most kBandBytes of values; stops at the first error or when `go_on()` says no.
template <class Band, class GoOn>
csgv::Status forEachBand(csgv::InputSource& src, Band band, GoOn go_on)
{
  const auto& dim = src.info().dim;
  const uint64_t rowValues = std::max<uint64_t>(1, dim[0]);
  // Sources that cannot read part of a slice cheaply (gzip) are read a whole slice at a time.
  const uint32_t rows = src.readsRows()
    ? uint32_t(std::max<uint64_t>(1, std::min<uint64_t>(dim[1], kBandBytes / 8 / rowValues)))
    : dim[1];
  std::vector<uint64_t> values;
  try
  {
    values.resize(size_t(rowValues * rows));
  }
  catch (const std::bad_alloc&)
  {
    return csgv::Status::error("out of memory for a band of " + std::to_string(rows) + " rows of " +
      std::to_string(dim[0]) + " labels");
  }
  for (uint32_t z = 0; z < dim[2]; ++z)
  {
    for (uint32_t y0 = 0; y0 < dim[1]; y0 += rows)
    {
      const uint32_t n = std::min(rows, dim[1] - y0);
      if (csgv::Status s = src.readRows(z, 1, y0, n, values.data()); !s)
      {
        return s;
      }
      band(z, y0, n, values.data());
      if (!go_on(z))
      {
        return csgv::Status::error("cancelled");
      }
    }
  }
  return csgv::Status::ok();
}

template <class T>
void convertValues(csgv::LabelType type, const uint64_t* in, size_t n, T* out)
{
  const bool isFloat = type == csgv::LabelType::F32 || type == csgv::LabelType::F64;
  for (size_t i = 0; i < n; ++i)
  {
    // Signed and float inputs hold int64 bits; unsigned ones their value.
    out[i] = (isFloat || csgv::isSignedType(type)) ? static_cast<T>(static_cast<int64_t>(in[i]))
                                                   : static_cast<T>(in[i]);
  }
}
} // namespace

int vtkCSGVNIfTIReader::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkInternals& in = *this->Internals;
  in.Source.reset();
  in.Path.clear();
  in.Failure.clear();
  if (!this->FileName || !*this->FileName)
  {
    vtkErrorMacro(<< "no FileName set");
    return 0;
  }
  in.Intensity = nullptr;
  csgv::Result<std::unique_ptr<csgv::InputSource>> src = csgv::openInput(this->FileName);
  csgv::Status labels = src.status();
  // Floats are labels only when every value is an integer: a streaming pass decides (bounded
  // memory), as reading the whole volume did before.
  if (src && ((*src)->info().type == csgv::LabelType::F32 || (*src)->info().type == csgv::LabelType::F64))
  {
    labels = forEachBand(
      **src, [](uint32_t, uint32_t, uint32_t, const uint64_t*) {}, [](uint32_t) { return true; });
  }
  if (!labels && vtkInternals::NotALabelVolume(labels.message()) && in.OpenIntensity(this->FileName))
  {
    if (!this->ExpectImages)
    {
      vtkWarningMacro(<< labels.message() << "; not a label volume, so it is read as an intensity "
                      << "image (point array 'Scalars', stored values) with VTK's NIfTI reader");
    }
    vtkInformation* vtkInfo = in.Intensity->GetOutputInformation(0);
    outInfo->CopyEntry(vtkInfo, vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    outInfo->CopyEntry(vtkInfo, vtkDataObject::SPACING());
    outInfo->Set(vtkDataObject::ORIGIN(), in.IntensityOrigin, 3);
    outInfo->Set(vtkDataObject::DIRECTION(), in.IntensityDirection, 9);
    in.Path = this->FileName;
    return 1;
  }
  if (!labels)
  {
    vtkErrorMacro(<< labels.message());
    in.Failure = labels.message();
    // Reported once; the pipeline goes on with an empty extent and RequestData leaves an empty
    // output, never the previous file's data.
    const int empty[6] = { 0, -1, 0, -1, 0, -1 };
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), empty, 6);
    return 1;
  }
  in.Source = std::move(*src);
  in.Path = this->FileName;
  const csgv::InputInfo& v = in.Source->info();
  // One point more than voxels per axis: voxels are the cells between them.
  int extent[6] = { 0, int(v.dim[0]), 0, int(v.dim[1]), 0, int(v.dim[2]) };
  const csgv::Geometry corner = csgv::cellGeometryFromPointGeometry(v.geometry);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  outInfo->Set(vtkDataObject::SPACING(), corner.spacing.data(), 3);
  outInfo->Set(vtkDataObject::ORIGIN(), corner.origin.data(), 3);
  outInfo->Set(vtkDataObject::DIRECTION(), corner.direction.data(), 9);
  return 1;
}

int vtkCSGVNIfTIReader::RequestData(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkImageData* output = vtkImageData::GetData(outInfo);
  vtkInternals& in = *this->Internals;
  if (!output || !this->FileName)
  {
    return 0;
  }
  output->Initialize();
  if (in.Intensity && in.Path == this->FileName)
  {
    in.Intensity->Update();
    output->ShallowCopy(in.Intensity->GetOutput());
    output->SetOrigin(in.IntensityOrigin);
    output->SetDirectionMatrix(in.IntensityDirection);
    if (vtkDataArray* scalars = output->GetPointData()->GetScalars())
    {
      scalars->SetName("Scalars");
    }
    return 1;
  }
  if (!in.Source || in.Path != this->FileName)
  {
    // RequestInformation reported why; the output stays empty, marked with it (a Segmentation
    // Volume's summary says why, under MPI naming the rank).
    csgvvtk::markReadError(output->GetFieldData(), in.Failure);
    return 1;
  }
  const csgv::InputInfo& v = in.Source->info();
  const int type = csgvvtk::vtkTypeOfName(csgv::labelTypeName(v.type));
  vtkSmartPointer<vtkDataArray> arr = vtk::TakeSmartPointer(vtkDataArray::CreateDataArray(type));
  arr->SetName(csgvvtk::kLabelsName);
  const uint64_t voxels = v.voxelCount();
  const uint64_t bytes = voxels * uint64_t(arr->GetDataTypeSize());
  bool allocated = true;
  try
  {
    arr->SetNumberOfTuples(static_cast<vtkIdType>(voxels));
  }
  catch (const std::bad_alloc&)
  {
    allocated = false;
  }
  if (!allocated || (voxels && !arr->GetVoidPointer(0)))
  {
    const std::string message = std::string(this->FileName) + ": " + std::to_string(v.dim[0]) + " x " +
      std::to_string(v.dim[1]) + " x " + std::to_string(v.dim[2]) + " labels need " + std::to_string(bytes >> 20) +
      " MiB, more than this process can allocate";
    vtkErrorMacro(<< message);
    csgvvtk::markReadError(output->GetFieldData(), message);
    return 1; // reported once, the output empty and marked (a failed request is run and said again)
  }
  void* base = arr->GetVoidPointer(0);
  const size_t size = size_t(arr->GetDataTypeSize());
  const uint64_t slice = uint64_t(v.dim[0]) * v.dim[1];
  const csgv::LabelType labelType = v.type;
  csgv::Status s = forEachBand(
    *in.Source,
    [&](uint32_t z, uint32_t y0, uint32_t rows, const uint64_t* values) {
      const uint64_t first = uint64_t(z) * slice + uint64_t(y0) * v.dim[0];
      char* out = static_cast<char*>(base) + first * size;
      switch (type)
      {
        vtkTemplateMacro(convertValues(labelType, values, size_t(rows) * v.dim[0], reinterpret_cast<VTK_TT*>(out)));
      }
    },
    [&](uint32_t z) {
      this->UpdateProgress(double(z + 1) / double(std::max<uint32_t>(1, v.dim[2])));
      return !this->GetAbortExecute();
    });
  if (!s)
  {
    const std::string message = this->GetAbortExecute()
      ? std::string("reading '") + this->FileName + "' was cancelled"
      : (s.message().find(this->FileName) == std::string::npos ? std::string(this->FileName) + ": " : "") + s.message();
    if (!this->GetAbortExecute())
    {
      vtkErrorMacro(<< message);
    }
    output->Initialize();
    csgvvtk::markReadError(output->GetFieldData(), message);
    return 1; // reported once, the output empty and marked (a failed request is run and said again)
  }
  output->SetExtent(0, int(v.dim[0]), 0, int(v.dim[1]), 0, int(v.dim[2]));
  csgvvtk::applyGeometry(output, csgv::cellGeometryFromPointGeometry(v.geometry), 0);
  output->GetCellData()->SetScalars(arr);
  // An atlas's label names beside it (MRIcron's `aal.nii.txt`): the Segmentation Volume reads
  // them as attributes (names in Segmentation Pick and the legend) without Load attributes.
  csgvvtk::setAttributeSidecar(output->GetFieldData(), csgvvtk::labelTableBeside(this->FileName));
  this->UpdateProgress(1.0);
  return 1;
}

void vtkCSGVNIfTIReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
  os << indent << "ExpectImages: " << this->ExpectImages << "\n";
}
