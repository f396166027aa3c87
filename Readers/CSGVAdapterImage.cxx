// SPDX-License-Identifier: MIT
// CSGVAdapter.h, which array of an image holds labels and where its voxels lie: the label
// array choice, image geometry, MPI piece extents and crops, world bounds.
#include "CSGVAdapter.h"

#include "csgv/codec/Partition.h"

#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkMatrix3x3.h>
#include <vtkPointData.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace csgvvtk
{
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

} // namespace csgvvtk
