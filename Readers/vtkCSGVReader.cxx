// SPDX-License-Identifier: MIT
#include "vtkCSGVReader.h"

#include "CSGVHeldValue.h"

#include "CSGVAdapter.h"
#include "CSGVFileSeries.h"

#include "csgv/base/MappedFile.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Partition.h"
#include "csgv/codec/Encoder.h"
#include "csgv/base/FileUtil.h"
#include "csgv/codec/LabelVolume.h"
#include "csgv/inputs/Relabel.h"

#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationDoubleVectorKey.h>
#include <vtkInformationIntegerKey.h>
#include <vtkInformationIntegerVectorKey.h>
#include <vtkInformationVector.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <functional>
#include <cctype>
#include <cstring>
#include <fstream>
#include <sys/stat.h>

vtkStandardNewMacro(vtkCSGVReader);
csgvHeldSetter(vtkCSGVReader, DecodeThreshold, vtkIdType, 0, VTK_ID_MAX)
csgvHeldSetter(vtkCSGVReader, Level, int, 0, 7)
vtkInformationKeyRestrictedMacro(vtkCSGVReader, CSGV_DIMENSIONS, IntegerVector, 3);
vtkInformationKeyMacro(vtkCSGVReader, CSGV_LEVELS, Integer);
vtkInformationKeyRestrictedMacro(vtkCSGVReader, CSGV_GEOMETRY, DoubleVector, 15);

namespace
{
bool isVrawName(const std::string& path)
{
  return csgv::endsWithNoCase(path, ".vraw") || csgv::endsWithNoCase(path, ".vraw.gz");
}

/// The level of detail `level` asks for, within a file of `levels` levels.
uint32_t levelWithin(int level, uint32_t levels)
{
  return std::min<uint32_t>(static_cast<uint32_t>(std::max(level, 0)), levels > 0 ? levels - 1 : 0);
}
} // namespace

/// @brief What a file yields before any decoding, cached while the file is unchanged so that
/// changing Level or DecodeLabels never reads the file again. RequestInformation reads a `.csgv`
/// file's header, brick starts and sidecars only; RequestData reads the whole encoding for one
/// piece, or only its own bricks when the pipeline asks for one of several pieces (MPI ranks).
class vtkCSGVReader::vtkInternals
{
public:
  csgvvtk::FileSeries FileNames; ///< as set (AddFileName)
  csgvvtk::StepShapes Shapes;    ///< of a series' files, for the extent of every step
  /// What the last RequestInformation chose (FileName alone, or FileNames) and the time step
  /// whose file is described.
  std::vector<std::string> Inputs;
  int Step = 0;

  std::string Path;
  int64_t MTime = -1;
  int64_t Size = -1;
  bool Loaded = false;
  bool Vraw = false; ///< a `.vraw` input, compressed in memory when loaded (always whole)

  // Described by the header and the sidecars.
  csgvvtk::LabelInfo Info;
  csgv::Geometry Geometry; ///< corner origin, level 0
  std::array<uint32_t, 3> Dim{ { 0, 0, 0 } };
  std::array<uint32_t, 3> Grid{ { 0, 0, 0 } }; ///< bricks along each axis
  uint32_t BrickSize = 0;
  uint32_t Levels = 0;
  std::vector<csgv::AttributeColumn> Attributes; ///< columns of `_csgv.db3`, indexed by id

  // The whole volume (one piece), read when first asked for.
  bool WholeRead = false;
  /// Why parsing the whole encoding failed (a damaged file): said once, not read again at every
  /// execution the pipeline asks for (a new file or a changed one clears it with the rest).
  /// Failures to map or read the file (which may pass) and pieces are tried again each time.
  std::string ReadFailure;
  std::string LoadFailure; ///< why the last Load failed ("" when it did not): marks the empty output
  vtkSmartPointer<vtkUnsignedCharArray> Encoding; ///< the container bytes (FieldData)
  csgv::CompressedVolume Volume; ///< the same, parsed once (RequestData decodes it)
  vtkSmartPointer<vtkDataArray> Range;

