// SPDX-License-Identifier: MIT
#include "CSGVViewRenderer.h"

#include "CSGVGpuContext.h"

#include "csgv/codec/TieredVolume.h"
#include "csgv/gpu/Context.h"
#include "csgv/gpu/GpuVolume.h"
#include "csgv/gpu/UploadPolicy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <system_error>

namespace csgvrep
{

namespace
{

std::string numberText(double v)
{
  char text[64];
  std::snprintf(text, sizeof(text), "%.10g", v);
  return text;
}

/// A number within [lo, hi]: held to the nearer end, a NaN to the default, each saying so (a value
/// set from Python or a state file passes no domain).
template <class T>
void holdWithin(T& v, double lo, double hi, T fallback, const char* name, std::vector<std::string>& notes)
{
  const double x = double(v);
  if (x >= lo && x <= hi)
  {
    return;
  }
  const T held = std::isnan(x) ? fallback : T(x < lo ? lo : hi);
  notes.push_back(std::string(name) + " " + numberText(x) + " is " +
    (std::isnan(x) ? std::string("not a number") : "outside [" + numberText(lo) + ", " + numberText(hi) + "]") + ": " +
    numberText(double(held)) + " is used");
  v = held;
}

/// An enumeration's value among `allowed`, else the default, saying so.
void holdAmong(int& v, const std::vector<int>& allowed, int fallback, const char* name, std::vector<std::string>& notes)
{
  if (std::find(allowed.begin(), allowed.end(), v) != allowed.end())
  {
    return;
  }
  std::string list;
  for (int a : allowed)
  {
    list += (list.empty() ? "" : ", ") + std::to_string(a);
  }
  notes.push_back(std::string(name) + " " + std::to_string(v) + " is not one of " + list + ": " + std::to_string(fallback) +
    " is used");
  v = fallback;
}

/// The values toViewSettings uses: numbers within their CSGVProperties.def ranges, enumerations
/// among their values, a light direction of finite, not all zero, components; `notes` says what
/// was changed.
RepresentationProperties heldProperties(const RepresentationProperties& given, std::vector<std::string>& notes)
{
  RepresentationProperties p = given;
  const RepresentationProperties d;
#define CSGV_PROPERTY(Name, member, type, count, values)
#define CSGV_RANGE(Name, member, lo, hi) holdWithin(p.member, lo, hi, d.member, "CSGV" #Name, notes);
#define CSGV_LIST(...) __VA_ARGS__
#define CSGV_ENUM(Name, member, values, texts) holdAmong(p.member, { CSGV_LIST values }, d.member, "CSGV" #Name, notes);
#include "CSGVProperties.def"
#undef CSGV_ENUM
#undef CSGV_LIST
#undef CSGV_RANGE
#undef CSGV_PROPERTY
  std::vector<int> modes(csgv::gpu::kShadingModes);
  for (size_t m = 0; m < modes.size(); ++m)
  {
    modes[m] = int(m);
  }
  holdAmong(p.shading, modes, d.shading, "CSGVShading", notes);
  const auto& l = p.lightDirection;
  const bool finite = std::isfinite(l[0]) && std::isfinite(l[1]) && std::isfinite(l[2]);
  if (!finite || (l[0] == 0 && l[1] == 0 && l[2] == 0))
  {
    notes.push_back("CSGVLightDirection (" + numberText(l[0]) + ", " + numberText(l[1]) + ", " + numberText(l[2]) +
      ") is " + (finite ? "zero" : "not finite") + ": the default (" + numberText(d.lightDirection[0]) + ", " +
      numberText(d.lightDirection[1]) + ", " + numberText(d.lightDirection[2]) + ") is used");
    p.lightDirection = d.lightDirection;
  }
  return p;
}

} // namespace

ViewSettings toViewSettings(const RepresentationProperties& given)
{
  ViewSettings s;
  const RepresentationProperties p = heldProperties(given, s.notes);
  s.render.shading = csgv::gpu::Shading(std::clamp(p.shading, 0, int(csgv::gpu::kShadingModes) - 1));
  s.render.shadingBlend = float(std::clamp(p.shadingBlend, 0.0, 1.0));
  s.render.lodBias = float(p.lodBias);
  int sub = 1;
  while (sub < 8 && sub < p.subsampling)
  {
    sub *= 2;
  }
  s.render.subsampling = uint32_t(sub);
  s.render.denoise = p.denoise != 0;
  // Components beyond float's range (1e308, 1e-300) would be infinite or 0 as floats, and the
  // backend's normalisation NaN (a black volume): such a direction is scaled in double first.
  const auto& l = p.lightDirection;
  const double largest = std::max({ std::abs(l[0]), std::abs(l[1]), std::abs(l[2]) }); // > 0: held
  const double scale = largest > 1e30 || largest < 1e-30 ? 1.0 / largest : 1.0;
  for (int i = 0; i < 3; ++i)
  {
    s.render.lightDirection[i] = float(l[size_t(i)] * scale);
  }
  s.cacheBytes = p.cacheSizeMiB > 0 ? uint64_t(std::max(16, p.cacheSizeMiB)) << 20 : 0;
  s.deviceMemoryBytes = uint64_t(std::max(0, p.deviceMemoryMiB)) << 20;
  s.hostMemoryBytes = uint64_t(std::max(0, p.hostMemoryMiB)) << 20;
  s.cachePaletting = std::clamp(p.cachePaletting, 0, 2);
  using Decode = csgv::gpu::RendererOptions::Decode;
  s.decode = p.decoding == 1 ? Decode::Gpu : p.decoding == 2 ? Decode::Host : Decode::Auto;
  // 0 automatic; more steps than any brick takes: every step (a brick's decoding in its frame).
  s.decodeSteps = uint32_t(std::clamp(p.decodeStepsPerFrame, 0, 1000000));
  s.framesPerStillRender = uint32_t(std::max(1, p.framesPerStillRender));
  s.stillRenderTimeBudget = std::max(0.0, p.stillRenderTimeBudget);
  s.refinementSlice = std::max(0.0, p.refinementSlice);
  s.clipBox = p.clipBox;
  return s;
}

std::shared_ptr<const csgv::TieredVolume> ViewRenderer::tiersFor(
  SharedVolume& shared, uint64_t hostMemoryBytes, std::string& error)
{
  std::lock_guard<std::mutex> lock(this->Cache->mutex());
  // Decided once per volume and setting: the automatic budget follows the memory available when
  // it is decided, not every render (a budget that moved with it would rebuild the tiers).
  // Views with different settings each keep theirs.
  auto known = shared.tiers.find(hostMemoryBytes);
  if (known != shared.tiers.end())
  {
    return known->second;
  }
  // Tiers of other settings that no upload draws from any more go (their coarse copies count
  // against the host memory too).
  for (auto it = shared.tiers.begin(); it != shared.tiers.end();)
  {
    it = it->second && it->second.use_count() == 1 ? shared.tiers.erase(it) : std::next(it);
  }
  const uint64_t budget = hostMemoryBytes ? hostMemoryBytes : csgv::TieredVolume::automaticBudget();
  if (!shared.owned.empty() || !csgv::TieredVolume::wanted(shared.volume, budget))
  {
    shared.tiers[hostMemoryBytes] = nullptr;
    return nullptr; // an MPI piece holds only its bricks; a volume within the budget stays whole
  }
  {
    csgv::TieredVolume::Options o;
    o.budgetBytes = budget;
    csgv::Result<std::shared_ptr<const csgv::TieredVolume>> t =
      csgv::TieredVolume::create(std::make_shared<const csgv::CompressedVolume>(shared.volume), o);
    if (!t)
    {
      error = "keeping the finest level on disk: " + t.message(); // asked again next time
      return nullptr;
    }
    shared.tiers[hostMemoryBytes] = *t;
    return *t;
  }
}

ViewRenderer::ViewRenderer()
  : Cache(VolumeCache::instance())
{
}

ViewRenderer::~ViewRenderer()
{
  this->clear();
}

void ViewRenderer::releaseShare()
{
  if (this->Counted && this->Source.shared)
  {
    std::lock_guard<std::mutex> lock(this->Cache->mutex());
    this->Source.shared->renderers--;
  }
  this->Counted = false;
}

void ViewRenderer::clear()
{
  this->settle();
  this->Renderer.reset();
  this->CachePressure = false;
  this->releaseShare();
  this->Source = VolumeSource{};
}

void ViewRenderer::setSource(const VolumeSource& source)
{
  if (source.shared == this->Source.shared && source.corner == this->Source.corner)
  {
    // Nothing changes, and nothing waits for the background preparation (which only reads the
    // source): the prop passes its placement before every frame.
    return;
  }
  this->settle();
  if (source.shared != this->Source.shared)
  {
    this->clear();
    this->Source = source;
  }
  else
  {
    this->Source.corner = source.corner;
  }
  this->GeometryDirty = true;
}

void ViewRenderer::setSettings(const ViewSettings& s)
{
  this->settle();
  const ViewSettings& o = this->Settings;
  const bool same = s.render == o.render && s.cacheBytes == o.cacheBytes && s.processes == o.processes &&
    s.deviceMemoryBytes == o.deviceMemoryBytes && s.hostMemoryBytes == o.hostMemoryBytes &&
    s.cachePaletting == o.cachePaletting &&
    s.decode == o.decode && s.decodeSteps == o.decodeSteps &&
    s.framesPerStillRender == o.framesPerStillRender &&
    s.stillRenderTimeBudget == o.stillRenderTimeBudget && s.refinementSlice == o.refinementSlice &&
    s.clipBox == o.clipBox;
  if (s.cachePaletting != o.cachePaletting)
  {
    this->CachePressure = false;
  }
  if (!same)
  {
    this->Settings = s;
    this->SettingsDirty = true;
  }
}

void ViewRenderer::setMaterials(
  const csgv::MaterialDocument& doc, std::map<std::string, std::vector<float>> attributes)
{
  this->settle();
  this->Materials = doc;
  this->Attributes = std::move(attributes);
  this->MaterialsDirty = true;
}

std::string ViewRenderer::ensureRenderer()
{
  std::string error;
  if (!this->Context)
  {
    this->Context = sharedContext(error);
    if (!this->Context)
    {
      return error;
    }
  }
  SharedVolume* shared = this->Source.shared.get();
  if (!shared)
  {
    return "no input";
  }
  int renderers = 1;
  std::shared_ptr<csgv::gpu::GpuVolume> gpu; // held from here: no other view releases it meanwhile
  // The backend's upload policy: which upload of the volume this view draws from, and its share
  // of the budgets (csgv/gpu/UploadPolicy.h).
  csgv::gpu::UploadRequest want;
  want.deviceMemoryBytes = this->Settings.deviceMemoryBytes;
  want.cacheBytes = this->Settings.cacheBytes;
  want.processes = this->Settings.processes;
  want.decode = this->Settings.decode;
  want.cachePaletting = this->Settings.cachePaletting;
  want.cachePressure = this->CachePressure;
  // An encoding larger than the host-memory budget keeps its finest level in the file (one set
  // of tiers per volume and budget, shared by its views).
  std::string tierError;
  want.tiers = tiersFor(*shared, this->Settings.hostMemoryBytes, tierError);
  if (!tierError.empty())
  {
    return tierError;
  }
  const csgv::CompressedVolume& drawn = want.tiers ? want.tiers->coarse() : shared->volume;
  csgv::gpu::UploadPlan plan = csgv::gpu::planUpload(this->Context->device(), drawn, want);
  plan.volume.owned = shared->owned;
  if (this->Renderer && !plan.serves(this->Renderer->volume()))
  {
    this->Renderer.reset(); // before the other upload is made: its memory counts
  }
  {
    std::lock_guard<std::mutex> lock(this->Cache->mutex());
    for (uint32_t k = 0; k < csgv::gpu::kUploadKinds; ++k)
    {
      if (k != plan.kind && shared->gpu[k] && shared->gpu[k].use_count() == 1)
      {
        shared->gpu[k].reset(); // no view draws from it any more
      }
    }
    std::shared_ptr<csgv::gpu::GpuVolume>& mine = shared->gpu[plan.kind];
    if (mine && !plan.serves(*mine) && mine.use_count() == 1)
    {
      mine.reset(); // made for another budget, and no other view draws from it
    }
    if (!mine)
    {
      if (!shared->palettes) // read elsewhere with atomic_load (CSGVAttributes.cxx)
      {
        std::atomic_store(&shared->palettes,
          std::shared_ptr<const csgv::PaletteSummary>(std::make_shared<const csgv::PaletteSummary>(
            csgv::summarizePalettes(shared->volume, csgv::kSummaryLabels))));
      }
      plan.volume.palettes = shared->palettes;
      csgv::Result<std::unique_ptr<csgv::gpu::GpuVolume>> upload =
        csgv::gpu::GpuVolume::create(*this->Context, drawn, plan.volume);
      if (!upload)
      {
        return "uploading the volume: " + upload.message();
      }
      shared->context = this->Context;
      mine = std::shared_ptr<csgv::gpu::GpuVolume>(std::move(*upload));
    }
    gpu = mine;
    if (!this->Counted)
    {
      shared->renderers++;
      this->Counted = true;
    }
    // Other views of this volume change the count under the mutex.
    renderers = std::max(1, shared->renderers);
  }
  csgv::gpu::RendererOptions options =
    plan.share(gpu->deviceBytes(), uint32_t(renderers), this->Settings.decode);
  options.decodeStepsPerFrame = this->Settings.decodeSteps;
  if (!shared->owned.empty())
  {
    std::lock_guard<std::mutex> lock(volumeMutex());
    options.largestOtherLabel = shared->largestOtherLabel; // its table covers the other ranks' labels
  }
  if (!this->Renderer || options.cacheBytes != this->RendererCacheBytes ||
    options.deviceMemoryBytes != this->RendererBudget ||
    options.decodeStepsPerFrame != this->RendererDecodeSteps ||
    options.largestOtherLabel != this->RendererOtherLabel || &this->Renderer->volume() != gpu.get())
  {
    this->Renderer.reset();
    csgv::Result<std::unique_ptr<csgv::gpu::Renderer>> r =
      csgv::gpu::Renderer::create(*this->Context, gpu, options);
    if (!r)
    {
      return "creating the renderer: " + r.message();
    }
    this->Renderer = std::move(*r);
    this->Warmed = false;
    this->RendererCacheBytes = options.cacheBytes;
    this->RendererBudget = options.deviceMemoryBytes;
    this->RendererDecodeSteps = options.decodeStepsPerFrame;
    this->RendererOtherLabel = options.largestOtherLabel;
    this->GeometryDirty = this->MaterialsDirty = this->SettingsDirty = true;
    this->GhostUploaded = this->CoarseUploaded = nullptr;
  }
  return this->updateRenderer(*shared);
}

std::string ViewRenderer::updateRenderer(SharedVolume& volume)
{
  SharedVolume* shared = &volume;
  std::shared_ptr<const GhostFaces> ghost;
  std::shared_ptr<const CoarseStandIns> coarse;
  {
    std::lock_guard<std::mutex> lock(volumeMutex());
    ghost = shared->ghost;
    coarse = shared->coarse;
  }
  if (coarse && coarse.get() != this->CoarseUploaded && !shared->owned.empty())
  {
    // An MPI rank's piece: the whole volume's coarse levels, for secondary rays.
    csgv::Status s = this->Renderer->setCoarseStandIns(coarse->first, coarse->levels);
    if (!s)
    {
      return s.message();
    }
    this->CoarseUploaded = coarse.get();
  }
  if (ghost && ghost.get() != this->GhostUploaded && !shared->owned.empty())
  {
    // An MPI rank's piece: the labels just beyond it (CSGVPieceAttributes' shareAcrossRanks).
    const uint32_t b = shared->volume.brickSize;
    std::array<uint32_t, 3> lo{}, hi{};
    for (int a = 0; a < 3; ++a)
    {
      lo[a] = shared->owned.lo[a] * b;
      hi[a] = lo[a] + shared->pieceDims[a];
    }
    csgv::Status s = this->Renderer->setGhostFaces(lo, hi, *ghost);
    if (!s)
    {
      return s.message();
    }
    this->GhostUploaded = ghost.get();
  }
  if (this->GeometryDirty)
  {
    this->Renderer->setGeometry(this->Source.corner);
    this->GeometryDirty = false;
  }
  if (this->MaterialsDirty)
  {
    csgv::Status s = this->Renderer->setMaterials(this->Materials, this->Attributes, shared->storedToOriginal);
    if (!s)
    {
      return "materials: " + s.message();
    }
    this->MaterialsDirty = false;
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
          // Refused: the backend reads an empty range on an axis as "whole volume", so passing
          // it on would draw everything instead of nothing.
          return "the clip box is empty";
        }
      }
    }
    this->Renderer->setSettings(rs);
    this->SettingsDirty = false;
  }
  return std::string();
}

