// SPDX-License-Identifier: MIT
#include "CSGVAdapter.h"

#include "csgv/codec/Partition.h"

#include <vtkAOSDataArrayTemplate.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkMatrix3x3.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkStringArray.h>
#include <vtkType.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <type_traits>

namespace csgvvtk
{
namespace
{

/// Calls f(T{}) for the C++ type of a VTK label type; false for unsupported types.
template <class F>
bool dispatchType(int type, F&& f)
{
  switch (type)
  {
    case VTK_TYPE_UINT8: f(vtkTypeUInt8{}); return true;
    case VTK_TYPE_INT8: f(vtkTypeInt8{}); return true;
    case VTK_TYPE_UINT16: f(vtkTypeUInt16{}); return true;
    case VTK_TYPE_INT16: f(vtkTypeInt16{}); return true;
    case VTK_TYPE_UINT32: f(vtkTypeUInt32{}); return true;
    case VTK_TYPE_INT32: f(vtkTypeInt32{}); return true;
    case VTK_TYPE_UINT64: f(vtkTypeUInt64{}); return true;
    case VTK_TYPE_INT64: f(vtkTypeInt64{}); return true;
    case VTK_TYPE_FLOAT32: f(vtkTypeFloat32{}); return true;
    case VTK_TYPE_FLOAT64: f(vtkTypeFloat64{}); return true;
    default: return false;
  }
}

/// True when `v` is exactly representable as T.
template <class T>
bool fitsUnsigned(uint64_t v)
{
  if constexpr (std::is_floating_point<T>::value)
  {
    const T t = static_cast<T>(v);
    return t < static_cast<T>(18446744073709551615.0) && static_cast<uint64_t>(t) == v;
  }
  else
  {
    return v <= static_cast<uint64_t>(std::numeric_limits<T>::max());
  }
}

template <class T>
bool fitsSigned(int64_t v)
{
  if (v >= 0)
  {
    return fitsUnsigned<T>(static_cast<uint64_t>(v));
  }
  if constexpr (std::is_floating_point<T>::value)
  {
    const T t = static_cast<T>(v);
    return t >= static_cast<T>(-9223372036854775808.0) && static_cast<int64_t>(t) == v;
  }
  else if constexpr (std::is_signed<T>::value)
  {
    return v >= static_cast<int64_t>(std::numeric_limits<T>::lowest());
  }
  else
  {
    return false;
  }
}

/// Calls f(value) for every palette entry of every brick (format labels, or ids when relabelled).
template <class F>
void forEachPaletteEntry(const csgv::CompressedVolume& vol, F&& f)
{
  const uint32_t L = vol.levels();
  const uint64_t bricks = vol.brickCount();
  for (uint64_t i = 0; i < bricks; ++i)
  {
    const csgv::BrickWords bw = vol.brick(i);
    if (bw.size < L + 1)
    {
      continue; // checkContainer refuses this; stay safe anyway
    }
    // The palette is stored reversed at the end of the brick (Container.h).
    const uint32_t n = std::min(bw.words[L], bw.size - (L + 1));
    for (uint32_t k = 0; k < n; ++k)
    {
      f(bw.words[bw.size - 1 - k]);
    }
  }
}

/// @brief Palette value -> label of type T, checked once up front so decoding never narrows.
template <class T>
struct Converter
{
  bool relabelled = false;
  std::vector<T> table; ///< id -> label when relabelled