  // One piece of several: its bricks only, as a volume of their own.
  int PieceCount = 0, PieceNumber = -1;
  csgv::BrickBox Box;
  vtkSmartPointer<vtkUnsignedCharArray> PieceEncoding;
  csgv::CompressedVolume PieceVolume;
  vtkSmartPointer<vtkDataArray> PieceRange;
  csgv::Geometry PieceGeometry; ///< the piece's corner (the volume's geometry, shifted)

  /// Describes the file (when it changed since the last call); returns an error message or "".
  std::string Load(const std::string& path)
  {
    struct stat st;
    if (::stat(path.c_str(), &st) != 0)
    {
      this->Loaded = false;
      return "cannot open '" + path + "': " + std::strerror(errno);
    }
    if (this->Loaded && path == this->Path && int64_t(st.st_mtime) == this->MTime &&
      int64_t(st.st_size) == this->Size)
    {
      return std::string();
    }
    this->Loaded = false;
    this->WholeRead = false;
    this->ReadFailure.clear();
    this->Encoding = nullptr;
    this->Volume = csgv::CompressedVolume{};
    this->Range = nullptr;
    this->ForgetPiece();
    this->Attributes.clear();
    this->Info = csgvvtk::LabelInfo{};
    this->Geometry = csgv::Geometry{};
    this->Vraw = isVrawName(path);
    this->Path = path;
    const std::string error = this->Vraw ? this->LoadVraw(path) : this->LoadHeader(path);
    if (!error.empty())
    {
      this->Encoding = nullptr;
      return error;
    }
    this->MTime = int64_t(st.st_mtime);
    this->Size = int64_t(st.st_size);
    this->Loaded = true;
    return std::string();
  }

  /// The whole encoding (one piece); an error message or "". `progress(f)` returns false to
  /// cancel (the palette sweep reads a file larger than memory from disk).
  std::string ReadWhole(const std::function<bool(double)>& progress)
  {
    if (this->WholeRead)
    {
      return std::string();
    }
    // The file's bytes, mapped read-only (csgv::MappedFile: guarded against the file being cut
    // short under the mapping; read where mapping is impossible), are the encoding handed
    // downstream (no re-serialisation, no private copy); parseCsgv checks and parses those same
    // bytes (the sidecars were read with the header: Load), and so does every later parse of the
    // FieldData array in this process (the representation's): one copy of the encoding, the
    // page cache's.
    const std::string& path = this->Path;
    csgv::MappedFile::Options mapping;
    mapping.copyOnWrite = true; // a VTK array: a user's script may write to it (its copy, never the file)
    csgv::Result<std::shared_ptr<const csgv::MappedFile>> file = csgv::MappedFile::open(path, mapping);
    if (!file)
    {
      return file.message();
    }
    if (uint64_t((*file)->size()) != uint64_t(this->Size))
    {
      return "'" + path + "' changed while it was read";
    }
    vtkSmartPointer<vtkUnsignedCharArray> enc = csgvvtk::mappedEncodingArray(*file);
    if (!enc)
    {
      return "cannot read '" + path + "'";
    }
    csgv::Result<csgv::CompressedVolume> volume = csgv::parseCsgvShared(
      enc->GetPointer(0), size_t(enc->GetNumberOfValues()), csgvvtk::keepArray(enc));
    if (!volume)
    {
      this->ReadFailure = csgv::Status(volume.status()).prefix(path).message();
      return this->ReadFailure;
    }
    if (volume->dim != this->Dim || volume->brickSize != this->BrickSize)
    {
      return "'" + path + "' changed while it was read";
    }
    // One sweep over the palettes (it gives the pages back behind it: a file larger than memory
    // opens within a window of it): the label range, and the summary that the representation's
    // parse of this array takes instead of sweeping again (csgvvtk::attachPaletteSummary).
    csgv::Result<csgv::PaletteSummary> summary = csgv::summarizePalettes(*volume, csgv::kSummaryLabels, progress);
    if (!summary)
    {
      return "'" + path + "': " + summary.message();
    }
    auto palettes = std::make_shared<const csgv::PaletteSummary>(std::move(*summary));
    this->Range = csgvvtk::paletteRange(*volume, this->Info, *palettes);
    csgvvtk::attachPaletteSummary(enc, palettes);
    this->Volume = std::move(*volume);
    this->Encoding = enc;
    this->WholeRead = true;
    return std::string();
  }

