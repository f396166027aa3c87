// SPDX-License-Identifier: MIT
#include "vtkCSGVRepresentation.h"

#include "vtkCSGVAttributes.h"
#include "vtkCSGVBackend.h"
#include "vtkCSGVVolumeProp.h"

#include <vtkAlgorithm.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkPVRenderView.h>
#include <vtkPVView.h>
#include <vtkRenderer.h>

#include <algorithm>

vtkStandardNewMacro(vtkCSGVRepresentation);

vtkCSGVRepresentation::vtkCSGVRepresentation()
  : Prop(vtkCSGVVolumeProp::New())
{
  this->PushSettings();
  this->Prop->SetMaterials("");
}

vtkCSGVRepresentation::~vtkCSGVRepresentation()
{
  this->Prop->Delete();
}

void vtkCSGVRepresentation::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "LabelArray: " << this->LabelArray << "\n";
  os << indent << "Shading: " << this->Shading << "\n";
}

int vtkCSGVRepresentation::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  return 1;
}

int vtkCSGVRepresentation::RequestData(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  this->Cache = nullptr;
  if (inputVector[0]->GetNumberOfInformationObjects() == 1)
  {
    if (vtkImageData* input = vtkImageData::GetData(inputVector[0], 0))
    {
      // A shallow copy: arrays (and the encoding) are shared, so the volume cache, keyed by
      // array and modification time, finds what it compressed or uploaded before.
      this->Cache = vtkSmartPointer<vtkImageData>::New();
      this->Cache->ShallowCopy(input);
    }
  }
  return this->Superclass::RequestData(request, inputVector, outputVector);
}

int vtkCSGVRepresentation::ProcessViewRequest(
  vtkInformationRequestKey* request, vtkInformation* inInfo, vtkInformation* outInfo)
{
  if (!this->Superclass::ProcessViewRequest(request, inInfo, outInfo))
  {
    return 0;
  }
  if (request == vtkPVView::REQUEST_UPDATE())
  {
    vtkPVView::SetPiece(inInfo, this, this->Cache);
    // The data stays where it is (the server in client/server mode): images travel, not labels.
    vtkPVRenderView::SetDeliverToClientAndRenderingProcesses(inInfo, this, false, false);
    double bounds[6];
    if (this->Cache && csgvrep::inputBounds(this->Cache, this->LabelArray, bounds))
    {
      vtkPVRenderView::SetGeometryBounds(inInfo, this, bounds);
    }
    vtkPVRenderView::SetRequiresDistributedRendering(inInfo, this, true);
  }
  else if (request == vtkPVView::REQUEST_RENDER())
  {
    this->Prop->SetInputImage(vtkImageData::SafeDownCast(vtkPVView::GetDeliveredPiece(inInfo, this)));
  }
  return 1;
}

bool vtkCSGVRepresentation::AddToView(vtkView* view)
{
  if (auto* rview = vtkPVRenderView::SafeDownCast(view))
  {
    rview->GetRenderer()->AddActor(this->Prop);
    return this->Superclass::AddToView(view);
  }
  return false;
}

bool vtkCSGVRepresentation::RemoveFromView(vtkView* view)
{
  if (auto* rview = vtkPVRenderView::SafeDownCast(view))
  {
    // GL resources go with the window (vtkTextureObject and the quad helper register their
    // release with it); releasing here could touch a context already gone at exit.
    rview->GetRenderer()->RemoveActor(this->Prop);
    return this->Superclass::RemoveFromView(view);
  }
  return false;
}

void vtkCSGVRepresentation::SetVisibility(bool visible)
{
  this->Superclass::SetVisibility(visible);
  this->Prop->SetVisibility(visible);
}

void vtkCSGVRepresentation::PushSettings()
{
  csgvrep::ViewSettings s;
  s.render.shading = csgv::gpu::Shading(std::clamp(this->Shading, 0, 3));
  s.render.shadingBlend = float(std::clamp(this->ShadingBlend, 0.0, 1.0));
  s.render.lodBias = float(this->LODBias);
  int sub = 1;
  while (sub < 8 && sub < this->Subsampling)
  {
    sub *= 2;
  }
  s.render.subsampling = uint32_t(sub);
  s.render.denoise = this->Denoise != 0;
  for (int i = 0; i < 3; ++i)
  {
    s.render.lightDirection[i] = float(this->LightDirection[i]);
  }
  s.cacheBytes = uint64_t(std::max(16, this->CacheSizeMiB)) << 20;
  s.framesPerStillRender = uint32_t(std::max(1, this->FramesPerStillRender));
  s.stillRenderTimeBudget = std::max(0.0, this->StillRenderTimeBudget);
  std::copy(this->ClipBox, this->ClipBox + 6, s.clipBox.begin());
  this->Prop->SetViewSettings(s);
  this->Modified();
}