  /// False when some label does not fit T.
  bool init(const csgv::CompressedVolume& vol, const LabelInfo& info)
  {
    this->relabelled = info.relabelled;
    if (info.relabelled)
    {
      this->table.resize(info.map.size());
      for (size_t id = 0; id < info.map.size(); ++id)
      {
        const int64_t bits = info.map[id];
        const bool ok = info.unsigned64 ? fitsUnsigned<T>(static_cast<uint64_t>(bits)) : fitsSigned<T>(bits);
        if (!ok)
        {
          return false;
        }
        this->table[id] = info.unsigned64 ? static_cast<T>(static_cast<uint64_t>(bits)) : static_cast<T>(bits);
      }
      return true;
    }
    bool ok = true;
    forEachPaletteEntry(vol, [&](uint32_t v) { ok = ok && fitsUnsigned<T>(v); });
    return ok;
  }
};

int canonicalType(const LabelInfo& info)
{
  if (!info.relabelled)
  {
    return VTK_TYPE_UINT32;
  }
  return info.unsigned64 ? VTK_TYPE_UINT64 : VTK_TYPE_INT64;
}

/// Runs f(T{}, converter) for the original type when every label fits it, else for the canonical
/// type (with a warning).
template <class F>
bool withConverter(const csgv::CompressedVolume& vol, const LabelInfo& info, std::string& warning, F&& f)
{
  int type = vtkTypeOfName(info.originalType);
  if (type < 0)
  {
    type = canonicalType(info);
  }
  bool done = false;
  dispatchType(type, [&](auto t) {
    using T = decltype(t);
    Converter<T> conv;
    if (conv.init(vol, info))
    {
      f(t, conv);
      done = true;
    }
  });
  if (done)
  {
    return true;
  }
  warning = "labels do not fit the original type '" + info.originalType + "' of the metadata; using " +
    (info.relabelled ? (info.unsigned64 ? "uint64" : "int64") : "uint32");
  return dispatchType(canonicalType(info), [&](auto t) {
    using T = decltype(t);
    Converter<T> conv;
    if (conv.init(vol, info))
    {
      f(t, conv);
      done = true;
    }
  }) && done;
}

} // namespace

int vtkTypeOfName(const std::string& name)
{
  static const std::pair<const char*, int> names[] = { { "uint8", VTK_TYPE_UINT8 },
    { "int8", VTK_TYPE_INT8 }, { "uint16", VTK_TYPE_UINT16 }, { "int16", VTK_TYPE_INT16 },
    { "uint32", VTK_TYPE_UINT32 }, { "int32", VTK_TYPE_INT32 }, { "uint64", VTK_TYPE_UINT64 },
    { "int64", VTK_TYPE_INT64 }, { "float32", VTK_TYPE_FLOAT32 }, { "float64", VTK_TYPE_FLOAT64 } };
  for (const auto& n : names)
  {
    if (name == n.first)
    {
      return n.second;
    }
  }
  return -1;
}

std::string decodeBox(const csgv::CompressedVolume& vol, uint32_t lod, const csgv::Box& box,
  const LabelInfo& info, const std::function<void(double)>& progress, DecodedLabels& out)
{
  if (lod >= vol.levels())
  {
    return "level " + std::to_string(lod) + " does not exist (the file has levels 0 to " +
      std::to_string(vol.levels() - 1) + ")";
  }
  const std::array<uint32_t, 3> ld = csgv::lodDimensions(vol.dim, lod);
  for (int a = 0; a < 3; ++a)
  {
    if (box.min[a] >= box.max[a] || box.max[a] > ld[a])
    {
      return "the box to decode is empty or leaves the " + std::to_string(ld[0]) + "x" +
        std::to_string(ld[1]) + "x" + std::to_string(ld[2]) + " image of level " + std::to_string(lod);
    }
  }
  const uint64_t nx = box.max[0] - box.min[0], ny = box.max[1] - box.min[1], nz = box.max[2] - box.min[2];
  const uint64_t sliceSize = nx * ny;
  std::string error;
  const bool ok = withConverter(vol, info, out.warning, [&](auto t, const auto& conv) {
    using T = decltype(t);
    vtkSmartPointer<vtkDataArray> arr = vtk::TakeSmartPointer(vtkDataArray::CreateDataArray(vtkTypeTraits<T>::VTK_TYPE_ID));
    auto* typed = static_cast<vtkAOSDataArrayTemplate<T>*>(arr.GetPointer());
    typed->SetName(kLabelsName);
    typed->SetNumberOfComponents(1);
    if (!typed->Allocate(static_cast<vtkIdType>(sliceSize * nz)))
    {
      error = "out of memory for " + std::to_string(sliceSize * nz) + " labels";
      return;
    }
    typed->SetNumberOfValues(static_cast<vtkIdType>(sliceSize * nz));
    T* dst = typed->GetPointer(0);
    // Slabs one brick deep at this level: decodeRegion touches each brick once, the temporary is
    // one slab of uint32, and progress advances per brick layer.
    const uint32_t nodesPerBrick = std::max(1u, vol.brickSize >> lod);
    csgv::DecodeOptions options; // ids stay ids: the converter maps them with its checked table
    for (uint32_t z = box.min[2]; z < box.max[2];)
    {
      const uint32_t z1 = std::min(box.max[2], (z / nodesPerBrick + 1) * nodesPerBrick);
      csgv::Box slab = box;
      slab.min[2] = z;
      slab.max[2] = z1;
      csgv::Result<csgv::LabelVolume> r = csgv::decodeRegion(vol, lod, slab, options);
      if (!r)
      {
        error = r.message();
        return;
      }
      const uint32_t* src = r->labels.data();
      const size_t count = r->labels.size();
      T* o = dst + (z - box.min[2]) * sliceSize;
      if (conv.relabelled)
      {
        const size_t tableSize = conv.table.size();
        for (size_t i = 0; i < count; ++i)
        {
          if (src[i] >= tableSize)
          {
            error = "label id " + std::to_string(src[i]) + " is past the attribute database's " +
              std::to_string(tableSize) + " labels";
            return;
          }
          o[i] = conv.table[src[i]];
        }
      }
      else
      {
        std::transform(src, src + count, o, [](uint32_t v) { return static_cast<T>(v); });
      }
      z = z1;
      if (progress)
      {
        progress(double(z - box.min[2]) / double(nz));
      }
    }
    out.array = arr;
  });
  if (!ok && error.empty())
  {
    error = "the labels fit no supported VTK type";
  }
  return error;
}

vtkSmartPointer<vtkDataArray> paletteRange(const csgv::CompressedVolume& vol, const LabelInfo& info)
{
  vtkSmartPointer<vtkDataArray> result;
  std::string warning;
  withConverter(vol, info, warning, [&](auto t, const auto& conv) {
    using T = decltype(t);
    bool any = false;
    T lo = T(0), hi = T(0);
    forEachPaletteEntry(vol, [&](uint32_t v) {
      T value;
      if (conv.relabelled)
      {
        if (v >= conv.table.size())
        {
          return; // reported when decoding
        }
        value = conv.table[v];
      }
      else
      {
        value = static_cast<T>(v);
      }
      lo = any ? std::min(lo, value) : value;
      hi = any ? std::max(hi, value) : value;
      any = true;
    });
    result = vtk::TakeSmartPointer(vtkDataArray::CreateDataArray(vtkTypeTraits<T>::VTK_TYPE_ID));
    auto* typed = static_cast<vtkAOSDataArrayTemplate<T>*>(result.GetPointer());
    typed->SetNumberOfValues(2);
    typed->SetValue(0, lo);
    typed->SetValue(1, hi);
  });
  return result;
}

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

std::string readEncodingArrays(vtkFieldData* fd, EncodedInput& out)
{
  vtkUnsignedCharArray* enc = encodingArray(fd);
  if (!enc || enc->GetNumberOfComponents() != 1)
  {
    return "the input carries no CSGV encoding (FieldData array 'CSGVEncoding', as the CSGV reader "
           "writes it)";
  }
  csgv::Result<csgv::CompressedVolume> vol =
    csgv::parseCsgv(enc->GetPointer(0), static_cast<size_t>(enc->GetNumberOfValues()));
  if (!vol)
  {
    return "CSGVEncoding: " + vol.message();
  }
  out.volume = std::move(*vol);

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
    this->Parsed = this->Error.empty() ? parsed : nullptr;
    this->Array = enc;
    this->MTime = mtime;
  }
  error = this->Error;
  return this->Parsed;
}

