// SPDX-License-Identifier: MIT
#include "vtkCSGVRepresentation.h"

#include "CSGVAttributes.h"
#include "CSGVPieceAttributes.h"
#include "CSGVViewRenderer.h"
#include "CSGVVolumeCache.h"
#include "vtkCSGVVolumeProp.h"

#include "CSGVAdapter.h"

#include <vtkAlgorithm.h>
#include <vtkExecutive.h>
#include <vtkInformationExecutivePortKey.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkCommunicator.h>
#include <vtkMultiProcessController.h>
#include <vtkObjectFactory.h>
#include <vtkPVRenderView.h>
#include <vtkPVView.h>
#include <vtkRenderer.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>

namespace
{

/// A property's value between the representation's members (T or T[n]) and
/// csgvrep::RepresentationProperties' fields (T or std::array<T, n>), both ways.
template <class T>
void copyProperty(const T& from, T& to)
{
  to = from;
}
template <class T, size_t n>
void copyProperty(const std::array<T, n>& from, T (&to)[n])
{
  std::copy(from.begin(), from.end(), to);
}
template <class T, size_t n>
void copyProperty(const T (&from)[n], std::array<T, n>& to)
{
  std::copy(from, from + n, to.begin());
}
template <class T>
void printProperty(ostream& os, const T& v)
{
  os << " " << v << "\n";
}
template <class T, size_t n>
void printProperty(ostream& os, const T (&v)[n])
{
  for (const T& x : v)
  {
    os << " " << x;
  }
  os << "\n";
}

/// vtkPVView::GetInCaptureScreenshot is protected in ParaView 5.11 (public from 5.12): read it
/// through a member pointer named by a subclass, which C++'s access rules allow.
struct CaptureState : vtkPVView
{
  static bool Of(vtkPVView* view)
  {
    return view && (view->*(&CaptureState::GetInCaptureScreenshot))();
  }
};
bool InCaptureScreenshot(vtkPVView* view)
{
  return CaptureState::Of(view);
}
} // namespace

vtkStandardNewMacro(vtkCSGVRepresentation);

/// @brief What the input resolved to, remembered per (image, modification time, label array),
/// so that REQUEST_UPDATE and REQUEST_RENDER of an unchanged input do no work at all.
struct vtkCSGVRepresentation::vtkInternals
{
  std::shared_ptr<csgvrep::VolumeCache> Volumes = csgvrep::VolumeCache::instance();
  vtkImageData* Image = nullptr; ///< identity only (Cache or the delivered piece keeps it alive)
  vtkSmartPointer<vtkImageData> NoPiece; ///< the piece of a process without input (ProcessViewRequest)
  /// The piece the last render drew where this copy has no input of its own (the client's copy,
  /// when a server that cannot render makes the client render: ParaView moved the piece there).
  vtkWeakPointer<vtkImageData> Delivered;
  vtkMTimeType ImageTime = 0;
  std::string Array;
  bool Resolved = false;
  csgvrep::VolumeSource Source;
  std::string Error;
  std::string Reported; ///< the last error reported (each is said once)
  /// RequestData runs (the same count on every rank) and the one whose computed attributes the
  /// ranks reduced together.
  unsigned long DataGeneration = 0;
  unsigned long SharedGeneration = 0; ///< the update whose data the ranks shared
  /// Resolutions of the input (ResolveInput: a new image, a new modification time or another
  /// label array), and the one the prop was last given (a render, or a query before one).
  unsigned long Resolutions = 0;
  unsigned long PropResolution = ~0ul;
  /// The brick piece asked of the input (csgvvtk::setBrickPiece's words), empty when none.
  std::vector<int> BrickPiece;
};

vtkCSGVRepresentation::vtkCSGVRepresentation()
  : Prop(vtkCSGVVolumeProp::New())
  , Internals(new vtkInternals)
{
  // The defaults: CSGVProperties.def's, which the XML's are written from.
  const csgvrep::RepresentationProperties d;
#define CSGV_PROPERTY(Name, member, type, count, values) copyProperty(d.member, this->Name);
#include "CSGVProperties.def"
#undef CSGV_PROPERTY
  this->Prop->SetMaterials("");
}

