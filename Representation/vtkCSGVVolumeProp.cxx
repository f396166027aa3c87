// SPDX-License-Identifier: MIT
#include "vtkCSGVVolumeProp.h"

#include "vtkCSGVAttributes.h"
#include "vtkCSGVBackend.h"

#include <vtkImageData.h>
#include <vtkMatrix3x3.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkOpenGLCamera.h>
#include <vtkOpenGLQuadHelper.h>
#include <vtkOpenGLRenderWindow.h>
#include <vtkOpenGLRenderer.h>
#include <vtkOpenGLShaderCache.h>
#include <vtkOpenGLState.h>
#include <vtkShaderProgram.h>
#include <vtkSmartPointer.h>
#include <vtkTextureObject.h>
#include <vtkWeakPointer.h>
#include <vtk_glew.h>

#include <nlohmann/json.hpp>

#include <atomic>
#include <cmath>
#include <sstream>
#include <vector>

namespace
{

const char* const kFragmentShader = R"(//VTK::System::Dec
in vec2 texCoord;
uniform sampler2D csgvColor;
uniform sampler2D csgvDepth;
//VTK::Output::Dec
void main()
{
  vec4 c = texture(csgvColor, texCoord);
  if (c.a <= 0.0)
  {
    discard;
  }
  gl_FragData[0] = c;
  gl_FragDepth = texture(csgvDepth, texCoord).r;
}
)";

/// The no-device message is the same for every view: say it once per process.
std::atomic<bool> deviceReported{ false };

} // namespace

struct vtkCSGVVolumeProp::Impl
{
  vtkSmartPointer<vtkImageData> Input;
  vtkMTimeType InputTime = 0;
  std::string LabelArray;
  bool SourceDirty = true;
  bool BoundsValid = false;
  vtkMTimeType BoundsTime = 0;
  double Bounds[6] = { 0, -1, 0, -1, 0, -1 };

  std::string MaterialsText;
  bool MaterialsParsed = false;
  bool MaterialsValid = false;
  bool MaterialsOpaque = true;

  csgv::MaterialDocument Doc; ///< the parsed document (colormaps resolved)
  bool AttributesDirty = true;  ///< the renderer needs materials and attribute arrays again
  csgvrep::AttributeConfig Config;
  csgvrep::AttributeCache Attributes;

  csgvrep::ViewRenderer View;
  std::string LastError;
  std::vector<float> Depth;

  vtkWeakPointer<vtkOpenGLRenderWindow> Window;
  vtkSmartPointer<vtkTextureObject> Color, DepthTexture;
  std::unique_ptr<vtkOpenGLQuadHelper> Quad;
  bool TexturesCurrent = false;

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
    this->Quad.reset();
    this->Window = nullptr;
    this->TexturesCurrent = false;
  }

  /// Parses the material text once per change; reports through `report`.
  template <class Fn>
  void ParseMaterials(Fn report)
  {
    if (this->MaterialsParsed)
    {
      return;
    }
    this->MaterialsParsed = true;
    csgv::MaterialDocument doc;
    const std::string error = csgvrep::resolveMaterials(this->MaterialsText, doc);
    this->MaterialsValid = error.empty();
    if (!this->MaterialsValid)
    {
      report("Materials: " + error + " (nothing is drawn until the document is valid)");
      return;
    }
    this->MaterialsOpaque = true;
    for (const csgv::Material& m : doc.materials)
    {
      this->MaterialsOpaque = this->MaterialsOpaque && m.opacity >= 1.0f;
    }
    this->Doc = std::move(doc);
    this->AttributesDirty = true;
  }
};

vtkStandardNewMacro(vtkCSGVVolumeProp);

vtkCSGVVolumeProp::vtkCSGVVolumeProp()
  : P(new Impl)
{
}

vtkCSGVVolumeProp::~vtkCSGVVolumeProp() = default;

void vtkCSGVVolumeProp::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "LabelArray: " << this->P->LabelArray << "\n";
}

void vtkCSGVVolumeProp::SetInputImage(vtkImageData* image)
{
  const vtkMTimeType t = image ? image->GetMTime() : 0;
  if (image != this->P->Input || t != this->P->InputTime)
  {
    this->P->Input = image;
    this->P->InputTime = t;
    this->P->SourceDirty = true;
    this->P->BoundsValid = false;
    this->Modified();
  }
}

