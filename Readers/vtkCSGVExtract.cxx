// SPDX-License-Identifier: MIT
#include "vtkCSGVExtract.h"

#include "CSGVHeldValue.h"

#include "CSGVAdapter.h"
#include "vtkCSGVReader.h"

#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkExecutive.h>
#include <vtkInformationExecutivePortKey.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationDoubleVectorKey.h>
#include <vtkInformationIntegerKey.h>
#include <vtkInformationIntegerVectorKey.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>

vtkStandardNewMacro(vtkCSGVExtract);
csgvHeldSetter(vtkCSGVExtract, Level, int, 0, 7)

class vtkCSGVExtract::vtkInternals
{
public:
  csgvvtk::EncodingMemo Encoding;
};

vtkCSGVExtract::vtkCSGVExtract()
  : Internals(new vtkInternals)
{
}

vtkCSGVExtract::~vtkCSGVExtract()
{
  delete this->Internals;
}

int vtkCSGVExtract::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

namespace
{
/// The reader's output information behind `inInfo`: ParaView puts a vtkPVPostFilter (array
/// conversions) after every source, which does not pass the reader's own keys on; look through
/// it (and only it: any other filter between may have changed the volume).
vtkInformation* readerInformation(vtkInformation* inInfo)
{
  vtkInformation* info = inInfo;
  for (int depth = 0; info && depth < 4; ++depth)
  {
    if (info->Has(vtkCSGVReader::CSGV_DIMENSIONS()) && info->Has(vtkCSGVReader::CSGV_LEVELS()) &&
      info->Has(vtkCSGVReader::CSGV_GEOMETRY()))
    {
      return info;
    }
    vtkExecutive* producer = vtkExecutive::PRODUCER()->GetExecutive(info);
    vtkAlgorithm* algorithm = producer ? producer->GetAlgorithm() : nullptr;
    if (!algorithm || !algorithm->IsA("vtkPVPostFilter") || algorithm->GetNumberOfInputPorts() < 1 ||
      algorithm->GetNumberOfInputConnections(0) < 1)
    {
      return nullptr;
    }
    info = algorithm->GetInputInformation(0, 0);
  }
  return nullptr;
}
} // namespace

bool vtkCSGVExtract::InputVolumeInfo(vtkInformation* inInfo, int dims[3], int& levels, double geometry[15])
{
  if (vtkInformation* info = readerInformation(inInfo))
  {
    info->Get(vtkCSGVReader::CSGV_DIMENSIONS(), dims);
    levels = info->Get(vtkCSGVReader::CSGV_LEVELS());
    info->Get(vtkCSGVReader::CSGV_GEOMETRY(), geometry);
    return true;
  }
  // Not straight from the reader: use the encoding of data that already exists upstream.
  vtkImageData* input = vtkImageData::SafeDownCast(inInfo->Get(vtkDataObject::DATA_OBJECT()));
  std::string error;
  std::shared_ptr<const csgvvtk::EncodedInput> parsed =
    input ? this->Internals->Encoding.get(input->GetFieldData(), error) : nullptr;
  if (!parsed)
  {
    return false;
  }
  const csgvvtk::EncodedInput& enc = *parsed;
  for (int a = 0; a < 3; ++a)
  {
    dims[a] = int(enc.volume.dim[a]);
    geometry[a] = enc.geometry.spacing[a];
    geometry[3 + a] = enc.geometry.origin[a];
  }
  std::copy(enc.geometry.direction.begin(), enc.geometry.direction.end(), geometry + 6);
  levels = int(enc.volume.levels());
  return true;
}

void vtkCSGVExtract::LevelBox(const int dims[3], int lod, int box[6]) const
{
  for (int a = 0; a < 3; ++a)
  {
    const int lo = std::min(std::max(this->VOI[2 * a], 0), dims[a] - 1);
    const int hi = std::min(std::max(this->VOI[2 * a + 1], lo), dims[a] - 1);
    box[2 * a] = lo >> lod;
    box[2 * a + 1] = (hi >> lod) + 1;
  }
}

