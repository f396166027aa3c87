// SPDX-License-Identifier: MIT
/**
 * @file pqCSGVMaterialDocument.h
 * @brief Qt adapters of Core's material document (csgv/materials/Materials.h: MATERIALS.md's
 * schema, its defaults and the label edits live there once) and the server-side questions of
 * misc/CSGVQuery, shared by the material editor and the pick panel.
 */
#ifndef pqCSGVMaterialDocument_h
#define pqCSGVMaterialDocument_h

#include "csgv/materials/Materials.h"

#include <QJsonObject>
#include <QString>

class pqView;
class vtkSMProxy;

namespace pqCSGV
{

/// The document of a CSGVMaterials text through Core (blank: the default document). Text Core
/// refuses gives the default document and, in `error`, Core's message.
csgv::MaterialDocument parseDocument(const QString& text, QString* error = nullptr);
/// The property text of a document: Core's serialisation on one line.
QString serialize(const csgv::MaterialDocument& doc);

/// The pick panel's label visibility: Core's overlay edits (csgv::hideLabelOver,
/// csgv::showOnlyLabelOver, csgv::showAllLabels) on a CSGVMaterials text, which keep the user's
/// materials. Text Core refuses is not edited: the result is empty and `error` says why.
enum class LabelVisibility
{
  Hide,
  ShowOnly,
  ShowAll
};
QString editLabelVisibility(
  const QString& materials, LabelVisibility edit, qint64 label, QString* error = nullptr);

/// Sets a display's CSGVMaterials (and pushes it) as a user's edit: in the Python trace, as the
/// Properties panel's edits are (the caller makes the undo step).
void setMaterials(vtkSMProxy* display, const QString& text);

/// The Segmentation Volume representation proxy behind a display (the composite's subproxy, or
/// the proxy itself); nullptr when it has none.
vtkSMProxy* segmentationProxy(vtkSMProxy* display);
/// Renders the view that shows `display` and `also` (the panel's view, which may be another:
/// a Spreadsheet view made active by a Label Table, GUI pass 14), each once.
void renderViewsShowing(vtkSMProxy* display, pqView* also = nullptr);
/// Asks misc/CSGVQuery on the rendering process (vtkCSGVQuery.h); "" on failure.
QString query(vtkSMProxy* display, const QString& request);
/// query() parsed as a JSON object.
QJsonObject queryJson(vtkSMProxy* display, const QString& request);

/// Makes a categorical lookup table of this data's own (labelColorTableName: the label array's
/// shared table, which other datasets use, is left alone) with one annotation per label the
/// volume shows: its material colour and name (a text attribute). Other values (label 0, hidden
/// labels, labels no material takes) are not drawn (NaN opacity 0), as in the volume. The
/// displays of this data and of filters made from it that are coloured by the label array take
/// the table and show its legend: one entry per label up to kLegendLabels, else the colours
/// alone under a title that names the count. Returns a message for the user.
QString exportLabelColors(vtkSMProxy* display);
/// The name of the display's label array (its `summary`; "Labels" when it does not say).
QString labelArrayOf(vtkSMProxy* display);
/// The table exportLabelColors makes for `array` (labelArrayOf), made (again) from what the
/// display draws now; null with a `message` when the display cannot tell (`message` also says
/// what was made).
vtkSMProxy* labelColorTable(vtkSMProxy* display, const QString& array, QString* message = nullptr);
/// Shows `lut`'s legend (titled `array`) for `display` in `view`, one entry per label up to
/// kLegendLabels, else the colours alone under a title that names the count.
void showLegend(vtkSMProxy* lut, const QString& array, vtkSMProxy* display, pqView* view);
/// Hides `lut`'s legend in `view` unless a visible display there maps its data through it.
void hideUnusedLegend(vtkSMProxy* lut, pqView* view);
/// The folder of the file the display's data was read from (its pipeline source's file name
/// property), where attribute files usually lie; empty when the data has no file.
QString dataFolder(vtkSMProxy* display);
/// The name of the lookup table exportLabelColors makes for `array` of the pipeline source named
/// `source`: "Labels (aal.nii.gz materials)".
QString labelColorTableName(const QString& array, const QString& source);
/// Legends with more labels than this show colours without names (they would run past the view).
constexpr int kLegendLabels = 40;
/// The grey a label table read as a continuous map gives values below its first label (0, which
/// the volume leaves empty). Examples/csgv_tools.py keeps a copy (BELOW_LABELS_GREY).
constexpr double kBelowLabelsGrey = 0.5;
/// How far that continuous map reaches beyond its first and last label, so that neither lies at
/// the range's end. Examples/csgv_tools.py keeps a copy (LABEL_MARGIN).
constexpr double kLabelMargin = 0.5;

} // namespace pqCSGV

#endif
