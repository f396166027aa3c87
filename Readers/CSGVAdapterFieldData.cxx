// SPDX-License-Identifier: MIT
// CSGVAdapter.h, the FieldData contract: the encoding, geometry, label map, original type,
// label range, piece and attribute arrays written (add*) and read back (readEncodingArrays).
#include "CSGVAdapter.h"

#include "csgv/base/MappedFile.h"

#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <cctype>
#include <sys/stat.h>
#include <mutex>
#include <unordered_map>
#include <utility>
#include <cstring>
#include <limits>

namespace csgvvtk
{
namespace
{

/// Adds an array the plugin keeps for itself (the encoding, its geometry and label map, piece
/// bookkeeping, per-label attributes) to `fd`, marked vtkAbstractArray::GUI_HIDE: ParaView's
/// array lists (colour by, selection, filters' array choices) leave such arrays out (issue 38,
/// item 6); the spreadsheet still shows them.
void addInternal(vtkFieldData* fd, vtkAbstractArray* array)
{
  array->GetInformation()->Set(vtkAbstractArray::GUI_HIDE(), 1);
  fd->AddArray(array);
}

} // namespace

std::string labelTableBeside(const std::string& input)
{
  auto endsWith = [&](const char* suffix) {
    const size_t n = std::strlen(suffix);
    if (input.size() < n)
    {
      return false;
    }
    for (size_t i = 0; i < n; ++i)
    {
      if (std::tolower(static_cast<unsigned char>(input[input.size() - n + i])) != suffix[i])
      {
        return false;
      }
    }
    return true;
  };
  std::string stem;
  if (endsWith(".nii.gz"))
  {
    stem = input.substr(0, input.size() - 3);
  }
  else if (endsWith(".nii"))
  {
    stem = input;
  }
  else
  {
    return std::string();
  }
  const std::string path = stem + ".txt";
  struct stat st
  {
  };
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) ? path : std::string();
}

void setAttributeSidecar(vtkFieldData* fd, const std::string& path)
{
  fd->RemoveArray(kAttributeSidecarName);
  if (path.empty())
  {
    return;
  }
  vtkNew<vtkStringArray> a;
  a->SetName(kAttributeSidecarName);
  a->InsertNextValue(path);
  addInternal(fd, a);
}

std::string attributeSidecar(vtkFieldData* fd)
{
  auto* a = fd ? vtkStringArray::SafeDownCast(fd->GetAbstractArray(kAttributeSidecarName)) : nullptr;
  return a && a->GetNumberOfValues() == 1 ? a->GetValue(0) : std::string();
}

void addAttributeArrays(vtkFieldData* fd, const std::vector<csgv::AttributeColumn>& columns)
{
  for (const csgv::AttributeColumn& c : columns)
  {
    const std::string name = std::string(kAttributePrefix) + c.name;
    if (c.numeric)
    {
      vtkNew<vtkDoubleArray> a;
      a->SetName(name.c_str());
      a->SetNumberOfValues(static_cast<vtkIdType>(c.values.size()));
      std::copy(c.values.begin(), c.values.end(), a->GetPointer(0));
      addInternal(fd, a);
    }
    else
    {
      vtkNew<vtkStringArray> a;
      a->SetName(name.c_str());
      a->SetNumberOfValues(static_cast<vtkIdType>(c.text.size()));
      for (size_t i = 0; i < c.text.size(); ++i)
      {
        a->SetValue(static_cast<vtkIdType>(i), c.text[i]);
      }
      addInternal(fd, a);
    }
  }
}

namespace
{

/// Stores the byte range of the encoding as the array's cached range (vtkAbstractArray's
/// PER_COMPONENT and PER_FINITE_COMPONENT, which its Modified() clears): ParaView's data
/// information asks every field-data array for its range, and VTK's sequential scan of a
/// gigabytes-long encoding took minutes. The range found here stops at the first 0 and 255.
void cacheByteRange(vtkUnsignedCharArray* a)
{
  const unsigned char* p = a->GetPointer(0);
  const vtkIdType n = a->GetNumberOfValues();
  unsigned char lo = 255, hi = 0;
  for (vtkIdType i = 0; i < n && (lo != 0 || hi != 255); ++i)
  {
    lo = std::min(lo, p[i]);
    hi = std::max(hi, p[i]);
  }
  const double range[2] = { n ? double(lo) : VTK_DOUBLE_MAX, n ? double(hi) : VTK_DOUBLE_MIN };
  for (vtkInformationInformationVectorKey* key :
    { vtkAbstractArray::PER_COMPONENT(), vtkAbstractArray::PER_FINITE_COMPONENT() })
  {
    vtkNew<vtkInformationVector> components;
    components->SetNumberOfInformationObjects(1);
    components->GetInformationObject(0)->Set(vtkDataArray::COMPONENT_RANGE(), range, 2);
    a->GetInformation()->Set(key, components);
  }
}

} // namespace

