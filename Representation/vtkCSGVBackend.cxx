// SPDX-License-Identifier: MIT
#include "vtkCSGVBackend.h"

#include "vtkCSGVInternals.h" // the readers' FieldData layout (Readers/)

#include "csgv/codec/Encoder.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Relabel.h"
#include "csgv/gpu/Context.h"
#include "csgv/gpu/GpuVolume.h"

#include <vtkCellData.h>
#include <vtkColorTransferFunction.h>
#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkMatrix3x3.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSMTransferFunctionPresets.h>
#include <vtkUnsignedCharArray.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <tuple>
#include <type_traits>

namespace csgvrep
{
namespace
{

using nlohmann::json;

// ---------------------------------------------------------------------------------------------
// Geometry of an image

/// Corner geometry of the voxel grid an image's cell (or point) array describes, with the
/// grid's voxel dimensions. Extents need not start at 0.
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
  for (int i = 0; i < 3; ++i)
  {
    const int points = ext[2 * i + 1] - ext[2 * i] + 1;
    dims[i] = uint32_t(std::max(isCell ? points - 1 : points, 1));
  }
  return isCell ? g : csgv::cellGeometryFromPointGeometry(g);
}

void worldBox(const csgv::Geometry& g, const std::array<uint32_t, 3>& dims, double b[6])
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

// ---------------------------------------------------------------------------------------------
// Which data an input shows

bool isLabelType(int t)
{
  switch (t)
  {
    case VTK_CHAR:
    case VTK_SIGNED_CHAR:
    case VTK_UNSIGNED_CHAR:
    case VTK_SHORT:
    case VTK_UNSIGNED_SHORT:
    case VTK_INT:
    case VTK_UNSIGNED_INT:
    case VTK_LONG:
    case VTK_UNSIGNED_LONG:
    case VTK_LONG_LONG:
    case VTK_UNSIGNED_LONG_LONG:
    case VTK_ID_TYPE:
      return true;
    default:
      return false;
  }
}

/// The label array: by name (cell data first), or the first one-component integer array (cell
/// data first, VTK's own arrays such as vtkGhostType skipped), else the first float array.
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
        if (!a || a->GetNumberOfComponents() != 1 ||
          (a->GetName() && std::strncmp(a->GetName(), "vtk", 3) == 0))
        {
          continue;
        }
        const int t = a->GetDataType();
        if (wantInteger ? isLabelType(t) : (t == VTK_FLOAT || t == VTK_DOUBLE))
        {
          isCell = k == 0;
          return a;
        }
      }
    }
  }
  return nullptr;
}

/// True when the CSGV reader's encoding in the FieldData describes this image (the reader at
/// any level); false for images derived from it (Extract's sub-boxes, resampled data).
bool encodingDescribes(vtkImageData* image, const csgvvtk::EncodedInput& enc)
{
  const csgv::Geometry& g = enc.geometry;
  int ext[6];
  image->GetExtent(ext);
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
    const uint32_t expected = ((enc.volume.dim[i] - 1) >> level) + 1;
    const double tol = 1e-6 * std::max(1.0, std::abs(g.spacing[i]) * enc.volume.dim[i]);
    if (dims[i] != expected || std::abs(ig.origin[i] - g.origin[i]) > tol)
    {
      return false;
    }
  }
  return true;
}

struct CacheKey
{
  const void* array;
  vtkMTimeType mtime;
  int kind; ///< 0: encoding, 1: cell array, 2: point array
  std::array<uint32_t, 3> dims;
  bool operator<(const CacheKey& o) const
  {
    return std::tie(array, mtime, kind, dims) < std::tie(o.array, o.mtime, o.kind, o.dims);
  }
};

std::mutex& cacheMutex()
{
  static std::mutex m;
  return m;
}

std::map<CacheKey, std::weak_ptr<SharedVolume>>& volumeCache()
{
  static auto* cache = new std::map<CacheKey, std::weak_ptr<SharedVolume>>();
  return *cache;
}