void applyGeometry(vtkImageData* image, const csgv::Geometry& corner, uint32_t lod)
{
  const double scale = double(uint64_t(1) << lod);
  image->SetSpacing(corner.spacing[0] * scale, corner.spacing[1] * scale, corner.spacing[2] * scale);
  image->SetOrigin(corner.origin.data());
  image->SetDirectionMatrix(corner.direction.data());
}


// ---------------------------------------------------------------------------------------------
// Which array, and where its voxels lie

const char* labelTypeNameOf(int vtkType, csgv::LabelType& type)
{
  bool isSigned = true;
  switch (vtkType)
  {
    case VTK_FLOAT: type = csgv::LabelType::F32; return csgv::labelTypeName(type);
    case VTK_DOUBLE: type = csgv::LabelType::F64; return csgv::labelTypeName(type);
    case VTK_UNSIGNED_CHAR:
    case VTK_UNSIGNED_SHORT:
    case VTK_UNSIGNED_INT:
    case VTK_UNSIGNED_LONG:
    case VTK_UNSIGNED_LONG_LONG: isSigned = false; break;
    case VTK_CHAR: isSigned = std::numeric_limits<char>::is_signed; break; // numpy's int8
    case VTK_SIGNED_CHAR:
    case VTK_SHORT:
    case VTK_INT:
    case VTK_LONG:
    case VTK_LONG_LONG:
    case VTK_ID_TYPE: break;
    default: return nullptr;
  }
  switch (vtkDataArray::GetDataTypeSize(vtkType))
  {
    case 1: type = isSigned ? csgv::LabelType::I8 : csgv::LabelType::U8; break;
    case 2: type = isSigned ? csgv::LabelType::I16 : csgv::LabelType::U16; break;
    case 4: type = isSigned ? csgv::LabelType::I32 : csgv::LabelType::U32; break;
    case 8: type = isSigned ? csgv::LabelType::I64 : csgv::LabelType::U64; break;
    default: return nullptr;
  }
  return csgv::labelTypeName(type);
}