vtkCSGVRepresentation::~vtkCSGVRepresentation()
{
  this->Prop->Delete();
  delete this->Internals;
}

void vtkCSGVRepresentation::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "LabelArray: " << this->LabelArray << "\n";
#define CSGV_PROPERTY(Name, member, type, count, values)                                           \
  printProperty(os << indent << #Name ":", this->Name);
#include "CSGVProperties.def"
#undef CSGV_PROPERTY
  os << indent << "AttributeFiles:";
  for (const std::string& f : this->AttributeFiles)
  {
    os << " '" << f << "'";
  }
  os << "\n";
  os << indent << "DerivedAttributes:";
  for (size_t i = 0; i + 1 < this->DerivedAttributes.size(); i += 2)
  {
    os << " " << this->DerivedAttributes[i] << " = '" << this->DerivedAttributes[i + 1] << "'";
  }
  os << "\n";
  os << indent << "ComputedAttributes: " << this->ComputedAttributes << "\n";
  os << indent << "Prop:\n";
  this->Prop->PrintSelf(os, indent.GetNextIndent());
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
  ++this->Internals->DataGeneration;
  if (inputVector[0]->GetNumberOfInformationObjects() == 1)
  {
    if (vtkImageData* input = vtkImageData::GetData(inputVector[0], 0))
    {
      // A shallow copy: arrays (and the encoding) are shared, so the volume cache, keyed by
      // array and modification time, finds what it compressed or uploaded before.
      this->Cache = vtkSmartPointer<vtkImageData>::New();
      this->Cache->ShallowCopy(input);
      // This rank's bricks of the whole image (RequestUpdateExtent): the volume cache places
      // them in the whole image's index space. Only this representation says so: an input that
      // carries the array itself (a saved image, another pipeline) is not taken for a piece.
      this->Cache->GetFieldData()->RemoveArray(csgvvtk::kBrickPieceName);
      if (!this->Internals->BrickPiece.empty())
      {
        csgvvtk::setBrickPiece(this->Cache->GetFieldData(), this->Internals->BrickPiece);
      }
    }
  }
  return this->Superclass::RequestData(request, inputVector, outputVector);
}

namespace
{

/// Whether the pipeline above `info` (an input's information) hands out pieces itself somewhere
/// (CAN_HANDLE_PIECE_REQUEST: the CSGV reader's whole bricks, which ParaView's post filter and any
/// filter between hide from the information at hand).
bool upstreamHandlesPieces(vtkInformation* info)
{
  for (int depth = 0; info && depth < 64; ++depth)
  {
    if (info->Get(vtkAlgorithm::CAN_HANDLE_PIECE_REQUEST()) == 1)
    {
      return true;
    }
    vtkExecutive* producer = nullptr;
    int port = 0;
    vtkExecutive::PRODUCER()->Get(info, producer, port);
    vtkAlgorithm* algorithm = producer ? producer->GetAlgorithm() : nullptr;
    if (!algorithm || algorithm->GetNumberOfInputPorts() == 0 || algorithm->GetNumberOfInputConnections(0) == 0)
    {
      return false;
    }
    info = algorithm->GetInputInformation(0, 0);
  }
  return false;
}

} // namespace

int vtkCSGVRepresentation::RequestUpdateExtent(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  const int result = this->Superclass::RequestUpdateExtent(request, inputVector, outputVector);
  this->Internals->BrickPiece.clear();
  vtkInformation* in = inputVector[0]->GetNumberOfInformationObjects() == 1
    ? inputVector[0]->GetInformationObject(0)
    : nullptr;
  if (!in || !in->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()) ||
    !in->Has(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES()) ||
    upstreamHandlesPieces(in))
  {
    return result;
  }
  const int pieces = in->Get(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES());
  const int piece = in->Get(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER());
  if (pieces <= 1 || piece < 0 || piece >= pieces)
  {
    return result;
  }
  int whole[6], ext[6];
  in->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  const int brick = int(csgv::EncodeOptions{}.brickSize);
  csgvvtk::brickPieceExtent(whole, brick, pieces, piece, ext);
  in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext, 6);
  in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER(), 0);
  in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES(), 1);
  in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_GHOST_LEVELS(), 0);
  in->Set(vtkStreamingDemandDrivenPipeline::EXACT_EXTENT(), 1);
  this->Internals->BrickPiece = { brick, pieces, piece, whole[0], whole[1], whole[2], whole[3], whole[4],
    whole[5] };
  return result;
}

