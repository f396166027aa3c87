// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVLabelArrayWidget
 * @brief A label array property (panel_widget "csgv_label_array"): a drop-down of the input's
 * one-component integer arrays, cell data first, after "(automatic)". The Segmentation Volume's
 * "Label Array" and the CSGV Writer's "Label Array Name" (Save Data) use it.
 *
 * "(automatic)" writes the empty string, which the representation reads as "the CSGV encoding
 * when present, else the first integer array (cell data first)", as pvpython's default does. The
 * property's hints may say otherwise: `<CSGVLabelArrays floats="1" automatic="..."/>` also lists
 * one-component float arrays (the writer takes floats that hold integers) and gives the tooltip of
 * "(automatic)". A
 * name the input does not offer (another array set from pvpython, or one not computed yet) stays
 * shown, marked "(not in the input)", so the widget never changes the property by itself.
 *
 * The list follows the input's data information (pqPipelineSource::dataUpdated). The static
 * helpers describe that input for the other widgets of the panel (the clip box's voxel extent).
 */
#ifndef pqCSGVLabelArrayWidget_h
#define pqCSGVLabelArrayWidget_h

#include "pqPropertyWidget.h"

#include <QPair>
#include <QString>
#include <QVector>

#include <array>

class QComboBox;
class vtkPVDataInformation;

class pqCSGVLabelArrayWidget : public pqPropertyWidget
{
  Q_OBJECT
  Q_PROPERTY(QString labelArray READ labelArray WRITE setLabelArray NOTIFY labelArrayChanged)
  typedef pqPropertyWidget Superclass;

public:
  pqCSGVLabelArrayWidget(vtkSMProxy* proxy, vtkSMProperty* property, QWidget* parent = nullptr);
  ~pqCSGVLabelArrayWidget() override;

  QString labelArray() const;
  void setLabelArray(const QString& name);

  /// One-component integer arrays of the display's input: (name, is cell data), cell data first.
  static QVector<QPair<QString, bool>> integerArrays(vtkSMProxy* display);
  /// The same, with one-component float arrays too when `floats` (after the integer ones).
  static QVector<QPair<QString, bool>> labelArrays(vtkSMProxy* display, bool floats);
  /// Voxels per axis of the label volume the display draws: cells when its label array is cell
  /// data (or the CSGV encoding), points when it is point data; zeros without input.
  static std::array<int, 3> voxelDimensions(vtkSMProxy* display);
  /// Calls `slot` of `receiver` whenever the display's input has new data.
  static void connectInputUpdates(vtkSMProxy* display, QObject* receiver, const char* slot);

Q_SIGNALS:
  void labelArrayChanged();

private Q_SLOTS:
  void refill();

private:
  QComboBox* Combo;
  bool Floats = false;     ///< the hints' floats="1": float arrays are listed too
  QString AutomaticTip;    ///< the tooltip of "(automatic)"
};

#endif