vtkDataArray* findLabelArray(vtkImageData* image, const std::string& name, bool& isCell)
{
  vtkDataSetAttributes* attrs[2] = { image->GetCellData(), image->GetPointData() };
  if (!name.empty())
  {
    for (int k = 0; k < 2; ++k)
    {
      if (vtkDataArray* a = attrs[k]->GetArray(name.c_str()))
      {
        isCell = k == 0;
        return a;
      }
    }
    return nullptr;
  }
  for (int wantInteger = 1; wantInteger >= 0; --wantInteger)
  {
    for (int k = 0; k < 2; ++k)
    {
      for (int i = 0; i < attrs[k]->GetNumberOfArrays(); ++i)
      {
        vtkDataArray* a = attrs[k]->GetArray(i);
        csgv::LabelType t;
        if (!a || a->GetNumberOfComponents() != 1 || !labelTypeNameOf(a->GetDataType(), t) ||
          (a->GetName() && std::strncmp(a->GetName(), "vtk", 3) == 0))
        {
          continue;
        }
        const bool integer = t != csgv::LabelType::F32 && t != csgv::LabelType::F64;
        if (integer == bool(wantInteger))
        {
          isCell = k == 0;
          return a;
        }
      }
    }
  }
  return nullptr;
}

csgv::Geometry imageGeometry(vtkImageData* image, bool isCell, std::array<uint32_t, 3>& dims)
{
  int ext[6];
  image->GetExtent(ext);
  csgv::Geometry g;
  const double* spacing = image->GetSpacing();
  const double* origin = image->GetOrigin();
  const double* dir = image->GetDirectionMatrix()->GetData();
  for (int i = 0; i < 9; ++i)
  {
    g.direction[i] = dir[i];
  }
  for (int r = 0; r < 3; ++r)
  {
    g.spacing[r] = spacing[r];
    double w = origin[r];
    for (int c = 0; c < 3; ++c)
    {
      w += dir[3 * r + c] * ext[2 * c] * spacing[c];
    }
    g.origin[r] = w; // world position of the extent's first point
  }
  dims = voxelDims(ext, isCell);
  for (uint32_t& d : dims)
  {
    d = std::max(d, 1u);
  }
  return isCell ? g : csgv::cellGeometryFromPointGeometry(g);
}

