// SPDX-License-Identifier: MIT
#include "vtkCSGVWriter.h"

#include "CSGVAdapter.h"

#include "csgv/attributes/AttributeDb.h"
#include "csgv/codec/Encoder.h"
#include "csgv/base/FileUtil.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Relabel.h"

#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkObjectFactory.h>

#include <cstdio>

vtkStandardNewMacro(vtkCSGVWriter);

vtkCSGVWriter::vtkCSGVWriter()
{
  this->SetOperations("default");
}

vtkCSGVWriter::~vtkCSGVWriter()
{
  this->SetFileName(nullptr);
  this->SetLabelArrayName(nullptr);
  this->SetOperations(nullptr);
}

vtkImageData* vtkCSGVWriter::GetInput()
{
  return vtkImageData::SafeDownCast(this->Superclass::GetInput());
}

int vtkCSGVWriter::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

void vtkCSGVWriter::WriteData()
{
  vtkImageData* image = this->GetInput();
  const std::string path = this->FileName ? this->FileName : "";
  if (!image)
  {
    vtkErrorMacro(<< "the input is not image data");
    return;
  }
  if (path.size() < 6 || path.compare(path.size() - 5, 5, ".csgv") != 0)
  {
    vtkErrorMacro(<< "the file name '" << path << "' must end in .csgv");
    return;
  }
  bool isCell = true;
  vtkDataArray* array =
    csgvvtk::findLabelArray(image, this->LabelArrayName ? this->LabelArrayName : "", isCell);
  if (!array)
  {
    if (this->LabelArrayName && *this->LabelArrayName)
    {
      vtkErrorMacro(<< "the input has no array named '" << this->LabelArrayName << "'");
    }
    else
    {
      vtkErrorMacro(<< "the input has no one-component integer or float array to write");
    }
    return;
  }
  const std::string arrayName = array->GetName() ? array->GetName() : "(unnamed)";

  // Voxel grid and where its voxel (0,0,0) lies.
  std::array<uint32_t, 3> dim;
  const csgv::Geometry geometry = csgvvtk::imageGeometry(image, isCell, dim);

  csgv::EncodeOptions options;
  options.brickSize = uint32_t(this->BrickSize);
  options.encoding = this->Encoding;
  options.threads = this->NumberOfThreads;
  csgv::Result<uint32_t> mask = csgv::parseOperationMask(this->Operations ? this->Operations : "default");
  if (!mask)
  {
    vtkErrorMacro(<< mask.message());
    return;
  }
  options.opMask = *mask;
  csgv::Status status = csgv::checkEncodeOptions(options);
  if (!status)
  {
    vtkErrorMacro(<< status.message());
    return;
  }

  this->UpdateProgress(0.0);
  csgvvtk::EncodedArray encoded;
  const std::string error = csgvvtk::encodeLabelArray(array, dim, options, this->Relabel != 0,
    [this](double f) { this->UpdateProgress(0.05 + 0.8 * f); }, encoded);
  if (!error.empty())
  {
    if (error.compare(0, 7, "array '") == 0)
    {
      // The array's type or size: nothing was written yet, the file name adds nothing.
      vtkErrorMacro(<< error);
    }
    else
    {
      vtkErrorMacro(<< path << ": " << error);
    }
    return;
  }
  const csgv::LabelMapping& mapping = encoded.mapping;
  this->UpdateProgress(0.9);

  csgv::VolumeMetadata md;
  md.dim = dim;
  md.geometry = geometry;
  md.originalType = encoded.originalType;
  md.relabelled = mapping.relabelled;
  md.source = "ParaView array '" + arrayName + "' (" + (isCell ? "cell" : "point") + " data)";
  // Sidecars first, the volume last, as Core's compress does.
  const std::string db = csgv::attributeDbPathFor(path);
  if (mapping.relabelled)
  {
    status = csgv::writeAttributeDb(db, dim, mapping.originalBits, csgv::isSignedType(mapping.type));
  }
  else if (csgv::fileExists(db) && std::remove(db.c_str()) != 0)
  {
    status = csgv::Status::error("cannot remove the stale attribute database '" + db + "'");
  }
  if (status)
  {
    status = csgv::writeMetadata(csgv::metadataPathFor(path), md);
  }
  if (status)
  {
    status = csgv::writeCsgv(path, encoded.volume);
  }
  if (!status)
  {
    vtkErrorMacro(<< status.message());
    return;
  }
  this->UpdateProgress(1.0);
}

void vtkCSGVWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
  os << indent << "LabelArrayName: " << (this->LabelArrayName ? this->LabelArrayName : "(first)") << "\n";
  os << indent << "BrickSize: " << this->BrickSize << "\n";
  os << indent << "Encoding: " << this->Encoding << "\n";
  os << indent << "Operations: " << (this->Operations ? this->Operations : "(none)") << "\n";
  os << indent << "Relabel: " << this->Relabel << "\n";
  os << indent << "NumberOfThreads: " << this->NumberOfThreads << "\n";
}