  /// Piece `piece` of `pieces` (csgv::brickPartition of the brick grid: whole bricks); its bricks
  /// only are read. An empty piece (more pieces than bricks) leaves PieceVolume without bricks.
  std::string ReadPiece(int pieces, int piece)
  {
    if (pieces == this->PieceCount && piece == this->PieceNumber)
    {
      return std::string();
    }
    this->ForgetPiece();
    this->Box = csgv::brickPartition(this->Grid, uint32_t(pieces), uint32_t(piece));
    if (!this->Box.empty())
    {
      csgv::Result<csgv::CompressedVolume> part = this->Vraw
        ? csgv::extractPiece(this->Volume, this->Box)
        : csgv::readCsgvPiece(this->Path, this->Box);
      if (!part)
      {
        return part.message();
      }
      // One copy of the piece: its bytes, handed downstream, which the parse views (as the whole
      // volume's parse views the mapped file).
      vtkNew<vtkUnsignedCharArray> enc;
      {
        std::vector<uint8_t> bytes = csgv::serializeCsgv(*part);
        *part = csgv::CompressedVolume{};
        enc->SetNumberOfValues(static_cast<vtkIdType>(bytes.size()));
        std::copy(bytes.begin(), bytes.end(), enc->GetPointer(0));
      }
      csgv::Result<csgv::CompressedVolume> viewed = csgv::parseCsgvShared(
        enc->GetPointer(0), size_t(enc->GetNumberOfValues()), csgvvtk::keepArray(enc));
      if (!viewed)
      {
        return viewed.message();
      }
      this->PieceVolume = std::move(*viewed);
      this->PieceEncoding = enc;
      this->PieceRange = csgvvtk::paletteRange(this->PieceVolume, this->Info);
    }
    // The piece's corner: the volume's geometry at its first voxel.
    this->PieceGeometry = this->Geometry;
    for (int r = 0; r < 3; ++r)
    {
      double w = this->Geometry.origin[r];
      for (int c = 0; c < 3; ++c)
      {
        w += this->Geometry.direction[3 * r + c] * double(this->Box.lo[c]) * this->BrickSize *
          this->Geometry.spacing[c];
      }
      this->PieceGeometry.origin[r] = w;
    }
    this->PieceCount = pieces;
    this->PieceNumber = piece;
    return std::string();
  }

private:
  void ForgetPiece()
  {
    this->PieceCount = 0;
    this->PieceNumber = -1;
    this->Box = csgv::BrickBox{};
    this->PieceEncoding = nullptr;
    this->PieceVolume = csgv::CompressedVolume{};
    this->PieceRange = nullptr;
  }

  /// What the header and sidecars say (no brick is read).
  void Describe(const csgv::CsgvFile& f)
  {
    this->Info.relabelled = f.hasAttributes;
    if (f.hasAttributes)
    {
      this->Attributes = f.attributes.columns;
      this->Info.map = f.attributes.labels;
      this->Info.unsigned64 = f.attributes.labelsUnsigned64;
    }
    if (f.hasMetadata)
    {
      this->Info.originalType = f.metadata.originalType;
    }
    else if (f.wideLabels)
    {
      this->Info.originalType = f.attributes.labelsUnsigned64 ? "uint64" : "int64";
    }
    this->Geometry = f.metadata.geometry;
    this->Dim = f.volume.dim;
    this->Grid = f.volume.brickGrid();
    this->BrickSize = f.volume.brickSize;
    this->Levels = f.volume.levels();
  }