std::shared_ptr<SharedVolume> lookup(const CacheKey& key)
{
  auto& cache = volumeCache();
  for (auto it = cache.begin(); it != cache.end();)
  {
    it = it->second.expired() ? cache.erase(it) : std::next(it);
  }
  auto it = cache.find(key);
  return it == cache.end() ? nullptr : it->second.lock();
}

/// Original labels of a relabelled volume as 32-bit labels, when every one fits.
std::vector<uint32_t> narrowMap(const std::vector<int64_t>& map, bool unsigned64)
{
  std::vector<uint32_t> out;
  out.reserve(map.size());
  for (int64_t v : map)
  {
    const bool fits = unsigned64 ? uint64_t(v) < 0xFFFFFFFFull : (v >= 0 && v < int64_t(0xFFFFFFFFll));
    if (!fits)
    {
      return {};
    }
    out.push_back(uint32_t(v));
  }
  return out;
}

template <class T>
std::string toLabels(const T* v, size_t n, const std::array<uint32_t, 3>& dims, const char* name,
  csgv::LabelVolume& labels, csgv::InputVolume& wide, bool& fits)
{
  fits = true;
  for (size_t i = 0; i < n; ++i)
  {
    const T x = v[i];
    if constexpr (std::is_floating_point<T>::value)
    {
      if (!(std::isfinite(x) && x == std::trunc(x) && std::abs(double(x)) < 9.2e18))
      {
        return std::string("array '") + name + "' holds " + std::to_string(double(x)) +
          ", which is not an integer label";
      }
    }
    if (!(x >= T(0) && double(x) < 4294967295.0))
    {
      fits = false;
    }
  }
  if (fits)
  {
    labels.dim = dims;
    labels.labels.resize(n);
    for (size_t i = 0; i < n; ++i)
    {
      labels.labels[i] = static_cast<uint32_t>(v[i]);
    }
    return std::string();
  }
  wide.dim = dims;
  const bool isSigned = std::is_floating_point<T>::value || std::is_signed<T>::value;
  wide.type = isSigned ? csgv::LabelType::I64 : csgv::LabelType::U64;
  wide.values.resize(n);
  for (size_t i = 0; i < n; ++i)
  {
    wide.values[i] = isSigned ? uint64_t(int64_t(v[i])) : uint64_t(v[i]);
  }
  return std::string();
}

/// Compresses a label array with Core's encoder (relabelling labels the format cannot hold).
std::string encodeArray(vtkDataArray* array, const std::array<uint32_t, 3>& dims, SharedVolume& out)
{
  const size_t n = size_t(dims[0]) * dims[1] * dims[2];
  if (array->GetNumberOfComponents() != 1)
  {
    return std::string("array '") + array->GetName() + "' has " +
      std::to_string(array->GetNumberOfComponents()) + " components; labels need one";
  }
  if (size_t(array->GetNumberOfTuples()) != n)
  {
    return std::string("array '") + array->GetName() + "' has " +
      std::to_string(array->GetNumberOfTuples()) + " values for " + std::to_string(n) + " voxels";
  }
  csgv::LabelVolume labels;
  csgv::InputVolume wide;
  bool fits = true;
  std::string error;
  const char* name = array->GetName() ? array->GetName() : "";
  switch (array->GetDataType())
  {
    vtkTemplateMacro(error = toLabels(static_cast<const VTK_TT*>(array->GetVoidPointer(0)), n, dims,
                       name, labels, wide, fits));
    default:
      return std::string("array '") + name + "' is not a label array (type " +
        array->GetDataTypeAsString() + ")";
  }
  if (!error.empty())
  {
    return error;
  }
  if (!fits)
  {
    csgv::LabelMapping mapping;
    csgv::Result<csgv::LabelVolume> relabelled = csgv::prepareLabels(wide, 32, false, mapping);
    if (!relabelled)
    {
      return relabelled.message();
    }
    labels = std::move(*relabelled);
    // Originals that do not fit 32 bits (negative, wide) cannot be named in materials:
    // materials then filter on the dense ids.
    std::vector<int64_t> bits(mapping.originalBits.begin(), mapping.originalBits.end());
    out.idToLabel = bits;
    out.storedToOriginal = narrowMap(bits, !csgv::isSignedType(mapping.type));
  }
  csgv::Result<csgv::CompressedVolume> encoded = csgv::encodeVolume(labels, csgv::EncodeOptions{});
  if (!encoded)
  {
    return encoded.message();
  }
  out.volume = std::move(*encoded);
  out.description = std::string("array '") + name + "' compressed" + (fits ? "" : " (relabelled)");
  return std::string();
}