void addEncodingArrays(vtkFieldData* fd, vtkUnsignedCharArray* encoding,
  const csgv::Geometry& corner, const LabelInfo& info, vtkDataArray* range)
{
  encoding->SetName(kEncodingName);
  cacheByteRange(encoding);
  addInternal(fd, encoding);

  vtkNew<vtkDoubleArray> geometry;
  geometry->SetName(kGeometryName);
  geometry->SetNumberOfValues(15);
  for (int i = 0; i < 3; ++i)
  {
    geometry->SetValue(i, corner.spacing[i]);
    geometry->SetValue(3 + i, corner.origin[i]);
  }
  for (int i = 0; i < 9; ++i)
  {
    geometry->SetValue(6 + i, corner.direction[i]);
  }
  addInternal(fd, geometry);

  if (info.relabelled)
  {
    vtkSmartPointer<vtkDataArray> map = vtk::TakeSmartPointer(
      vtkDataArray::CreateDataArray(info.unsigned64 ? VTK_TYPE_UINT64 : VTK_TYPE_INT64));
    map->SetName(kLabelMapName);
    map->SetNumberOfTuples(static_cast<vtkIdType>(info.map.size()));
    if (!info.map.empty())
    {
      std::memcpy(map->GetVoidPointer(0), info.map.data(), info.map.size() * sizeof(int64_t));
    }
    addInternal(fd, map);
  }

  vtkNew<vtkStringArray> type;
  type->SetName(kOriginalTypeName);
  type->InsertNextValue(info.originalType);
  addInternal(fd, type);

  if (range)
  {
    range->SetName(kLabelRangeName);
    addInternal(fd, range);
  }
}

void addPieceOffset(vtkFieldData* fd, const std::array<uint32_t, 3>& offset, const std::array<uint32_t, 3>& volumeDims)
{
  vtkNew<vtkIntArray> a;
  a->SetName(kPieceOffsetName);
  a->SetNumberOfValues(6);
  for (int i = 0; i < 3; ++i)
  {
    a->SetValue(i, int(offset[size_t(i)]));
    a->SetValue(3 + i, int(volumeDims[size_t(i)]));
  }
  addInternal(fd, a);
}

std::array<uint32_t, 3> pieceVolumeDims(vtkFieldData* fd)
{
  std::array<uint32_t, 3> out{ { 0, 0, 0 } };
  vtkIntArray* a = fd ? vtkIntArray::SafeDownCast(fd->GetArray(kPieceOffsetName)) : nullptr;
  for (int i = 0; a && a->GetNumberOfValues() == 6 && i < 3; ++i)
  {
    out[size_t(i)] = uint32_t(std::max(a->GetValue(3 + i), 0));
  }
  return out;
}

void setBrickPiece(vtkFieldData* fd, const std::vector<int>& words)
{
  vtkNew<vtkIntArray> a;
  a->SetName(kBrickPieceName);
  for (int w : words)
  {
    a->InsertNextValue(w);
  }
  addInternal(fd, a);
}

bool brickPiece(vtkFieldData* fd, int& brick, int& pieces, int& piece, int whole[6])
{
  vtkIntArray* a = fd ? vtkIntArray::SafeDownCast(fd->GetArray(kBrickPieceName)) : nullptr;
  if (!a || a->GetNumberOfValues() != 9)
  {
    return false;
  }
  brick = a->GetValue(0);
  pieces = a->GetValue(1);
  piece = a->GetValue(2);
  for (int i = 0; i < 6; ++i)
  {
    whole[i] = a->GetValue(3 + i);
  }
  return brick > 0 && pieces > 1 && piece >= 0 && piece < pieces;
}