void ViewRenderer::prepareInBackground(bool depthInput)
{
  this->settle();
  if (this->Renderer || !this->Source.shared)
  {
    return;
  }
  try
  {
    this->Preparing = std::async(std::launch::async,
      [this, depthInput]
      {
        try
        {
          if (this->ensureRenderer().empty())
          {
            (void)this->Renderer->preparePipelines(depthInput); // the frame reports an error
          }
        }
        catch (...)
        {
          // Out of memory, say: render() makes what is missing, and meets (and reports) it there.
        }
      });
  }
  catch (const std::system_error&)
  {
    // No thread to be had: render() makes all of it, as without this call.
  }
}

void ViewRenderer::settle() const
{
  if (this->Preparing.valid())
  {
    this->Preparing.get();
  }
}

const csgv::gpu::FrameOutput& ViewRenderer::output(uint32_t parts)
{
  this->settle();
  static const csgv::gpu::FrameOutput none;
  return this->Renderer ? this->Renderer->output(parts) : none;
}

int ViewRenderer::interactiveReduction(double pixels, double desiredRate) const
{
  this->settle();
  return this->Renderer ? this->Renderer->interactiveReduction(pixels, desiredRate) : 1;
}

void ViewRenderer::recordDraw(double seconds, uint32_t frames, double pixels)
{
  this->settle();
  if (this->Renderer)
  {
    this->Renderer->recordDraw(seconds, frames, pixels);
  }
}