void vtkCSGVVolumeProp::SetLabelArrayName(const std::string& name)
{
  if (name != this->P->LabelArray)
  {
    this->P->LabelArray = name;
    this->P->SourceDirty = true;
    this->P->BoundsValid = false;
    this->Modified();
  }
}

void vtkCSGVVolumeProp::SetViewSettings(const csgvrep::ViewSettings& settings)
{
  this->P->View.setSettings(settings);
  this->Modified();
}

void vtkCSGVVolumeProp::SetMaterials(const std::string& json)
{
  if (json != this->P->MaterialsText || !this->P->MaterialsParsed)
  {
    this->P->MaterialsText = json;
    this->P->MaterialsParsed = false;
    // Parse now so that errors appear when the property is set, not at the next render.
    this->P->ParseMaterials([this](const std::string& m) { this->Report(m); });
    this->Modified();
  }
}

void vtkCSGVVolumeProp::SetAttributeConfig(const csgvrep::AttributeConfig& config)
{
  if (config != this->P->Config)
  {
    this->P->Config = config;
    this->P->AttributesDirty = true;
    this->Modified();
  }
}

void vtkCSGVVolumeProp::Report(const std::string& message)
{
  if (message == this->P->LastError)
  {
    return;
  }
  this->P->LastError = message;
  vtkErrorMacro(<< "Segmentation Volume: " << message);
}

double* vtkCSGVVolumeProp::GetBounds()
{
  Impl& p = *this->P;
  if (!p.BoundsValid)
  {
    p.BoundsValid = true;
    if (!p.Input || !csgvrep::inputBounds(p.Input, p.LabelArray, p.Bounds))
    {
      vtkMath::UninitializeBounds(p.Bounds);
      return nullptr;
    }
  }
  if (!vtkMath::AreBoundsInitialized(p.Bounds))
  {
    return nullptr;
  }
  std::copy(p.Bounds, p.Bounds + 6, this->Bounds);
  return this->Bounds;
}

vtkTypeBool vtkCSGVVolumeProp::HasOpaqueGeometry()
{
  return this->P->MaterialsValid && this->P->MaterialsOpaque ? 1 : 0;
}

int vtkCSGVVolumeProp::RenderOpaqueGeometry(vtkViewport* viewport)
{
  this->P->ParseMaterials([this](const std::string& m) { this->Report(m); });
  if (!this->P->MaterialsValid || !this->P->MaterialsOpaque)
  {
    return 0;
  }
  return this->Draw(viewport, true);
}

int vtkCSGVVolumeProp::RenderVolumetricGeometry(vtkViewport* viewport)
{
  this->P->ParseMaterials([this](const std::string& m) { this->Report(m); });
  if (!this->P->MaterialsValid || this->P->MaterialsOpaque)
  {
    return 0;
  }
  return this->Draw(viewport, false);
}

int vtkCSGVVolumeProp::GetFramesLastRender()
{
  return int(this->P->View.framesLastRender());
}

int vtkCSGVVolumeProp::GetMinSamples()
{
  return int(this->P->View.lastStats().minSamples);
}

double vtkCSGVVolumeProp::GetCacheMiB()
{
  return double(this->P->View.cacheBytes()) / (1 << 20);
}

double vtkCSGVVolumeProp::GetDeviceMiB()
{
  return double(this->P->View.deviceBytes()) / (1 << 20);
}

