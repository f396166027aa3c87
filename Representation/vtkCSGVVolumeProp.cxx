// SPDX-License-Identifier: MIT
#include "vtkCSGVVolumeProp.h"

#include "CSGVAttributes.h"
#include "CSGVGpuContext.h"
#include "CSGVPresets.h"
#include "CSGVAdapter.h"
#include "CSGVQueryProtocol.h"
#include "CSGVViewRenderer.h"
#include "CSGVVolumeCache.h"

#include <vtkCallbackCommand.h>
#include <nlohmann/json.hpp>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkMatrix4x4.h>
#include <vtkObjectFactory.h>
#include <vtkOpenGLCamera.h>
#include <vtkOpenGLQuadHelper.h>
#include <vtkOpenGLRenderWindow.h>
#include <vtkOpenGLRenderPass.h>
#include <vtkOpenGLRenderer.h>
#include <vtkOpenGLShaderCache.h>
#include <vtkOpenGLState.h>
#include <vtkShaderProgram.h>
#include <vtkSmartPointer.h>
#include <vtkTextureObject.h>
#include <vtkWeakPointer.h>
#include <vtk_glew.h>

#include <algorithm>
#include <limits>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <map>
#include <vector>

namespace
{

/// The compositing shader: the output's premultiplied colour and its window depth. The
/// `//VTK::DepthPeeling::*` tags are where a translucent render pass (dual depth peeling, order
/// independent translucency) puts its code, as in VTK's own polygon shaders: the frame is then one
/// translucent layer at its first hit's depth, sorted with every other translucent surface.
/// `//CSGV::Straight::Impl` becomes an un-premultiplication when such a pass is active (VTK's
/// passes take straight colour, as VTK's mappers write it).
const char* const kFragmentShader = R"(//VTK::System::Dec
in vec2 texCoord;
uniform sampler2D csgvColor;
uniform sampler2D csgvDepth;
//VTK::DepthPeeling::Dec
//VTK::Output::Dec
void main()
{
  vec4 c = texture(csgvColor, texCoord);
  if (c.a <= 0.0)
  {
    discard;
  }
  gl_FragDepth = texture(csgvDepth, texCoord).r;
  //VTK::DepthPeeling::PreColor
  gl_FragData[0] = c;
  //CSGV::Straight::Impl
  //VTK::DepthPeeling::Impl
}
)";

/// CSGV_PROFILE_DISPATCHES: each draw prints its stages' times (README, "CSGV_PROFILE_DISPATCHES").
bool profiling()
{
  static const bool on = std::getenv("CSGV_PROFILE_DISPATCHES") != nullptr;
  return on;
}

/// The no-device message is the same for every view: say it once per process.
std::atomic<bool> deviceReported{ false };

/// The opaque depth of a reduced frame: the full tile's depth at each reduced pixel's centre.
void reduceDepth(const std::vector<float>& full, int width, int height, int factor, uint32_t w, uint32_t h,
  std::vector<float>& out)
{
  out.resize(size_t(w) * h);
  for (uint32_t y = 0; y < h; ++y)
  {
    const int fy = std::min(height - 1, int(y) * factor + factor / 2);
    for (uint32_t x = 0; x < w; ++x)
    {
      const int fx = std::min(width - 1, int(x) * factor + factor / 2);
      out[size_t(y) * w + x] = full[size_t(fy) * size_t(width) + size_t(fx)];
    }
  }
}

} // namespace

struct vtkCSGVVolumeProp::Impl
{
  vtkSmartPointer<vtkImageData> Input;
  csgvrep::VolumeSource Source; ///< what Input resolved to (in the representation's data phase)
  std::string SourceError;      ///< why it did not (reported there)
  uint64_t ReportedBadBricks = 0; ///< bricks that failed to decode, as last reported
  bool ReportedShortfall = false; ///< said that the cache cannot hold the view, until it can

  std::string MaterialsText;
  bool MaterialsParsed = false; ///< MaterialsText was parsed (the first SetMaterials may pass "")
  bool MaterialsValid = false;
  bool MaterialsOpaque = true;

  csgv::MaterialDocument Doc; ///< the parsed document (colormaps resolved)
  /// Doc without the materials that cannot be drawn as they stand (a half-finished edit, an
  /// attribute the volume does not have), its label-visibility overlay still on (the renderer
  /// gets it applied, csgv::effectiveMaterials); Skipped says why.
  csgv::MaterialDocument Drawn;
  std::vector<std::string> Skipped;
  std::string ReportedSkipped; ///< the Skipped reasons last warned about
  bool AttributesDirty = true;  ///< the renderer needs materials and attribute arrays again
  /// A query made while AttributesDirty built the next render's arrays and attribute function
  /// (DrawnMaterials): the render takes them instead of building them again. Valid while
  /// AttributesDirty has not been set anew (markAttributesDirty drops them).
  bool Queried = false;
  std::map<std::string, std::vector<float>> QueriedArrays;
  csgv::MaterialEvaluator::AttributeFn QueriedAttribute;
  void markAttributesDirty()
  {
    this->AttributesDirty = true;
    this->Queried = false;
    this->QueriedArrays.clear();
    this->QueriedAttribute = nullptr;
  }
  bool Prepared = false;        ///< PrepareRender handed the renderer all it needs
  bool Capture = false;         ///< SetCapture: the render is for a saved image
  csgvrep::AttributeConfig Config;
  csgvrep::AttributeCache Attributes;