std::array<uint32_t, 3> voxelDims(const int ext[6], bool isCell)
{
  std::array<uint32_t, 3> dims{};
  for (int a = 0; a < 3; ++a)
  {
    const int points = ext[2 * a + 1] - ext[2 * a] + 1;
    dims[a] = uint32_t(std::max(isCell ? points - 1 : points, points > 0 ? 1 : 0));
  }
  return dims;
}

bool pieceVoxels(const std::array<uint32_t, 3>& dims, int brickSize, int pieces, int piece,
  std::array<uint32_t, 3>& lo, std::array<uint32_t, 3>& hi)
{
  if (brickSize <= 0 || dims[0] == 0 || dims[1] == 0 || dims[2] == 0)
  {
    return false;
  }
  const uint32_t b = uint32_t(brickSize);
  const std::array<uint32_t, 3> grid = { (dims[0] + b - 1) / b, (dims[1] + b - 1) / b,
    (dims[2] + b - 1) / b };
  const csgv::BrickBox box = csgv::brickPartition(grid, uint32_t(pieces), uint32_t(piece));
  for (int a = 0; a < 3; ++a)
  {
    lo[a] = box.lo[a] * b;
    hi[a] = std::min(box.hi[a] * b, dims[a]);
  }
  return !box.empty();
}

std::string cropVoxels(vtkDataArray* array, const int ext[6], const int whole[6], bool isCell,
  const std::array<uint32_t, 3>& lo, const std::array<uint32_t, 3>& hi,
  vtkSmartPointer<vtkDataArray>& out)
{
  const std::array<uint32_t, 3> have = voxelDims(ext, isCell);
  std::array<uint64_t, 3> off{}, size{};
  for (int a = 0; a < 3; ++a)
  {
    const long first = long(whole[2 * a]) + long(lo[a]) - long(ext[2 * a]);
    size[a] = hi[a] - lo[a];
    if (first < 0 || uint64_t(first) + size[a] > have[a])
    {
      return "the input's extent (" + std::to_string(ext[0]) + ".." + std::to_string(ext[1]) + ", " +
        std::to_string(ext[2]) + ".." + std::to_string(ext[3]) + ", " + std::to_string(ext[4]) +
        ".." + std::to_string(ext[5]) + ") does not hold this piece's voxels";
    }
    off[a] = uint64_t(first);
  }
  if (uint64_t(array->GetNumberOfTuples()) != uint64_t(have[0]) * have[1] * have[2])
  {
    return std::string("array '") + (array->GetName() ? array->GetName() : "(unnamed)") +
      "' does not match its image's extent";
  }
  vtkSmartPointer<vtkDataArray> aos = array;
  if (!array->HasStandardMemoryLayout())
  {
    aos = vtk::TakeSmartPointer(vtkDataArray::CreateDataArray(array->GetDataType()));
    aos->DeepCopy(array);
  }
  out = vtk::TakeSmartPointer(vtkDataArray::CreateDataArray(array->GetDataType()));
  out->SetName(array->GetName());
  out->SetNumberOfComponents(array->GetNumberOfComponents());
  out->SetNumberOfTuples(vtkIdType(size[0] * size[1] * size[2]));
  const size_t tuple = size_t(array->GetDataTypeSize()) * size_t(array->GetNumberOfComponents());
  const auto* src = static_cast<const unsigned char*>(aos->GetVoidPointer(0));
  auto* dst = static_cast<unsigned char*>(out->GetVoidPointer(0));
  for (uint64_t z = 0; z < size[2]; ++z)
  {
    for (uint64_t y = 0; y < size[1]; ++y)
    {
      const uint64_t from = ((z + off[2]) * have[1] + (y + off[1])) * have[0] + off[0];
      std::memcpy(dst + ((z * size[1] + y) * size[0]) * tuple, src + from * tuple, size[0] * tuple);
    }
  }
  return std::string();
}

