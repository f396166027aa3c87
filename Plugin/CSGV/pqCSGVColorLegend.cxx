// SPDX-License-Identifier: MIT
#include "pqCSGVColorLegend.h"

#include "pqCSGVMaterialDocument.h"

#include <pqApplicationCore.h>
#include <pqDataRepresentation.h>
#include <pqServerManagerModel.h>
#include <pqUndoStack.h>
#include <pqView.h>
#include <vtkCommand.h>
#include <vtkSMPVRepresentationProxy.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>
#include <vtkSMTrace.h>
#include <vtkSMTransferFunctionProxy.h>

#include <QTimer>

#include <cstring>

pqCSGVColorLegend::pqCSGVColorLegend(QObject* parent)
  : QObject(parent)
{
}

pqCSGVColorLegend::~pqCSGVColorLegend()
{
  this->shutdown();
}

void pqCSGVColorLegend::startup()
{
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  QObject::connect(model, &pqServerManagerModel::representationAdded, this, &pqCSGVColorLegend::representationAdded);
  QObject::connect(
    model, &pqServerManagerModel::preRepresentationRemoved, this, &pqCSGVColorLegend::representationRemoved);
  for (pqRepresentation* r : model->findItems<pqRepresentation*>())
  {
    this->representationAdded(r);
  }
}

void pqCSGVColorLegend::shutdown()
{
  if (pqApplicationCore* core = pqApplicationCore::instance())
  {
    QObject::disconnect(core->getServerManagerModel(), nullptr, this, nullptr);
  }
  for (auto it = this->Observed.begin(); it != this->Observed.end(); ++it)
  {
    it.key()->RemoveObserver(it.value());
  }
  this->Observed.clear();
  this->Pending.clear();
}

void pqCSGVColorLegend::representationAdded(pqRepresentation* representation)
{
  vtkSMProxy* proxy = representation ? representation->getProxy() : nullptr;
  if (!proxy || this->Observed.contains(proxy) || !proxy->GetProperty("CSGVMaterials") ||
    !proxy->GetProperty("ColorArrayName") || !proxy->GetProperty("LookupTable"))
  {
    return;
  }
  this->Observed[proxy] =
    proxy->AddObserver(vtkCommand::PropertyModifiedEvent, this, &pqCSGVColorLegend::propertyModified);
}

void pqCSGVColorLegend::representationRemoved(pqRepresentation* representation)
{
  vtkSMProxy* proxy = representation ? representation->getProxy() : nullptr;
  if (this->Observed.contains(proxy))
  {
    proxy->RemoveObserver(this->Observed.take(proxy));
    this->Pending.remove(proxy);
  }
}

void pqCSGVColorLegend::propertyModified(vtkObject* object, unsigned long, void* name)
{
  const char* property = static_cast<const char*>(name);
  if (!property ||
    (std::strcmp(property, "ColorArrayName") != 0 && std::strcmp(property, "CSGVMaterials") != 0 &&
      std::strcmp(property, "Representation") != 0 && std::strcmp(property, "CSGVLabelArray") != 0))
  {
    return;
  }
  auto* proxy = static_cast<vtkSMProxy*>(object);
  // Once the change is applied (the panel sets several properties in a row): from the event loop.
  if (!this->Pending.contains(proxy))
  {
    this->Pending.insert(proxy);
    QTimer::singleShot(0, this, [this, proxy]() {
      if (this->Pending.remove(proxy) && this->Observed.contains(proxy))
      {
        this->update(proxy);
      }
    });
  }
}

void pqCSGVColorLegend::update(vtkSMProxy* proxy)
{
  // Follows the user's change (colouring, materials) and is undone with it: no undo steps of its own,
  // and no trace lines (a trace replays the user's change, which makes the legend again; each
  // selection edit traced the whole table and a name that would not exist on replay: GUI pass).
  pqScopedUndoExclude exclude;
  SM_SCOPED_TRACE(BlockTraceItems);
  const QString representation = vtkSMPropertyHelper(proxy, "Representation", true).GetAsString();
  const QString colorBy = vtkSMPropertyHelper(proxy, "ColorArrayName", true).GetInputArrayNameToProcess();
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  auto* display = model->findItem<pqDataRepresentation*>(proxy);
  pqView* view = display ? display->getView() : nullptr;
  vtkSMProxy* shared = vtkSMPropertyHelper(proxy, "LookupTable", true).GetAsProxy();
  if (representation != "Segmentation Volume" || colorBy.isEmpty())
  {
    // Not coloured any more (Solid Color, or an undo of the colouring, which leaves the table
    // this class set): its legend goes unless another display uses it.
    if (shared && view && colorBy.isEmpty())
    {
      pqCSGV::hideUnusedLegend(shared, view);
    }
    return;
  }
  const QString labels = pqCSGV::labelArrayOf(proxy);
  if (colorBy != labels)
  {
    return; // another array: ParaView's own legend of it, as for any display
  }
  vtkSMProxy* own = pqCSGV::labelColorTable(proxy, labels);
  if (!own || !view)
  {
    return;
  }
  if (shared != own)
  {
    vtkSMPropertyHelper(proxy, "LookupTable").Set(own);
    proxy->UpdateVTKObjects();
    if (shared)
    {
      pqCSGV::hideUnusedLegend(shared, view);
    }
  }
  pqCSGV::showLegend(own, labels, proxy, view);
  view->render();
}