  std::shared_ptr<csgv::gpu::Context> Gpu; ///< held while this prop draws
  /// The device, opened in the background from construction on (loading the Vulkan driver and
  /// opening a CPU device takes a good part of a second, which Show's own work hides).
  std::future<std::shared_ptr<csgv::gpu::Context>> GpuOpening;
  csgvrep::ViewRenderer View;
  std::string LastError;
  std::vector<float> Depth, ReducedDepth;
  int LodFactor = 1; ///< the reduction of the frame in the textures (1: full resolution)

  vtkWeakPointer<vtkOpenGLRenderWindow> Window;
  vtkSmartPointer<vtkTextureObject> Color, DepthTexture;
  /// The compositing quads, one per shader variant (plain, and each stage of a translucent
  /// render pass), keyed by their fragment source.
  std::map<std::string, std::unique_ptr<vtkOpenGLQuadHelper>> Quads;
  bool TexturesCurrent = false;
  /// One frame per render of the renderer: the first pass that draws in a render renders and
  /// uploads it, every pass of that render composites it (a depth-peeling translucent pass
  /// draws several times). The renderer's StartEvent sets FramePending.
  vtkWeakPointer<vtkRenderer> Watched;
  unsigned long WatchTag = 0;
  bool FramePending = true;
  bool FrameReady = false;  ///< the render's frame is in the textures
  /// The view's last output is what the last render of the renderer showed: cleared when the
  /// renderer starts a render, set when this prop's frame is ready. A render that drew nothing
  /// (an error, invalid materials, the display hidden) leaves it clear, so picks and the label
  /// image do not answer an older frame's pixels (found by an attack pass).
  bool ShowsLastFrame = false;
  int FrameRect[4] = {};    ///< its non-empty pixels in the tile: x, y, width, height
  // The output rectangle the textures were last uploaded from: outside it they hold empty texels,
  // as the output does outside its own rectangle (csgv::gpu::FrameOutput::rect).
  std::array<uint32_t, 4> UploadedRect{};

  /// The window the GL resources belong to: another one releases them first.
  void AdoptWindow(vtkOpenGLRenderWindow* win)
  {
    if (this->Window != win)
    {
      this->ReleaseGL(this->Window);
      this->Window = win;
    }
  }

  /// The compositing quad of a fragment source in window `win`, made (its shader compiled) at
  /// its first use there.
  vtkOpenGLQuadHelper* Quad(vtkOpenGLRenderWindow* win, const std::string& fragmentSource)
  {
    this->AdoptWindow(win);
    std::unique_ptr<vtkOpenGLQuadHelper>& quad = this->Quads[fragmentSource];
    if (!quad)
    {
      quad.reset(new vtkOpenGLQuadHelper(win, nullptr, fragmentSource.c_str(), ""));
    }
    else
    {
      win->GetShaderCache()->ReadyShaderProgram(quad->Program);
    }
    return quad.get();
  }

  void ReleaseGL(vtkWindow* window)
  {
    if (this->Color)
    {
      this->Color->ReleaseGraphicsResources(window);
    }
    if (this->DepthTexture)
    {
      this->DepthTexture->ReleaseGraphicsResources(window);
    }
    this->Color = nullptr;
    this->DepthTexture = nullptr;
    this->Quads.clear();
    this->Window = nullptr;
    this->TexturesCurrent = false;
  }
};

vtkStandardNewMacro(vtkCSGVVolumeProp);

void vtkCSGVVolumeProp::SetCapture(bool capture)
{
  this->P->Capture = capture;
}

vtkCSGVVolumeProp::vtkCSGVVolumeProp()
  : P(new Impl)
{
  this->P->GpuOpening = std::async(std::launch::async,
    []
    {
      std::string error; // kept by sharedContext: HaveDevice reports it
      return csgvrep::sharedContext(error);
    });
}

vtkCSGVVolumeProp::~vtkCSGVVolumeProp()
{
  if (this->P->Watched)
  {
    this->P->Watched->RemoveObserver(this->P->WatchTag);
  }
}

void vtkCSGVVolumeProp::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Input: " << this->P->Input.GetPointer() << "\n";
  os << indent << "Source: " << (this->P->Source.shared ? this->P->Source.shared->description : this->P->SourceError) << "\n";
  os << indent << "MaterialsValid: " << this->P->MaterialsValid << "\n";
  os << indent << "MaterialsOpaque: " << this->P->MaterialsOpaque << "\n";
}

void vtkCSGVVolumeProp::SetInput(
  vtkImageData* image, const csgvrep::VolumeSource& source, const std::string& error)
{
  Impl& p = *this->P;
  p.SourceError = error;
  if (image == p.Input && source.shared == p.Source.shared && source.corner == p.Source.corner)
  {
    return;
  }
  const bool newVolume = source.shared != p.Source.shared || image != p.Input;
  p.Input = image;
  p.Source = source;
  if (!source.shared)
  {
    p.View.clear();
  }
  else
  {
    p.View.setSource(source.placed(this->GetMatrix()));
  }
  if (newVolume)
  {
    p.markAttributesDirty(); // attributes come from the image's FieldData and the volume
  }
  this->Modified();
}

bool vtkCSGVVolumeProp::HasInput()
{
  return this->P->Source.shared != nullptr;
}

void vtkCSGVVolumeProp::SetViewSettings(const csgvrep::ViewSettings& settings)
{
  // Called once per render with every property: the view renderer detects what changed.
  this->P->View.setSettings(settings);
}

