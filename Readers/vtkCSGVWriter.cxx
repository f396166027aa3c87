// SPDX-License-Identifier: MIT
#include "vtkCSGVWriter.h"

#include "CSGVHeldValue.h"

#include "CSGVAdapter.h"
#include "CSGVMpiAgreement.h"

#include "csgv/base/FileUtil.h"
#include "csgv/codec/Encoder.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Compress.h"
#include "csgv/inputs/Relabel.h"

#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMultiProcessController.h>
#include <vtkMultiProcessStream.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>
#include <cstdio>
#include <cstring>

vtkStandardNewMacro(vtkCSGVWriter);
csgvHeldSetter(vtkCSGVWriter, NumberOfThreads, int, 0, 1024)
csgvHeldSetter(vtkCSGVWriter, NumberOfPieces, int, 1, VTK_INT_MAX)
csgvHeldSetter(vtkCSGVWriter, Piece, int, 0, VTK_INT_MAX)

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

namespace
{

using csgvvtk::kOtherFailed;
using csgvvtk::MpiAgreement;

/// The settings as Core's options, or an error message (the same on every process).
std::string checkSettings(const char* fileName, int brickSize, int encoding, const char* operations,
  int threads, csgv::EncodeOptions& options)
{
  const std::string path = fileName ? fileName : "";
  if (path.size() < 6 || path.compare(path.size() - 5, 5, ".csgv") != 0)
  {
    return "the file name '" + path + "' must end in .csgv";
  }
  options.brickSize = uint32_t(brickSize);
  options.encoding = encoding;
  options.threads = threads;
  csgv::Result<uint32_t> mask = csgv::parseOperationMask(operations ? operations : "default");
  if (!mask)
  {
    return mask.message();
  }
  options.opMask = *mask;
  csgv::Status status = csgv::checkEncodeOptions(options);
  return status ? std::string() : status.message();
}

std::string missingArrayMessage(const char* name)
{
  if (name && *name)
  {
    const std::string n = name;
    return "the input has no array named '" + n.substr(0, 200) + (n.size() > 200 ? "...'" : "'");
  }
  return "the input has no one-component integer or float array to write";
}

/// Bytes move between processes in messages of at most this many.
constexpr vtkIdType kMessageBytes = vtkIdType(1) << 28;
constexpr int kPieceTag = 41731;

/// vtkCSGVWriter::WriteData with NumberOfPieces > 1: every process runs it together.
void writePieces(vtkCSGVWriter* self, csgv::EncodeOptions options)
{
  vtkMultiProcessController* c = vtkMultiProcessController::GetGlobalController();
  const int n = self->GetNumberOfPieces();
  if (!c || c->GetNumberOfProcesses() != n || c->GetLocalProcessId() != self->GetPiece())
  {
    // Nothing collective can run safely: every process reports this alone.
    vtkErrorWithObjectMacro(self, << "writing in " << n << " pieces needs as many MPI processes, this one "
                  << "writing piece " << self->GetPiece() << "; there are "
                  << (c ? c->GetNumberOfProcesses() : 1) << " (process "
                  << (c ? c->GetLocalProcessId() : 0) << ")");
    return;
  }
  const int rank = self->GetPiece();
  const std::string path = self->GetFileName() ? self->GetFileName() : "";
  vtkImageData* image = self->GetInput();

  std::string error;

  // The first process whose piece holds the array chooses it (a process whose piece holds no
  // voxels, with fewer bricks than processes, may get an image without arrays: attack pass 8,
  // every process failed when it was process 0); every process then takes it from its own piece.
  vtkMultiProcessStream candidate;
  csgv::LabelType labelType = csgv::LabelType::U32; // the chooser's, for the attribute database
  std::string originalType;
  {
    bool isCell = true;
    vtkDataArray* array = image
      ? csgvvtk::findLabelArray(image, self->GetLabelArrayName() ? self->GetLabelArrayName() : "", isCell)
      : nullptr;
    std::string name, typeName;
    csgv::LabelType t = csgv::LabelType::U32;
    if (!image)
    {
      error = "the input is not image data";
    }
    else if (!array)
    {
      error = missingArrayMessage(self->GetLabelArrayName());
    }
    else
    {
      name = array->GetName() ? array->GetName() : "";
      const char* n = csgvvtk::labelTypeNameOf(array->GetDataType(), t);
      typeName = n ? n : "";
    }
    candidate << error << name << int(isCell) << typeName << int(t);
  }
  std::vector<vtkMultiProcessStream> candidates;
  c->Gather(candidate, candidates, 0);
  vtkMultiProcessStream choice;
  if (rank == 0)
  {
    std::string firstError;
    bool chosen = false;
    for (vtkMultiProcessStream& s : candidates)
    {
      std::string e, name, typeName;
      int cell = 1, type = 0;
      s >> e >> name >> cell >> typeName >> type;
      if (e.empty() && !chosen)
      {
        choice << e << name << cell << typeName << type;
        chosen = true;
      }
      firstError = firstError.empty() ? e : firstError;
    }
    if (!chosen)
    {
      choice << firstError << std::string() << 1 << std::string() << int(csgv::LabelType::U32);
    }
  }
  c->Broadcast(choice, 0);
  std::string arrayName;
  int cellData = 1;
  int chosenType = int(csgv::LabelType::U32);
  choice >> error >> arrayName >> cellData >> originalType >> chosenType;
  labelType = csgv::LabelType(chosenType);
  if (!error.empty())
  {
    vtkErrorWithObjectMacro(self, << error);
    return;
  }
  const bool isCell = cellData != 0;
  int whole[6];
  self->GetInputInformation(0, 0)->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  const std::array<uint32_t, 3> dims = csgvvtk::voxelDims(whole, isCell);
  std::array<uint32_t, 3> lo{}, hi{};
  const bool mine = csgvvtk::pieceVoxels(dims, self->GetBrickSize(), n, rank, lo, hi);

  // Every process relabels when one must, with ids of the whole volume; pass 1 over this piece,
  // counts summed over all pieces, pass 2 with the common tables.
  csgvvtk::EncodedArray encoded;
  MpiAgreement agreement(c, uint32_t(self->GetBrickSize()), true);
  agreement.offset = lo;
  agreement.volumeDims = dims;
  options.shareCounts = [&](const csgv::SymbolCounts& counts) {
    return agreement.counts(true, counts);
  };
  if (mine)
  {
    vtkDataArray* array = image
      ? (isCell ? static_cast<vtkDataSetAttributes*>(image->GetCellData()) : image->GetPointData())
          ->GetArray(arrayName.c_str())
      : nullptr;
    vtkSmartPointer<vtkDataArray> piece;
    if (!array)
    {
      error = "this process's piece has no array '" + arrayName + "'";
    }
    else
    {
      error = csgvvtk::cropVoxels(array, image->GetExtent(), whole, isCell, lo, hi, piece);
    }
    if (error.empty())
    {
      const std::array<uint32_t, 3> size = { hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2] };
      error = csgvvtk::encodeLabelArray(piece, size, options, self->GetRelabel() != 0,
        [self](double f) { self->UpdateProgress(0.05 + 0.8 * f); }, encoded, &agreement);
    }
  }
  agreement.catchUp(error.empty());