bool vtkCSGVRepresentation::ResolveInput(vtkImageData* image, bool report)
{
  vtkInternals& in = *this->Internals;
  const vtkMTimeType t = image ? image->GetMTime() : 0;
  if (!in.Resolved || image != in.Image || t != in.ImageTime || this->LabelArray != in.Array)
  {
    in.Image = image;
    in.ImageTime = t;
    in.Array = this->LabelArray;
    in.Resolved = true;
    ++in.Resolutions;
    // Held until the new input resolved: a new image sharing the old one's arrays (the pipeline
    // re-executed, the label array named again) finds the volume still in the cache.
    const csgvrep::VolumeSource previous = std::move(in.Source);
    in.Source = csgvrep::VolumeSource{};
    in.Error.clear();
    if (image && image->GetNumberOfPoints() > 0)
    {
      // Parsing an encoding or compressing a plain array happens here, in the data phase, and
      // once per (array, modification time) in the process (the volume cache).
      in.Error = in.Volumes->resolve(image, this->LabelArray, in.Source);
    }
  }
  if (report)
  {
    this->ReportInputError();
  }
  return in.Source.shared != nullptr;
}

void vtkCSGVRepresentation::ReportInputError()
{
  vtkInternals& in = *this->Internals;
  if (!in.Error.empty() && in.Error != in.Reported)
  {
    in.Reported = in.Error;
    vtkErrorMacro(<< "Segmentation Volume: " << in.Error);
  }
  else if (in.Error.empty())
  {
    in.Reported.clear();
  }
}

void vtkCSGVRepresentation::SetPosition(double x, double y, double z)
{
  this->Prop->SetPosition(x, y, z);
}

void vtkCSGVRepresentation::SetOrientation(double x, double y, double z)
{
  this->Prop->SetOrientation(x, y, z);
}

void vtkCSGVRepresentation::SetScale(double x, double y, double z)
{
  this->Prop->SetScale(x, y, z);
}