void vtkCSGVVolumeProp::SetMaterials(const std::string& json)
{
  Impl& p = *this->P;
  if (p.MaterialsParsed && json == p.MaterialsText)
  {
    return;
  }
  // Parsed here, not at render, so that errors appear when the property is set; the
  // representation sets the (default) document on construction, so rendering always has one.
  p.MaterialsText = json;
  p.MaterialsParsed = true;
  csgv::MaterialDocument doc;
  const std::string error = csgvrep::resolveMaterials(json, doc);
  p.MaterialsValid = error.empty();
  if (!p.MaterialsValid)
  {
    this->Report("Materials: " + error + " (nothing is drawn until the document is valid)");
  }
  else
  {
    // Opaque when every material is and hiding labels adds no transparent one (unknown attribute
    // values make effectiveMaterials add one wherever the exact document might).
    auto opaque = [](const csgv::MaterialDocument& d) {
      return std::all_of(d.materials.begin(), d.materials.end(),
        [](const csgv::Material& m) { return m.opacity >= 1.0f; });
    };
    p.MaterialsOpaque = opaque(doc) && opaque(csgv::effectiveMaterials(doc, {}));
    p.Doc = std::move(doc);
    p.markAttributesDirty();
  }
  this->Modified();
}

void vtkCSGVVolumeProp::SetAttributeConfig(const csgvrep::AttributeConfig& config)
{
  if (config != this->P->Config)
  {
    this->P->Config = config;
    this->P->markAttributesDirty();
    this->Modified();
  }
}

void vtkCSGVVolumeProp::AttributesChanged()
{
  this->P->markAttributesDirty();
  this->Modified();
}

void vtkCSGVVolumeProp::Report(const std::string& message)
{
  if (message == this->P->LastError)
  {
    return;
  }
  this->P->LastError = message;
  // A message quotes what it names: a value of megabytes set from Python stays a line.
  constexpr size_t kLongest = 2000;
  vtkErrorMacro(<< "Segmentation Volume: " << message.substr(0, kLongest)
                << (message.size() > kLongest ? "... (" + std::to_string(message.size() - kLongest) + " more characters)" : ""));
}

double* vtkCSGVVolumeProp::GetBounds()
{
  if (!this->P->Source.bounds(this->Bounds))
  {
    return nullptr;
  }
  // A placement that is not finite has no bounds (RenderFrame says why nothing is drawn).
  return csgvrep::placeBounds(this->GetMatrix(), this->Bounds) ? this->Bounds : nullptr;
}

bool vtkCSGVVolumeProp::LastLabels(
  uint32_t& width, uint32_t& height, std::vector<uint32_t>& labels, std::vector<float>& depths)
{
  if (!this->P->ShowsLastFrame)
  {
    width = height = 0; // the last render drew nothing here
    labels.clear();
    depths.clear();
    return false;
  }
  const csgv::gpu::FrameOutput& out = this->P->View.output(csgv::gpu::Renderer::GBuffer);
  width = out.width;
  height = out.height;
  labels = out.label;
  depths.assign(labels.size(), 0.0f);
  for (size_t i = 0; i < labels.size(); ++i)
  {
    depths[i] = float(csgvrep::hitOrder(labels[i] != csgv::kInvalidLabel, i < out.translucent.size() && out.translucent[i],
      i < out.hitDepth.size() ? out.hitDepth[i] : 1.0));
  }
  return !labels.empty();
}

bool vtkCSGVVolumeProp::DrawsTranslucent() const
{
  return this->P->MaterialsValid && !this->P->MaterialsOpaque;
}

vtkTypeBool vtkCSGVVolumeProp::HasTranslucentPolygonalGeometry()
{
  return this->DrawsTranslucent() ? 1 : 0;
}

vtkTypeBool vtkCSGVVolumeProp::HasOpaqueGeometry()
{
  return this->P->MaterialsValid && this->P->MaterialsOpaque ? 1 : 0;
}

int vtkCSGVVolumeProp::RenderOpaqueGeometry(vtkViewport* viewport)
{
  if (!this->P->MaterialsValid || !this->P->MaterialsOpaque)
  {
    return 0;
  }
  return this->Draw(viewport, true);
}

int vtkCSGVVolumeProp::RenderTranslucentPolygonalGeometry(vtkViewport* viewport)
{
  if (!this->P->MaterialsValid || this->P->MaterialsOpaque)
  {
    return 0;
  }
  return this->Draw(viewport, false);
}

int vtkCSGVVolumeProp::GetFramesLastRender()
{
  return csgvrep::renderStatistics(this->P->View).framesLastRender;
}

int vtkCSGVVolumeProp::GetMinSamples()
{
  return csgvrep::renderStatistics(this->P->View).minSamples;
}

double vtkCSGVVolumeProp::GetCacheMiB()
{
  return csgvrep::renderStatistics(this->P->View).cacheMiB;
}

double vtkCSGVVolumeProp::GetDeviceMiB()
{
  return csgvrep::renderStatistics(this->P->View).deviceMiB;
}

double vtkCSGVVolumeProp::GetDeviceBudgetMiB()
{
  return csgvrep::renderStatistics(this->P->View).deviceBudgetMiB;
}

int vtkCSGVVolumeProp::GetCacheBits()
{
  return csgvrep::renderStatistics(this->P->View).cacheBits;
}