void brickPieceExtent(const int whole[6], int brickSize, int pieces, int piece, int ext[6])
{
  for (int a = 0; a < 3; ++a)
  {
    ext[2 * a] = ext[2 * a + 1] = whole[2 * a];
  }
  bool any = false;
  for (bool isCell : { true, false })
  {
    std::array<uint32_t, 3> lo, hi;
    if (!pieceVoxels(voxelDims(whole, isCell), brickSize, pieces, piece, lo, hi))
    {
      continue;
    }
    for (int a = 0; a < 3; ++a)
    {
      const int first = whole[2 * a] + int(lo[a]);
      const int last = std::min(whole[2 * a + 1], whole[2 * a] + int(hi[a]) - (isCell ? 0 : 1));
      ext[2 * a] = any ? std::min(ext[2 * a], first) : first;
      ext[2 * a + 1] = any ? std::max(ext[2 * a + 1], last) : last;
    }
    any = true;
  }
}


void worldBounds(const csgv::Geometry& g, const std::array<uint32_t, 3>& dims, double b[6])
{
  for (int r = 0; r < 3; ++r)
  {
    b[2 * r] = std::numeric_limits<double>::max();
    b[2 * r + 1] = -std::numeric_limits<double>::max();
  }
  for (int c = 0; c < 8; ++c)
  {
    const double idx[3] = { (c & 1) ? double(dims[0]) : 0.0, (c & 2) ? double(dims[1]) : 0.0,
      (c & 4) ? double(dims[2]) : 0.0 };
    for (int r = 0; r < 3; ++r)
    {
      double w = g.origin[r];
      for (int k = 0; k < 3; ++k)
      {
        w += g.direction[3 * r + k] * idx[k] * g.spacing[k];
      }
      b[2 * r] = std::min(b[2 * r], w);
      b[2 * r + 1] = std::max(b[2 * r + 1], w);
    }
  }
}

