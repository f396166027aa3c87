// SPDX-License-Identifier: MIT
#include "pqCSGVSharedAttributes.h"

#include <pqApplicationCore.h>
#include <pqDataRepresentation.h>
#include <pqOutputPort.h>
#include <pqServerManagerModel.h>
#include <vtkSMLink.h>
#include <vtkSMProperty.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMPropertyLink.h>
#include <vtkSMProxy.h>

#include <QPointer>
#include <QTimer>

namespace
{
bool isSegmentationCapable(vtkSMProxy* proxy)
{
  return proxy && proxy->GetProperty("CSGVAttributeFiles") && proxy->GetProperty("CSGVDerivedAttributes") &&
    proxy->GetProperty("CSGVComputedAttributes");
}

/// True while the data properties are as a new representation has them.
bool atDefaults(vtkSMProxy* proxy)
{
  return vtkSMPropertyHelper(proxy, "CSGVAttributeFiles").GetNumberOfElements() == 0 &&
    vtkSMPropertyHelper(proxy, "CSGVDerivedAttributes").GetNumberOfElements() == 0 &&
    vtkSMPropertyHelper(proxy, "CSGVComputedAttributes").GetAsInt() == 0;
}

pqOutputPort* portOf(pqRepresentation* representation)
{
  auto* data = qobject_cast<pqDataRepresentation*>(representation);
  return data ? data->getOutputPortFromInput() : nullptr;
}
} // namespace

pqCSGVSharedAttributes::pqCSGVSharedAttributes(QObject* parent)
  : QObject(parent)
{
}

pqCSGVSharedAttributes::~pqCSGVSharedAttributes() = default;

const QList<const char*>& pqCSGVSharedAttributes::dataProperties()
{
  static const QList<const char*> names{ "CSGVAttributeFiles", "CSGVDerivedAttributes", "CSGVComputedAttributes" };
  return names;
}

QList<vtkSMProxy*> pqCSGVSharedAttributes::siblings(vtkSMProxy* representation)
{
  QList<vtkSMProxy*> out;
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  auto* self = model->findItem<pqDataRepresentation*>(representation);
  pqOutputPort* port = self ? self->getOutputPortFromInput() : nullptr;
  if (!port)
  {
    return out;
  }
  for (pqDataRepresentation* other : port->getRepresentations(nullptr))
  {
    if (other != self && isSegmentationCapable(other->getProxy()))
    {
      out << other->getProxy();
    }
  }
  return out;
}

void pqCSGVSharedAttributes::startup()
{
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  QObject::connect(model, &pqServerManagerModel::representationAdded, this,
    &pqCSGVSharedAttributes::representationAdded);
  QObject::connect(model, &pqServerManagerModel::preRepresentationRemoved, this,
    &pqCSGVSharedAttributes::representationRemoved);
  for (pqRepresentation* r : model->findItems<pqRepresentation*>())
  {
    this->link(r);
  }
}

void pqCSGVSharedAttributes::shutdown()
{
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  QObject::disconnect(model, nullptr, this, nullptr);
  this->Ports.clear();
}

void pqCSGVSharedAttributes::representationAdded(pqRepresentation* representation)
{
  // The model announces a representation before it has read its Input (initialize()): link it
  // once the event loop comes back.
  QPointer<pqRepresentation> later(representation);
  QTimer::singleShot(0, this, [this, later]() {
    if (later)
    {
      this->link(later);
    }
  });
}

void pqCSGVSharedAttributes::link(pqRepresentation* representation)
{
  vtkSMProxy* proxy = representation ? representation->getProxy() : nullptr;
  pqOutputPort* port = portOf(representation);
  if (!port || !isSegmentationCapable(proxy))
  {
    return;
  }
  PortLinks& entry = this->Ports[port];
  if (entry.members.contains(proxy))
  {
    return;
  }
  // A new view of data that other views show with attributes: it sees them too.
  if (!entry.members.isEmpty() && atDefaults(proxy) && !atDefaults(entry.members.front()))
  {
    for (const char* name : dataProperties())
    {
      proxy->GetProperty(name)->Copy(entry.members.front()->GetProperty(name));
    }
    proxy->UpdateVTKObjects();
  }
  if (entry.links.isEmpty())
  {
    for (int i = 0; i < dataProperties().size(); ++i)
    {
      entry.links << vtkSmartPointer<vtkSMPropertyLink>::New();
    }
  }
  for (int i = 0; i < dataProperties().size(); ++i)
  {
    // Both ways, as pqLinksModel links two properties: each is a source and a target.
    entry.links[i]->AddLinkedProperty(proxy, dataProperties()[i], vtkSMLink::INPUT);
    entry.links[i]->AddLinkedProperty(proxy, dataProperties()[i], vtkSMLink::OUTPUT);
  }
  entry.members << proxy;
}

void pqCSGVSharedAttributes::representationRemoved(pqRepresentation* representation)
{
  vtkSMProxy* proxy = representation ? representation->getProxy() : nullptr;
  for (auto it = this->Ports.begin(); it != this->Ports.end(); ++it)
  {
    if (!it->members.contains(proxy))
    {
      continue;
    }
    for (int i = 0; i < it->links.size(); ++i)
    {
      // Its source and its target entry, whether the link removes one at a time or both.
      unsigned int before = 0;
      do
      {
        before = it->links[i]->GetNumberOfLinkedObjects();
        it->links[i]->RemoveLinkedProperty(proxy, dataProperties()[i]);
      } while (it->links[i]->GetNumberOfLinkedObjects() < before);
    }
    it->members.removeAll(proxy);
    if (it->members.isEmpty())
    {
      this->Ports.erase(it);
    }
    return;
  }
}