  // Process 0 gathers every piece (its words as a container of their own) and writes the file.
  std::vector<uint8_t> bytes;
  if (error.empty() && mine)
  {
    bytes = csgv::serializeCsgv(encoded.volume);
    encoded.volume = csgv::CompressedVolume{};
  }
  vtkMultiProcessStream head;
  head << error << static_cast<unsigned long long>(bytes.size());
  std::vector<vtkMultiProcessStream> heads;
  c->Gather(head, heads, 0);
  if (rank != 0 && !bytes.empty())
  {
    for (size_t at = 0; at < bytes.size(); at += size_t(kMessageBytes))
    {
      c->Send(bytes.data() + at, std::min<vtkIdType>(kMessageBytes, vtkIdType(bytes.size() - at)), 0,
        kPieceTag);
    }
  }
  std::string outcome;
  if (rank == 0)
  {
    std::vector<csgv::BrickBox> boxes(static_cast<size_t>(n));
    std::vector<csgv::CompressedVolume> pieces(static_cast<size_t>(n));
    self->UpdateProgress(0.85);
    for (int r = 0; r < n; ++r)
    {
      std::string theirError;
      unsigned long long size = 0;
      heads[size_t(r)] >> theirError >> size;
      std::vector<uint8_t> theirs;
      if (r == 0)
      {
        theirs.swap(bytes);
      }
      else if (size > 0)
      {
        theirs.resize(size_t(size));
        for (size_t at = 0; at < theirs.size(); at += size_t(kMessageBytes))
        {
          c->Receive(theirs.data() + at,
            std::min<vtkIdType>(kMessageBytes, vtkIdType(theirs.size() - at)), r, kPieceTag);
        }
      }
      // The first process that names a cause; the others only know that one failed.
      if (theirError == kOtherFailed)
      {
        outcome = outcome.empty() ? theirError : outcome;
      }
      else if (!theirError.empty() && (outcome.empty() || outcome == kOtherFailed))
      {
        outcome = "process " + std::to_string(r) + ": " + theirError;
      }
      std::array<uint32_t, 3> plo{}, phi{};
      if (!csgvvtk::pieceVoxels(dims, self->GetBrickSize(), n, r, plo, phi) || !outcome.empty())
      {
        continue;
      }
      const uint32_t b = uint32_t(self->GetBrickSize());
      for (int a = 0; a < 3; ++a)
      {
        boxes[size_t(r)].lo[a] = plo[a] / b;
        boxes[size_t(r)].hi[a] = (phi[a] + b - 1) / b;
      }
      csgv::Result<csgv::CompressedVolume> parsed = csgv::parseCsgv(theirs.data(), theirs.size());
      if (!parsed)
      {
        outcome = "the piece of process " + std::to_string(r) + " is not valid: " + parsed.message();
        continue;
      }
      pieces[size_t(r)] = std::move(*parsed);
    }
    if (outcome.empty())
    {
      csgv::Result<csgv::CompressedVolume> joined =
        csgv::joinPieces(dims, boxes, pieces, options.maxArrayWords, uint64_t(64) << 30);
      csgv::Status status = joined.status();
      if (status)
      {
        self->UpdateProgress(0.9);
        // Geometry of the whole image (this process holds a piece of it).
        vtkNew<vtkImageData> wholeImage;
        wholeImage->SetExtent(whole);
        wholeImage->SetOrigin(image->GetOrigin());
        wholeImage->SetSpacing(image->GetSpacing());
        wholeImage->SetDirectionMatrix(image->GetDirectionMatrix());
        std::array<uint32_t, 3> geometryDims;
        csgv::VolumeMetadata md;
        md.dim = dims;
        md.geometry = csgvvtk::imageGeometry(wholeImage, isCell, geometryDims);
        md.originalType = originalType;
        md.relabelled = agreement.Relabelled;
        md.source = "ParaView array '" + arrayName + "' (" + (isCell ? "cell" : "point") + " data)";
        csgv::LabelMapping mapping;
        mapping.relabelled = agreement.Relabelled;
        mapping.type = labelType;
        mapping.originalBits = std::move(agreement.Table);
        status = csgv::writeVolumeFiles(path, *joined, md, mapping);
      }
      if (!status)
      {
        outcome = status.message();
      }
    }
    else
    {
      outcome = path + ": " + outcome;
    }
  }
  vtkMultiProcessStream result;
  result << outcome;
  c->Broadcast(result, 0);
  result >> outcome;
  if (!outcome.empty())
  {
    vtkErrorWithObjectMacro(self, << outcome);
    return;
  }
  self->UpdateProgress(1.0);
}

} // namespace