uint64_t ViewRenderer::cacheBytes() const
{
  this->settle();
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
  this->settle();
  return this->Renderer ? this->Renderer->memory().total() : 0;
}

bool ViewRenderer::detailSeparated() const
{
  this->settle();
  return this->Renderer && this->Renderer->volume().separated();
}

uint64_t ViewRenderer::detailStreamedBytes() const
{
  this->settle();
  return this->Renderer ? this->Renderer->detailCounts().uploadedBytes : 0;
}

int ViewRenderer::levelsOnDisk() const
{
  this->settle();
  const csgv::TieredVolume* t = this->Renderer ? this->Renderer->volume().tiers() : nullptr;
  return t ? (t->hasCoarseTier() ? 1 : 2) : 0;
}

uint64_t ViewRenderer::fileReadBytes() const
{
  this->settle();
  const csgv::TieredVolume* t = this->Renderer ? this->Renderer->volume().tiers() : nullptr;
  return t ? t->counts().fileBytes : 0;
}

uint64_t ViewRenderer::badBricks() const
{
  this->settle();
  return this->Renderer ? this->Renderer->badBricks() : 0;
}

std::string ViewRenderer::firstBadBrick() const
{
  this->settle();
  return this->Renderer ? this->Renderer->firstBadBrick() : std::string();
}