std::array<long, 3> pieceOffset(vtkFieldData* fd)
{
  std::array<long, 3> out{ { 0, 0, 0 } };
  vtkIntArray* a = fd ? vtkIntArray::SafeDownCast(fd->GetArray(kPieceOffsetName)) : nullptr;
  for (int i = 0; a && a->GetNumberOfValues() >= 3 && i < 3; ++i)
  {
    out[size_t(i)] = a->GetValue(i);
  }
  return out;
}

vtkUnsignedCharArray* encodingArray(vtkFieldData* fd)
{
  return fd ? vtkUnsignedCharArray::SafeDownCast(fd->GetAbstractArray(kEncodingName)) : nullptr;
}

void markReadError(vtkFieldData* fd, const std::string& message)
{
  vtkNew<vtkStringArray> a;
  a->SetName("CSGVReadError");
  a->InsertNextValue(message.empty() ? std::string("the read failed (its error was reported)") : message.substr(0, 4096));
  fd->AddArray(a);
}

std::string readErrorOf(vtkFieldData* fd)
{
  auto* a = fd ? vtkStringArray::SafeDownCast(fd->GetAbstractArray("CSGVReadError")) : nullptr;
  return a && a->GetNumberOfValues() > 0 ? a->GetValue(0) : std::string();
}

void requestWholeInput(vtkInformation* inInfo)
{
  int whole[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), whole, 6);
}

namespace
{
/// The pieces the output is asked in, and which one.
std::pair<int, int> outputPiece(vtkInformation* outInfo)
{
  using SDDP = vtkStreamingDemandDrivenPipeline;
  return { outInfo->Has(SDDP::UPDATE_NUMBER_OF_PIECES()) ? outInfo->Get(SDDP::UPDATE_NUMBER_OF_PIECES()) : 1,
    outInfo->Has(SDDP::UPDATE_PIECE_NUMBER()) ? outInfo->Get(SDDP::UPDATE_PIECE_NUMBER()) : 0 };
}
} // namespace

bool makesWholeOutput(vtkInformation* outInfo, bool everyPiece)
{
  const auto [pieces, piece] = outputPiece(outInfo);
  return pieces <= 1 || everyPiece || piece == 0;
}

void requestWholeVolume(vtkInformation* outInfo, vtkInformation* inInfo)
{
  using SDDP = vtkStreamingDemandDrivenPipeline;
  requestWholeInput(inInfo);
  if (outputPiece(outInfo).first <= 1)
  {
    return;
  }
  // Every rank asks alike (those that make nothing too): the reader executes on all ranks or on
  // none, so the representations downstream see as many data updates on every rank (their
  // exchange across ranks counts on it).
  inInfo->Set(SDDP::UPDATE_PIECE_NUMBER(), 0);
  inInfo->Set(SDDP::UPDATE_NUMBER_OF_PIECES(), 1);
  inInfo->Set(SDDP::UPDATE_NUMBER_OF_GHOST_LEVELS(), 0);
}

namespace
{
// The mappings that encoding arrays hold, by their first byte (a VTK array's free function gets
// the pointer alone).
std::mutex& mappedMutex()
{
  static std::mutex m;
  return m;
}
struct MappedArray
{
  std::shared_ptr<const csgv::MappedFile> file;
  int arrays = 0;
  /// What the reader found in the palettes when it opened the file (attachPaletteSummary).
  std::shared_ptr<const csgv::PaletteSummary> palettes;
};
std::unordered_map<const void*, MappedArray>& mappedArrays()
{
  static std::unordered_map<const void*, MappedArray> m;
  return m;
}
void releaseMapped(void* bytes)
{
  std::shared_ptr<const csgv::MappedFile> last; // unmapped outside the lock
  std::lock_guard<std::mutex> lock(mappedMutex());
  auto it = mappedArrays().find(bytes);
  if (it != mappedArrays().end() && --it->second.arrays == 0)
  {
    last = std::move(it->second.file);
    mappedArrays().erase(it);
  }
}
} // namespace