int vtkCSGVVolumeProp::GetDetailSeparated()
{
  return csgvrep::renderStatistics(this->P->View).detailSeparated;
}

double vtkCSGVVolumeProp::GetDetailStreamedMiB()
{
  return csgvrep::renderStatistics(this->P->View).detailStreamedMiB;
}

int vtkCSGVVolumeProp::GetLevelsOnDisk()
{
  return csgvrep::renderStatistics(this->P->View).levelsOnDisk;
}

double vtkCSGVVolumeProp::GetFileReadMiB()
{
  return csgvrep::renderStatistics(this->P->View).fileReadMiB;
}

int vtkCSGVVolumeProp::GetBadBricks()
{
  return csgvrep::renderStatistics(this->P->View).badBricks;
}

bool vtkCSGVVolumeProp::DrawnMaterials(
  std::map<std::string, std::vector<float>>* arrays, csgv::MaterialEvaluator::AttributeFn* attribute)
{
  Impl& p = *this->P;
  // Attribute files and derived attributes a user gave are read even when no material names
  // them yet, so that one that cannot be read is said now.
  bool needed = !p.Config.files.empty() || !p.Config.derived.empty();
  for (const std::string& n : csgv::attributesUsed(p.Doc))
  {
    needed = needed || n != "label";
  }
  // The attribute table only when the document names attributes besides the label; one that
  // cannot be read is a real error, and the materials that need it are left out.
  std::shared_ptr<const csgv::AttributeTable> table;
  std::vector<std::string> available{ "label" };
  if (needed)
  {
    std::string error;
    table = p.Attributes.get(p.Input, p.View.source(), p.Config, error);
    if (table)
    {
      available = table->columnNames();
    }
    if (!error.empty())
    {
      // Unusable (no table), or a source left out of it: materials naming what is missing are
      // skipped below, with the reason.
      this->Report("attributes: " + error);
    }
  }
  p.Skipped.clear();
  p.Drawn = csgv::drawableMaterials(p.Doc, &available, &p.Skipped);
  // The same check whether a render asks (arrays) or a query (what is drawn): a query before the
  // next render says what that render will leave out.
  std::map<std::string, std::vector<float>> unused;
  if (table)
  {
    if (!arrays)
    {
      arrays = &unused;
    }
    if (attribute)
    {
      *attribute = table->attributeFunction();
    }
    // Arrays for the attributes the drawn materials name (only those are built and uploaded).
    // An attribute that cannot be one (text, or labels too large to index an array) leaves out
    // the materials that name it, with the reason; the others draw.
    std::map<std::string, std::string> unusable;
    for (const std::string& name : csgv::attributesUsed(p.Drawn))
    {
      std::map<std::string, std::vector<float>> one;
      const std::string why = csgvrep::denseColumns(*table, *p.View.source().shared, { name }, one);
      if (why.empty())
      {
        arrays->insert(one.begin(), one.end());
      }
      else
      {
        unusable[name] = why;
      }
    }
    if (!unusable.empty())
    {
      std::vector<std::string> usable;
      for (const std::string& name : available)
      {
        if (!unusable.count(name))
        {
          usable.push_back(name);
        }
      }
      p.Skipped.clear();
      p.Drawn = csgv::drawableMaterials(p.Doc, &usable, &p.Skipped);
      for (std::string& why : p.Skipped)
      {
        for (const auto& [name, reason] : unusable)
        {
          if (why.find("'" + name + "'") != std::string::npos)
          {
            why += " (" + reason + ")";
          }
        }
      }
      const std::vector<std::string> used = csgv::attributesUsed(p.Drawn);
      for (auto it = arrays->begin(); it != arrays->end();)
      {
        it = std::find(used.begin(), used.end(), it->first) == used.end() ? arrays->erase(it) : std::next(it);
      }
    }
  }
  // Materials left out (an attribute not available or not usable, an empty colormap range) are
  // said once, until the reasons change.
  std::string skipped;
  for (const std::string& why : p.Skipped)
  {
    skipped += (skipped.empty() ? "" : "; ") + why;
  }
  if (!skipped.empty() && skipped != p.ReportedSkipped)
  {
    vtkWarningMacro(<< "Segmentation Volume: " << skipped);
  }
  p.ReportedSkipped = skipped;
  return true;
}

bool vtkCSGVVolumeProp::PrepareRender()
{
  Impl& p = *this->P;
  p.Prepared = false;
  if (!p.Source.shared || !p.MaterialsValid)
  {
    return false;
  }
  if (p.AttributesDirty)
  {
    std::map<std::string, std::vector<float>> arrays;
    csgv::MaterialEvaluator::AttributeFn attribute;
    if (p.Queried)
    {
      // A query since the change built them (and said what it had to say).
      arrays = std::move(p.QueriedArrays);
      attribute = std::move(p.QueriedAttribute);
      p.Queried = false;
    }
    else if (!this->DrawnMaterials(&arrays, &attribute))
    {
      return false;
    }
    // The label-visibility overlay applied: the plain document that draws what p.Drawn means.
    p.View.setMaterials(csgv::effectiveMaterials(p.Drawn, attribute), std::move(arrays));
    p.AttributesDirty = false;
  }

  p.Prepared = true;
  // The first frame's renderer and pipelines are made from here on, beside ParaView's own work
  // until the prop draws (nothing once the renderer exists).
  p.View.prepareInBackground(this->DrawsTranslucent());
  return true;
}

