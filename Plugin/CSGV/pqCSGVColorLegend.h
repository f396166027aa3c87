// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVColorLegend
 * @brief GUI auto-start: colouring a Segmentation Volume by its label array shows the legend of
 * what its materials draw.
 *
 * A Segmentation Volume is coloured by its materials, not by ParaView's lookup tables; before,
 * choosing the label array in the colour toolbar changed only the legend, which showed the label
 * array's shared table (issue 38, item 6). Now, while a Segmentation Volume is coloured by its
 * label array, its display takes the table of its own that the material editor's export makes
 * (pqCSGV::exportLabelColors: each drawn label's material colour and region name, a legend that
 * fits), made again whenever the materials change; the shared table's legend is hidden unless
 * something else uses it. "Solid Color" shows no legend, as before.
 */
#ifndef pqCSGVColorLegend_h
#define pqCSGVColorLegend_h

#include <QMap>
#include <QObject>
#include <QPointer>
#include <QSet>

class pqRepresentation;
class pqView;
class vtkObject;
class vtkSMProxy;

class pqCSGVColorLegend : public QObject
{
  Q_OBJECT
public:
  pqCSGVColorLegend(QObject* parent = nullptr);
  ~pqCSGVColorLegend() override;

  void startup();
  void shutdown();

public Q_SLOTS:
  void representationAdded(pqRepresentation* representation);
  void representationRemoved(pqRepresentation* representation);

private:
  void propertyModified(vtkObject* proxy, unsigned long, void* name);
  /// Gives the display its own legend when it is a Segmentation Volume coloured by its labels.
  void update(vtkSMProxy* proxy);

  QMap<vtkSMProxy*, unsigned long> Observed; ///< proxy -> its PropertyModifiedEvent observer
  QSet<vtkSMProxy*> Pending;                 ///< updates queued for the event loop
};

#endif
