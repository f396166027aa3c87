// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVLabelSelection
 * @brief GUI auto-start: the one label selection of a segmentation (issue 41), shared by the
 * Segmentation Pick panel, ParaView's own selection tools on the render view, the CSGV Label
 * Table in the Spreadsheet view (and Find Data on it), and CSGV Extract Labels.
 *
 * Where it lives: in the representation's CSGVMaterials, as the document's "selected" overlay
 * (csgv::editSelection; MATERIALS.md), so it is drawn (highlighted, or the rest dimmed), saved in
 * state files, set from pvpython, and every edit is one undo step. The selection of a data set
 * is the same in every view that shows it: an edit goes to every Segmentation Volume display of
 * the same pipeline output.
 *
 * The links, both ways, none of which ParaView's hardware selector can make (our prop draws no
 * selection pass):
 * - ParaView's rectangle selection tools (Select Cells/Points On, Frustum, Block: every tool that
 *   reports a screen rectangle) on a render view select the labels the Segmentation Volumes there
 *   show in the rectangle (the first opaque hits of their last render); Ctrl adds, Shift removes,
 *   as ParaView's modifiers do.
 * - A selection of rows of a CSGV Label Table (clicking rows in the Spreadsheet view, Find Data's
 *   query on it, Edit > Select ...) selects those rows' labels in the volume the table was made
 *   from.
 * - A selection of labels made in 3D (the tools above, the pick panel) selects their rows in every
 *   CSGV Label Table of the same volume (an ID selection of rows), so the Spreadsheet follows.
 *
 * In client/server mode the rows are fetched to the client (ParaView's ReductionFilter, as
 * servermanager.Fetch does) and the label image of the last render comes through misc/CSGVQuery.
 */
#ifndef pqCSGVLabelSelection_h
#define pqCSGVLabelSelection_h

#include "csgv/materials/Materials.h"

class pqSelectionManager;

#include <QMap>
#include <QObject>
#include <QPointer>

#include <cstdint>
#include <vector>

class pqOutputPort;
class pqPipelineSource;
class pqRepresentation;
class pqView;
class vtkObject;
class vtkSMProxy;

namespace pqCSGV
{
/// The label selection of a Segmentation Volume display (its document's "selected"; empty when the
/// display has none or its materials are not valid).
std::vector<uint32_t> selectedLabels(vtkSMProxy* display);
/// The distinct labels a display's last render shows (first opaque hits) in the pixel rectangle
/// [x0, x1] x [y0, y1] (inclusive, either order, origin bottom left), ascending.
std::vector<uint32_t> labelsInRectangle(vtkSMProxy* display, int x0, int y0, int x1, int y1);
/// "3 17 40": labels as CSGV Extract Labels' Labels property reads them.
QString labelsText(const std::vector<uint32_t>& labels);
}

class pqCSGVLabelSelection : public QObject
{
  Q_OBJECT
public:
  pqCSGVLabelSelection(QObject* parent = nullptr);
  ~pqCSGVLabelSelection() override;

  void startup();
  void shutdown();

  /// The running instance (null before startup and after shutdown).
  static pqCSGVLabelSelection* instance();

  /// Edits the label selection of `display`'s data: every Segmentation Volume display of the same
  /// pipeline output, in every view, as one undo step named `undoLabel`, then the rows of its
  /// label tables. False with `error` when the display's materials are not valid (nothing is
  /// changed then).
  static bool edit(vtkSMProxy* display, const std::vector<uint32_t>& labels, csgv::SelectionEdit edit,
    const QString& undoLabel, QString* error = nullptr);
  /// Selects the labels of a screen rectangle of `view` (a ParaView selection tool's region) in
  /// the Segmentation Volumes it shows; `edit` as ParaView's modifiers (Ctrl adds, Shift removes).
  static void selectRectangle(pqView* view, const int region[4], csgv::SelectionEdit edit);
  /// Every display (all views) of `port` that holds a label selection (a Segmentation Volume's):
  /// the selection is one per data set.
  static QList<vtkSMProxy*> volumeDisplaysOf(pqOutputPort* port);

private Q_SLOTS:
  void viewAdded(pqView* view);
  void viewRemoved(pqView* view);
  void selectionChanged(pqOutputPort* port);
  void forgetRows(pqPipelineSource* table);
  /// A new CSGV Label Table takes the labels selected already: its rows follow at its first update.
  void sourceAdded(pqPipelineSource* source);
  /// A new display of a data set (another view, a state file) takes the selection the data set's
  /// other displays show: the labels, their style and colour.
  void representationAdded(pqRepresentation* representation);

private:
  /// A selection tool's region (SelectionChangedEvent of a render view proxy).
  void regionSelected(vtkObject* caller, unsigned long, void* calldata);
  /// Selects the rows of `labels` in every CSGV Label Table made from `input`.
  void selectRows(pqOutputPort* input, const std::vector<uint32_t>& labels);
  /// A label table's rows by the label the volume draws for them: its `label` column, or its
  /// `csgv_id` column where a label does not fit 32 bits (`ids`: the volume is drawn by ids,
  /// csgvrep::drawsIds).
  struct TableRows
  {
    std::vector<std::pair<int64_t, int64_t>> byLabel; ///< (drawn label, row), ascending
    bool ids = false;
  };
  /// A label table's rows, fetched once per update of its data.
  const TableRows& rowLabels(pqPipelineSource* table);

  /// Connects to ParaView's selection manager once it exists (true when connected). A plugin on
  /// PV_PLUGIN_PATH starts while pqApplicationCore is being made, before pqPVApplicationCore and
  /// its selection manager (GUI pass 11: table rows never selected in 3D that way).
  bool connectSelectionManager();

  QMap<pqView*, unsigned long> Observed; ///< render view -> its SelectionChangedEvent observer
  QPointer<pqSelectionManager> Selections; ///< the selection manager connected to
  QMap<pqPipelineSource*, TableRows> RowLabels; ///< rowLabels' answers, dropped on dataUpdated
  bool Busy = false;                    ///< an edit of ours is on its way round the links
};

#endif
