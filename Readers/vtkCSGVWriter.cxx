// SPDX-License-Identifier: MIT
#include "vtkCSGVWriter.h"

#include "csgv/attributes/AttributeDb.h"
#include "csgv/codec/Encoder.h"
#include "csgv/base/FileUtil.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Relabel.h"

#include <vtkAOSDataArrayTemplate.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkMatrix3x3.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <sstream>
#include <type_traits>

vtkStandardNewMacro(vtkCSGVWriter);

namespace
{

/// Core's name for a VTK label type; nullptr when the type cannot hold labels. By size and
/// signedness, because 64-bit integers come as long, long long or vtkIdType arrays.
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

bool isIntegerType(int vtkType)
{
  csgv::LabelType t;
  return labelTypeNameOf(vtkType, t) && vtkType != VTK_FLOAT && vtkType != VTK_DOUBLE;
}

/// @brief Labels of a VTK array handed to the encoder z-slab by z-slab, converted to uint32 on
/// the way (values are checked to fit before), reporting progress per slab.
template <class T>
class ArraySlabSource : public csgv::SlabSource
{
public:
  ArraySlabSource(const T* data, const std::array<uint32_t, 3>& dim, std::function<void(double)> progress)
    : Data(data)
    , Dim(dim)
    , Progress(std::move(progress))
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
    this->Progress(double(z0 + depth) / this->Dim[2]);
    return csgv::Status::ok();
  }
  const uint32_t* slabInMemory(uint32_t z0) const override
  {
    if constexpr (std::is_same<T, uint32_t>::value)
    {
      // uint32 labels are encoded in place, without a copy.
      this->Progress(double(z0) / this->Dim[2]);
      return this->Data + size_t(this->Dim[0]) * this->Dim[1] * z0;
    }
    else
    {
      (void)z0;
      return nullptr;
    }
  }

private:
  const T* Data;
  std::array<uint32_t, 3> Dim;
  std::function<void(double)> Progress;
};

/// @brief Result of one pass over the labels.
struct Scan
{
  bool fits = true;  ///< all values are format labels (0 .. 0xFFFFFFFE)
  std::string error; ///< a float that is not an integer
};

template <class T>
Scan scanValues(const T* v, size_t n, const std::array<uint32_t, 3>& dim, const std::string& name)
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
        os << "voxel (" << sx << ", " << sy << ", " << sz << ") of array '" << name << "' holds " << x
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

/// The label array: by name, or the first integer array (cell data first), else the first float.
vtkDataArray* findLabelArray(vtkImageData* image, const char* name, bool& isCell)
{
  vtkDataSetAttributes* attrs[2] = { image->GetCellData(), image->GetPointData() };
  if (name && *name)
  {
    for (int k = 0; k < 2; ++k)
    {
      if (vtkDataArray* a = attrs[k]->GetArray(name))
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
        if (a && a->GetNumberOfComponents() == 1 && labelTypeNameOf(a->GetDataType(), t) &&
          isIntegerType(a->GetDataType()) == bool(wantInteger))
        {
          isCell = k == 0;
          return a;
        }
      }
    }
  }
  return nullptr;
}

} // namespace

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
  vtkDataArray* array = findLabelArray(image, this->LabelArrayName, isCell);
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
  csgv::LabelType labelType;
  const char* typeName = labelTypeNameOf(array->GetDataType(), labelType);
  if (!typeName || array->GetNumberOfComponents() != 1)
  {
    vtkErrorMacro(<< "array '" << arrayName << "' is " << array->GetDataTypeAsString() << " with "
                  << array->GetNumberOfComponents()
                  << " components; labels need one component of an integer type of 8 to 64 bits or "
                     "a float type holding integers");
    return;
  }

  // Voxel grid and where its voxel (0,0,0) lies.
  int ext[6];
  image->GetExtent(ext);
  std::array<uint32_t, 3> dim;
  for (int a = 0; a < 3; ++a)
  {
    const int points = ext[2 * a + 1] - ext[2 * a] + 1;
    dim[a] = uint32_t(isCell ? std::max(points - 1, 1) : points);
  }
  const uint64_t voxels = uint64_t(dim[0]) * dim[1] * dim[2];
  if (voxels == 0 || uint64_t(array->GetNumberOfTuples()) != voxels)
  {
    vtkErrorMacro(<< "array '" << arrayName << "' has " << array->GetNumberOfTuples() << " values for "
                  << voxels << " voxels");
    return;
  }
  csgv::Geometry geometry;
  {
    double spacing[3], origin[3], first[3];
    image->GetSpacing(spacing);
    image->GetOrigin(origin);
    const double* d = image->GetDirectionMatrix()->GetData();
    for (int a = 0; a < 3; ++a)
    {
      geometry.spacing[a] = spacing[a];
    }
    for (int i = 0; i < 9; ++i)
    {
      geometry.direction[i] = d[i];
    }
    // Index (ext[0], ext[2], ext[4]) in world space: the extent need not start at 0.
    for (int r = 0; r < 3; ++r)
    {
      first[r] = origin[r];
      for (int c = 0; c < 3; ++c)
      {
        first[r] += d[3 * r + c] * ext[2 * c] * spacing[c];
      }
      geometry.origin[r] = first[r];
    }
    if (!isCell)
    {
      geometry = csgv::cellGeometryFromPointGeometry(geometry);
    }
  }

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

  // Plain contiguous storage for the scan and the encoder (deep copy only for exotic layouts).
  vtkSmartPointer<vtkDataArray> aos = array;
  if (!array->HasStandardMemoryLayout())
  {
    aos = vtk::TakeSmartPointer(vtkDataArray::CreateDataArray(array->GetDataType()));
    aos->DeepCopy(array);
  }
  const void* raw = aos->GetVoidPointer(0);
  this->UpdateProgress(0.0);

  csgv::LabelMapping mapping;
  csgv::Result<csgv::CompressedVolume> vol = csgv::Status::error("no labels");
  std::string error;
  auto progress = [this](double f) { this->UpdateProgress(0.05 + 0.8 * f); };
  switch (aos->GetDataType())
  {
    vtkTemplateMacro({
      const VTK_TT* values = static_cast<const VTK_TT*>(raw);
      const Scan scan = scanValues(values, size_t(voxels), dim, arrayName);
      if (!scan.error.empty())
      {
        error = scan.error;
        break;
      }
      if (scan.fits && !this->Relabel)
      {
        // Streamed from the array: no full-size copy.
        ArraySlabSource<VTK_TT> source(values, dim, progress);
        vol = csgv::encodeVolume(source, options);
      }
      else
      {
        csgv::InputVolume in;
        in.dim = dim;
        in.type = labelType;
        toInputValues(values, size_t(voxels), in.values);
        csgv::Result<csgv::LabelVolume> labels =
          csgv::prepareLabels(in, options.brickSize, this->Relabel != 0, mapping);
        if (!labels)
        {
          error = labels.message();
          break;
        }
        in = csgv::InputVolume{};
        ArraySlabSource<uint32_t> source(labels->labels.data(), dim, progress);
        vol = csgv::encodeVolume(source, options);
      }
    });
  }
  if (error.empty() && !vol)
  {
    error = vol.message();
  }
  if (!error.empty())
  {
    vtkErrorMacro(<< path << ": " << error);
    return;
  }
  this->UpdateProgress(0.9);

  csgv::VolumeMetadata md;
  md.dim = dim;
  md.geometry = geometry;
  md.originalType = typeName;
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
    status = csgv::writeCsgv(path, *vol);
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
