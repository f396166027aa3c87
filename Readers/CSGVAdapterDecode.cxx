// SPDX-License-Identifier: MIT
// CSGVAdapter.h, compressed volume -> VTK: decoding a box of a level into an array of the
// original label type (decodeBox), the palette label range, VTK type names.
#include "CSGVAdapter.h"


#include <vtkAOSDataArrayTemplate.h>
#include <vtkDataArray.h>
#include <vtkType.h>

#include <algorithm>
#include <cstdlib>
#include <limits>
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
  // In chunks whose pages leave the process behind the sweep (a mapped file larger than memory).
  csgv::sweepBricks(vol, csgv::kSweepBricks, [&](uint64_t from, uint64_t to) {
    for (uint64_t i = from; i < to; ++i)
    {
      if (!csgv::brickSound(vol, i))
      {
        continue; // a bad brick (checkBrick): its decoder names it when it is reached
      }
      const csgv::BrickWords bw = vol.brick(i);
      // The palette is stored reversed at the end of the brick (Container.h).
      const uint32_t n = bw.words[L];
      for (uint32_t k = 0; k < n; ++k)
      {
        f(bw.words[bw.size - 1 - k]);
      }
    }
    return true;
  });
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
    if (fitsUnsigned<T>(std::numeric_limits<uint32_t>::max()))
    {
      return true; // every stored label fits: no sweep
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
    // Zeros past the labels, as many as the image has points beyond its cells: ParaView 5.11's
    // Contour by these cell labels runs vtkSynchronizedTemplates3D, which reads them as point
    // scalars, past the array's end (a fault where a guard page follows the allocation: an
    // OpenMP thread's stack did in paraview_filters).
    const uint64_t cells = sliceSize * nz, slack = (nx + 1) * (ny + 1) * (nz + 1) - cells;
    T* dst = static_cast<T*>(std::malloc(size_t(cells + slack) * sizeof(T)));
    if (!dst)
    {
      error = "out of memory for " + std::to_string(cells) + " labels";
      return;
    }
    std::fill(dst + cells, dst + cells + slack, T(0));
    typed->SetArray(dst, static_cast<vtkIdType>(cells), 0, vtkAOSDataArrayTemplate<T>::VTK_DATA_ARRAY_FREE);
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
  return paletteRange(vol, info, csgv::summarizePalettes(vol, csgv::kSummaryLabels));
}

vtkSmartPointer<vtkDataArray> paletteRange(
  const csgv::CompressedVolume& vol, const LabelInfo& info, const csgv::PaletteSummary& palettes)
{
  vtkSmartPointer<vtkDataArray> result;
  std::string warning;
  withConverter(vol, info, warning, [&](auto t, const auto& conv) {
    using T = decltype(t);
    bool any = false;
    T lo = T(0), hi = T(0);
    auto take = [&](uint32_t v) {
      if (conv.relabelled && v >= conv.table.size())
      {
        return; // reported when decoding
      }
      const T value = conv.relabelled ? conv.table[v] : static_cast<T>(v);
      lo = any ? std::min(lo, value) : value;
      hi = any ? std::max(hi, value) : value;
      any = true;
    };
    if (!conv.relabelled && palettes.entries)
    {
      take(palettes.smallest);
      take(palettes.largest);
    }
    else if (palettes.labelsComplete)
    {
      for (uint32_t v : palettes.labels)
      {
        take(v);
      }
    }
    else if (palettes.entries)
    {
      forEachPaletteEntry(vol, take); // more distinct ids than the summary lists
    }
    result = vtk::TakeSmartPointer(vtkDataArray::CreateDataArray(vtkTypeTraits<T>::VTK_TYPE_ID));
    auto* typed = static_cast<vtkAOSDataArrayTemplate<T>*>(result.GetPointer());
    typed->SetNumberOfValues(2);
    typed->SetValue(0, lo);
    typed->SetValue(1, hi);
  });
  return result;
}

} // namespace csgvvtk