/// What an input shows: the encoding, or an array. `kind` 0: encoding (enc filled), 1: cell
/// array, 2: point array. Returns an error message or "".
std::string chooseSource(vtkImageData* image, const std::string& labelArray, int& kind,
  csgvvtk::EncodedInput* enc, vtkUnsignedCharArray*& encArray, vtkDataArray*& array)
{
  encArray = nullptr;
  array = nullptr;
  vtkFieldData* fd = image->GetFieldData();
  auto* candidate = fd ? vtkUnsignedCharArray::SafeDownCast(fd->GetAbstractArray(csgvvtk::kEncodingName)) : nullptr;
  if (candidate && (labelArray.empty() || labelArray == csgvvtk::kLabelsName))
  {
    csgvvtk::EncodedInput local;
    csgvvtk::EncodedInput& e = enc ? *enc : local;
    const std::string error = csgvvtk::readEncodingArrays(fd, e);
    if (error.empty() && encodingDescribes(image, e))
    {
      kind = 0;
      encArray = candidate;
      return std::string();
    }
  }
  bool isCell = true;
  array = findLabelArray(image, labelArray, isCell);
  if (!array)
  {
    return labelArray.empty() ? std::string("the input has no label array (one-component integer "
                                            "cell or point data) and no CSGV encoding")
                              : "the input has no array named '" + labelArray + "'";
  }
  kind = isCell ? 1 : 2;
  return std::string();
}

// ---------------------------------------------------------------------------------------------
// ParaView presets

/// Control points of a ParaView preset, sampled at 1024 positions over [0, 1]; false when
/// ParaView has no preset of that name (or it holds no colours).
bool presetPoints(const std::string& name, json& points)
{
  vtkSMTransferFunctionPresets* presets = vtkSMTransferFunctionPresets::GetInstance();
  if (!presets)
  {
    return false;
  }
  int index = -1;
  presets->GetFirstPresetWithName(name.c_str(), index);
  if (index < 0)
  {
    return false;
  }
  json preset = json::parse(presets->GetPresetAsString(unsigned(index)), nullptr, false);
  if (preset.is_discarded() || !preset.is_object())
  {
    return false;
  }
  vtkNew<vtkColorTransferFunction> ctf;
  const std::string space = preset.value("ColorSpace", std::string("RGB"));
  if (space == "HSV")
    ctf->SetColorSpaceToHSV();
  else if (space == "Lab")
    ctf->SetColorSpaceToLab();
  else if (space == "Lab/CIEDE2000")
    ctf->SetColorSpaceToLabCIEDE2000();
  else if (space == "Diverging")
    ctf->SetColorSpaceToDiverging();
  else if (space == "Step")
    ctf->SetColorSpaceToStep();
  else
    ctf->SetColorSpaceToRGB();
  double lo = 0, hi = 1;
  if (preset.contains("RGBPoints") && preset["RGBPoints"].is_array() && preset["RGBPoints"].size() >= 8)
  {
    const json& p = preset["RGBPoints"];
    lo = p[0].get<double>();
    hi = p[p.size() - 4].get<double>();
    for (size_t i = 0; i + 3 < p.size(); i += 4)
    {
      ctf->AddRGBPoint(p[i].get<double>(), p[i + 1].get<double>(), p[i + 2].get<double>(),
        p[i + 3].get<double>());
    }
  }
  else if (preset.contains("IndexedColors") && preset["IndexedColors"].is_array() &&
    preset["IndexedColors"].size() >= 3)
  {
    // Categorical preset: equal steps of each colour.
    const json& c = preset["IndexedColors"];
    const size_t n = c.size() / 3;
    ctf->SetColorSpaceToStep();
    for (size_t i = 0; i < n; ++i)
    {
      ctf->AddRGBPoint(double(i) / double(n), c[3 * i].get<double>(), c[3 * i + 1].get<double>(),
        c[3 * i + 2].get<double>());
    }
    lo = 0;
    hi = double(n - 1) / double(n);
  }
  else
  {
    return false;
  }
  if (!(hi > lo))
  {
    hi = lo + 1;
  }
  points = json::array();
  const int samples = 1024;
  for (int i = 0; i < samples; ++i)
  {
    const double x = double(i) / (samples - 1);
    double rgb[3];
    ctf->GetColor(lo + x * (hi - lo), rgb);
    points.push_back({ x, std::clamp(rgb[0], 0.0, 1.0), std::clamp(rgb[1], 0.0, 1.0),
      std::clamp(rgb[2], 0.0, 1.0) });
  }
  return true;
}

} // namespace

