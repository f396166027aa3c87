// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVClipBoxWidget
 * @brief "Clip Box (voxels)" of the Segmentation Volume (panel_widget "csgv_clip_box"): first and
 * last voxel per axis, in spin boxes bounded by the volume's extent (0 .. voxels - 1).
 *
 * The property keeps pvpython's meaning: inclusive voxel indices, clamped to the volume by the
 * representation, with the XML default (2147483647 as maximum) meaning "up to the last voxel".
 * The widget shows such values clamped, so a new user sees 0 .. 180 for the AAL atlas, and writes
 * a maximum set to the last voxel back as that "whole volume" value, so the box still covers the
 * whole volume when the input grows; an input without voxels (a file that failed to read) shows
 * "-" in disabled boxes and leaves the property as it is. The extent follows the input's data
 * (pqCSGVLabelArrayWidget::voxelDimensions) and the chosen label array. Spin boxes apply on
 * Enter, focus change or the arrows, not on every keystroke (each change re-renders).
 *
 * The extent is the delivered image's, read from the client's data information (so it also
 * works with a pvserver): for a CSGV reader at Level k > 0 that is the coarse grid, smaller than
 * the full-resolution voxels the property counts, so the boxes then stop short of the last
 * full-resolution voxels (a maximum at the end still means the whole volume).
 */
#ifndef pqCSGVClipBoxWidget_h
#define pqCSGVClipBoxWidget_h

#include "pqPropertyWidget.h"

#include <QList>
#include <QVariant>

#include <array>
#include <climits>

class QSpinBox;

class pqCSGVClipBoxWidget : public pqPropertyWidget
{
  Q_OBJECT
  Q_PROPERTY(QList<QVariant> clipBox READ clipBox WRITE setClipBox NOTIFY clipBoxChanged)
  typedef pqPropertyWidget Superclass;

public:
  pqCSGVClipBoxWidget(vtkSMProxy* proxy, vtkSMProperty* property, QWidget* parent = nullptr);
  ~pqCSGVClipBoxWidget() override;

  /// xmin xmax ymin ymax zmin zmax, as the property stores them.
  QList<QVariant> clipBox() const;
  void setClipBox(const QList<QVariant>& values);

Q_SIGNALS:
  void clipBoxChanged();

private Q_SLOTS:
  /// Bounds the spin boxes by the input's voxel extent.
  void updateExtent();

private:
  /// Whether the input has voxels on every axis (else the boxes show "-", disabled).
  bool hasVoxels() const;
  std::array<QSpinBox*, 6> Boxes;
  std::array<int, 3> Dimensions{ { 0, 0, 0 } };
  /// The property's default maximum, stored for a maximum at the last voxel.
  int WholeMaximum = INT_MAX;
  /// The values last set from the property: shown clamped, kept for when the extent changes.
  QList<QVariant> Stored;
};

#endif