uint32_t ViewRenderer::cacheBits() const
{
  this->settle();
  return this->Renderer ? this->Renderer->volume().cacheBits() : 0;
}

uint64_t ViewRenderer::deviceBudget() const
{
  this->settle();
  return this->Renderer ? this->Renderer->deviceMemoryBudget() : 0;
}

std::string ViewRenderer::labelLookup() const
{
  this->settle();
  if (!this->Renderer)
  {
    return std::string();
  }
  return this->Renderer->labelLookup() == csgv::gpu::kLookupDense ? "dense" : "scan";
}

std::string ViewRenderer::render(const FrameRequest& req, bool& changed)
{
  this->settle();
  changed = false;
  this->FramesLastRender = 0;
  std::string error = this->ensureRenderer();
  if (!error.empty())
  {
    return error;
  }
  this->LastMatrix = req.worldToClip;
  // The backend detects what changed (camera, size, opaque depth, settings) and runs the
  // still-render loop within the time budget.
  csgv::gpu::RenderRequest request;
  request.frame.worldToClip = req.worldToClip;
  request.frame.width = req.width;
  request.frame.height = req.height;
  request.frame.opaqueDepth = req.opaqueDepth;
  request.interactive = req.interactive;
  request.timeBudgetSeconds = this->Settings.stillRenderTimeBudget;
  if (this->Settings.refinementSlice > 0)
  {
    request.timeBudgetSeconds = std::min(request.timeBudgetSeconds, this->Settings.refinementSlice);
  }
  if (req.capture)
  {
    request.interactive = false;
    request.timeBudgetSeconds = std::numeric_limits<double>::infinity();
  }
  const uint32_t mark = this->Renderer->frameMark();
  csgv::Result<csgv::gpu::RenderResult> r = this->Renderer->render(request);
  if (!r)
  {
    return r.message();
  }
  changed = r->changed;
  const bool packNext = r->cacheRanFull && this->Settings.cachePaletting == 2 && !this->CachePressure &&
    this->Renderer->volume().cacheBits() == 32;
  if (!request.interactive && r->frames > 0)
  {
    // A still render that filled the cache: did the cache hold what its frames touched? (The
    // brick table read back, 16 bytes a brick, only then; not when the next renderer packs the
    // cache anyway.)
    this->Shortfall = {};
    if (r->cacheRanFull && !packNext)
    {
      csgv::Result<csgv::gpu::Renderer::WorkingSet> ws = this->Renderer->workingSet(mark);
      if (ws && ws->bytes > ws->cacheBytes)
      {
        this->Shortfall = *ws;
      }
    }
  }
  if (packNext)
  {
    this->CachePressure = true; // the next render packs the cache (a new renderer, a new accumulation)
  }
  if (r->frames > 0)
  {
    this->Stats = r->last;
    this->FramesLastRender = r->frames;
    if (!request.interactive && !this->Warmed)
    {
      // The first still frame is on screen: the other shading modes' pipelines are made in the
      // background, so that switching the mode shows a frame at once (issue 38, item 4).
      this->Renderer->warmShadingModes(req.opaqueDepth != nullptr);
      this->Warmed = true;
    }
  }
  return std::string();
}

} // namespace csgvrep