int vtkCSGVVolumeProp::Draw(vtkViewport* viewport, bool opaquePass)
{
  Impl& p = *this->P;
  auto* ren = vtkOpenGLRenderer::SafeDownCast(viewport);
  if (!ren || ren->GetSelector() || !p.Input || p.Input->GetNumberOfPoints() == 0)
  {
    // Hardware selection (picking) has no use for our colours; an empty input (a reader that
    // failed and said so) draws nothing without a second message.
    return 0;
  }
  auto* win = vtkOpenGLRenderWindow::SafeDownCast(ren->GetRenderWindow());
  auto* camera = vtkOpenGLCamera::SafeDownCast(ren->GetActiveCamera());
  if (!win || !camera)
  {
    return 0;
  }
  if (p.SourceDirty)
  {
    csgvrep::VolumeSource source;
    const std::string error = csgvrep::resolveInput(p.Input, p.LabelArray, source);
    if (!error.empty())
    {
      p.View.clear();
      this->Report(error);
      return 0;
    }
    p.View.setSource(source);
    p.SourceDirty = false;
    p.AttributesDirty = true;
  }
  if (p.AttributesDirty)
  {
    // Attribute arrays for the attributes the materials name (only those are built and uploaded).
    std::map<std::string, std::vector<float>> arrays;
    bool needed = false;
    for (const std::string& n : csgv::attributesUsed(p.Doc))
    {
      needed = needed || n != "label";
    }
    if (needed)
    {
      std::string error;
      std::shared_ptr<const csgv::AttributeTable> table =
        p.Attributes.get(p.Input, p.View.source(), p.Config, error);
      if (!table)
      {
        this->Report("attributes: " + error);
        return 0;
      }
      error = csgvrep::denseColumns(*table, *p.View.source().shared, csgv::attributesUsed(p.Doc), arrays);
      if (!error.empty())
      {
        this->Report("Materials: " + error);
        return 0;
      }
    }
    p.View.setMaterials(p.Doc, std::move(arrays));
    p.AttributesDirty = false;
  }

  std::string contextError;
  if (!csgvrep::sharedContext(contextError))
  {
    if (!deviceReported.exchange(true))
    {
      vtkErrorMacro(<< "Segmentation Volume: no usable Vulkan device, nothing is drawn ("
                    << contextError << ")");
    }
    return 0;
  }

  int width = 0, height = 0, x0 = 0, y0 = 0;
  ren->GetTiledSizeAndOrigin(&width, &height, &x0, &y0);
  if (width <= 0 || height <= 0)
  {
    return 0;
  }
  vtkMatrix4x4* wcvc = nullptr;
  vtkMatrix4x4* vcdc = nullptr;
  vtkMatrix4x4* wcdc = nullptr;
  vtkMatrix3x3* normals = nullptr;
  camera->GetKeyMatrices(ren, wcvc, normals, vcdc, wcdc);

  csgvrep::FrameRequest request;
  // wcdc is stored transposed (ready for OpenGL): its row-major elements are the column-major
  // world-to-clip matrix the backend takes.
  const double* m = wcdc->GetData();
  std::copy(m, m + 16, request.worldToClip.begin());
  request.width = uint32_t(width);
  request.height = uint32_t(height);
  request.interactive = win->GetDesiredUpdateRate() > 1.0;

  vtkOpenGLState* state = win->GetState();
  if (!opaquePass)
  {
    // Opaque geometry's depth: rays stop there. Read from the framebuffer being drawn.
    p.Depth.resize(size_t(width) * height);
    GLint drawFbo = 0, readFbo = 0, sampleBuffers = 0;
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &drawFbo);
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &readFbo);
    glGetIntegerv(GL_SAMPLE_BUFFERS, &sampleBuffers);
    bool haveDepth = false;
    if (sampleBuffers == 0)
    {
      while (glGetError() != GL_NO_ERROR)
      {
      }
      if (readFbo != drawFbo)
      {
        glBindFramebuffer(GL_READ_FRAMEBUFFER, GLuint(drawFbo));
      }
      state->vtkglPixelStorei(GL_PACK_ALIGNMENT, 4);
      glReadPixels(x0, y0, width, height, GL_DEPTH_COMPONENT, GL_FLOAT, p.Depth.data());
      haveDepth = glGetError() == GL_NO_ERROR;
      if (readFbo != drawFbo)
      {
        glBindFramebuffer(GL_READ_FRAMEBUFFER, GLuint(readFbo));
      }
    }
    if (haveDepth)
    {
      request.opaqueDepth = p.Depth.data();
    }
  }

  bool changed = false;
  const std::string error = p.View.render(request, changed);
  if (!error.empty())
  {
    this->Report(error);
    return 0;
  }
  p.LastError.clear();

  const csgv::gpu::FrameOutput& out = p.View.output();
  if (out.width != uint32_t(width) || out.height != uint32_t(height) || out.rgba.empty())
  {
    return 0;
  }
  if (p.Window != win)
  {
    p.ReleaseGL(p.Window);
    p.Window = win;
  }
  if (changed || !p.TexturesCurrent || !p.Color || p.Color->GetWidth() != out.width ||
    p.Color->GetHeight() != out.height)
  {
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
    state->vtkglPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    if (!p.Color->Create2DFromRaw(out.width, out.height, 4, VTK_FLOAT, const_cast<float*>(out.rgba.data())) ||
      !p.DepthTexture->Create2DFromRaw(out.width, out.height, 1, VTK_FLOAT, const_cast<float*>(out.depth.data())))
    {
      this->Report("could not create the compositing textures");
      return 0;
    }
    p.TexturesCurrent = true;
  }

  if (!p.Quad)
  {
    p.Quad.reset(new vtkOpenGLQuadHelper(win, nullptr, kFragmentShader, ""));
  }
  else
  {
    win->GetShaderCache()->ReadyShaderProgram(p.Quad->Program);
  }
  if (!p.Quad->Program || !p.Quad->Program->GetCompiled())
  {
    this->Report("the compositing shader did not compile");
    return 0;
  }

  vtkOpenGLState::ScopedglEnableDisable depthTest(state, GL_DEPTH_TEST);
  vtkOpenGLState::ScopedglEnableDisable blend(state, GL_BLEND);
  vtkOpenGLState::ScopedglDepthFunc depthFunc(state);
  vtkOpenGLState::ScopedglDepthMask depthMask(state);
  vtkOpenGLState::ScopedglBlendFuncSeparate blendFunc(state);
  state->vtkglEnable(GL_DEPTH_TEST);
  state->vtkglDepthFunc(GL_LEQUAL);
  state->vtkglDepthMask(GL_TRUE);
  state->vtkglEnable(GL_BLEND);
  // Premultiplied colour over what is there.
  state->vtkglBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);

  p.Color->Activate();
  p.DepthTexture->Activate();
  p.Quad->Program->SetUniformi("csgvColor", p.Color->GetTextureUnit());
  p.Quad->Program->SetUniformi("csgvDepth", p.DepthTexture->GetTextureUnit());
  p.Quad->Render();
  p.DepthTexture->Deactivate();
  p.Color->Deactivate();
  return 1;
}

