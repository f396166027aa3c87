// SPDX-License-Identifier: MIT
#include "pqCSGVProgressiveRendering.h"
#include "pqCSGVMaterialDocument.h"

#include <pqApplicationCore.h>
#include <pqRepresentation.h>
#include <pqServer.h>
#include <pqServerManagerModel.h>
#include <pqView.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>
#include <vtkSMViewProxy.h>
#include <vtkRenderWindow.h>

#include <QJsonObject>
#include <QTimer>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace
{
/// A still render's length in the GUI (at least one frame, and the image whole): about what a
/// user waits for the first interactive frame when grabbing a volume that is still refining.
constexpr double kRefinementSliceSeconds = 0.5;
}

pqCSGVProgressiveRendering::pqCSGVProgressiveRendering(QObject* parent)
  : QObject(parent)
{
}

pqCSGVProgressiveRendering::~pqCSGVProgressiveRendering() = default;

void pqCSGVProgressiveRendering::startup()
{
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  QObject::connect(model, &pqServerManagerModel::representationAdded, this, &pqCSGVProgressiveRendering::slice);
  for (pqRepresentation* repr : model->findItems<pqRepresentation*>())
  {
    this->slice(repr);
  }
  QObject::connect(model, &pqServerManagerModel::viewAdded, this, &pqCSGVProgressiveRendering::watch);
  QObject::connect(model, &pqServerManagerModel::viewRemoved, this,
    [this](pqView* view) {
      this->LastSamples.remove(view);
      this->Stalls.remove(view);
      this->AfterInteraction.remove(view);
      this->Pending.remove(view);
    });
  for (pqView* view : model->findItems<pqView*>())
  {
    this->watch(view);
  }
}

void pqCSGVProgressiveRendering::shutdown() {}

void pqCSGVProgressiveRendering::slice(pqRepresentation* repr)
{
  // This GUI renders again until the volumes converge, so a still render need not hold the GUI
  // for its whole budget: short ones keep it answering the mouse while the image refines. Through
  // the representation's own property (not saved in state files).
  vtkSMProxy* proxy = repr ? repr->getProxy() : nullptr;
  if (!proxy || !proxy->GetProperty("CSGVRefinementSlice"))
  {
    return;
  }
  vtkSMPropertyHelper(proxy, "CSGVRefinementSlice").Set(kRefinementSliceSeconds);
  proxy->UpdateVTKObjects();
}

void pqCSGVProgressiveRendering::watch(pqView* view)
{
  QObject::connect(view, &pqView::endRender, this, &pqCSGVProgressiveRendering::renderEnded,
    Qt::UniqueConnection);
}

void pqCSGVProgressiveRendering::renderEnded()
{
  pqView* view = qobject_cast<pqView*>(this->sender());
  if (!view || !view->getServer())
  {
    return;
  }
  // Interactive renders (the mouse moving) neither refine nor count as stalls: the user drives
  // them, and the still render that follows the release refines from there.
  vtkSMViewProxy* viewProxy = view->getViewProxy();
  vtkRenderWindow* window = viewProxy ? viewProxy->GetRenderWindow() : nullptr;
  if (window && window->GetDesiredUpdateRate() > 1.0)
  {
    this->AfterInteraction[view] = true;
    return;
  }
  if (this->Pending.contains(view))
  {
    return;
  }
  this->Pending.insert(view);
  QPointer<pqView> guard(view);
  QTimer::singleShot(0, this, [this, guard, view]() {
    this->Pending.remove(view);
    if (guard)
    {
      this->refine(guard);
    }
  });
}

void pqCSGVProgressiveRendering::refine(pqView* view)
{
  const bool afterInteraction = this->AfterInteraction.take(view);
  int fewest = -1;
  bool refine = false;
  for (pqRepresentation* repr : view->getRepresentations())
  {
    vtkSMProxy* proxy = repr ? repr->getProxy() : nullptr;
    if (!proxy || !repr->isVisible() || !proxy->GetProperty("CSGVMinSamples") ||
      !proxy->GetProperty("Representation") ||
      QString(vtkSMPropertyHelper(proxy, "Representation").GetAsString()) != "Segmentation Volume")
    {
      continue;
    }
    // Asked where it renders (a remote server's, every rank's): the display's information
    // property reads the client's copy of the representation, which never renders there.
    const int samples = pqCSGV::queryJson(proxy, "render").value("CSGVMinSamples").toInt();
    const int target = vtkSMPropertyHelper(proxy, "CSGVFramesPerStillRender").GetAsInt();
    if (samples < target)
    {
      refine = true;
      fewest = fewest < 0 ? samples : std::min(fewest, samples);
    }
  }
  // Only while renders make progress: a few renders in a row that add no sample (an error, or
  // renders that did not draw the volume) end the refinement until something changes.
  const int last = this->LastSamples.value(view, -1);
  this->LastSamples[view] = fewest;
  int& stalls = this->Stalls[view];
  stalls = (!refine || afterInteraction || fewest > last || fewest < last) ? 0 : stalls + 1;
  if (std::getenv("CSGV_TRACE_REFINEMENT"))
  {
    std::fprintf(stderr, "csgv refinement: fewest samples %d (last %d), stalls %d%s\n", fewest, last, stalls,
      afterInteraction ? ", after interaction" : "");
  }
  if (refine && stalls < 3)
  {
    view->render();
  }
}
