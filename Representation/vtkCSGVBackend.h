// SPDX-License-Identifier: MIT
/**
 * @file vtkCSGVBackend.h
 * @brief Glue between ParaView's image data and VulkanBackend for the "Segmentation Volume"
 * representation: one Vulkan context per process, one GpuVolume per distinct encoding (shared by
 * every view that shows it), on-the-fly compression of plain label arrays (cached until the array
 * changes), ParaView preset names in material documents, and the per-view frame loop.
 *
 * Not a wrapped header: Core and VulkanBackend types may appear here.
 */
#ifndef vtkCSGVBackend_h
#define vtkCSGVBackend_h

#include "csgv/attributes/Attributes.h"
#include "csgv/codec/Container.h"
#include "csgv/base/Geometry.h"
#include "csgv/materials/Materials.h"
#include "csgv/gpu/Renderer.h"

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

class vtkImageData;

namespace csgvrep
{

/// @brief One compressed volume and its upload, shared by every view showing the same data.
struct SharedVolume
{
  csgv::CompressedVolume volume;
  /// Stored label -> original label when the volume is relabelled and originals fit 32 bits.
  std::vector<uint32_t> storedToOriginal;
  /// Stored id -> original label bits for any relabelled volume (empty: stored labels are the
  /// originals); the key of attribute arrays.
  std::vector<int64_t> idToLabel;
  /// Computed attributes (voxel count, surface area, ...), computed once per volume on demand
  /// (guarded by the volume cache's mutex while being set).
  std::shared_ptr<const csgv::AttributeTable> computed;
  std::string arrayName;   ///< the label array users see ("Labels" for the CSGV encoding)
  std::string description; ///< where it came from ("CSGVEncoding", "array 'Labels' encoded")
  /// Declared after `volume`: destroyed first (it keeps a reference to `volume`).
  std::shared_ptr<csgv::gpu::GpuVolume> gpu;
  /// Renderers using this volume; each one's cache gets an equal share of the cache budget.
  int renderers = 0;
  uint64_t sharesGeneration = 0; ///< bumped when `renderers` changes
};

/// @brief What an input image resolves to.
struct VolumeSource
{
  std::shared_ptr<SharedVolume> shared;
  csgv::Geometry corner; ///< corner geometry of voxel (0,0,0) (Metadata.h)
};

/// Resolves the input: the FieldData encoding of the CSGV reader when it describes this image,
/// else the label array (by name, or the first integer array, cell data first), compressed once
/// and cached until the array changes. Returns an error message, or "" on success.
std::string resolveInput(vtkImageData* image, const std::string& labelArray, VolumeSource& out);

/// World bounds of the voxels the representation draws (point data: voxels centred on points,
/// so half a voxel beyond the image's bounds). False when there is nothing to draw.
bool inputBounds(vtkImageData* image, const std::string& labelArray, double bounds[6]);

/// The lock that guards the volume cache and SharedVolume's mutable members.
std::mutex& volumeMutex();

/// The process-wide Vulkan context, created on first use; null with the reason when there is
/// no usable device (the reason is the same on every call).
csgv::gpu::Context* sharedContext(std::string& error);

/// Parses a material document (MATERIALS.md; empty text: the default document), replacing
/// ParaView preset names by control points (1024 samples) and then Core's built-in names.
/// Returns an error message or "".
std::string resolveMaterials(const std::string& json, csgv::MaterialDocument& out);

/// @brief Everything the representation's properties set, besides materials and the array.
struct ViewSettings
{
  csgv::gpu::RenderSettings render;
  uint64_t cacheBytes = 256ull << 20;
  uint32_t framesPerStillRender = 16;
  double stillRenderTimeBudget = 3.0; ///< seconds
  std::array<int, 6> clipBox{ { 0, 2147483647, 0, 2147483647, 0, 2147483647 } }; ///< inclusive voxels
};

/// @brief One frame request from the compositing prop.
struct FrameRequest
{
  std::array<double, 16> worldToClip{}; ///< column-major (VTK's wcdc as it comes)
  uint32_t width = 0, height = 0;
  const float* opaqueDepth = nullptr; ///< window depth of the tile, row 0 at the bottom
  bool interactive = false;
};

/// @brief The renderer of one view (one representation instance) and its accumulation state.
class ViewRenderer
{
public:
  ViewRenderer();
  ~ViewRenderer();

  /// A changed source recreates the renderer; a changed geometry only resets accumulation.
  void setSource(const VolumeSource& source);
  void setSettings(const ViewSettings& settings);
  /// Materials and the per-stored-label arrays of the attributes they name.
  void setMaterials(const csgv::MaterialDocument& doc,
    std::map<std::string, std::vector<float>> attributes = {});
  /// The source this renderer draws (its shared volume and corner geometry).
  const VolumeSource& source() const { return this->Source; }
  /// The camera of the last render (column-major world-to-clip).
  const std::array<double, 16>& lastMatrix() const { return this->LastMatrix; }
  /// Forgets the source (and the renderer).
  void clear();

  /// Renders the frames this request calls for. `changed` is false when the previous output is
  /// still exact (same camera, size, depth and settings, accumulation complete): nothing was
  /// rendered and the caller may keep what it drew last time. Returns an error message or "".
  std::string render(const FrameRequest& request, bool& changed);
  /// The last rendered image (premultiplied RGBA and window depth, rows bottom-up).
  const csgv::gpu::FrameOutput& output() const { return this->Output; }
  /// The same with the G-buffer (label, face, hit depth, distance), read on demand: compositing
  /// needs only colour and depth, picking and the label image need the rest.
  const csgv::gpu::FrameOutput& outputWithGBuffer();
  /// Statistics of the last frame rendered.
  const csgv::gpu::FrameStats& lastStats() const { return this->Stats; }
  uint32_t framesLastRender() const { return this->FramesLastRender; }
  /// Device memory of this view's renderer: its brick cache and everything (the shared encoding
  /// upload included); 0 without a renderer.
  uint64_t cacheBytes() const;
  uint64_t deviceBytes() const;

private:
  std::string ensureRenderer();
  void releaseShare();

  VolumeSource Source;
  csgv::gpu::Context* Context = nullptr;
  std::unique_ptr<csgv::gpu::Renderer> Renderer; ///< destroyed before Source's volume
  uint64_t RendererCacheBytes = 0;
  uint64_t RendererGeneration = 0;
  bool Counted = false;
  ViewSettings Settings;
  csgv::MaterialDocument Materials;
  std::map<std::string, std::vector<float>> Attributes;
  bool MaterialsDirty = true, SettingsDirty = true, GeometryDirty = true;
  bool Dirty = true; ///< accumulation must restart
  bool Converged = false;
  std::array<double, 16> LastMatrix{};
  uint32_t LastWidth = 0, LastHeight = 0;
  std::vector<float> LastDepth;
  csgv::gpu::FrameOutput Output;
  bool GBufferCurrent = false;
  csgv::gpu::FrameStats Stats;
  uint32_t FramesLastRender = 0;
};

} // namespace csgvrep

#endif