// -----------------------------------------------------------------------------------------------

std::string resolveInput(vtkImageData* image, const std::string& labelArray, VolumeSource& out)
{
  out = VolumeSource{};
  if (!image || image->GetNumberOfPoints() == 0)
  {
    return "the input is empty";
  }
  int kind = 0;
  csgvvtk::EncodedInput enc;
  vtkUnsignedCharArray* encArray = nullptr;
  vtkDataArray* array = nullptr;
  std::string error = chooseSource(image, labelArray, kind, &enc, encArray, array);
  if (!error.empty())
  {
    return error;
  }
  std::array<uint32_t, 3> dims{ { 0, 0, 0 } };
  CacheKey key;
  if (kind == 0)
  {
    out.corner = enc.geometry;
    dims = enc.volume.dim;
    key = CacheKey{ encArray, encArray->GetMTime(), 0, dims };
  }
  else
  {
    out.corner = imageGeometry(image, kind == 1, dims);
    key = CacheKey{ array, array->GetMTime(), kind, dims };
  }
  std::lock_guard<std::mutex> lock(cacheMutex());
  out.shared = lookup(key);
  if (out.shared)
  {
    return std::string();
  }
  auto shared = std::make_shared<SharedVolume>();
  if (kind == 0)
  {
    shared->volume = std::move(enc.volume);
    shared->description = "CSGVEncoding";
    shared->arrayName = csgvvtk::kLabelsName;
    if (enc.info.relabelled)
    {
      shared->idToLabel = enc.info.map;
      shared->storedToOriginal = narrowMap(enc.info.map, enc.info.unsigned64);
    }
  }
  else
  {
    error = encodeArray(array, dims, *shared);
    if (!error.empty())
    {
      return error;
    }
    shared->arrayName = array->GetName() ? array->GetName() : "";
  }
  volumeCache()[key] = shared;
  out.shared = shared;
  return std::string();
}

bool inputBounds(vtkImageData* image, const std::string& labelArray, double bounds[6])
{
  if (!image || image->GetNumberOfPoints() == 0)
  {
    return false;
  }
  int kind = 0;
  csgvvtk::EncodedInput enc;
  vtkUnsignedCharArray* encArray = nullptr;
  vtkDataArray* array = nullptr;
  if (!chooseSource(image, labelArray, kind, &enc, encArray, array).empty())
  {
    return false;
  }
  if (kind == 0)
  {
    worldBox(enc.geometry, enc.volume.dim, bounds);
  }
  else
  {
    std::array<uint32_t, 3> dims;
    const csgv::Geometry g = imageGeometry(image, kind == 1, dims);
    worldBox(g, dims, bounds);
  }
  return true;
}