namespace
{

/// The camera and tile of a frame: VTK's world-to-clip matrix and the renderer's tile.
bool frameRequest(vtkOpenGLRenderer* ren, vtkOpenGLCamera* camera, vtkOpenGLRenderWindow* win,
  csgvrep::FrameRequest& request, int& x0, int& y0)
{
  int width = 0, height = 0;
  ren->GetTiledSizeAndOrigin(&width, &height, &x0, &y0);
  if (width <= 0 || height <= 0)
  {
    return false;
  }
  vtkMatrix4x4* wcvc = nullptr;
  vtkMatrix4x4* vcdc = nullptr;
  vtkMatrix4x4* wcdc = nullptr;
  vtkMatrix3x3* normals = nullptr;
  camera->GetKeyMatrices(ren, wcvc, normals, vcdc, wcdc);
  // wcdc is stored transposed (ready for OpenGL): its row-major elements are the column-major
  // world-to-clip matrix the backend takes.
  const double* m = wcdc->GetData();
  std::copy(m, m + 16, request.worldToClip.begin());
  request.width = uint32_t(width);
  request.height = uint32_t(height);
  request.interactive = win->GetDesiredUpdateRate() > 1.0;
  return true;
}

/// Reads the opaque geometry's window depth of the tile (rays stop there) from the framebuffer
/// bound for reading, which holds the opaque pass's depth: the window's in a plain translucent
/// pass, and still the window's while dual depth peeling draws into its own framebuffer (which
/// has no depth buffer; VTK's peeling copies the opaque depth from the read framebuffer the same
/// way). No binding changes: vtkOpenGLState's cache stays true. False when there is no depth
/// to read (no depth attachment, a multisampled framebuffer).
bool readOpaqueDepth(vtkOpenGLState* state, int x0, int y0, int width, int height, std::vector<float>& depth)
{
  depth.resize(size_t(width) * height);
  while (glGetError() != GL_NO_ERROR)
  {
  }
  GLint readFbo = 0, type = GL_NONE;
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &readFbo);
  glGetFramebufferAttachmentParameteriv(GL_READ_FRAMEBUFFER, readFbo != 0 ? GL_DEPTH_ATTACHMENT : GL_DEPTH,
    GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE, &type);
  if (glGetError() != GL_NO_ERROR || type == GL_NONE)
  {
    return false;
  }
  state->vtkglPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(x0, y0, width, height, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
  return glGetError() == GL_NO_ERROR;
}

/// The render passes that asked to shape this prop's shaders in the current pass (dual depth
/// peeling, order-independent translucency: vtkOpenGLRenderPass::RenderPasses on its keys).
std::vector<vtkOpenGLRenderPass*> activeRenderPasses(vtkProp* prop)
{
  std::vector<vtkOpenGLRenderPass*> passes;
  vtkInformation* info = prop->GetPropertyKeys();
  if (info && info->Has(vtkOpenGLRenderPass::RenderPasses()))
  {
    const int n = info->Length(vtkOpenGLRenderPass::RenderPasses());
    for (int i = 0; i < n; ++i)
    {
      passes.push_back(static_cast<vtkOpenGLRenderPass*>(info->Get(vtkOpenGLRenderPass::RenderPasses(), i)));
    }
  }
  return passes;
}

} // namespace

bool vtkCSGVVolumeProp::UploadTextures(vtkOpenGLRenderWindow* win, bool changed)
{
  Impl& p = *this->P;
  const csgv::gpu::FrameOutput& out = p.View.output();
  p.AdoptWindow(win);
  if (!changed && p.TexturesCurrent && p.Color && p.Color->GetWidth() == out.width &&
    p.Color->GetHeight() == out.height)
  {
    return true; // the textures hold this output already
  }
  if (!p.Color)
  {
    p.Color = vtkSmartPointer<vtkTextureObject>::New();
    p.DepthTexture = vtkSmartPointer<vtkTextureObject>::New();
  }
  for (vtkTextureObject* t : { p.Color.GetPointer(), p.DepthTexture.GetPointer() })
  {
    t->SetContext(win);
    t->SetMinificationFilter(vtkTextureObject::Nearest);
    t->SetMagnificationFilter(vtkTextureObject::Nearest);
    t->SetWrapS(vtkTextureObject::ClampToEdge);
    t->SetWrapT(vtkTextureObject::ClampToEdge);
  }
  // A reduced interactive frame is stretched over the view: smooth colours, its depth as it is.
  p.Color->SetMagnificationFilter(p.LodFactor > 1 ? vtkTextureObject::Linear : vtkTextureObject::Nearest);
  vtkOpenGLState* state = win->GetState();
  state->vtkglPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  const std::array<uint32_t, 4> last = p.UploadedRect;
  p.UploadedRect = out.rect;
  if (p.TexturesCurrent && p.Color->GetHandle() && p.Color->GetWidth() == out.width &&
    p.Color->GetHeight() == out.height)
  {
    // Textures of this size hold the last output: only its rectangle and this one's change (a
    // CPU OpenGL copies every texel it is given).
    std::array<uint32_t, 4> r = csgv::gpu::rectUnion(out.rect, last);
    r[2] = std::min(r[2], out.width);
    r[3] = std::min(r[3], out.height);
    if (csgv::gpu::rectEmpty(r))
    {
      return true;
    }
    const size_t first = size_t(r[1]) * out.width + r[0];
    const GLsizei w = GLsizei(r[2] - r[0]), h = GLsizei(r[3] - r[1]);
    while (glGetError() != GL_NO_ERROR)
    {
    }
    state->vtkglPixelStorei(GL_UNPACK_ROW_LENGTH, GLint(out.width));
    p.Color->Activate();
    glTexSubImage2D(GL_TEXTURE_2D, 0, GLint(r[0]), GLint(r[1]), w, h, GL_RGBA, GL_UNSIGNED_BYTE,
      out.rgba8.data() + first);
    p.Color->Deactivate();
    p.DepthTexture->Activate();
    glTexSubImage2D(
      GL_TEXTURE_2D, 0, GLint(r[0]), GLint(r[1]), w, h, GL_RED, GL_FLOAT, out.depth.data() + first);
    p.DepthTexture->Deactivate();
    state->vtkglPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    if (glGetError() != GL_NO_ERROR)
    {
      p.TexturesCurrent = false; // created anew at the next frame
      this->Report("could not update the compositing textures");
      return false;
    }
    return true;
  }
  if (!p.Color->Create2DFromRaw(out.width, out.height, 4, VTK_UNSIGNED_CHAR, const_cast<uint32_t*>(out.rgba8.data())) ||
    !p.DepthTexture->Create2DFromRaw(out.width, out.height, 1, VTK_FLOAT, const_cast<float*>(out.depth.data())))
  {
    p.TexturesCurrent = false;
    this->Report("could not create the compositing textures");
    return false;
  }
  p.TexturesCurrent = true;
  return true;
}