  std::string LoadHeader(const std::string& path)
  {
    csgv::Result<csgv::CsgvFile> file = csgv::openCsgvHeader(path);
    if (!file)
    {
      return file.message();
    }
    this->Describe(*file);
    return std::string();
  }

  std::string LoadVraw(const std::string& path)
  {
    csgv::Result<csgv::LabelVolume> raw = csgv::readVraw(path);
    if (!raw)
    {
      return raw.message();
    }
    csgv::LabelVolume& labels = *raw;
    // 0xFFFFFFFF is reserved by the format: such volumes are relabelled as the codec does.
    if (std::find(labels.labels.begin(), labels.labels.end(), csgv::kInvalidLabel) != labels.labels.end())
    {
      const std::vector<uint64_t> map = csgv::relabelDense(labels, csgv::EncodeOptions{}.brickSize);
      this->Info.relabelled = true;
      this->Info.map.assign(map.begin(), map.end());
    }
    csgv::Result<csgv::CompressedVolume> vol = csgv::encodeVolume(labels, csgv::EncodeOptions{});
    if (!vol)
    {
      return path + ": " + vol.message();
    }
    labels = csgv::LabelVolume{};
    this->Dim = vol->dim;
    this->Grid = vol->brickGrid();
    this->BrickSize = vol->brickSize;
    this->Levels = vol->levels();
    this->Range = csgvvtk::paletteRange(*vol, this->Info);
    const std::vector<uint8_t> bytes = csgv::serializeCsgv(*vol);
    this->Volume = std::move(*vol);
    vtkNew<vtkUnsignedCharArray> enc;
    enc->SetNumberOfValues(static_cast<vtkIdType>(bytes.size()));
    std::copy(bytes.begin(), bytes.end(), enc->GetPointer(0));
    this->Encoding = enc;
    this->WholeRead = true;
    return std::string();
  }
};

vtkCSGVReader::vtkCSGVReader()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(0);
}

vtkCSGVReader::~vtkCSGVReader()
{
  this->SetFileName(nullptr);
  delete this->Internals;
}

int vtkCSGVReader::GetNumberOfLevels()
{
  return this->Internals->Loaded ? static_cast<int>(this->Internals->Levels) : 0;
}

int vtkCSGVReader::CanReadFile(const char* fileName)
{
  if (!fileName)
  {
    return 0;
  }
  const std::string path(fileName);
  if (csgv::existsButNotRegular(path))
  {
    // Only regular files: opening a FIFO here blocks ParaView's File > Open until a writer
    // comes, and a device never ends (ParaView then says no reader takes it).
    return 0;
  }
  if (csgv::endsWithNoCase(path, ".vraw.gz"))
  {
    return 1; // the header is compressed; RequestInformation reports a bad one
  }
  std::ifstream in(path, std::ios::binary);
  if (!in)
  {
    return 0;
  }
  uint8_t head[160];
  in.read(reinterpret_cast<char*>(head), sizeof(head));
  const size_t n = static_cast<size_t>(in.gcount());
  if (csgv::endsWithNoCase(path, ".vraw"))
  {
    return csgv::parseVrawHeader(head, n).isOk() ? 1 : 0;
  }
  return n >= 12 && std::memcmp(head, "CMPSGVOL", 8) == 0 &&
      (std::memcmp(head + 8, "0016", 4) == 0 || std::memcmp(head + 8, "0015", 4) == 0)
    ? 1
    : 0;
}

void vtkCSGVReader::AddFileName(const char* fileName)
{
  this->Internals->FileNames.Add(fileName);
  this->Modified();
}

void vtkCSGVReader::RemoveAllFileNames()
{
  if (this->Internals->FileNames.Clear())
  {
    this->Modified();
  }
}

int vtkCSGVReader::GetNumberOfFileNames()
{
  return this->Internals->FileNames.Count();
}

const char* vtkCSGVReader::GetFileNameAt(int index)
{
  return this->Internals->FileNames.At(index);
}

