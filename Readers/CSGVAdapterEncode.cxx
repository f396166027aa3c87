// SPDX-License-Identifier: MIT
// CSGVAdapter.h, VTK array -> compressed volume: the one streaming encoder (encodeLabelArray),
// z-slab by z-slab from the array, relabelling (agreed between MPI pieces) when needed.
#include "CSGVAdapter.h"

#include <vtkDataArray.h>
#include <vtkSmartPointer.h>

#include <cmath>
#include <sstream>
#include <string>
#include <type_traits>

namespace csgvvtk
{
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