void vtkCSGVRepresentation::SetLabelArray(const char* name)
{
  const std::string n = name ? name : "";
  if (n != this->LabelArray)
  {
    this->LabelArray = n;
    this->Prop->SetLabelArrayName(n);
    this->MarkModified(); // bounds may change (cell vs point data)
  }
}

void vtkCSGVRepresentation::SetShading(int mode)
{
  this->Shading = mode;
  this->PushSettings();
}

void vtkCSGVRepresentation::SetShadingBlend(double blend)
{
  this->ShadingBlend = blend;
  this->PushSettings();
}

void vtkCSGVRepresentation::SetFramesPerStillRender(int frames)
{
  this->FramesPerStillRender = frames;
  this->PushSettings();
}

void vtkCSGVRepresentation::SetStillRenderTimeBudget(double seconds)
{
  this->StillRenderTimeBudget = seconds;
  this->PushSettings();
}

void vtkCSGVRepresentation::SetLODBias(double bias)
{
  this->LODBias = bias;
  this->PushSettings();
}

void vtkCSGVRepresentation::SetSubsampling(int s)
{
  this->Subsampling = s;
  this->PushSettings();
}

void vtkCSGVRepresentation::SetDenoise(int on)
{
  this->Denoise = on;
  this->PushSettings();
}

void vtkCSGVRepresentation::SetLightDirection(double x, double y, double z)
{
  this->LightDirection[0] = x;
  this->LightDirection[1] = y;
  this->LightDirection[2] = z;
  this->PushSettings();
}

void vtkCSGVRepresentation::SetCacheSizeMiB(int mib)
{
  this->CacheSizeMiB = mib;
  this->PushSettings();
}

void vtkCSGVRepresentation::SetClipBox(int x0, int x1, int y0, int y1, int z0, int z1)
{
  const int box[6] = { x0, x1, y0, y1, z0, z1 };
  std::copy(box, box + 6, this->ClipBox);
  this->PushSettings();
}

void vtkCSGVRepresentation::SetMaterials(const char* json)
{
  this->Prop->SetMaterials(json ? json : "");
  this->Modified();
}

int vtkCSGVRepresentation::GetFramesLastRender()
{
  return this->Prop->GetFramesLastRender();
}

int vtkCSGVRepresentation::GetMinSamples()
{
  return this->Prop->GetMinSamples();
}

double vtkCSGVRepresentation::GetCacheMiB()
{
  return this->Prop->GetCacheMiB();
}

double vtkCSGVRepresentation::GetDeviceMiB()
{
  return this->Prop->GetDeviceMiB();
}

void vtkCSGVRepresentation::PushAttributes()
{
  csgvrep::AttributeConfig c;
  c.files = this->AttributeFiles;
  for (size_t i = 0; i + 1 < this->DerivedAttributes.size(); i += 2)
  {
    c.derived.emplace_back(this->DerivedAttributes[i], this->DerivedAttributes[i + 1]);
  }
  c.computed = this->ComputedAttributes != 0;
  this->Prop->SetAttributeConfig(c);
  this->Modified();
}

void vtkCSGVRepresentation::AddAttributeFile(const char* path)
{
  this->AttributeFiles.emplace_back(path ? path : "");
  this->PushAttributes();
}

void vtkCSGVRepresentation::ClearAttributeFiles()
{
  this->AttributeFiles.clear();
  this->PushAttributes();
}

void vtkCSGVRepresentation::AddDerivedAttribute(const char* name, const char* expression)
{
  this->DerivedAttributes.emplace_back(name ? name : "");
  this->DerivedAttributes.emplace_back(expression ? expression : "");
  this->PushAttributes();
}

void vtkCSGVRepresentation::ClearDerivedAttributes()
{
  this->DerivedAttributes.clear();
  this->PushAttributes();
}

void vtkCSGVRepresentation::SetComputedAttributes(int on)
{
  this->ComputedAttributes = on;
  this->PushAttributes();
}

const char* vtkCSGVRepresentation::Query(const char* request)
{
  if (!this->Cache && this->GetNumberOfInputConnections(0) > 0)
  {
    // Asked before the view updated this representation (attributes right after Show): bring
    // the input here first. Queries run on the rendering processes only (vtkCSGVQuery).
    this->Update();
  }
  this->QueryResult = this->Prop->Query(request ? request : "", this->Cache);
  return this->QueryResult.c_str();
}
