// SPDX-License-Identifier: MIT
/**
 * @file CSGVViewRenderer.h
 * @brief The renderer of one view: the view's share of the volume's cache budget and the
 * backend renderer created on demand. Frame state (change detection, the opaque depth,
 * accumulation, the still-render loop with its time budget) belongs to csgv::gpu::Renderer;
 * render() below is one call of Renderer::render. Settings, materials and geometry arrive here
 * once per render.
 *
 * Not a wrapped header: Core and VulkanBackend types may appear here.
 */
#ifndef CSGVViewRenderer_h
#define CSGVViewRenderer_h

#include "CSGVVolumeCache.h"

#include "csgv/gpu/Renderer.h"
#include "csgv/materials/Materials.h"

#include <array>
#include <cstdint>
#include <future>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace csgvrep
{

/// A property's value: one T, or `count` of them.
template <class T, int count>
using PropertyValue = std::conditional_t<count == 1, T, std::array<T, size_t(count)>>;
#define CSGV_UNPAREN(...) __VA_ARGS__

/// @brief The representation's property values, one field per row of CSGVProperties.def, which
/// holds their defaults (the server-manager XML's default_values are written from the same rows).
/// Units and meanings: the XML's documentation (Plugin/CSGV/CSGVRepresentation.xml.in).
struct RepresentationProperties
{
#define CSGV_PROPERTY(Name, member, type, count, values)                                           \
  PropertyValue<type, count> member{ CSGV_UNPAREN values };
#include "CSGVProperties.def"
#undef CSGV_PROPERTY
};

/// @brief Everything the representation's properties set, besides materials and the array, in
/// the backend's units. Made by toViewSettings (its defaults are RepresentationProperties').
struct ViewSettings
{
  csgv::gpu::RenderSettings render;
  uint64_t cacheBytes = 0;        ///< 0: automatic
  uint32_t processes = 1;         ///< ranks of the MPI job, which an automatic cache is shared by
  uint64_t deviceMemoryBytes = 0; ///< 0: automatic
  uint64_t hostMemoryBytes = 0;   ///< 0: automatic (csgv::TieredVolume::automaticBudget)
  int cachePaletting = 2;         ///< RepresentationProperties::cachePaletting
  csgv::gpu::RendererOptions::Decode decode = csgv::gpu::RendererOptions::Decode::Auto;
  uint32_t decodeSteps = 0; ///< csgv::gpu::RendererOptions::decodeStepsPerFrame (0: automatic)
  uint32_t framesPerStillRender = 0;
  double stillRenderTimeBudget = 0; ///< seconds
  double refinementSlice = 0;       ///< a still render's seconds when shorter than the budget (0: none)
  std::array<int, 6> clipBox{};     ///< inclusive voxels
  /// Values the settings do not take as given (outside their ranges, NaN, not among an
  /// enumeration's values, a light direction of zero or not finite), each naming the property and
  /// what is used instead: the representation warns with them.
  std::vector<std::string> notes;
};

/// The backend's settings of a set of property values (held to their ranges, as `notes` says, and
/// clamped to what the backend takes).
ViewSettings toViewSettings(const RepresentationProperties& p);

/// @brief One frame request from the compositing prop.
struct FrameRequest
{
  std::array<double, 16> worldToClip{}; ///< column-major (VTK's wcdc as it comes)
  uint32_t width = 0, height = 0;
  const float* opaqueDepth = nullptr; ///< window depth of the tile, row 0 at the bottom
  bool interactive = false;
  /// An image that will be written: no time budget, the still loop runs until every pixel holds
  /// the sample target (or the renderer's own idle limit: a cache too small to progress).
  bool capture = false;
};

/// @brief The renderer of one view (one representation instance) and its accumulation state.
class ViewRenderer
{
public:
  ViewRenderer();
  ~ViewRenderer();

  /// A changed source recreates the renderer; a changed geometry only resets accumulation; the
  /// same source and geometry return at once (no wait for the background preparation).
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
  /// Makes the renderer and the pipelines of its first frame on a thread of its own (compiling
  /// them takes a CPU device about 70 ms), so that the caller's work until that frame (ParaView's
  /// own first render) hides it; does nothing once a renderer exists. Every other call waits
  /// for it first; an error it meets is met again, and reported, by the next render().
  void prepareInBackground(bool depthInput);
  /// The last rendered image (premultiplied RGBA, 8 bits a channel, and window depth, rows
  /// bottom-up), plus the `parts` asked for (csgv::gpu::Renderer::Color: as floats; GBuffer:
  /// label, face, hit depth, distance), read on demand by the backend: compositing needs only
  /// the 8-bit colour and depth (each other part is a conversion of the whole image), picking the rest.
  const csgv::gpu::FrameOutput& output(uint32_t parts = csgv::gpu::Renderer::Color8 | csgv::gpu::Renderer::Depth);
  /// Statistics of the last frame rendered.
  const csgv::gpu::FrameStats& lastStats() const { return this->Stats; }
  /// The reduction factor per axis (1..8) of an interactive frame of `pixels` for a view drawn
  /// at `desiredRate` frames a second: the backend's time model (csgv::gpu::Renderer::
  /// interactiveReduction); 1 without a renderer.
  int interactiveReduction(double pixels, double desiredRate) const;
  /// The last render()'s `frames` of `pixels` each were drawn (rendered, read back, composited)
  /// in `seconds`: what the time model learns of a whole draw.
  void recordDraw(double seconds, uint32_t frames, double pixels);
  uint32_t framesLastRender() const { return this->FramesLastRender; }
  /// Device memory of this view's renderer: its brick cache and everything (the shared encoding
  /// upload included); 0 without a renderer.
  uint64_t cacheBytes() const;
  uint64_t deviceBytes() const;
  /// The device-memory budget of this view's renderer (its share of the volume's; 0 without one).
  uint64_t deviceBudget() const;
  /// How this view's renderer finds a label's material: "dense" (one table for every label its
  /// rays meet), "scan" (LabelLookup.h); "" without a renderer.
  std::string labelLookup() const;
  /// Bits per voxel of this view's brick cache: 32 (labels), fewer with cache paletting; 0
  /// without a renderer.
  uint32_t cacheBits() const;
  /// Whether this view's upload keeps the finest level in host memory (detail separation).
  bool detailSeparated() const;
  /// Finest-level streams this view's renderer uploaded (detail streaming), since it was made.
  uint64_t detailStreamedBytes() const;
  /// Where this view's upload reads the encoding (csgv::TieredVolume): 0 all in host memory, 1
  /// the coarse levels in memory and the finest level from the file, 2 every level from the file.
  int levelsOnDisk() const;
  /// Bytes the volume's tiers read from the file on demand (shared by its views).
  uint64_t fileReadBytes() const;
  /// Bricks this view's renderer failed to decode (drawn empty) and the first one's error.
  uint64_t badBricks() const;
  std::string firstBadBrick() const;
  /// The last still render whose view the brick cache could not hold (it decoded bricks again
  /// before it converged): the bricks its rays touched, the cache bytes they take and the cache's
  /// size; zeros when the last still render's cache held its view or never ran full.
  const csgv::gpu::Renderer::WorkingSet& cacheShortfall() const { return this->Shortfall; }

private:
  /// Makes the renderer (the backend's upload policy: csgv::gpu::planUpload) when there is none
  /// or it is made for other budgets, then updateRenderer. Returns an error message or "".
  std::string ensureRenderer();
  /// The volume's tiers under this host-memory budget (0: automatic), made once per volume and
  /// budget and shared by its views; null when the volume stays whole (it fits the budget, is
  /// not a mapped rANS two-table encoding, or is an MPI piece). `error` says why they failed.
  std::shared_ptr<const csgv::TieredVolume> tiersFor(SharedVolume& shared, uint64_t hostMemoryBytes, std::string& error);
  /// Brings the renderer up to date with what changed since: a piece's ghost faces and coarse
  /// stand-ins, geometry, materials, settings.
  std::string updateRenderer(SharedVolume& shared);
  /// Waits for prepareInBackground's work (every public call starts here).
  void settle() const;
  void releaseShare();

  VolumeSource Source;
  std::shared_ptr<VolumeCache> Cache; ///< the cache whose mutex guards Source.shared
  std::shared_ptr<csgv::gpu::Context> Context; ///< outlives Renderer
  std::unique_ptr<csgv::gpu::Renderer> Renderer; ///< destroyed before Source's volume
  uint64_t RendererCacheBytes = 0, RendererBudget = 0;
  uint32_t RendererDecodeSteps = 0;
  uint32_t RendererOtherLabel = 0; ///< RendererOptions::largestOtherLabel the renderer was made with
  /// Automatic cache paletting: a render found the cache of labels full (reset with the source
  /// and when the property changes).
  bool CachePressure = false;
  bool Warmed = false; ///< this renderer was asked to warm the other shading modes' pipelines
  bool Counted = false;
  ViewSettings Settings;
  csgv::MaterialDocument Materials;
  std::map<std::string, std::vector<float>> Attributes;
  bool MaterialsDirty = true, SettingsDirty = true, GeometryDirty = true;
  const void* GhostUploaded = nullptr;  ///< the SharedVolume::ghost the renderer has
  const void* CoarseUploaded = nullptr; ///< the SharedVolume::coarse the renderer has
  std::array<double, 16> LastMatrix{};
  csgv::gpu::FrameStats Stats;
  csgv::gpu::Renderer::WorkingSet Shortfall;
  uint32_t FramesLastRender = 0;
  mutable std::future<void> Preparing; ///< prepareInBackground's work
};

} // namespace csgvrep

#endif