int vtkCSGVReader::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkInternals& in = *this->Internals;
  csgvvtk::ClearSteps(outInfo);
  std::string error;
  if (!in.FileNames.Choose(this->FileName, in.Inputs, error))
  {
    vtkErrorMacro(<< error);
    in.Loaded = false; // never the previous file's data
    return 0;
  }
  const int steps = static_cast<int>(in.Inputs.size());
  if (steps > 1)
  {
    csgvvtk::AnnounceSteps(outInfo, steps);
  }
  in.Step = csgvvtk::RequestedStep(outInfo, steps);
  this->DescribeFile(outInfo);
  if (steps > 1)
  {
    // Consumers downstream (ParaView's post filter, every representation) keep the whole extent
    // they see here and ask for it again at every step, cropping what a larger step gives to it
    // (found by an attack pass: a later step of 100x80 drawn as the first step's 64x48). They see
    // the extent that holds every step; each step's output has its own (SwitchStep).
    int whole[6];
    outInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
    for (const std::string& path : in.Inputs)
    {
      if (isVrawName(path))
      {
        continue; // read whole to be described: its extent is announced when it is shown
      }
      // The header and brick starts alone (no sidecars: a step's attribute database is read
      // when the step is shown), once per version of the file.
      const auto readHeader = [](const std::string& file, csgvvtk::StepShape& shape) {
        csgv::Result<csgv::CompressedVolume> header = csgv::readCsgvHeader(file);
        if (header)
        {
          shape.Dims = header->dim;
          shape.Levels = header->levels();
        }
        return header.isOk();
      };
      csgvvtk::StepShape shape;
      if (in.Shapes.Get(path, readHeader, shape))
      {
        csgvvtk::HoldStep(whole, shape.Dims, levelWithin(this->Level, shape.Levels));
      }
    }
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole, 6);
  }
  return 1;
}

vtkTypeBool vtkCSGVReader::ProcessRequest(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  if (request->Has(vtkStreamingDemandDrivenPipeline::REQUEST_TIME_DEPENDENT_INFORMATION()))
  {
    this->SwitchStep(outputVector->GetInformationObject(0));
    return 1;
  }
  return this->Superclass::ProcessRequest(request, inputVector, outputVector);
}

int vtkCSGVReader::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  this->SwitchStep(outputVector->GetInformationObject(0));
  return 1;
}

void vtkCSGVReader::SwitchStep(vtkInformation* outInfo)
{
  vtkInternals& in = *this->Internals;
  if (in.Inputs.size() < 2)
  {
    return;
  }
  // Another time step is another file: announce its extent, as vtkFileSeriesReader does.
  if (csgvvtk::TakeRequestedStep(outInfo, static_cast<int>(in.Inputs.size()), in.Step))
  {
    this->DescribeFile(outInfo);
  }
  else if (in.Loaded)
  {
    // The step's own extent, not the one of every step that RequestInformation announced.
    const std::array<int, 6> extent = csgvvtk::LevelExtent(in.Dim, levelWithin(this->Level, in.Levels));
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent.data(), 6);
  }
  csgvvtk::AskWholeExtent(outInfo);
}