void vtkCSGVVolumeProp::ReleaseGraphicsResources(vtkWindow* window)
{
  this->P->ReleaseGL(window);
  this->Superclass::ReleaseGraphicsResources(window);
}

namespace
{

std::string base64(const uint8_t* data, size_t n)
{
  static const char* const digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((n + 2) / 3 * 4);
  for (size_t i = 0; i < n; i += 3)
  {
    const uint32_t b0 = data[i], b1 = i + 1 < n ? data[i + 1] : 0, b2 = i + 2 < n ? data[i + 2] : 0;
    const uint32_t v = (b0 << 16) | (b1 << 8) | b2;
    out += digits[(v >> 18) & 63];
    out += digits[(v >> 12) & 63];
    out += i + 1 < n ? digits[(v >> 6) & 63] : '=';
    out += i + 2 < n ? digits[v & 63] : '=';
  }
  return out;
}

/// World point of window coordinates (pixel centre x, y; window depth z) under a column-major
/// world-to-clip matrix.
bool unproject(const std::array<double, 16>& m, double ndcX, double ndcY, double ndcZ, double world[3])
{
  vtkNew<vtkMatrix4x4> a;
  for (int r = 0; r < 4; ++r)
  {
    for (int c = 0; c < 4; ++c)
    {
      a->SetElement(r, c, m[size_t(4 * c + r)]);
    }
  }
  if (a->Determinant() == 0.0)
  {
    return false;
  }
  a->Invert();
  const double in[4] = { ndcX, ndcY, ndcZ, 1.0 };
  double out[4];
  a->MultiplyPoint(in, out);
  if (out[3] == 0.0)
  {
    return false;
  }
  for (int i = 0; i < 3; ++i)
  {
    world[i] = out[i] / out[3];
  }
  return true;
}

} // namespace

