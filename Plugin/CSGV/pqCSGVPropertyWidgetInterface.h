// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVPropertyWidgetInterface
 * @brief The plugin's property widgets for the Segmentation Volume (panel_widget
 * "csgv_label_array", "csgv_clip_box", "csgv_enumeration"), a default decorator that hides the
 * composite representation's controls that do nothing for it, and the "csgv_several_files"
 * decorator of the readers' file-series options.
 *
 * The representation is a subproxy of ParaView's UniformGridRepresentation, so the Properties
 * panel also shows the surface representation's Coloring, Styling, Lighting... groups. Their
 * `<Hints>` live in ParaView's XML and cannot be extended from a plugin, but ParaView asks every
 * pqPropertyWidgetInterface for default decorators of each property widget
 * (createDefaultWidgetDecorators). The groups to hide are listed once, in the Segmentation
 * Volume proxy's hints with the decorator they get (`<CSGVHideGroups labels="Coloring;...">`
 * holding ParaView's own GenericDecorator, mode="visibility" property="Representation"
 * value="Segmentation Volume" inverse="1", in CSGVRepresentation.xml), so they come back as soon
 * as another representation is chosen.
 *
 * ParaView 5.11 gives default decorators to single-property widgets only, not to custom group
 * widgets such as Coloring's ColorEditor (pqProxyWidget::createWidgetForProperty). A group widget
 * already created by the panel gets its decorator when the next property widget is decorated;
 * the panel re-filters every item whenever a decorator of a property widget reports a change,
 * which the other hidden groups' decorators do when Representation changes.
 */
#ifndef pqCSGVPropertyWidgetInterface_h
#define pqCSGVPropertyWidgetInterface_h

#include "pqPropertyWidgetInterface.h"

#include <QObject>

class pqCSGVPropertyWidgetInterface
  : public QObject
  , public pqPropertyWidgetInterface
{
  Q_OBJECT
  Q_INTERFACES(pqPropertyWidgetInterface)

public:
  explicit pqCSGVPropertyWidgetInterface(QObject* parent = nullptr);
  ~pqCSGVPropertyWidgetInterface() override;

  pqPropertyWidget* createWidgetForProperty(vtkSMProxy* proxy, vtkSMProperty* property,
                                            QWidget* parent) override;
  void createDefaultWidgetDecorators(pqPropertyWidget* widget) override;
  /// "csgv_several_files" (attribute `property`, a repeatable file list; optional `extensions`,
  /// blank-separated): the widget shows only while that list holds more than one file, the first
  /// ending with one of the extensions (ReadAsImageStack means nothing for one file, nor for a
  /// series of HDF5, NRRD, ... volumes).
  pqPropertyWidgetDecorator* createWidgetDecorator(const QString& type, vtkPVXMLElement* config,
                                                   pqPropertyWidget* widget) override;
};

#endif
