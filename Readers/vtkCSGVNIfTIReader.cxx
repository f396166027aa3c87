// SPDX-License-Identifier: MIT
#include "vtkCSGVNIfTIReader.h"

#include "CSGVAdapter.h"

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

#include <cstring>
#include <fstream>

vtkStandardNewMacro(vtkCSGVNIfTIReader);

/// @brief The last file's volume. Core reads header and voxels together, so the values read in
/// RequestInformation are kept for the RequestData that follows, then released.
class vtkCSGVNIfTIReader::vtkInternals
{
public:
  std::string Path;
  bool HasValues = false;
  csgv::InputVolume Volume;

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
  return IsNIfTIFile(fileName) && !IsImageHeader(fileName) ? 1 : 0;
}

int vtkCSGVNIfTIReader::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkInternals& in = *this->Internals;
  in.HasValues = false;
  in.Volume = csgv::InputVolume{};
  in.Path.clear();
  if (!this->FileName || !*this->FileName)
  {
    vtkErrorMacro(<< "no FileName set");
    return 0;
  }
  in.Intensity = nullptr;
  csgv::Result<csgv::InputVolume> vol = csgv::readNifti(this->FileName);
  if (!vol && vtkInternals::NotALabelVolume(vol.message()) && in.OpenIntensity(this->FileName))
  {
    if (!this->ExpectsImages)
    {
      vtkWarningMacro(<< vol.message() << "; not a label volume, so it is read as an intensity "
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
  if (!vol)
  {
    vtkErrorMacro(<< vol.message());
    // Reported once; the pipeline goes on with an empty extent and RequestData leaves an empty
    // output, never the previous file's data.
    const int empty[6] = { 0, -1, 0, -1, 0, -1 };
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), empty, 6);
    return 1;
  }
  in.Volume = std::move(*vol);
  in.Path = this->FileName;
  in.HasValues = true;
  const csgv::InputVolume& v = in.Volume;
  // One point more than voxels per axis: voxels are the cells between them.
  int extent[6] = { 0, int(v.dim[0]), 0, int(v.dim[1]), 0, int(v.dim[2]) };
  const csgv::Geometry corner = csgv::cellGeometryFromPointGeometry(v.geometry);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  outInfo->Set(vtkDataObject::SPACING(), corner.spacing.data(), 3);
  outInfo->Set(vtkDataObject::ORIGIN(), corner.origin.data(), 3);
  outInfo->Set(vtkDataObject::DIRECTION(), corner.direction.data(), 9);
  return 1;
}

namespace
{
template <class T>
void convertValues(const csgv::InputVolume& v, T* out)
{
  const size_t n = v.values.size();
  const bool isFloat = v.type == csgv::LabelType::F32 || v.type == csgv::LabelType::F64;
  for (size_t i = 0; i < n; ++i)
  {
    // Signed and float inputs hold int64 bits; unsigned ones their value.
    out[i] = (isFloat || csgv::isSignedType(v.type)) ? static_cast<T>(static_cast<int64_t>(v.values[i]))
                                                      : static_cast<T>(v.values[i]);
  }
}
} // namespace

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
  if (!in.HasValues && in.Path != this->FileName)
  {
    return 1; // RequestInformation reported why; the output stays empty
  }
  if (!in.HasValues)
  {
    csgv::Result<csgv::InputVolume> vol = csgv::readNifti(this->FileName);
    if (!vol)
    {
      vtkErrorMacro(<< vol.message());
      return 0;
    }
    in.Volume = std::move(*vol);
    in.Path = this->FileName;
  }
  this->UpdateProgress(0.5);
  const csgv::InputVolume& v = in.Volume;
  // The whole volume: the file is read whole anyway.
  output->SetExtent(0, int(v.dim[0]), 0, int(v.dim[1]), 0, int(v.dim[2]));
  csgvvtk::applyGeometry(output, csgv::cellGeometryFromPointGeometry(v.geometry), 0);
  const int type = csgvvtk::vtkTypeOfName(csgv::labelTypeName(v.type));
  vtkSmartPointer<vtkDataArray> arr = vtk::TakeSmartPointer(vtkDataArray::CreateDataArray(type));
  arr->SetName(csgvvtk::kLabelsName);
  arr->SetNumberOfTuples(static_cast<vtkIdType>(v.values.size()));
  switch (type)
  {
    vtkTemplateMacro(convertValues(v, static_cast<VTK_TT*>(arr->GetVoidPointer(0))));
  }
  output->GetCellData()->SetScalars(arr);
  // Release the 8-byte-per-voxel copy: the output now holds the labels.
  in.Volume = csgv::InputVolume{};
  in.HasValues = false;
  this->UpdateProgress(1.0);
  return 1;
}

void vtkCSGVNIfTIReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
}