vtkSmartPointer<vtkUnsignedCharArray> mappedEncodingArray(std::shared_ptr<const csgv::MappedFile> file)
{
  if (!file || file->size() == 0 || file->size() > size_t(std::numeric_limits<vtkIdType>::max()))
  {
    return nullptr;
  }
  void* bytes = const_cast<uint8_t*>(file->data()); // read-only: nothing writes an encoding array
  {
    std::lock_guard<std::mutex> lock(mappedMutex());
    auto& entry = mappedArrays()[bytes];
    entry.file = file;
    entry.arrays++;
  }
  auto array = vtkSmartPointer<vtkUnsignedCharArray>::New();
  array->SetVoidArray(bytes, static_cast<vtkIdType>(file->size()), 0, vtkUnsignedCharArray::VTK_DATA_ARRAY_USER_DEFINED);
  array->SetArrayFreeFunction(releaseMapped);
  return array;
}

void attachPaletteSummary(vtkAbstractArray* mapped, std::shared_ptr<const csgv::PaletteSummary> palettes)
{
  if (!mapped || mapped->GetNumberOfValues() == 0)
  {
    return;
  }
  std::lock_guard<std::mutex> lock(mappedMutex());
  auto it = mappedArrays().find(mapped->GetVoidPointer(0));
  if (it != mappedArrays().end() && it->second.file &&
    it->second.file->size() == size_t(mapped->GetNumberOfValues()))
  {
    it->second.palettes = std::move(palettes);
  }
}

std::shared_ptr<const csgv::PaletteSummary> paletteSummaryOf(vtkAbstractArray* array)
{
  if (!array || array->GetNumberOfValues() == 0)
  {
    return nullptr;
  }
  std::lock_guard<std::mutex> lock(mappedMutex());
  auto it = mappedArrays().find(array->GetVoidPointer(0));
  // The same mapping, whole: a parse of this array has the reader's palettes.
  const bool same = it != mappedArrays().end() && it->second.file &&
    it->second.file->size() == size_t(array->GetNumberOfValues());
  return same ? it->second.palettes : nullptr;
}

std::shared_ptr<const void> keepArray(vtkAbstractArray* array)
{
  if (!array)
  {
    return nullptr;
  }
  array->Register(nullptr);
  return std::shared_ptr<const void>(array->GetVoidPointer(0), [array](const void*) { array->UnRegister(nullptr); });
}

std::string readEncodingArrays(vtkFieldData* fd, EncodedInput& out)
{
  vtkUnsignedCharArray* enc = encodingArray(fd);
  if (!enc || enc->GetNumberOfComponents() != 1)
  {
    return "the input carries no CSGV encoding (FieldData array 'CSGVEncoding', as the CSGV reader "
           "writes it)";
  }
  csgv::Result<csgv::CompressedVolume> vol = csgv::parseCsgvShared(
    enc->GetPointer(0), static_cast<size_t>(enc->GetNumberOfValues()), keepArray(enc));
  if (!vol)
  {
    return "CSGVEncoding: " + vol.message();
  }
  out.volume = std::move(*vol);
  out.palettes = paletteSummaryOf(enc);

  out.geometry = csgv::Geometry{};
  vtkDataArray* geometry = vtkDataArray::SafeDownCast(fd->GetAbstractArray(kGeometryName));
  if (geometry && geometry->GetNumberOfValues() == 15)
  {
    for (int i = 0; i < 3; ++i)
    {
      out.geometry.spacing[i] = geometry->GetComponent(i, 0);
      out.geometry.origin[i] = geometry->GetComponent(3 + i, 0);
    }
    for (int i = 0; i < 9; ++i)
    {
      out.geometry.direction[i] = geometry->GetComponent(6 + i, 0);
    }
  }

  out.info = LabelInfo{};
  vtkStringArray* type = vtkStringArray::SafeDownCast(fd->GetAbstractArray(kOriginalTypeName));
  if (type && type->GetNumberOfValues() == 1)
  {
    out.info.originalType = type->GetValue(0);
  }
  vtkDataArray* map = vtkDataArray::SafeDownCast(fd->GetAbstractArray(kLabelMapName));
  if (map)
  {
    const int t = map->GetDataType();
    const bool isUnsigned = t == VTK_UNSIGNED_LONG || t == VTK_UNSIGNED_LONG_LONG;
    const bool isSigned = t == VTK_LONG || t == VTK_LONG_LONG || t == VTK_ID_TYPE;
    if (map->GetDataTypeSize() != 8 || (!isUnsigned && !isSigned) || map->GetNumberOfComponents() != 1)
    {
      return "CSGVLabelMap must be a one-component 64-bit integer array";
    }
    out.info.relabelled = true;
    out.info.unsigned64 = isUnsigned;
    out.info.map.resize(static_cast<size_t>(map->GetNumberOfValues()));
    if (!out.info.map.empty())
    {
      std::memcpy(out.info.map.data(), map->GetVoidPointer(0), out.info.map.size() * sizeof(int64_t));
    }
  }
  return std::string();
}