bool vtkCSGVVolumeProp::Composite(vtkOpenGLRenderWindow* win, bool opaquePass)
{
  Impl& p = *this->P;
  // A translucent render pass shapes the shader (its tags) and owns the blending and depth-test
  // state it set up (peeling draws with MAX blending into a framebuffer of its own,
  // without depth test); without one, the frame is blended here, premultiplied, over what is
  // there, with depth test, writing depth in the opaque pass only (VTK's translucent surfaces
  // leave the depth buffer as the opaque pass left it).
  const std::vector<vtkOpenGLRenderPass*> passes =
    opaquePass ? std::vector<vtkOpenGLRenderPass*>() : activeRenderPasses(this);
  std::string vertexSource, geometrySource, fragmentSource = kFragmentShader;
  for (vtkOpenGLRenderPass* pass : passes)
  {
    pass->PreReplaceShaderValues(vertexSource, geometrySource, fragmentSource, nullptr, this);
  }
  if (!passes.empty())
  {
    vtkShaderProgram::Substitute(fragmentSource, "//CSGV::Straight::Impl", "gl_FragData[0].rgb /= c.a;");
  }
  for (vtkOpenGLRenderPass* pass : passes)
  {
    pass->PostReplaceShaderValues(vertexSource, geometrySource, fragmentSource, nullptr, this);
  }
  if (p.Window != win || !p.Color || !p.DepthTexture)
  {
    return false; // no frame uploaded to this window (RenderFrame adopts it first)
  }
  vtkOpenGLQuadHelper* quad = p.Quad(win, fragmentSource);
  if (!quad->Program || !quad->Program->GetCompiled())
  {
    this->Report("the compositing shader did not compile");
    return false;
  }
  vtkOpenGLState* state = win->GetState();
  vtkOpenGLState::ScopedglEnableDisable depthTest(state, GL_DEPTH_TEST);
  vtkOpenGLState::ScopedglEnableDisable blend(state, GL_BLEND);
  vtkOpenGLState::ScopedglDepthFunc depthFunc(state);
  vtkOpenGLState::ScopedglDepthMask depthMask(state);
  vtkOpenGLState::ScopedglBlendFuncSeparate blendFunc(state);
  vtkOpenGLState::ScopedglEnableDisable scissorTest(state, GL_SCISSOR_TEST);
  vtkOpenGLState::ScopedglScissor scissorBox(state);
  // The quad covers the viewport (the tile, or a peeling pass's framebuffer of the tile's size);
  // the rasteriser fills the output's non-empty part alone (a CPU OpenGL shades every covered
  // fragment: at 1280x720 a whole-tile quad costs milliseconds).
  int viewport[4];
  state->vtkglGetIntegerv(GL_VIEWPORT, viewport);
  state->vtkglEnable(GL_SCISSOR_TEST);
  state->vtkglScissor(viewport[0] + p.FrameRect[0], viewport[1] + p.FrameRect[1], p.FrameRect[2], p.FrameRect[3]);
  // Translucent layers never write depth (as vtkOpenGLActor does for translucent actors; order-
  // independent translucency leaves the mask on, so a later surface behind the frame's first hit
  // would be lost).
  state->vtkglDepthMask(opaquePass ? GL_TRUE : GL_FALSE);
  if (passes.empty())
  {
    state->vtkglEnable(GL_DEPTH_TEST);
    state->vtkglDepthFunc(GL_LEQUAL);
    state->vtkglEnable(GL_BLEND);
    // Premultiplied colour over what is there.
    state->vtkglBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  }

  p.Color->Activate();
  p.DepthTexture->Activate();
  quad->Program->SetUniformi("csgvColor", p.Color->GetTextureUnit());
  quad->Program->SetUniformi("csgvDepth", p.DepthTexture->GetTextureUnit());
  for (vtkOpenGLRenderPass* pass : passes)
  {
    pass->SetShaderParameters(quad->Program, nullptr, this, quad->VAO);
  }
  quad->Render();
  p.DepthTexture->Deactivate();
  p.Color->Deactivate();
  return true;
}