std::mutex& volumeMutex()
{
  return cacheMutex();
}

csgv::gpu::Context* sharedContext(std::string& error)
{
  static std::mutex m;
  static csgv::gpu::Context* context = nullptr;
  static std::string failure;
  static bool tried = false;
  std::lock_guard<std::mutex> lock(m);
  if (!tried)
  {
    tried = true;
    csgv::Result<std::unique_ptr<csgv::gpu::Context>> c = csgv::gpu::Context::create();
    if (c)
    {
      // Never destroyed: representations may outlive static destruction at exit, and the
      // driver reclaims everything when the process ends.
      context = c->release();
    }
    else
    {
      failure = c.message();
    }
  }
  error = failure;
  return context;
}

std::string resolveMaterials(const std::string& text, csgv::MaterialDocument& out)
{
  std::string trimmed = text;
  trimmed.erase(0, trimmed.find_first_not_of(" \t\r\n"));
  if (trimmed.empty())
  {
    out = csgv::defaultMaterials();
    return std::string();
  }
  std::string toParse = text;
  json doc = json::parse(text, nullptr, false);
  if (!doc.is_discarded() && doc.is_object() && doc.contains("materials") && doc["materials"].is_array())
  {
    bool replaced = false;
    for (json& m : doc["materials"])
    {
      if (!m.is_object() || !m.contains("color") || !m["color"].is_object())
      {
        continue;
      }
      json& color = m["color"];
      if (color.contains("colormap") && color["colormap"].is_string())
      {
        json points;
        if (presetPoints(color["colormap"].get<std::string>(), points))
        {
          color["colormap"] = points;
          replaced = true;
        }
      }
    }
    if (replaced)
    {
      toParse = doc.dump();
    }
  }
  csgv::Result<csgv::MaterialDocument> parsed = csgv::parseMaterials(toParse);
  if (!parsed)
  {
    return parsed.message();
  }
  csgv::Status s = csgv::resolveColormapNames(*parsed);
  if (!s)
  {
    return s.message();
  }
  out = std::move(*parsed);
  return std::string();
}

// -----------------------------------------------------------------------------------------------

ViewRenderer::ViewRenderer() = default;

ViewRenderer::~ViewRenderer()
{
  this->clear();
}

void ViewRenderer::releaseShare()
{
  if (this->Counted && this->Source.shared)
  {
    std::lock_guard<std::mutex> lock(cacheMutex());
    this->Source.shared->renderers--;
    this->Source.shared->sharesGeneration++;
  }
  this->Counted = false;
}

void ViewRenderer::clear()
{
  this->Renderer.reset();
  this->releaseShare();
  this->Source = VolumeSource{};
  this->Dirty = true;
  this->Converged = false;
}

void ViewRenderer::setSource(const VolumeSource& source)
{
  if (source.shared != this->Source.shared)
  {
    this->clear();
    this->Source = source;
    this->GeometryDirty = true;
    return;
  }
  const csgv::Geometry& a = source.corner;
  const csgv::Geometry& b = this->Source.corner;
  if (a.origin != b.origin || a.spacing != b.spacing || a.direction != b.direction)
  {
    this->Source.corner = source.corner;
    this->GeometryDirty = true;
  }
}

void ViewRenderer::setSettings(const ViewSettings& s)
{
  const ViewSettings& o = this->Settings;
  const csgv::gpu::RenderSettings& a = s.render;
  const csgv::gpu::RenderSettings& b = o.render;
  const bool same = a.shading == b.shading && a.shadingBlend == b.shadingBlend &&
    a.lodBias == b.lodBias && a.subsampling == b.subsampling && a.denoise == b.denoise &&
    a.lightDirection == b.lightDirection && s.cacheBytes == o.cacheBytes &&
    s.framesPerStillRender == o.framesPerStillRender &&
    s.stillRenderTimeBudget == o.stillRenderTimeBudget && s.clipBox == o.clipBox;
  if (!same)
  {
    this->Settings = s;
    this->SettingsDirty = true;
  }
}