int vtkCSGVExtract::RequestInformation(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  int dims[3], levels = 0;
  double geometry[15];
  if (!this->InputVolumeInfo(inInfo, dims, levels, geometry) || levels < 1)
  {
    vtkErrorMacro(<< "the input carries no CSGV volume (apply CSGV Extract to the CSGV reader's output)");
    const int empty[6] = { 0, -1, 0, -1, 0, -1 };
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), empty, 6);
    return 1; // reported once; RequestData leaves an empty output
  }
  const int lod = std::min(this->Level, levels - 1);
  int box[6];
  this->LevelBox(dims, lod, box);
  const double scale = double(1 << lod);
  const double spacing[3] = { geometry[0] * scale, geometry[1] * scale, geometry[2] * scale };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), box, 6);
  outInfo->Set(vtkDataObject::SPACING(), spacing, 3);
  outInfo->Set(vtkDataObject::ORIGIN(), geometry + 3, 3);
  outInfo->Set(vtkDataObject::DIRECTION(), geometry + 6, 9);
  outInfo->Set(vtkAlgorithm::CAN_PRODUCE_SUB_EXTENT(), 1);
  return 1;
}

int vtkCSGVExtract::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  csgvvtk::requestWholeVolume(outputVector->GetInformationObject(0), inputVector[0]->GetInformationObject(0));
  return 1;
}

int vtkCSGVExtract::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0], 0);
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkImageData* output = vtkImageData::GetData(outInfo);
  if (!input || !output)
  {
    return 0;
  }
  output->Initialize();
  int ext[6];
  outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext);
  if (ext[1] < ext[0] || ext[3] < ext[2] || ext[5] < ext[4])
  {
    return 1; // RequestInformation reported why there is nothing to extract
  }
  std::string error;
  std::shared_ptr<const csgvvtk::EncodedInput> parsed =
    this->Internals->Encoding.get(input->GetFieldData(), error);
  if (!parsed)
  {
    vtkErrorMacro(<< error);
    return 1; // reported once; the output stays empty
  }
  const csgvvtk::EncodedInput& enc = *parsed;
  const int dims[3] = { int(enc.volume.dim[0]), int(enc.volume.dim[1]), int(enc.volume.dim[2]) };
  const int lod = std::min<int>(this->Level, int(enc.volume.levels()) - 1);
  int box[6];
  this->LevelBox(dims, lod, box);
  output->SetExtent(ext);
  csgvvtk::applyGeometry(output, enc.geometry, uint32_t(lod));
  output->GetFieldData()->ShallowCopy(input->GetFieldData());

  // Cells [ext[2a], ext[2a+1]) of the level image, inside the VOI's box.
  csgv::Box cells;
  for (int a = 0; a < 3; ++a)
  {
    const int lo = std::max(ext[2 * a], box[2 * a]);
    const int hi = std::min(ext[2 * a + 1], box[2 * a + 1]);
    if (hi <= lo || lo != ext[2 * a] || hi != ext[2 * a + 1])
    {
      if (hi <= lo)
      {
        return 1; // a piece without cells
      }
      vtkErrorMacro(<< "the requested extent leaves the VOI");
      return 0;
    }
    cells.min[a] = uint32_t(lo);
    cells.max[a] = uint32_t(hi);
  }
  csgvvtk::DecodedLabels decoded;
  const std::string decodeError = csgvvtk::decodeBox(
    enc.volume, uint32_t(lod), cells, enc.info, [this](double f) { this->UpdateProgress(f); }, decoded);
  if (!decodeError.empty())
  {
    vtkErrorMacro(<< decodeError);
    output->Initialize();
    return 1; // reported once; the output stays empty
  }
  if (!decoded.warning.empty())
  {
    vtkWarningMacro(<< decoded.warning);
  }
  output->GetCellData()->SetScalars(decoded.array);
  return 1;
}

void vtkCSGVExtract::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "VOI: " << this->VOI[0] << " " << this->VOI[1] << " " << this->VOI[2] << " "
     << this->VOI[3] << " " << this->VOI[4] << " " << this->VOI[5] << "\n";
  os << indent << "Level: " << this->Level << "\n";
}