bool vtkCSGVVolumeProp::HaveDevice()
{
  Impl& p = *this->P;
  std::string contextError;
  if (!p.Gpu && p.GpuOpening.valid())
  {
    p.Gpu = p.GpuOpening.get();
  }
  if (!p.Gpu)
  {
    p.Gpu = csgvrep::sharedContext(contextError);
  }
  if (!p.Gpu && !deviceReported.exchange(true))
  {
    vtkErrorMacro(<< "Segmentation Volume: no usable Vulkan device, nothing is drawn ("
                  << contextError << ")");
  }
  return p.Gpu != nullptr;
}

int vtkCSGVVolumeProp::Draw(vtkViewport* viewport, bool opaquePass)
{
  Impl& p = *this->P;
  auto* ren = vtkOpenGLRenderer::SafeDownCast(viewport);
  // Hardware selection (picking) has no use for our colours; an input that did not resolve or
  // materials that did not apply (PrepareRender reported why) draw nothing.
  if (!ren || ren->GetSelector() || !p.Source.shared || !p.Prepared)
  {
    return 0;
  }
  auto* win = vtkOpenGLRenderWindow::SafeDownCast(ren->GetRenderWindow());
  if (!win)
  {
    return 0;
  }
  if (p.Watched != ren)
  {
    if (p.Watched)
    {
      p.Watched->RemoveObserver(p.WatchTag);
    }
    vtkNew<vtkCallbackCommand> onStart;
    onStart->SetClientData(&p);
    onStart->SetCallback([](vtkObject* caller, unsigned long, void* impl, void*)
      {
        static_cast<Impl*>(impl)->FramePending = true;
        // A hardware selection's render (ParaView's rectangle tools) draws no frame of ours and
        // leaves the screen as it was.
        auto* renderer = vtkRenderer::SafeDownCast(caller);
        if (!renderer || !renderer->GetSelector())
        {
          static_cast<Impl*>(impl)->ShowsLastFrame = false;
        }
      });
    p.WatchTag = ren->AddObserver(vtkCommand::StartEvent, onStart);
    p.Watched = ren;
    p.FramePending = true;
  }
  if (p.FramePending)
  {
    p.FramePending = false;
    p.FrameReady = this->RenderFrame(ren, win, opaquePass);
    p.ShowsLastFrame = p.FrameReady;
  }
  if (!p.FrameReady)
  {
    return 0;
  }
  const auto t0 = std::chrono::steady_clock::now();
  if (p.FrameRect[2] > 0 && p.FrameRect[3] > 0 && !this->Composite(win, opaquePass))
  {
    return 0;
  }
  if (profiling())
  {
    glFinish(); // the composite's own time
    std::fprintf(stderr, "composite: %.2f ms (%dx%d pixels)\n",
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(), p.FrameRect[2],
      p.FrameRect[3]);
  }
  return 1;
}