void vtkCSGVReader::DescribeFile(vtkInformation* outInfo)
{
  const std::string error = this->Internals->Load(this->Internals->Inputs[size_t(this->Internals->Step)]);
  this->Internals->LoadFailure = error;
  if (!error.empty())
  {
    vtkErrorMacro(<< error);
    // Reported once; the pipeline goes on with an empty extent and RequestData leaves an empty
    // output, never the previous file's data.
    const int empty[6] = { 0, -1, 0, -1, 0, -1 };
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), empty, 6);
    return;
  }
  const vtkInternals& in = *this->Internals;
  const uint32_t lod = levelWithin(this->Level, in.Levels);
  const std::array<int, 6> extent = csgvvtk::LevelExtent(in.Dim, lod);
  const double scale = double(uint64_t(1) << lod);
  double spacing[3];
  for (int a = 0; a < 3; ++a)
  {
    spacing[a] = in.Geometry.spacing[a] * scale;
  }
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent.data(), 6);
  outInfo->Set(vtkDataObject::SPACING(), spacing, 3);
  outInfo->Set(vtkDataObject::ORIGIN(), in.Geometry.origin.data(), 3);
  outInfo->Set(vtkDataObject::DIRECTION(), in.Geometry.direction.data(), 9);
  const int dims[3] = { int(in.Dim[0]), int(in.Dim[1]), int(in.Dim[2]) };
  outInfo->Set(vtkCSGVReader::CSGV_DIMENSIONS(), dims, 3);
  outInfo->Set(vtkCSGVReader::CSGV_LEVELS(), int(in.Levels));
  double geometry[15];
  for (int i = 0; i < 3; ++i)
  {
    geometry[i] = in.Geometry.spacing[i];
    geometry[3 + i] = in.Geometry.origin[i];
  }
  std::copy(in.Geometry.direction.begin(), in.Geometry.direction.end(), geometry + 6);
  outInfo->Set(vtkCSGVReader::CSGV_GEOMETRY(), geometry, 15);
  // Pieces (MPI ranks) are whole bricks that RequestData chooses (csgv::brickPartition) and
  // reads alone; one piece honours the update extent (decoding only the bricks under it).
  outInfo->Set(vtkAlgorithm::CAN_HANDLE_PIECE_REQUEST(), 1);
}