void ViewRenderer::setMaterials(
  const csgv::MaterialDocument& doc, std::map<std::string, std::vector<float>> attributes)
{
  this->Materials = doc;
  this->Attributes = std::move(attributes);
  this->MaterialsDirty = true;
}

std::string ViewRenderer::ensureRenderer()
{
  std::string error;
  this->Context = sharedContext(error);
  if (!this->Context)
  {
    return error;
  }
  SharedVolume* shared = this->Source.shared.get();
  if (!shared)
  {
    return "no input";
  }
  {
    std::lock_guard<std::mutex> lock(cacheMutex());
    if (!shared->gpu)
    {
      csgv::Result<std::unique_ptr<csgv::gpu::GpuVolume>> gpu =
        csgv::gpu::GpuVolume::create(*this->Context, shared->volume);
      if (!gpu)
      {
        return "uploading the volume: " + gpu.message();
      }
      shared->gpu = std::shared_ptr<csgv::gpu::GpuVolume>(std::move(*gpu));
    }
    if (!this->Counted)
    {
      shared->renderers++;
      shared->sharesGeneration++;
      this->Counted = true;
    }
  }
  // Views of one volume split one cache budget.
  const uint64_t share = std::max<uint64_t>(
    this->Settings.cacheBytes / uint64_t(std::max(1, shared->renderers)), 16ull << 20);
  if (!this->Renderer || share != this->RendererCacheBytes)
  {
    this->Renderer.reset();
    csgv::gpu::RendererOptions options;
    options.cacheBytes = share;
    csgv::Result<std::unique_ptr<csgv::gpu::Renderer>> r =
      csgv::gpu::Renderer::create(*this->Context, shared->gpu, options);
    if (!r)
    {
      return "creating the renderer: " + r.message();
    }
    this->Renderer = std::move(*r);
    this->RendererCacheBytes = share;
    this->GeometryDirty = this->MaterialsDirty = this->SettingsDirty = true;
  }
  if (this->GeometryDirty)
  {
    this->Renderer->setGeometry(this->Source.corner);
    this->GeometryDirty = false;
    this->Dirty = true;
  }
  if (this->MaterialsDirty)
  {
    csgv::Status s = this->Renderer->setMaterials(this->Materials, this->Attributes, shared->storedToOriginal);
    if (!s)
    {
      return "materials: " + s.message();
    }
    this->MaterialsDirty = false;
    this->Dirty = true;
  }
  if (this->SettingsDirty)
  {
    csgv::gpu::RenderSettings rs = this->Settings.render;
    rs.sampleTarget = std::max<uint32_t>(1, this->Settings.framesPerStillRender);
    const std::array<int, 6>& c = this->Settings.clipBox;
    const bool whole = c[0] <= 0 && c[2] <= 0 && c[4] <= 0 && int64_t(c[1]) >= int64_t(shared->volume.dim[0]) - 1 &&
      int64_t(c[3]) >= int64_t(shared->volume.dim[1]) - 1 && int64_t(c[5]) >= int64_t(shared->volume.dim[2]) - 1;
    for (int a = 0; a < 3; ++a)
    {
      if (whole)
      {
        rs.clipMin[a] = rs.clipMax[a] = 0;
      }
      else
      {
        rs.clipMin[a] = std::max<int64_t>(0, c[2 * a]);
        rs.clipMax[a] = std::min<int64_t>(int64_t(shared->volume.dim[a]), int64_t(c[2 * a + 1]) + 1);
        if (rs.clipMax[a] <= rs.clipMin[a])
        {
          // An empty box on an axis would mean "whole volume" to the backend: keep it empty.
          rs.clipMin[a] = 0;
          rs.clipMax[a] = 0;
          return "the clip box is empty";
        }
      }
    }
    this->Renderer->setSettings(rs);
    this->SettingsDirty = false;
    this->Dirty = true;
  }
  return std::string();
}

