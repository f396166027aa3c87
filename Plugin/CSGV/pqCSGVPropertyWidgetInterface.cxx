// SPDX-License-Identifier: MIT
#include "pqCSGVPropertyWidgetInterface.h"

#include "pqCSGVClipBoxWidget.h"
#include "pqCSGVEnumerationWidget.h"
#include "pqCSGVLabelArrayWidget.h"
#include "pqCSGVLogRangeWidget.h"
#include "pqCSGVMaterialDocument.h"

#include <pqGenericPropertyWidgetDecorator.h>
#include <pqPropertyWidget.h>
#include <vtkPVXMLElement.h>
#include <vtkSMProperty.h>
#include <vtkCommand.h>
#include <vtkSMPropertyGroup.h>
#include <vtkSMStringVectorProperty.h>
#include <vtkSMVectorProperty.h>
#include <vtkWeakPointer.h>
#include <vtkSMProxy.h>

#include <QString>
#include <QStringList>

#include <cstring>

namespace
{
/// `<CSGVHideGroups labels="...">` of the Segmentation Volume behind `display`, when `display`
/// is the composite representation that holds it (not the bare representation proxy).
vtkPVXMLElement* hideGroupsHint(vtkSMProxy* display)
{
  vtkSMProxy* segmentation = pqCSGV::segmentationProxy(display);
  if (!segmentation || segmentation == display || !segmentation->GetHints())
  {
    return nullptr;
  }
  return segmentation->GetHints()->FindNestedElementByName("CSGVHideGroups");
}

bool groupHolds(vtkSMPropertyGroup* group, vtkSMProperty* property)
{
  for (unsigned int i = 0; i < group->GetNumberOfProperties(); ++i)
  {
    if (group->GetProperty(i) == property)
    {
      return true;
    }
  }
  return false;
}

/// Gives `widget` the decorator of the hidden groups, once.
void hideForSegmentationVolume(pqPropertyWidget* widget, vtkPVXMLElement* config)
{
  const QString name = QStringLiteral("CSGVHideGroups");
  if (!widget->findChild<pqPropertyWidgetDecorator*>(name, Qt::FindDirectChildrenOnly))
  {
    (new pqGenericPropertyWidgetDecorator(config, widget))->setObjectName(name);
  }
}

/// Decorates the group widgets (panel_widget groups such as Coloring's ColorEditor) of hidden
/// groups that the panel holding `widget` has already created.
void decorateGroupWidgets(pqPropertyWidget* widget, vtkSMProxy* display, const QStringList& labels,
                          vtkPVXMLElement* config)
{
  QWidget* panel = widget->parentWidget();
  if (!panel)
  {
    return;
  }
  for (size_t g = 0; g < display->GetNumberOfPropertyGroups(); ++g)
  {
    vtkSMPropertyGroup* group = display->GetPropertyGroup(g);
    const char* panelWidget = group->GetPanelWidget();
    if (!panelWidget || !group->GetXMLLabel() || !labels.contains(group->GetXMLLabel()))
    {
      continue;
    }
    // pqProxyWidget names a group widget after its panel_widget, without spaces.
    const QString name = QString(panelWidget).remove(' ');
    const auto groupWidgets =
      panel->findChildren<pqPropertyWidget*>(name, Qt::FindDirectChildrenOnly);
    for (pqPropertyWidget* groupWidget : groupWidgets)
    {
      hideForSegmentationVolume(groupWidget, config);
    }
  }
}
/// Shows its widget only while the proxy's file list (the `property` attribute) holds more than
/// one file.
class SeveralFilesDecorator : public pqPropertyWidgetDecorator
{
public:
  SeveralFilesDecorator(vtkPVXMLElement* config, pqPropertyWidget* widget)
    : pqPropertyWidgetDecorator(config, widget)
  {
    vtkSMProxy* proxy = widget->proxy();
    this->Files = proxy ? proxy->GetProperty(config->GetAttributeOrEmpty("property")) : nullptr;
    this->Extensions = QString(config->GetAttributeOrEmpty("extensions")).split(' ', Qt::SkipEmptyParts);
    if (this->Files)
    {
      this->Tag = this->Files->AddObserver(vtkCommand::ModifiedEvent, this, &SeveralFilesDecorator::changed);
    }
  }
  ~SeveralFilesDecorator() override
  {
    if (this->Files)
    {
      this->Files->RemoveObserver(this->Tag);
    }
  }
  bool canShowWidget(bool showAdvanced) const override
  {
    auto* files = vtkSMStringVectorProperty::SafeDownCast(this->Files);
    if (files && files->GetNumberOfElements() < 2)
    {
      return false;
    }
    if (files && !this->Extensions.isEmpty())
    {
      const QString first = QString::fromUtf8(files->GetElement(0)).toLower();
      bool known = false;
      for (const QString& e : this->Extensions)
      {
        known = known || first.endsWith(e.toLower());
      }
      if (!known)
      {
        return false;
      }
    }
    return this->pqPropertyWidgetDecorator::canShowWidget(showAdvanced);
  }

private:
  void changed() { Q_EMIT this->visibilityChanged(); }
  vtkWeakPointer<vtkSMProperty> Files;
  QStringList Extensions; ///< the first file must end with one of these (none given: any)
  unsigned long Tag = 0;
};
} // namespace