int vtkCSGVReader::RequestData(
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
  if (in.Inputs.size() > 1)
  {
    // RequestUpdateExtent has switched to the requested step's file; a request that came
    // without one (it should not) switches here. Every output says which step it is, failed
    // ones too (an output without a time would be asked for again at every render).
    this->SwitchStep(outInfo);
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), double(in.Step));
  }
  if (!in.Loaded)
  {
    // RequestInformation reported why; the output stays empty, marked with it (a Segmentation
    // Volume's summary says why, under MPI naming the rank).
    csgvvtk::markReadError(output->GetFieldData(), in.LoadFailure);
    return 1;
  }
  const uint32_t lod = levelWithin(this->Level, in.Levels);
  const std::array<uint32_t, 3> ld = csgv::lodDimensions(in.Dim, lod);
  const int pieces = outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES())
    ? outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES())
    : 1;
  const int piece = outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER())
    ? outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER())
    : 0;
  int ext[6] = { 0, int(ld[0]), 0, int(ld[1]), 0, int(ld[2]) };
  // A read cancelled before is read again now (the executive does not clear the flag; cleared
  // here, while executing, the MTime it bumps asks for no second execution).
  this->SetAbortExecute(0);
  if (pieces <= 1 && !in.ReadFailure.empty())
  {
    csgvvtk::markReadError(output->GetFieldData(), in.ReadFailure);
    return 1; // said when it failed; the output stays empty
  }
  this->SetProgressText("Reading the palettes");
  const std::string readError = pieces > 1 ? in.ReadPiece(pieces, piece) : in.ReadWhole([this](double f) {
    this->UpdateProgress(0.05 * f); // the sweep of the palettes at open; decoding labels follows
    return !this->GetAbortExecute();
  });
  this->SetProgressText(nullptr);
  if (!readError.empty())
  {
    vtkErrorMacro(<< readError);
    csgvvtk::markReadError(output->GetFieldData(), readError);
    return 1; // reported once: a failed request would be re-executed and reported again
  }
  const bool isPiece = pieces > 1;
  if (isPiece)
  {
    if (in.Box.empty())
    {
      const int none[6] = { 0, -1, 0, -1, 0, -1 };
      output->SetExtent(const_cast<int*>(none));
      return 1; // more pieces than bricks: this one has none
    }
    // The piece's point extent at this level (whole bricks; the last ones end with the volume).
    const uint32_t step = in.BrickSize >> lod;
    for (int a = 0; a < 3; ++a)
    {
      ext[2 * a] = int(in.Box.lo[a] * step);
      ext[2 * a + 1] = in.Box.hi[a] == in.Grid[a] ? int(ld[a]) : int(in.Box.hi[a] * step);
    }
  }
  else if (outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT()))
  {
    // Within this file's volume (a request made for a larger step of a series holds more).
    int asked[6];
    outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), asked);
    for (int a = 0; a < 3; ++a)
    {
      ext[2 * a] = std::max(asked[2 * a], 0);
      ext[2 * a + 1] = std::min(asked[2 * a + 1], ext[2 * a + 1]);
    }
  }
  output->SetExtent(ext);
  csgvvtk::applyGeometry(output, in.Geometry, lod);
  // A piece carries its own bricks as a volume of their own, with its corner: the representation
  // renders it as it renders a whole volume.
  csgvvtk::addEncodingArrays(output->GetFieldData(), isPiece ? in.PieceEncoding : in.Encoding,
    isPiece ? in.PieceGeometry : in.Geometry, in.Info, isPiece ? in.PieceRange : in.Range);
  csgvvtk::addAttributeArrays(output->GetFieldData(), in.Attributes);
  if (isPiece)
  {
    // Where the piece's voxel (0,0,0) lies in the volume (level 0): picking answers in the
    // volume's voxel coordinates.
    csgvvtk::addPieceOffset(output->GetFieldData(),
      { in.Box.lo[0] * in.BrickSize, in.Box.lo[1] * in.BrickSize, in.Box.lo[2] * in.BrickSize }, in.Dim);
  }
  const csgv::CompressedVolume& volume = isPiece ? in.PieceVolume : in.Volume;

  const uint64_t levelVoxels = uint64_t(ld[0]) * ld[1] * ld[2];
  if (!this->DecodeLabels || levelVoxels > static_cast<uint64_t>(this->DecodeThreshold))
  {
    return 1; // labels stay compressed: geometry, encoding and range only
  }
  // Update extents are in points; cells [ext[2a], ext[2a+1]) of the level image (of the piece's
  // own volume for a piece).
  csgv::Box box;
  for (int a = 0; a < 3; ++a)
  {
    const int lo = std::max(ext[2 * a], 0);
    const int hi = std::min<int64_t>(ext[2 * a + 1], ld[a]);
    if (hi <= lo)
    {
      return 1; // a piece without cells
    }
    const int shift = isPiece ? ext[2 * a] : 0;
    box.min[a] = static_cast<uint32_t>(lo - shift);
    box.max[a] = static_cast<uint32_t>(hi - shift);
  }
  this->UpdateProgress(0.05);
  csgvvtk::DecodedLabels decoded;
  const std::string error = csgvvtk::decodeBox(
    volume, lod, box, in.Info, [this](double f) { this->UpdateProgress(0.05 + 0.95 * f); }, decoded);
  if (!error.empty())
  {
    // The encoding stays on the output (the Segmentation Volume draws every other brick and
    // names the bad ones); only the decoded label array is missing.
    vtkErrorMacro(<< in.Path << ": " << error
                  << " (the Labels array is not loaded; the Segmentation Volume draws the other bricks)");
    return 1; // reported once: a failed request would be re-executed and reported again
  }
  if (!decoded.warning.empty())
  {
    vtkWarningMacro(<< in.Path << ": " << decoded.warning);
  }
  output->GetCellData()->SetScalars(decoded.array);
  return 1;
}

void vtkCSGVReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
  os << indent << "FileNames: " << this->Internals->FileNames.Count() << "\n";
  for (const std::string& name : this->Internals->FileNames.All())
  {
    os << indent.GetNextIndent() << name << "\n";
  }
  os << indent << "DecodeLabels: " << this->DecodeLabels << "\n";
  os << indent << "DecodeThreshold: " << this->DecodeThreshold << "\n";
  os << indent << "Level: " << this->Level << "\n";
}