const csgv::gpu::FrameOutput& ViewRenderer::outputWithGBuffer()
{
  if (!this->GBufferCurrent && this->Renderer && this->Output.width > 0)
  {
    if (this->Renderer->readOutput(this->Output, csgv::gpu::Renderer::GBuffer))
    {
      this->GBufferCurrent = true;
    }
  }
  return this->Output;
}

uint64_t ViewRenderer::cacheBytes() const
{
  if (!this->Renderer)
  {
    return 0;
  }
  for (const auto& b : this->Renderer->memory().buffers)
  {
    if (b.first == "brick cache")
    {
      return b.second;
    }
  }
  return 0;
}

uint64_t ViewRenderer::deviceBytes() const
{
  return this->Renderer ? this->Renderer->memory().total() : 0;
}

std::string ViewRenderer::render(const FrameRequest& req, bool& changed)
{
  changed = false;
  this->FramesLastRender = 0;
  std::string error = this->ensureRenderer();
  if (!error.empty())
  {
    return error;
  }
  if (req.worldToClip != this->LastMatrix || req.width != this->LastWidth || req.height != this->LastHeight)
  {
    this->LastMatrix = req.worldToClip;
    this->LastWidth = req.width;
    this->LastHeight = req.height;
    this->Dirty = true;
  }
  const size_t pixels = size_t(req.width) * req.height;
  if (req.opaqueDepth)
  {
    if (this->LastDepth.size() != pixels ||
      std::memcmp(this->LastDepth.data(), req.opaqueDepth, pixels * sizeof(float)) != 0)
    {
      this->LastDepth.assign(req.opaqueDepth, req.opaqueDepth + pixels);
      this->Dirty = true;
    }
  }
  else if (!this->LastDepth.empty())
  {
    this->LastDepth.clear();
    this->Dirty = true;
  }
  if (this->Dirty)
  {
    this->Renderer->resetAccumulation();
    this->Dirty = false;
    this->Converged = false;
  }
  else if (this->Converged)
  {
    return std::string(); // the last output is exact: nothing to render
  }

  csgv::gpu::FrameInput in;
  in.worldToClip = req.worldToClip;
  in.width = req.width;
  in.height = req.height;
  in.opaqueDepth = req.opaqueDepth;
  const uint32_t target = std::max<uint32_t>(1, this->Settings.framesPerStillRender);
  const uint32_t sub = std::max<uint32_t>(1, this->Settings.render.subsampling);
  const uint32_t maxFrames = target * sub * sub + 256;
  const auto t0 = std::chrono::steady_clock::now();
  uint32_t idle = 0;
  for (uint32_t f = 0; f < maxFrames; ++f)
  {
    csgv::Result<csgv::gpu::FrameStats> st = this->Renderer->renderFrame(in);
    if (!st)
    {
      return st.message();
    }
    this->Stats = *st;
    this->FramesLastRender++;
    if (req.interactive || st->minSamples >= target)
    {
      break;
    }
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The budget never cuts a frame short of one sample in every pixel (no holes).
    if (st->minSamples >= 1 && elapsed > this->Settings.stillRenderTimeBudget)
    {
      break;
    }
    idle = (st->newSamples == 0 && st->decodedBricks == 0) ? idle + 1 : 0;
    if (idle >= 3)
    {
      break;
    }
  }
  this->Converged = this->Stats.minSamples >= target;
  csgv::Status s = this->Renderer->readOutput(
    this->Output, csgv::gpu::Renderer::Color | csgv::gpu::Renderer::Depth);
  this->GBufferCurrent = false;
  if (!s)
  {
    return s.message();
  }
  changed = true;
  return std::string();
}

} // namespace csgvrep