std::string vtkCSGVVolumeProp::Query(const std::string& request, vtkImageData* image)
{
  using nlohmann::json;
  Impl& p = *this->P;
  std::istringstream in(request);
  std::string what;
  in >> what;

  // The source: the one this prop renders, else the image resolved now.
  csgvrep::VolumeSource source = p.View.source();
  vtkImageData* input = p.Input;
  std::string sourceError;
  if (!source.shared)
  {
    input = p.Input ? p.Input.GetPointer() : image;
    sourceError = csgvrep::resolveInput(input, p.LabelArray, source);
  }
  std::shared_ptr<const csgv::AttributeTable> table;
  std::string tableError = sourceError;
  if (source.shared)
  {
    table = p.Attributes.get(input, source, p.Config, tableError);
  }

  if (what == "summary")
  {
    return csgvrep::attributeSummary(
      table.get(), source.shared.get(), source.shared ? source.shared->arrayName : std::string(), tableError);
  }
  if (what == "colors")
  {
    size_t cap = 4096;
    in >> cap;
    if (!source.shared)
    {
      return json({ { "error", sourceError } }).dump();
    }
    if (!p.MaterialsValid)
    {
      return json({ { "error", "the materials are not valid" } }).dump();
    }
    return csgvrep::labelColorsJson(p.Doc, table.get(), *source.shared, cap);
  }
  const csgv::gpu::FrameOutput& out = p.View.outputWithGBuffer();
  if (what == "labels")
  {
    // "W H base64(uint32 little-endian labels, row 0 at the bottom)" of the last render.
    std::ostringstream o;
    o << out.width << " " << out.height << " "
      << base64(reinterpret_cast<const uint8_t*>(out.label.data()), out.label.size() * 4);
    return o.str();
  }
  if (what == "pick")
  {
    long x = -1, y = -1;
    in >> x >> y;
    json r = { { "hit", false } };
    if (x < 0 || y < 0 || size_t(x) >= out.width || size_t(y) >= out.height || out.label.empty())
    {
      r["error"] = "no rendered pixel there";
      return r.dump();
    }
    const size_t i = size_t(y) * out.width + size_t(x);
    const uint32_t label = out.label[i];
    if (label == csgv::kInvalidLabel)
    {
      return r.dump();
    }
    r["hit"] = true;
    r["label"] = label;
    r["depth"] = i < out.hitDepth.size() ? double(out.hitDepth[i]) : 1.0;
    const csgv::Geometry& g = source.corner;
    const double nx = (double(x) + 0.5) / out.width * 2.0 - 1.0;
    const double ny = (double(y) + 0.5) / out.height * 2.0 - 1.0;
    double nearP[3], hitP[3];
    const std::array<double, 16>& m = p.View.lastMatrix();
    if (source.shared && unproject(m, nx, ny, -1.0, nearP) &&
      unproject(m, nx, ny, 2.0 * out.hitDepth[i] - 1.0, hitP))
    {
      double dir[3] = { hitP[0] - nearP[0], hitP[1] - nearP[1], hitP[2] - nearP[2] };
      const double len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
      if (len > 0 && i < out.distance.size() && std::isfinite(out.distance[i]) && out.distance[i] > 0)
      {
        // The world distance is more precise than window depth far from the camera.
        for (int k = 0; k < 3; ++k)
        {
          hitP[k] = nearP[k] + dir[k] / len * double(out.distance[i]);
        }
      }
      // Index coordinates: world = origin + D (idx * spacing).
      vtkNew<vtkMatrix3x3> d;
      for (int k = 0; k < 9; ++k)
      {
        d->SetElement(k / 3, k % 3, g.direction[size_t(k)]);
      }
      d->Invert();
      const double rel[3] = { hitP[0] - g.origin[0], hitP[1] - g.origin[1], hitP[2] - g.origin[2] };
      double idx[3];
      d->MultiplyPoint(rel, idx);
      const csgv::Face face = i < out.face.size() ? out.face[i] : csgv::Face::None;
      json voxel = json::array();
      for (int k = 0; k < 3; ++k)
      {
        idx[k] /= g.spacing[size_t(k)];
        long v = long(std::floor(idx[k]));
        // On the entry face the coordinate is an integer: the face says which side is the voxel.
        if (face == csgv::Face(1 + 2 * k))
        {
          v = long(std::lround(idx[k]));
        }
        else if (face == csgv::Face(2 + 2 * k))
        {
          v = long(std::lround(idx[k])) - 1;
        }
        const long dim = long(source.shared->volume.dim[size_t(k)]);
        voxel.push_back(std::max(0L, std::min(dim - 1, v)));
      }
      r["voxel"] = voxel;
      r["world"] = { hitP[0], hitP[1], hitP[2] };
    }
    r["attributes"] = json::parse(csgvrep::labelAttributesJson(table.get(), int64_t(label)));
    if (!tableError.empty())
    {
      r["error"] = tableError;
    }
    return r.dump();
  }
  return json({ { "error", "unknown query '" + what + "'" } }).dump();
}