std::shared_ptr<const EncodedInput> EncodingMemo::get(vtkFieldData* fd, std::string& error)
{
  vtkUnsignedCharArray* enc = encodingArray(fd);
  const vtkMTimeType mtime = enc ? enc->GetMTime() : 0;
  if (!enc || enc != this->Array || mtime != this->MTime)
  {
    auto parsed = std::make_shared<EncodedInput>();
    this->Error = readEncodingArrays(fd, *parsed);
    this->Rewritten =
      !this->Error.empty() && enc && enc->GetNumberOfValues() > 0 && csgv::MappedFile::rewrittenAt(enc->GetPointer(0));
    if (this->Rewritten)
    {
      // The reader's view of a file that was written over while it was open (an attack pass saw
      // only "unexpected bytes after the last field").
      this->Error = "the .csgv file changed on disk while it was open: reload it (File > Reload Files; " + this->Error + ")";
    }
    this->Parsed = this->Error.empty() ? parsed : nullptr;
    this->Array = enc;
    this->MTime = mtime;
  }
  error = this->Error;
  return this->Parsed;
}

std::string EncodingMemo::advice(const std::string& filter) const
{
  return this->Rewritten ? std::string() : " (apply " + filter + " to the CSGV reader's output)";
}

void applyGeometry(vtkImageData* image, const csgv::Geometry& corner, uint32_t lod)
{
  const double scale = double(uint64_t(1) << lod);
  image->SetSpacing(corner.spacing[0] * scale, corner.spacing[1] * scale, corner.spacing[2] * scale);
  image->SetOrigin(corner.origin.data());
  image->SetDirectionMatrix(corner.direction.data());
}

/// The opened file the FieldData describes: its encoding (views: no copy), geometry, and, for a
/// relabelled file, its labels and attribute columns (the CSGVAttribute arrays).
csgv::CsgvFile fileOfInput(const EncodedInput& enc, vtkFieldData* fd)
{
  csgv::CsgvFile file;
  file.path = "the input's CSGV encoding";
  file.volume = enc.volume;
  file.metadata.geometry = enc.geometry;
  if (!enc.info.relabelled)
  {
    return file;
  }
  file.hasAttributes = true;
  file.attributes.path = "the input's attribute arrays";
  file.attributes.labelColumn = "label";
  file.attributes.labels = enc.info.map;
  file.attributes.labelsUnsigned64 = enc.info.unsigned64;
  const size_t prefix = std::strlen(kAttributePrefix);
  for (int i = 0; fd && i < fd->GetNumberOfArrays(); ++i)
  {
    vtkAbstractArray* a = fd->GetAbstractArray(i);
    if (!a || !a->GetName() || std::strncmp(a->GetName(), kAttributePrefix, prefix) != 0 ||
      a->GetNumberOfComponents() != 1 || size_t(a->GetNumberOfTuples()) != enc.info.map.size())
    {
      continue;
    }
    csgv::AttributeColumn c;
    c.name = a->GetName() + prefix;
    if (auto* d = vtkDataArray::SafeDownCast(a))
    {
      c.values.resize(size_t(d->GetNumberOfTuples()));
      for (vtkIdType k = 0; k < d->GetNumberOfTuples(); ++k)
      {
        c.values[size_t(k)] = d->GetComponent(k, 0);
      }
    }
    else if (auto* s = vtkStringArray::SafeDownCast(a))
    {
      c.numeric = false;
      c.text.resize(size_t(s->GetNumberOfValues()));
      for (vtkIdType k = 0; k < s->GetNumberOfValues(); ++k)
      {
        c.text[size_t(k)] = s->GetValue(k);
      }
    }
    else
    {
      continue;
    }
    file.attributes.columns.push_back(std::move(c));
  }
  csgv::Result<std::vector<uint32_t>> narrow = file.attributes.labelsAsUint32();
  if (narrow)
  {
    file.idToLabel = std::move(*narrow);
  }
  else
  {
    file.wideLabels = true;
  }
  return file;
}

} // namespace csgvvtk
