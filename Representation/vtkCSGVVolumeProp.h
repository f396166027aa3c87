// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVVolumeProp
 * @brief The prop of the "Segmentation Volume" representation: renders its image through
 * VulkanBackend and composites premultiplied colour and window depth into the OpenGL frame.
 *
 * Which pass draws it:
 * - Volumes whose materials are all opaque draw in the opaque pass. Depth testing then decides
 *   per pixel between the volume's first hit and other opaque geometry (the result is the same as
 *   stopping rays at that geometry), and translucent ParaView geometry, drawn later, blends over
 *   the volume correctly.
 * - Volumes with translucent materials draw in the volumetric pass (after opaque and translucent
 *   geometry): the opaque depth buffer is read and rays stop there, so opaque geometry occludes
 *   and is occluded correctly; translucent geometry in front of such a volume is overdrawn (the
 *   same limitation as VTK's own volume mappers without depth peeling for volumes).
 *
 * The camera is VTK's own: vtkOpenGLCamera::GetKeyMatrices' world-to-clip matrix (column-major,
 * as the backend takes it) and the renderer's tile, so perspective, parallel projection, tiles of
 * large screenshots and several views all match VTK exactly. Still renders accumulate frames
 * (FramesPerStillRender within StillRenderTimeBudget); interactive renders (the window's desired
 * update rate above 1, as vtkPVRenderView::InteractiveRender sets it) render one frame.
 *
 * Private header of CSGV::Representation (not wrapped): Core and VulkanBackend types appear only
 * behind the pimpl.
 */
#ifndef vtkCSGVVolumeProp_h
#define vtkCSGVVolumeProp_h

#include "vtkProp3D.h"

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

class vtkImageData;
class vtkOpenGLRenderWindow;
class vtkOpenGLRenderer;
class vtkWindow;

namespace csgvrep
{
struct AttributeConfig;
struct ViewSettings;
struct VolumeSource;
}

class vtkCSGVVolumeProp : public vtkProp3D
{
public:
  static vtkCSGVVolumeProp* New();
  vtkTypeMacro(vtkCSGVVolumeProp, vtkProp3D);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// Set while the view renders an image that will be written (SaveScreenshot, SaveAnimation,
  /// any resolution): such a render ignores the refinement slice and the still-render time
  /// budget and goes on until every pixel holds CSGVFramesPerStillRender samples at full
  /// resolution, denoised where the mode denoises. The budget limits interactive refinement,
  /// never the quality of a saved image.
  void SetCapture(bool capture);

  /// The image to draw (the delivered piece) and what it resolved to in the representation's
  /// data phase (the error when it did not): Draw only renders and composites.
  void SetInput(vtkImageData* image, const csgvrep::VolumeSource& source, const std::string& error);
  /// True when the input resolved to a volume.
  bool HasInput();
  /// Hands the view renderer the materials and the attribute arrays they name (building the
  /// attribute table, computed attributes included, when they changed): called by the
  /// representation before each render (REQUEST_RENDER), so that Draw only renders and
  /// composites. False (reported once) when there is nothing to draw.
  bool PrepareRender();
  void SetViewSettings(const csgvrep::ViewSettings& settings);
  /// The material document (MATERIALS.md); errors are reported and nothing is drawn.
  void SetMaterials(const std::string& json);
  /// Where per-label attributes come from besides the input's FieldData (CSGVAttributes.h).
  void SetAttributeConfig(const csgvrep::AttributeConfig& config);
  /// The attribute table behind the materials changed (computed attributes of all ranks).
  void AttributesChanged();

  /// Answers a query of vtkCSGVQuery (the commands: CSGVQueryProtocol.h).
  std::string Query(const std::string& request);

  double* GetBounds() override;
  using vtkProp3D::GetBounds;

  int RenderOpaqueGeometry(vtkViewport* viewport) override;
  /// Translucent materials are drawn as translucent geometry, not as a volume: the frame is one
  /// translucent layer at its first hit's depth, so that depth peeling (and order-independent
  /// translucency) sorts it with translucent surfaces and widgets; VTK's volume peeling needs
  /// its ray-casting shader, which a finished frame cannot take part in.
  int RenderTranslucentPolygonalGeometry(vtkViewport* viewport) override;
  vtkTypeBool HasTranslucentPolygonalGeometry() override;
  vtkTypeBool HasOpaqueGeometry() override;
  void ReleaseGraphicsResources(vtkWindow* window) override;

  /// Frames rendered by the last render call and the fewest samples of any pixel after it
  /// (for tests and benchmarks).
  int GetFramesLastRender();
  int GetMinSamples();
  /// This view's brick cache and its whole device memory (the shared encoding included), MiB.
  double GetCacheMiB();
  double GetDeviceMiB();
  double GetDeviceBudgetMiB();
  int GetCacheBits();
  int GetDetailSeparated();
  double GetDetailStreamedMiB();
  int GetLevelsOnDisk();
  double GetFileReadMiB();
  int GetBadBricks();
  /// The materials are valid and some are translucent (drawn in the translucent pass).
  bool DrawsTranslucent() const;
  /// The last render's first-hit labels (row 0 at the bottom) and their order among several
  /// ranks' hits (csgvrep::hitOrder: the window depth of an opaque hit); false when nothing was
  /// rendered.
  bool LastLabels(uint32_t& width, uint32_t& height, std::vector<uint32_t>& labels, std::vector<float>& depths);

protected:
  vtkCSGVVolumeProp();
  ~vtkCSGVVolumeProp() override;

private:
  vtkCSGVVolumeProp(const vtkCSGVVolumeProp&) = delete;
  void operator=(const vtkCSGVVolumeProp&) = delete;

  /// One pass: the first pass of a render of the renderer renders the frame (RenderFrame), every
  /// pass composites it with depth (a translucent pass may draw several times in one render:
  /// depth peeling).
  int Draw(vtkViewport* viewport, bool opaquePass);
  /// Renders through the view renderer (nothing when its output is still exact) and uploads
  /// the output; false when there is nothing to composite.
  bool RenderFrame(vtkOpenGLRenderer* ren, vtkOpenGLRenderWindow* win, bool opaquePass);

  /// The shared Vulkan context is there (reported once per process when not).
  bool HaveDevice();
  /// The document the renderer draws (Impl::Drawn, Impl::Skipped) and, when `arrays` is given,
  /// the per-label arrays of the attributes it names and (`attribute`) its per-label lookup;
  /// false after reporting a real error.
  bool DrawnMaterials(std::map<std::string, std::vector<float>>* arrays,
    std::function<double(const std::string&, uint32_t)>* attribute);
  /// The last output as colour and depth textures (uploaded again only when it changed).
  bool UploadTextures(vtkOpenGLRenderWindow* window, bool changed);
  /// Draws the textures over the framebuffer with depth, within the output's non-empty part
  /// (Impl::FrameRect): blended premultiplied with depth test on its own, or as the active
  /// translucent render pass (depth peeling) shapes its shader and state.
  bool Composite(vtkOpenGLRenderWindow* window, bool opaquePass);
  void Report(const std::string& message);

  struct Impl;
  std::unique_ptr<Impl> P;
};

#endif