bool encodingDescribes(vtkImageData* image, const csgv::Geometry& g, const std::array<uint32_t, 3>& dim)
{
  const double* spacing = image->GetSpacing();
  if (!(g.spacing[0] > 0) || !(spacing[0] > 0))
  {
    return false;
  }
  const double ratio = spacing[0] / g.spacing[0];
  const int level = int(std::lround(std::log2(ratio)));
  if (level < 0 || level > 7 || std::abs(ratio - double(1 << level)) > 1e-6 * ratio)
  {
    return false;
  }
  std::array<uint32_t, 3> dims;
  const csgv::Geometry ig = imageGeometry(image, true, dims);
  for (int i = 0; i < 3; ++i)
  {
    const uint32_t expected = ((dim[i] - 1) >> level) + 1;
    const double tol = 1e-6 * std::max(1.0, std::abs(g.spacing[i]) * dim[i]);
    if (dims[i] != expected || std::abs(ig.origin[i] - g.origin[i]) > tol)
    {
      return false;
    }
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// VTK array -> compressed volume

namespace
{

/// @brief Labels of a VTK array handed to the encoder z-slab by z-slab, converted to uint32 on
/// the way (values are checked to fit before), reporting progress per slab.
template <class T>
class ArraySlabSource : public csgv::SlabSource
{
public:
  ArraySlabSource(const T* data, const std::array<uint32_t, 3>& dim, const std::function<void(double)>& progress)
    : Data(data)
    , Dim(dim)
    , Progress(progress)
  {
  }
  std::array<uint32_t, 3> dimensions() const override { return this->Dim; }
  csgv::Status readSlab(uint32_t z0, uint32_t depth, uint32_t* out) override
  {
    const size_t slice = size_t(this->Dim[0]) * this->Dim[1];
    const T* src = this->Data + slice * z0;
    for (size_t i = 0, n = slice * depth; i < n; ++i)
    {
      out[i] = static_cast<uint32_t>(src[i]);
    }
    this->Report(double(z0 + depth) / this->Dim[2]);
    return csgv::Status::ok();
  }
  const uint32_t* slabInMemory(uint32_t z0) const override
  {
    if constexpr (std::is_same<T, uint32_t>::value)
    {
      // uint32 labels are encoded in place, without a copy.
      this->Report(double(z0) / this->Dim[2]);
      return this->Data + size_t(this->Dim[0]) * this->Dim[1] * z0;
    }
    else
    {
      (void)z0;
      return nullptr;
    }
  }

private:
  void Report(double f) const
  {
    if (this->Progress)
    {
      this->Progress(f);
    }
  }
  const T* Data;
  std::array<uint32_t, 3> Dim;
  const std::function<void(double)>& Progress;
};

/// @brief Result of one pass over the labels.
struct Scan
{
  bool fits = true;  ///< all values are format labels (0 .. 0xFFFFFFFE)
  std::string error; ///< a float that is not an integer
};

template <class T>
Scan scanValues(const T* v, size_t n, const std::array<uint32_t, 3>& dim, const std::string& name,
  const std::array<uint32_t, 3>& offset)
{
  Scan s;
  for (size_t i = 0; i < n; ++i)
  {
    const T x = v[i];
    if constexpr (std::is_floating_point<T>::value)
    {
      if (!(std::isfinite(x) && x == std::trunc(x) && x >= T(-9.2233720368547758e18) &&
            x < T(9.2233720368547758e18)))
      {
        const size_t sx = i % dim[0], sy = (i / dim[0]) % dim[1], sz = i / (size_t(dim[0]) * dim[1]);
        std::ostringstream os;
        os.precision(17);
        os << "voxel (" << sx + offset[0] << ", " << sy + offset[1] << ", " << sz + offset[2]
           << ") of array '" << name << "' holds " << x
           << ", which is not an integer label";
        s.error = os.str();
        return s;
      }
    }
    if (!(x >= T(0) && x < T(4294967295.0)))
    {
      s.fits = false;
    }
  }
  return s;
}

template <class T>
void toInputValues(const T* v, size_t n, std::vector<uint64_t>& out)
{
  out.resize(n);
  for (size_t i = 0; i < n; ++i)
  {
    if constexpr (std::is_floating_point<T>::value || std::is_signed<T>::value)
    {
      out[i] = static_cast<uint64_t>(static_cast<int64_t>(v[i])); // int64 bits, as Core stores them
    }
    else
    {
      out[i] = static_cast<uint64_t>(v[i]);
    }
  }
}

} // namespace

std::string encodeLabelArray(vtkDataArray* array, const std::array<uint32_t, 3>& dims,
  const csgv::EncodeOptions& options, bool relabel, const std::function<void(double)>& progress,
  EncodedArray& out, PieceAgreement* pieces)
{
  const std::string name = array->GetName() ? array->GetName() : "(unnamed)";
  csgv::LabelType labelType;
  const char* typeName = labelTypeNameOf(array->GetDataType(), labelType);
  if (!typeName || array->GetNumberOfComponents() != 1)
  {
    return "array '" + name + "' is " + array->GetDataTypeAsString() + " with " +
      std::to_string(array->GetNumberOfComponents()) +
      " components; labels need one component of an integer type of 8 to 64 bits or a float type "
      "holding integers";
  }
  const uint64_t voxels = uint64_t(dims[0]) * dims[1] * dims[2];
  if (voxels == 0 || uint64_t(array->GetNumberOfTuples()) != voxels)
  {
    return "array '" + name + "' has " + std::to_string(array->GetNumberOfTuples()) +
      " values for " + std::to_string(voxels) + " voxels";
  }
  out = EncodedArray{};
  out.originalType = typeName;

  // Plain contiguous storage for the scan and the encoder (deep copy only for exotic layouts).
  vtkSmartPointer<vtkDataArray> aos = array;
  if (!array->HasStandardMemoryLayout())
  {
    aos = vtk::TakeSmartPointer(vtkDataArray::CreateDataArray(array->GetDataType()));
    aos->DeepCopy(array);
  }
  const void* raw = aos->GetVoidPointer(0);
  csgv::Result<csgv::CompressedVolume> vol = csgv::Status::error("no labels");
  std::string error;
  switch (aos->GetDataType())
  {
    vtkTemplateMacro({
      const VTK_TT* values = static_cast<const VTK_TT*>(raw);
      const Scan scan =
        scanValues(values, size_t(voxels), dims, name, pieces ? pieces->offset : std::array<uint32_t, 3>{});
      bool relabelling = !scan.fits || relabel;
      if (pieces)
      {
        // Every piece relabels when one does, with ids of the whole volume.
        csgv::Result<bool> any = pieces->anyRelabels(scan.error.empty(), relabelling);
        if (!any)
        {
          error = scan.error.empty() ? any.message() : scan.error;
          break;
        }
        relabelling = *any;
      }
      if (!scan.error.empty())
      {
        error = scan.error;
        break;
      }
      if (!relabelling)
      {
        // Streamed from the array: no full-size copy.
        ArraySlabSource<VTK_TT> source(values, dims, progress);
        vol = csgv::encodeVolume(source, options);
      }
      else if (pieces)
      {
        csgv::InputVolume in;
        in.dim = dims;
        in.type = labelType;
        toInputValues(values, size_t(voxels), in.values);
        csgv::StreamingRelabeller relabeller(pieces->volumeDims, options.brickSize);
        relabeller.observeBox(pieces->offset, dims, in.values.data());
        csgv::Result<std::vector<uint64_t>> ids = pieces->ids(true, relabeller);
        csgv::Status used = ids ? relabeller.useIds(*ids) : ids.status();
        if (!used)
        {
          error = used.message();
          break;
        }
        csgv::LabelVolume labels;
        labels.dim = dims;
        labels.labels.resize(in.values.size());
        relabeller.toIds(in.values.data(), in.values.size(), labels.labels.data());
        in = csgv::InputVolume{};
        out.mapping.relabelled = true;
        out.mapping.type = labelType;
        out.mapping.originalBits = std::move(*ids);
        ArraySlabSource<uint32_t> source(labels.labels.data(), dims, progress);
        vol = csgv::encodeVolume(source, options);
      }
      else
      {
        csgv::InputVolume in;
        in.dim = dims;
        in.type = labelType;
        toInputValues(values, size_t(voxels), in.values);
        csgv::Result<csgv::LabelVolume> labels =
          csgv::prepareLabels(in, options.brickSize, relabel, out.mapping);
        if (!labels)
        {
          error = labels.message();
          break;
        }
        in = csgv::InputVolume{};
        ArraySlabSource<uint32_t> source(labels->labels.data(), dims, progress);
        vol = csgv::encodeVolume(source, options);
      }
    });
    default:
      error = "array '" + name + "' is not a label array (type " + array->GetDataTypeAsString() + ")";
  }
  if (error.empty() && !vol)
  {
    error = vol.message();
  }
  if (!error.empty())
  {
    return error;
  }
  out.volume = std::move(*vol);
  return std::string();
}

} // namespace csgvvtk
