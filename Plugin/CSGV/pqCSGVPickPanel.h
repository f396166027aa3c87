// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVPickPanel
 * @brief Dock panel "Segmentation Pick": clicking (or, with "Follow mouse", hovering) on a
 * Segmentation Volume in the active render view reports the original label under the cursor,
 * its attributes (names and text included) and the voxel position, with "Hide this label" and
 * "Show only this label" and "Show all": edits of the label-visibility overlay of the
 * representation's CSGVMaterials ("hidden", "only"; csgv::effectiveMaterials), which keep the
 * user's materials as they are (undoable, like every property edit).
 *
 * ParaView's hardware selector does not see the volume (its prop draws no selection pass), so
 * the pick reads the G-buffer of the volume's last render on the rendering process through
 * misc/CSGVQuery ("pick X Y"): the label of the first opaque voxel per pixel, its entry face and
 * distance, turned into a voxel index with the camera and the volume's geometry. Translucent
 * materials are not picked (their labels are not in the G-buffer). The panel follows the active
 * view; a click is a press and release within a few pixels (drags still rotate the camera).
 * The pick clears when the picked data goes away or another view becomes active.
 *
 * Like ParaView's own optional docks (Find Data, Memory Inspector, ...) the panel starts hidden;
 * View > Segmentation Pick opens it (pqPluginDockWidgetsBehavior adds an explicitly hidden dock
 * without showing it).
 *
 * The label selection (pqCSGVLabelSelection: one per data set, drawn highlighted or with the rest
 * dimmed, linked to CSGV Label Tables and ParaView's selection tools): with "Select on click", a
 * click selects the picked label, Ctrl+click adds it, Shift+click removes it (ParaView's
 * modifiers). "Clear selection" empties it, the style box switches highlight and dim, and
 * "Extract selection" makes a CSGV Extract Labels filter of the selected labels (waiting for
 * Apply). The query box selects the labels for which an SQL condition over their attributes is
 * true (`voxels > 1000 and region = 'hippocampus'`; Enter). The line under the buttons counts the selection of the display last picked (or the
 * active one).
 *
 * objectNames: pickEnabled, followMouse, pickResult, hideLabel, showOnlyLabel, showAllLabels,
 * selectOnClick, clearSelection, extractSelection, selectionStyle, selectQuery, selectionInfo.
 */
#ifndef pqCSGVPickPanel_h
#define pqCSGVPickPanel_h

#include <QDockWidget>
#include <QJsonObject>
#include <QPoint>
#include <QPointer>

#include <vtkWeakPointer.h>

class QCheckBox;
class QComboBox;
class QLabel;
class QLineEdit;
class QPushButton;
class QTextBrowser;
class pqRepresentation;
class pqView;
class vtkSMProxy;
namespace pqCSGV
{
enum class LabelVisibility;
}

class pqCSGVPickPanel : public QDockWidget
{
  Q_OBJECT
  typedef QDockWidget Superclass;

public:
  pqCSGVPickPanel(const QString& title, QWidget* parent = nullptr,
    Qt::WindowFlags flags = Qt::WindowFlags());
  pqCSGVPickPanel(QWidget* parent = nullptr);
  ~pqCSGVPickPanel() override;

  /// Picks at a pixel of the view (Qt widget coordinates, origin top left); true on a hit.
  bool pickAt(const QPoint& widgetPos);
  /// The last pick's answer (hit, label, voxel, world, attributes).
  QJsonObject lastPick() const { return this->Last; }

public Q_SLOTS:
  void hideLabel();
  void showOnlyLabel();
  void showAllLabels();
  void clearSelection();
  /// A CSGV Extract Labels filter of the selected labels (on the display's input), not yet applied.
  void extractSelection();
  void setSelectionStyle(int index);
  /// Selects the labels for which the SQL condition in the query box is true (misc/CSGVQuery
  /// `match`: the representation's attributes, loaded and derived ones included).
  void selectByQuery();
  /// Says what the selection of the current display holds.
  void updateSelectionInfo();

protected:
  bool eventFilter(QObject* watched, QEvent* event) override;

  /// Forgets the last pick (text, buttons, display).
  void clearPick();

private Q_SLOTS:
  void setView(pqView* view);
  void representationRemoved(pqRepresentation* representation);

private:
  void build();
  /// The display the selection buttons and Show all act on: the last picked one, else the active
  /// one, else the volume of an active filter's input (a Label Table), else the active data set's
  /// volume in another view; none: they are disabled.
  vtkSMProxy* selectionDisplay() const;
  void editVisibility(const QString& undoLabel, vtkSMProxy* display, pqCSGV::LabelVisibility edit);

  QPointer<pqView> View;
  QPointer<QWidget> ViewWidget;
  QMetaObject::Connection TimeChange; ///< the view's server's time keeper: a new time clears the pick
  QMetaObject::Connection DataShown;  ///< the view: data shown in it clears the pick
  QPoint PressPos;
  bool Pressed = false;
  QJsonObject Last;
  /// Weak: the display may be deleted after the pick (Hide then finds it gone, not dangling).
  vtkWeakPointer<vtkSMProxy> LastDisplay;
  QCheckBox* Enabled;
  QCheckBox* Follow;
  QTextBrowser* Result;
  QPushButton *Hide, *ShowOnly, *ShowAll;
  QCheckBox* SelectOnClick;
  QPushButton *ClearSelection, *ExtractSelection;
  QComboBox* SelectionStyle;
  QLineEdit* SelectQuery;
  QLabel* SelectionInfo;
  Qt::KeyboardModifiers PressModifiers;
};

#endif