vtkTypeBool vtkCSGVWriter::ProcessRequest(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  const vtkTypeBool result = this->Superclass::ProcessRequest(request, inputVector, outputVector);
  if (this->NumberOfPieces <= 1 ||
    !request->Has(vtkStreamingDemandDrivenPipeline::REQUEST_UPDATE_EXTENT()) ||
    inputVector[0]->GetNumberOfInformationObjects() < 1)
  {
    return result;
  }
  vtkInformation* in = inputVector[0]->GetInformationObject(0);
  if (!in->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    return result;
  }
  // The label array may be cell or point data (it is found in WriteData): ask for the voxels
  // of this piece either way.
  int whole[6], ext[6];
  in->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  csgvvtk::brickPieceExtent(whole, this->BrickSize, this->NumberOfPieces, this->Piece, ext);
  in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext, 6);
  in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER(), 0);
  in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES(), 1);
  in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_GHOST_LEVELS(), 0);
  in->Set(vtkStreamingDemandDrivenPipeline::EXACT_EXTENT(), 1);
  return result;
}

void vtkCSGVWriter::WriteData()
{
  csgv::removeTemporariesOnSignals(); // Ctrl-C in pvbatch or the GUI leaves no temporaries
  // Settings are the same on every process: they fail everywhere or nowhere.
  csgv::EncodeOptions options;
  std::string error = checkSettings(this->FileName, this->BrickSize, this->Encoding,
    this->Operations, this->NumberOfThreads, options);
  if (!error.empty())
  {
    vtkErrorMacro(<< error);
    return;
  }
  if (this->NumberOfPieces > 1)
  {
    writePieces(this, options);
    return;
  }
  vtkImageData* image = this->GetInput();
  const std::string path = this->FileName ? this->FileName : "";
  if (!image)
  {
    vtkErrorMacro(<< "the input is not image data");
    return;
  }
  bool isCell = true;
  vtkDataArray* array =
    csgvvtk::findLabelArray(image, this->LabelArrayName ? this->LabelArrayName : "", isCell);
  if (!array)
  {
    vtkErrorMacro(<< missingArrayMessage(this->LabelArrayName));
    return;
  }
  const std::string arrayName = array->GetName() ? array->GetName() : "(unnamed)";

  // Voxel grid and where its voxel (0,0,0) lies.
  std::array<uint32_t, 3> dim;
  const csgv::Geometry geometry = csgvvtk::imageGeometry(image, isCell, dim);

  this->UpdateProgress(0.0);
  csgvvtk::EncodedArray encoded;
  error = csgvvtk::encodeLabelArray(array, dim, options, this->Relabel != 0,
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
  this->UpdateProgress(0.9);

  csgv::VolumeMetadata md;
  md.dim = dim;
  md.geometry = geometry;
  md.originalType = encoded.originalType;
  md.relabelled = encoded.mapping.relabelled;
  md.source = "ParaView array '" + arrayName + "' (" + (isCell ? "cell" : "point") + " data)";
  const csgv::Status status = csgv::writeVolumeFiles(path, encoded.volume, md, encoded.mapping);
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