void vtkCSGVRepresentation::SetOrigin(double x, double y, double z)
{
  this->Prop->SetOrigin(x, y, z);
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
    // A data object on every process, an empty one where there is none (the client's copy of
    // the representation has no input): a server that cannot render remotely (no display) makes
    // the client render, and the view then moves every representation's piece to the client. A
    // null piece on the client side of that move aborted the client ("Wrong tag", GUI re-check 12).
    if (!this->Cache && !this->Internals->NoPiece)
    {
      this->Internals->NoPiece = vtkSmartPointer<vtkImageData>::New();
    }
    vtkPVView::SetPiece(inInfo, this, this->Cache ? this->Cache.GetPointer() : this->Internals->NoPiece.GetPointer());
    // The data stays where it is (the server in client/server mode): images travel, not labels.
    vtkPVRenderView::SetDeliverToClientAndRenderingProcesses(inInfo, this, false, false);
    double bounds[6];
    const bool resolved = this->Cache && this->ResolveInput(this->Cache);
    this->ShareAcrossRanks(resolved);
    // Where the Transforming properties place the piece (an axis-aligned box around it); none
    // for a placement that is not finite (the prop says so when it draws).
    const bool placed =
      resolved && this->Internals->Source.bounds(bounds) && csgvrep::placeBounds(this->Prop->GetMatrix(), bounds);
    if (placed)
    {
      // This rank's piece (the reader hands each rank whole bricks; a piece is a volume of its
      // own). Translucent materials need the pieces blended front to back: ParaView 5.11's
      // ordered compositing sorts the ranks by these bounds (it reads the geometry bounds even
      // where the configuration names others, so both get the piece's). So do opaque images of
      // several samples a pixel: a pixel on a piece's silhouette holds the samples that hit the
      // piece, its alpha their share; blended in visibility order, the samples that passed it
      // meet the pieces behind, as one rank's rays do, where a depth composite keeps the nearest
      // piece's pixel alone (1.2-1.6 % of the pixels of a 160x120 view differed from one rank's
      // by more than 16/255 at 16 samples, 0.10-0.15 % now; docs/mpi-design.md, "Silhouettes").
      // Other representations' geometry is then redistributed by these bounds, as ParaView does
      // for any translucent display.
      vtkPVRenderView::SetGeometryBounds(inInfo, this, bounds);
    }
    // Every rank alike, those without a piece to draw too (more ranks than bricks, a reader that
    // failed on one rank): a rank that asked for no ordered compositing while the others did
    // waited for them in another collective, and the job hung at its first render.
    int ordered = this->Prop->DrawsTranslucent() || this->FramesPerStillRender > 1 ? 1 : 0;
    vtkMultiProcessController* c = vtkMultiProcessController::GetGlobalController();
    if (c && c->GetNumberOfProcesses() > 1)
    {
      int mine = ordered;
      c->AllReduce(&mine, &ordered, 1, vtkCommunicator::MAX_OP);
    }
    if (ordered)
    {
      outInfo->Set(vtkPVRenderView::NEED_ORDERED_COMPOSITING(), 1);
      vtkPVRenderView::SetOrderedCompositingConfiguration(
        inInfo, this, vtkPVRenderView::USE_BOUNDS_FOR_REDISTRIBUTION, placed ? bounds : nullptr);
    }
    // Rendered where the data lives, where it can be (the labels stay on the server). A server
    // that cannot render (no display: ParaView turns remote rendering off on every process)
    // makes the client render the moved piece; asking for distributed rendering there only
    // printed "Some of the representations in this view require remote rendering" in red.
    auto* view = vtkPVRenderView::SafeDownCast(inInfo->Get(vtkPVView::VIEW()));
    if (!view || view->GetRemoteRenderingAvailable())
    {
      vtkPVRenderView::SetRequiresDistributedRendering(inInfo, this, true);
    }
  }
  else if (request == vtkPVView::REQUEST_RENDER())
  {
    auto* image = vtkImageData::SafeDownCast(vtkPVView::GetDeliveredPiece(inInfo, this));
    this->Internals->Delivered = image;
    this->ResolveInput(image);
    this->Prop->SetInput(image, this->Internals->Source, this->Internals->Error);
    this->Internals->PropResolution = this->Internals->Resolutions;
    // Every property, gathered once per render (the view renderer detects what changed).
    csgvrep::RepresentationProperties p;
#define CSGV_PROPERTY(Name, member, type, count, values) copyProperty(this->Name, p.member);
#include "CSGVProperties.def"
#undef CSGV_PROPERTY
    csgvrep::ViewSettings settings = csgvrep::toViewSettings(p);
    // Values that are not taken as given (from Python or a state file: no domain checks them)
    // are said once, until they change.
    std::string notes;
    for (const std::string& n : settings.notes)
    {
      notes += (notes.empty() ? "" : "; ") + n;
    }
    if (notes != this->SettingsNotes && !notes.empty())
    {
      vtkWarningMacro(<< "Segmentation Volume: " << notes);
    }
    this->SettingsNotes = notes;
    // Ranks may share a device: an automatic cache takes its share of it.
    vtkMultiProcessController* controller = vtkMultiProcessController::GetGlobalController();
    settings.processes = uint32_t(std::max(1, controller ? controller->GetNumberOfProcesses() : 1));
    this->Prop->SetViewSettings(settings);
    // SaveScreenshot and SaveAnimation render between the view's PrepareForScreenshot and
    // CleanupAfterScreenshot: those images are written, so they converge whatever the budget.
    this->Prop->SetCapture(InCaptureScreenshot(vtkPVView::SafeDownCast(this->GetView())));
    this->Prop->PrepareRender();
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

void vtkCSGVRepresentation::SetLabelArray(const char* name)
{
  const std::string n = name ? name : "";
  if (n != this->LabelArray)
  {
    this->LabelArray = n;
    this->MarkModified(); // bounds may change (cell vs point data)
  }
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

double vtkCSGVRepresentation::GetDeviceBudgetMiB()
{
  return this->Prop->GetDeviceBudgetMiB();
}

int vtkCSGVRepresentation::GetCacheBits()
{
  return this->Prop->GetCacheBits();
}

int vtkCSGVRepresentation::GetDetailSeparated()
{
  return this->Prop->GetDetailSeparated();
}

bool vtkCSGVRepresentation::LastLabels(
  uint32_t& width, uint32_t& height, std::vector<uint32_t>& labels, std::vector<float>& depths)
{
  return this->Prop->LastLabels(width, height, labels, depths);
}

double vtkCSGVRepresentation::GetDetailStreamedMiB()
{
  return this->Prop->GetDetailStreamedMiB();
}

int vtkCSGVRepresentation::GetLevelsOnDisk()
{
  return this->Prop->GetLevelsOnDisk();
}

double vtkCSGVRepresentation::GetFileReadMiB()
{
  return this->Prop->GetFileReadMiB();
}

int vtkCSGVRepresentation::GetBadBricks()
{
  return this->Prop->GetBadBricks();
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
  // Under MPI the ranks compute them together in the next update.
  this->MarkModified();
}

void vtkCSGVRepresentation::ShareAcrossRanks(bool resolved)
{
  vtkInternals& in = *this->Internals;
  vtkMultiProcessController* c = vtkMultiProcessController::GetGlobalController();
  // Every rank decides alike: the count of data updates is the same on all (a change of
  // ComputedAttributes is one: MarkModified).
  if (!c || c->GetNumberOfProcesses() < 2 || in.SharedGeneration == in.DataGeneration)
  {
    return;
  }
  in.SharedGeneration = in.DataGeneration;
  // A plain image's pieces relabelled apart (labels the format cannot hold): every rank asked
  // for bricks alike (RequestUpdateExtent), so all take part when one holds such a piece, and
  // compress their bricks again with the whole image's ids.
  if (!in.BrickPiece.empty())
  {
    int mine = resolved && in.Source.shared->ownIds ? 1 : 0, any = 0;
    c->AllReduce(&mine, &any, 1, vtkCommunicator::MAX_OP);
    if (any != 0)
    {
      in.Error = in.Volumes->resolveAgreed(this->Cache, this->LabelArray, c, in.Source);
      resolved = in.Source.shared != nullptr;
      this->ReportInputError();
    }
  }
  bool reduced = false;
  const std::string error = csgvrep::shareAcrossRanks(
    c, resolved ? in.Source : csgvrep::VolumeSource{}, this->ComputedAttributes != 0, reduced);
  if (!error.empty())
  {
    vtkErrorMacro(<< "Segmentation Volume: " << error);
  }
  if (reduced)
  {
    this->Prop->AttributesChanged();
  }
}

const char* vtkCSGVRepresentation::Query(const char* request)
{
  if (!this->Cache && this->GetNumberOfInputConnections(0) > 0)
  {
    // Asked before the view updated this representation (attributes right after Show): bring
    // the input here first. Queries run on the rendering processes only (vtkCSGVQuery).
    this->Update();
  }
  // The input as the representation last updated it (a new file's data, a file that failed to
  // read, after the view's update), resolved with the label array set now: the query answers for
  // that, not for what the last render drew. Nothing is resolved again when nothing changed. A
  // copy without input that rendered (the client's, rendering for a server that cannot) answers
  // for the piece it drew: resolving nothing would have dropped its renderer and its image.
  vtkInternals& in = *this->Internals;
  vtkImageData* input = this->Cache ? this->Cache.GetPointer() : in.Delivered.GetPointer();
  this->ResolveInput(input, false);
  if (in.PropResolution != in.Resolutions)
  {
    this->Prop->SetInput(input, in.Source, in.Error);
    in.PropResolution = in.Resolutions;
  }
  this->QueryResult = this->Prop->Query(request ? request : "");
  return this->QueryResult.c_str();
}