pqPropertyWidgetDecorator* pqCSGVPropertyWidgetInterface::createWidgetDecorator(const QString& type,
                                                                                vtkPVXMLElement* config,
                                                                                pqPropertyWidget* widget)
{
  if (type == "csgv_several_files" && config && widget)
  {
    return new SeveralFilesDecorator(config, widget);
  }
  return nullptr;
}

pqCSGVPropertyWidgetInterface::pqCSGVPropertyWidgetInterface(QObject* parent)
  : QObject(parent)
{
}

pqCSGVPropertyWidgetInterface::~pqCSGVPropertyWidgetInterface() = default;

pqPropertyWidget* pqCSGVPropertyWidgetInterface::createWidgetForProperty(vtkSMProxy* proxy,
                                                                         vtkSMProperty* property,
                                                                         QWidget* parent)
{
  const char* type = property ? property->GetPanelWidget() : nullptr;
  if (!type)
  {
    return nullptr;
  }
  if (std::strcmp(type, "csgv_label_array") == 0)
  {
    return new pqCSGVLabelArrayWidget(proxy, property, parent);
  }
  if (std::strcmp(type, "csgv_clip_box") == 0)
  {
    return new pqCSGVClipBoxWidget(proxy, property, parent);
  }
  if (std::strcmp(type, "csgv_enumeration") == 0)
  {
    return new pqCSGVEnumerationWidget(proxy, property, parent);
  }
  if (std::strcmp(type, "csgv_log_range") == 0)
  {
    return new pqCSGVLogRangeWidget(proxy, property, parent);
  }
  return nullptr;
}

void pqCSGVPropertyWidgetInterface::createDefaultWidgetDecorators(pqPropertyWidget* widget)
{
  vtkSMProxy* display = widget ? widget->proxy() : nullptr;
  vtkPVXMLElement* hint = hideGroupsHint(display);
  vtkPVXMLElement* config =
    hint ? hint->FindNestedElementByName("PropertyWidgetDecorator") : nullptr;
  if (!config)
  {
    return;
  }
  QStringList labels;
  for (const QString& label : QString(hint->GetAttributeOrEmpty("labels")).split(';'))
  {
    if (!label.trimmed().isEmpty())
    {
      labels << label.trimmed(); // the XML attribute may wrap
    }
  }
  decorateGroupWidgets(widget, display, labels, config);
  vtkSMProperty* property = widget->property();
  for (size_t g = 0; property && g < display->GetNumberOfPropertyGroups(); ++g)
  {
    vtkSMPropertyGroup* group = display->GetPropertyGroup(g);
    if (group->GetXMLLabel() && labels.contains(group->GetXMLLabel()) &&
        groupHolds(group, property))
    {
      hideForSegmentationVolume(widget, config);
      return;
    }
  }
}