bool vtkCSGVVolumeProp::RenderFrame(vtkOpenGLRenderer* ren, vtkOpenGLRenderWindow* win, bool opaquePass)
{
  Impl& p = *this->P;
  if (p.Source.shared)
  {
    // Where the display's Position, Orientation and Scale put the volume now: a new place
    // starts the accumulation anew, the same place changes nothing.
    if (!csgvrep::usablePlacement(this->GetMatrix()))
    {
      char largest[32];
      std::snprintf(largest, sizeof largest, "%g", csgvrep::kLargestPlacement);
      this->Report(std::string("the display's Position, Scale, Orientation or Origin is not finite or beyond +-") +
        largest + " (the renderer works in floats): nothing is drawn");
      return false;
    }
    p.View.setSource(p.Source.placed(this->GetMatrix()));
  }
  auto* camera = vtkOpenGLCamera::SafeDownCast(ren->GetActiveCamera());
  csgvrep::FrameRequest request;
  int x0 = 0, y0 = 0;
  if (!camera || !this->HaveDevice() || !frameRequest(ren, camera, win, request, x0, y0))
  {
    return false;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const int width = int(request.width), height = int(request.height);
  // A saved image is never a preview: full resolution, no slice, no budget (SetCapture).
  request.capture = p.Capture;
  request.interactive = request.interactive && !p.Capture;
  // ParaView's level of detail: interactive frames at a resolution the backend's time model
  // chooses for the view's desired update rate (csgv/gpu/FramePolicy.h).
  const int factor = request.interactive
    ? p.View.interactiveReduction(double(width) * height, win->GetDesiredUpdateRate())
    : 1;
  request.width = uint32_t((width + factor - 1) / factor);
  request.height = uint32_t((height + factor - 1) / factor);
  // Translucent materials (drawn in the translucent pass): rays stop at the opaque geometry's
  // depth.
  if (!opaquePass && readOpaqueDepth(win->GetState(), x0, y0, width, height, p.Depth))
  {
    if (factor > 1)
    {
      reduceDepth(p.Depth, width, height, factor, request.width, request.height, p.ReducedDepth);
    }
    request.opaqueDepth = factor > 1 ? p.ReducedDepth.data() : p.Depth.data();
  }
  const auto tDepth = std::chrono::steady_clock::now();

  // An opaque pass's first compositing shader is compiled here, while the renderer and its
  // pipelines are still being made in the background (prepareInBackground): 30-40 ms of a CPU
  // OpenGL's first frame off its critical path.
  if (opaquePass && (p.Window != win || !p.Quads.count(kFragmentShader)))
  {
    (void)p.Quad(win, kFragmentShader);
  }
  bool changed = false;
  const std::string error = p.View.render(request, changed);
  if (!error.empty())
  {
    this->Report(error);
    return false;
  }
  p.LastError.clear();
  // Bricks whose encoding failed to decode are drawn empty and the rest renders: said once per
  // renderer (the count is CSGVBadBricks), naming the first.
  const uint64_t bad = p.View.badBricks();
  if (bad > 0 && p.ReportedBadBricks == 0)
  {
    vtkWarningMacro(<< "Segmentation Volume: " << bad << " brick(s) failed to decode and are drawn empty; the first: "
                    << p.View.firstBadBrick());
  }
  p.ReportedBadBricks = bad;
  // A view the brick cache cannot hold converges slowly (its bricks decoded again and again):
  // said once, until a still render's cache holds its view again.
  const csgv::gpu::Renderer::WorkingSet& shortfall = p.View.cacheShortfall();
  if (shortfall.bytes > shortfall.cacheBytes && !p.ReportedShortfall)
  {
    char text[512];
    std::snprintf(text, sizeof(text),
      "Segmentation Volume: this view touches %llu bricks, about %.1f MiB of brick cache, and the cache holds "
      "%.1f MiB: bricks are decoded again before the image converges (raise Cache Size (MiB) or Device "
      "Memory Budget (MiB) by at least %.0f MiB, or make the view smaller)",
      static_cast<unsigned long long>(shortfall.bricks), shortfall.bytes / 1048576.0,
      shortfall.cacheBytes / 1048576.0, std::ceil((shortfall.bytes - shortfall.cacheBytes) / 1048576.0));
    vtkWarningMacro(<< text);
  }
  p.ReportedShortfall = shortfall.bytes > shortfall.cacheBytes;
  const csgv::gpu::FrameOutput& out = p.View.output();
  if (out.width != request.width || out.height != request.height || out.rgba8.empty())
  {
    return false;
  }
  changed = changed || factor != p.LodFactor;
  p.LodFactor = factor;
  const auto t1 = std::chrono::steady_clock::now();
  if (!this->UploadTextures(win, changed))
  {
    return false;
  }
  const auto t2 = std::chrono::steady_clock::now();
  // The output's non-empty pixels in the tile's: the reduced frame's rectangle, a texel wider
  // (a stretched frame is filtered linearly), times the reduction, within the tile.
  for (int k = 0; k < 2; ++k)
  {
    const int extent = k == 0 ? width : height;
    const int margin = factor > 1 ? 1 : 0;
    const int lo = std::clamp((int(out.rect[size_t(k)]) - margin) * factor, 0, extent);
    const int hi = std::clamp((int(out.rect[size_t(k) + 2]) + margin) * factor, 0, extent);
    p.FrameRect[k] = lo;
    p.FrameRect[k + 2] = std::max(0, hi - lo);
  }
  const uint32_t frames = p.View.framesLastRender();
  if (profiling())
  {
    glFinish(); // the upload's own time, not the next GL call's
    auto ms = [](std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b)
    { return std::chrono::duration<double, std::milli>(b - a).count(); };
    std::fprintf(stderr, "draw: %u frames %.2f ms (opaque depth %.2f ms), textures %.2f ms\n", frames,
      ms(t0, t1), ms(t0, tDepth), ms(t1, t2));
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  p.View.recordDraw(seconds, frames, double(request.width) * request.height);
  return true;
}

void vtkCSGVVolumeProp::ReleaseGraphicsResources(vtkWindow* window)
{
  this->P->ReleaseGL(window);
  this->Superclass::ReleaseGraphicsResources(window);
}

std::string vtkCSGVVolumeProp::Query(const std::string& request)
{
  Impl& p = *this->P;
  csgvrep::QueryContext c;
  c.input = p.Input;
  c.source = p.Source.placed(this->GetMatrix()); // picks answer where the volume is drawn
  c.sourceError = p.Source.shared ? std::string() : (p.SourceError.empty() ? "no input" : p.SourceError);
  c.emptyInput = !p.Source.shared && (!p.Input || p.Input->GetNumberOfPoints() == 0);
  c.readError = p.Input ? csgvvtk::readErrorOf(p.Input->GetFieldData()) : std::string();
  if (p.MaterialsValid && p.Source.shared && p.AttributesDirty && !p.Queried)
  {
    // Not rendered since the last change: what it will draw. The arrays are kept for that render.
    p.QueriedArrays.clear();
    p.QueriedAttribute = nullptr;
    p.Queried = this->DrawnMaterials(&p.QueriedArrays, &p.QueriedAttribute);
  }
  c.materials = p.MaterialsValid ? &p.Drawn : nullptr;
  c.skipped = &p.Skipped;
  c.attributes = &p.Attributes;
  c.config = &p.Config;
  c.view = &p.View;
  c.drawn = p.ShowsLastFrame;
  // A request comes from any client or script: whatever it holds, the session goes on.
  try
  {
    return csgvrep::answerQuery(request, c);
  }
  catch (const std::exception& e)
  {
    return nlohmann::json({ { "error", std::string("cannot answer '") + request.substr(0, 80) + "': " + e.what() } })
      .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  }
}
