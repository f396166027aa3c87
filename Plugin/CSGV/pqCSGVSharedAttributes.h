// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVSharedAttributes
 * @brief GUI auto-start: a segmentation's attributes belong to its data, in every view.
 *
 * Attribute files, derived attributes and the computed-attributes switch are display properties
 * of the representation (they are read where it renders), so a second view of the same data
 * used to start without them: no region names when picking, materials filtering on attributes
 * that were not there (issue 38, item 7). This keeps them one setting per output port: a new
 * representation of a port that other representations show takes their values when its own are
 * still the defaults, and the three properties of every representation of the port are linked
 * both ways (vtkSMPropertyLink, as ParaView's own property links), so that a change in any view
 * reaches all. Materials stay per view, as ParaView's display properties are; the material editor
 * copies them from another view in one click (pqCSGVMaterialEditor's "From view").
 *
 * The links are not registered with the proxy manager: a state file holds each representation's
 * values, and loading it links them again.
 */
#ifndef pqCSGVSharedAttributes_h
#define pqCSGVSharedAttributes_h

#include <QList>
#include <QMap>
#include <QObject>
#include <QPair>

#include <vtkSmartPointer.h>

class pqOutputPort;
class pqRepresentation;
class vtkSMPropertyLink;
class vtkSMProxy;

class pqCSGVSharedAttributes : public QObject
{
  Q_OBJECT
public:
  pqCSGVSharedAttributes(QObject* parent = nullptr);
  ~pqCSGVSharedAttributes() override;

  void startup();
  void shutdown();

  /// The properties that belong to the data (linked across views).
  static const QList<const char*>& dataProperties();
  /// The other representations of the same output port that have the Segmentation Volume's
  /// properties (in other views), in the order the views were made.
  static QList<vtkSMProxy*> siblings(vtkSMProxy* representation);

public Q_SLOTS:
  void representationAdded(pqRepresentation* representation);
  void representationRemoved(pqRepresentation* representation);

private:
  /// Links a representation whose input is known with the others of its output port.
  void link(pqRepresentation* representation);

  /// The links of one output port, one per data property.
  struct PortLinks
  {
    QList<vtkSmartPointer<vtkSMPropertyLink>> links;
    QList<vtkSMProxy*> members;
  };
  QMap<pqOutputPort*, PortLinks> Ports;
};

#endif
