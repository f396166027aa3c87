// SPDX-License-Identifier: MIT
// QtTest of the label tools in a builtin ParaView session: "Export colours to lookup table"
// clicked in the material editor makes the label array's lookup table categorical (the proxy
// property IndexedLookup) with annotations for exactly the labels the volume shows and nothing
// drawn for the others; the pick panel's visibility edits keep the user's materials (and material
// edits keep the visibility overlay); the pick
// panel starts hidden when docked the way ParaView docks a plugin's panel, and its pick (a click
// in a render view) clears when another view becomes active or the picked data is deleted.
// The label selection (pqCSGVLabelSelection, issue 41): a click selects (Ctrl adds, Shift
// removes), ParaView's rectangle tools select what the view shows in the rectangle, a CSGV Label
// Table's rows follow the 3D selection and a selection of rows selects their labels, the
// selected labels are drawn in the highlight colour, every edit is one undo step, and "Extract
// selection" makes a CSGV Extract Labels filter of them.
// Usage: csgv_label_panel_test PLUGIN.so FIXTURES_DIR
#include "PvQtTestMain.h"
#include "pqCSGVColorLegend.h"
#include "pqCSGVLabelSelection.h"
#include "pqCSGVMaterialDocument.h"
#include "pqCSGVMaterialEditor.h"
#include "pqCSGVPickPanel.h"

#include <pqActiveObjects.h>
#include <pqDataRepresentation.h>
#include <pqFindDataCurrentSelectionFrame.h>
#include <pqApplicationCore.h>
#include <pqObjectBuilder.h>
#include <pqOutputPort.h>
#include <pqRenderView.h>
#include <pqSelectionManager.h>
#include <pqServerManagerModel.h>
#include <pqUndoStack.h>
#include <pqUndoStackBuilder.h>
#include <vtkAbstractArray.h>
#include <vtkAlgorithm.h>
#include <vtkCommand.h>
#include <vtkPVRenderView.h>
#include <vtkSMRenderViewProxy.h>
#include <vtkSMSelectionHelper.h>
#include <vtkSMSourceProxy.h>
#include <vtkSMTrace.h>
#include <vtkSelectionNode.h>
#include <vtkTable.h>
#include <vtkDataObject.h>
#include <QTableView>
#include <QFile>
#include <QProcess>
#include <QTemporaryDir>
#include <pqPipelineSource.h>
#include <pqTimeKeeper.h>
#include <pqView.h>
#include <pqPVApplicationCore.h>
#include <pqServer.h>
#include <pqServerResource.h>
#include <vtkNew.h>
#include <vtkSMPluginManager.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>
#include <vtkSMProxyManager.h>
#include <vtkSMSessionProxyManager.h>
#include <vtkSMTransferFunctionManager.h>
#include <vtkScalarsToColors.h>
#include <vtkSMTransferFunctionProxy.h>
#include <vtkSMPVRepresentationProxy.h>
#include <vtkDataObject.h>
#include <vtkSmartPointer.h>

#include <QAction>
#include <QComboBox>
#include <QLabel>
#include <QLineEdit>
#include <QApplication>
#include <QJsonArray>
#include <QJsonDocument>
#include <QMainWindow>
#include <QPushButton>
#include <QFile>
#include <QSet>
#include <QTemporaryDir>
#include <QTextBrowser>
#include <QtTest>

#include <algorithm>

namespace
{
QString gPlugin, gFixtures;

QSet<qint64> labelsOf(const QJsonObject& colors)
{
  QSet<qint64> out;
  for (const QJsonValue& e : colors.value("labels").toArray())
  {
    out.insert(qint64(e.toArray().at(0).toDouble()));
  }
  return out;
}
}

class TestLabelPanel : public QObject
{
  Q_OBJECT

  vtkSmartPointer<vtkSMProxy> Reader, Repr;

  QString materials() const { return vtkSMPropertyHelper(this->Repr, "CSGVMaterials").GetAsString(); }
  void setMaterials(const QString& text)
  {
    vtkSMPropertyHelper(this->Repr, "CSGVMaterials").Set(text.toUtf8().constData());
    this->Repr->UpdateVTKObjects();
  }

  /// The application's undo stack, made as the GUI makes it when there is none.
  void ensureUndoStack() { pvqttest::ensureUndoStack(this); }
  /// `files` (by default the attribute fixture) read into a new, active 160x160 render view as a
  /// Segmentation Volume (camera reset, rendered): its display's proxy, or nullptr when any step
  /// fails.
  vtkSMProxy* shownInNewView(pqPipelineSource*& source, pqRenderView*& view, QStringList files = {})
  {
    pqServer* server = pqActiveObjects::instance().activeServer();
    pqObjectBuilder* builder = pqApplicationCore::instance()->getObjectBuilder();
    if (files.isEmpty())
    {
      files << gFixtures + "/synthA_b32_rans2_attr.csgv";
    }
    source = builder->createReader("sources", "CSGVReader", files, server);
    view = source ? qobject_cast<pqRenderView*>(builder->createView("RenderView", server)) : nullptr;
    if (!view)
    {
      return nullptr;
    }
    view->widget()->resize(160, 160);
    view->widget()->show();
    pqActiveObjects::instance().setActiveView(view);
    pqDataRepresentation* display = builder->createDataRepresentation(source->getOutputPort(0), view);
    if (!display)
    {
      return nullptr;
    }
    vtkSMPropertyHelper(display->getProxy(), "Representation").Set("Segmentation Volume");
    display->getProxy()->UpdateVTKObjects();
    view->resetDisplay();
    view->forceRender();
    return display->getProxy();
  }

  /// A new CSGV Label Table of `source`, updated: its output (nullptr when it could not be made).
  static vtkTable* newLabelTable(pqPipelineSource* source, pqPipelineSource*& table)
  {
    table = pqApplicationCore::instance()->getObjectBuilder()->createFilter("filters", "CSGVLabelTable", source);
    if (!table)
      return nullptr;
    vtkSMSourceProxy::SafeDownCast(table->getProxy())->UpdatePipeline();
    return vtkTable::SafeDownCast(
      vtkAlgorithm::SafeDownCast(table->getProxy()->GetClientSideObject())->GetOutputDataObject(0));
  }
  /// Selects rows of a table output as the Spreadsheet view does: an ID selection of (process,
  /// row) pairs in an AppendSelections, ParaView 5.11's kind, handed to the selection manager.
  static void selectTableRows(pqPipelineSource* table, const std::vector<vtkIdType>& processAndRow)
  {
    vtkSmartPointer<vtkSMSourceProxy> rowsSel;
    rowsSel.TakeReference(vtkSMSourceProxy::SafeDownCast(
      table->getProxy()->GetSessionProxyManager()->NewProxy("sources", "IDSelectionSource")));
    vtkSMPropertyHelper(rowsSel, "FieldType").Set(vtkSelectionNode::ROW);
    vtkSMPropertyHelper(rowsSel, "IDs").Set(processAndRow.data(), static_cast<unsigned int>(processAndRow.size()));
    rowsSel->UpdateVTKObjects();
    selectTable(table, rowsSel);
  }
  /// Hands a selection source of a table's rows to the selection manager (in an AppendSelections).
  static void selectTable(pqPipelineSource* table, vtkSMSourceProxy* selection)
  {
    vtkSmartPointer<vtkSMSourceProxy> appended;
    appended.TakeReference(
      vtkSMSourceProxy::SafeDownCast(vtkSMSelectionHelper::NewAppendSelectionsFromSelectionSource(selection)));
    table->getOutputPort(0)->setSelectionInput(appended, 0);
    pqPVApplicationCore::instance()->selectionManager()->select(table->getOutputPort(0));
  }
  /// The (process, row) pairs of a table's ID selection (an AppendSelections of one source).
  static std::vector<vtkIdType> selectedTableRows(pqPipelineSource* table)
  {
    vtkSMSourceProxy* append = table->getOutputPort(0)->getSelectionInput();
    vtkSMProxy* sel = append && append->GetProperty("Input") ? vtkSMPropertyHelper(append, "Input").GetAsProxy(0) : nullptr;
    return sel && sel->GetProperty("IDs") ? vtkSMPropertyHelper(sel, "IDs").GetIdTypeArray() : std::vector<vtkIdType>();
  }

private Q_SLOTS:
  void initTestCase()
  {
    QVERIFY(pvqttest::segmentationVolume(
      gPlugin, gFixtures + "/synthA_b32_rans2_attr.csgv", this->Reader, this->Repr));
  }

  void cleanupTestCase()
  {
    this->Repr = nullptr;
    this->Reader = nullptr;
  }

  /// Hide, Show only and Show all edit the overlay; the materials stay as the user wrote them.
  void visibilityKeepsTheMaterials()
  {
    const QString user = R"({"materials": [{"name": "red", "filter": {"min": 1, "max": 9},
      "color": {"mode": "constant", "rgb": [1, 0, 0]}}, {"name": "rest"}]})";
    const QJsonValue kept = QJsonDocument::fromJson(pqCSGV::serialize(pqCSGV::parseDocument(user)).toUtf8())
                              .object()
                              .value("materials");
    auto doc = [](const QString& text) { return QJsonDocument::fromJson(text.toUtf8()).object(); };
    QString text = pqCSGV::editLabelVisibility(user, pqCSGV::LabelVisibility::Hide, 3);
    QCOMPARE(doc(text).value("materials"), kept);
    QCOMPARE(doc(text).value("hidden").toArray(), QJsonArray({ 3 }));
    text = pqCSGV::editLabelVisibility(text, pqCSGV::LabelVisibility::ShowOnly, 12);
    QCOMPARE(doc(text).value("materials"), kept);
    QCOMPARE(doc(text).value("only").toArray(), QJsonArray({ 12 }));
    text = pqCSGV::editLabelVisibility(text, pqCSGV::LabelVisibility::ShowAll, 0);
    QCOMPARE(doc(text).value("materials"), kept);
    QVERIFY(!doc(text).contains("hidden") && !doc(text).contains("only"));
    // Text Core refuses is never replaced (by the default document or anything else).
    QString error;
    QVERIFY(pqCSGV::editLabelVisibility("{\"materials\": 1}", pqCSGV::LabelVisibility::ShowAll, 0, &error).isEmpty());
    QVERIFY(!error.isEmpty());
  }

  /// The editor's "Export colours" button, clicked: a categorical table of the shown labels.
  void exportColorsMakesACategoricalTable()
  {
    this->setMaterials("");
    const QSet<qint64> all = labelsOf(pqCSGV::queryJson(this->Repr, "colors 4096"));
    QVERIFY2(all.size() >= 3, "the fixture shows several labels");
    QVERIFY(!all.contains(0));
    const qint64 hidden = *all.begin();
    this->setMaterials(pqCSGV::editLabelVisibility(this->materials(), pqCSGV::LabelVisibility::Hide, hidden));
    const QJsonObject colors = pqCSGV::queryJson(this->Repr, "colors 4096");
    QCOMPARE(labelsOf(colors), all - QSet<qint64>{ hidden }); // the query reports what is drawn

    pqCSGVMaterialEditor editor(this->Repr, nullptr);
    editor.show();
    QPushButton* button = editor.findChild<QPushButton*>("exportColors");
    QVERIFY(button);
    QTest::mouseClick(button, Qt::LeftButton);

    QString array = pqCSGV::queryJson(this->Repr, "summary").value("labelArray").toString();
    vtkNew<vtkSMTransferFunctionManager> mgr;
    // A table of its own (the display is no pipeline's here: no source name); the label array's
    // shared table stays as it was (issue 38, item 6).
    vtkSMProxy* lut = mgr->GetColorTransferFunction(
      pqCSGV::labelColorTableName(array, QString()).toUtf8().constData(), this->Repr->GetSessionProxyManager());
    QVERIFY(lut);
    vtkSMProxy* shared = mgr->GetColorTransferFunction(array.toUtf8().constData(), this->Repr->GetSessionProxyManager());
    QVERIFY(shared && shared != lut);
    QCOMPARE(vtkSMPropertyHelper(shared, "IndexedLookup").GetAsInt(), 0);
    QCOMPARE(vtkSMPropertyHelper(lut, "IndexedLookup").GetAsInt(), 1);
    QCOMPARE(vtkSMPropertyHelper(lut, "AutomaticRescaleRangeMode").GetAsInt(), int(vtkSMTransferFunctionManager::NEVER));
    // Ours, not computed from the data (ParaView's GUI said in a dialog that it could not, with
    // more than 32 labels, each time a display was coloured by the table).
    QCOMPARE(vtkSMPropertyHelper(lut, "AnnotationsInitialized").GetAsInt(), 1);
    QCOMPARE(vtkSMPropertyHelper(lut, "NanOpacity").GetAsDouble(), 0.0); // label 0, hidden: not drawn
    vtkSMPropertyHelper ann(lut, "Annotations");
    QSet<qint64> annotated;
    for (unsigned i = 0; i + 1 < ann.GetNumberOfElements(); i += 2)
    {
      annotated.insert(QString(ann.GetAsString(i)).toLongLong());
    }
    QCOMPARE(annotated, labelsOf(colors)); // the legend: only the labels the volume shows
    const QJsonArray first = colors.value("labels").toArray().at(0).toArray();
    vtkSMPropertyHelper rgb(lut, "IndexedColors");
    QCOMPARE(rgb.GetNumberOfElements(), 3u * unsigned(colors.value("labels").toArray().size()));
    for (int k = 0; k < 3; ++k)
    {
      QVERIFY(qAbs(rgb.GetAsDouble(unsigned(k)) - first.at(k + 1).toDouble()) < 1e-6);
    }
    // "Interpret Values As Categories" unticked: read as a continuous map, the table still gives
    // every shown label its material's colour (it was Cool to Warm over 0..1: a legend of
    // nothing drawn).
    vtkSMPropertyHelper(lut, "IndexedLookup").Set(0);
    lut->UpdateVTKObjects();
    auto* continuous = vtkScalarsToColors::SafeDownCast(lut->GetClientSideObject());
    QVERIFY(continuous);
    int compared = 0;
    for (const QJsonValue& v : colors.value("labels").toArray())
    {
      const QJsonArray e = v.toArray();
      double c[3];
      continuous->GetColor(e.at(0).toDouble(), c);
      for (int k = 0; k < 3; ++k)
      {
        QVERIFY2(qAbs(c[k] - e.at(k + 1).toDouble()) < 1e-6, qPrintable(QString("label %1").arg(e.at(0).toDouble())));
      }
      ++compared;
    }
    QVERIFY(compared >= 2);
    vtkSMPropertyHelper(lut, "IndexedLookup").Set(1);
    lut->UpdateVTKObjects();
    // Editing the materials keeps the overlay: the label stays hidden.
    QPushButton* add = editor.findChild<QPushButton*>("addMaterial");
    QVERIFY(add);
    QTest::mouseClick(add, Qt::LeftButton);
    editor.apply();
    const QJsonObject edited = QJsonDocument::fromJson(this->materials().toUtf8()).object();
    QCOMPARE(edited.value("materials").toArray().size(), 2);
    QCOMPARE(edited.value("hidden").toArray(), QJsonArray({ double(hidden) }));
    this->setMaterials("");
  }

  /// Docked as pqPluginDockWidgetsBehavior docks it, the panel stays hidden until opened.
  void pickPanelStartsHidden()
  {
    QMainWindow window;
    window.show();
    auto* panel = new pqCSGVPickPanel(&window);
    window.addDockWidget(Qt::RightDockWidgetArea, panel);
    QApplication::processEvents();
    QVERIFY(!panel->isVisible());
    panel->toggleViewAction()->trigger(); // View > Segmentation Pick
    QVERIFY(panel->isVisible());
    // Nothing picked: the edits that need a pick are off.
    QVERIFY(!panel->findChild<QPushButton*>("hideLabel")->isEnabled());
    QVERIFY(!panel->findChild<QPushButton*>("showOnlyLabel")->isEnabled());
    QVERIFY2(!panel->findChild<QPushButton*>("showAllLabels")->isEnabled(), "no volume to show all of");
    // Narrow enough to sit beside a view: two buttons a row (one row of four widened a window
    // that filled a 1600-pixel screen past it).
    QVERIFY2(panel->minimumSizeHint().width() < 420,
      qPrintable(QString("the panel needs %1 pixels").arg(panel->minimumSizeHint().width())));
  }

  /// A click in the view picks; Hide edits the overlay only; the pick clears when another view
  /// becomes active and when its data is deleted.
  void pickPanelFollowsItsViewAndData()
  {
    pqServer* server = pqActiveObjects::instance().activeServer();
    pqObjectBuilder* builder = pqApplicationCore::instance()->getObjectBuilder();
    pqPipelineSource* source = builder->createReader(
      "sources", "CSGVReader", { gFixtures + "/synthA_b32_rans2_attr.csgv" }, server);
    QVERIFY(source);
    pqView* view = builder->createView("RenderView", server);
    QVERIFY(view);
    view->widget()->resize(160, 160);
    view->widget()->show();
    pqActiveObjects::instance().setActiveView(view);
    pqDataRepresentation* display = builder->createDataRepresentation(source->getOutputPort(0), view);
    QVERIFY(display);
    vtkSMProxy* proxy = display->getProxy();
    // The GUI's Apply picks the reader's RepresentationType; a bare builder gives Outline.
    vtkSMPropertyHelper(proxy, "Representation").Set("Segmentation Volume");
    const QString user = R"({"materials": [{"name": "mine", "color": {"mode": "constant", "rgb": [1, 0.5, 0]}}]})";
    vtkSMPropertyHelper(proxy, "CSGVMaterials").Set(user.toUtf8().constData());
    proxy->UpdateVTKObjects();
    view->resetDisplay();
    view->forceRender();

    pqCSGVPickPanel panel;
    panel.show(); // opened from the View menu
    QPushButton* hide = panel.findChild<QPushButton*>("hideLabel");
    auto* result = panel.findChild<QTextBrowser*>("pickResult");
    const QPoint centre(80, 80);
    QTest::mouseClick(view->widget(), Qt::LeftButton, Qt::NoModifier, centre);
    QVERIFY2(panel.lastPick().value("hit").toBool(), "a click on the volume picks a label");
    const qint64 label = qint64(panel.lastPick().value("label").toDouble());
    QVERIFY(hide->isEnabled());
    QPushButton* showAll = panel.findChild<QPushButton*>("showAllLabels");
    QVERIFY(showAll->isEnabled());
    QTest::mouseClick(hide, Qt::LeftButton);
    const QJsonObject edited =
      QJsonDocument::fromJson(vtkSMPropertyHelper(proxy, "CSGVMaterials").GetAsString()).object();
    QVERIFY2(edited.value("hidden").toArray() == QJsonArray({ double(label) }),
      vtkSMPropertyHelper(proxy, "CSGVMaterials").GetAsString());
    QCOMPARE(edited.value("materials").toArray().size(), 1);
    QCOMPARE(edited.value("materials").toArray().at(0).toObject().value("name").toString(), QString("mine"));

    pqView* other = builder->createView("RenderView", server);
    pqActiveObjects::instance().setActiveView(other);
    QVERIFY2(panel.lastPick().isEmpty() && !hide->isEnabled() && result->toPlainText().isEmpty(),
      "another active view clears the pick");
    // Show all acts on the active data set's volume, shown in the other view, and is disabled
    // with no data set active (GUI pass 15: enabled, it edited nothing).
    pqActiveObjects::instance().setActiveSource(nullptr);
    QVERIFY(!showAll->isEnabled());
    pqActiveObjects::instance().setActiveSource(source);
    QVERIFY(showAll->isEnabled());

    pqActiveObjects::instance().setActiveView(view);
    view->forceRender();
    QTest::mouseClick(view->widget(), Qt::LeftButton, Qt::NoModifier, centre);
    QVERIFY(panel.lastPick().value("hit").toBool());
    // Found by a GUI pass: a pick made at one time step stayed after a change of time, naming a
    // voxel the new step does not have.
    pqTimeKeeper* time = server->getTimeKeeper();
    time->setTime(time->getTime() + 1.0);
    QVERIFY2(panel.lastPick().isEmpty() && !hide->isEnabled() && result->toPlainText().isEmpty(),
      "another time clears the pick");
    time->setTime(time->getTime() - 1.0);
    QTest::mouseClick(view->widget(), Qt::LeftButton, Qt::NoModifier, centre);
    QVERIFY(panel.lastPick().value("hit").toBool());
    // Data shown in the view since the pick may be under that pixel now (GUI pass 11: "No label
    // at pixel ..." stayed after the volume appeared).
    {
      pqPipelineSource* more = builder->createReader(
        "sources", "CSGVReader", { gFixtures + "/synthA_b32_rans2.csgv" }, server);
      QVERIFY(more && builder->createDataRepresentation(more->getOutputPort(0), view));
      QVERIFY2(panel.lastPick().isEmpty() && !hide->isEnabled() && result->toPlainText().isEmpty(),
        "data shown in the view clears the pick");
      builder->destroy(more);
      QTest::mouseClick(view->widget(), Qt::LeftButton, Qt::NoModifier, centre);
      QVERIFY(panel.lastPick().value("hit").toBool());
    }
    builder->destroy(source);
    QVERIFY2(panel.lastPick().isEmpty() && !hide->isEnabled() && result->toPlainText().isEmpty(),
      "deleting the picked data clears the pick");
    builder->destroy(other);
    builder->destroy(view);
  }

  void selectionLinksPickToolsTableAndExtract()
  {
    pqApplicationCore* core = pqApplicationCore::instance();
    this->ensureUndoStack();
    // (The plugin's own instance runs too; a second one makes the same edits, which change nothing.)
    pqCSGVLabelSelection links;
    links.startup();
    // Find Data's "current selection" frame, as the GUI has it: it reads every new selection
    // (and crashed on a selection input that was not an AppendSelections).
    pqFindDataCurrentSelectionFrame findData;
    pqObjectBuilder* builder = core->getObjectBuilder();
    pqPipelineSource* source = nullptr;
    pqRenderView* view = nullptr;
    vtkSMProxy* proxy = this->shownInNewView(source, view);
    QVERIFY(proxy);
    pqPipelineSource* table = nullptr;
    vtkTable* tableData = newLabelTable(source, table);
    QVERIFY(tableData && tableData->GetColumnByName("label"));
    vtkAbstractArray* rows = tableData->GetColumnByName("label");
    auto rowOf = [rows](uint32_t label) {
      for (vtkIdType i = 0; i < rows->GetNumberOfTuples(); ++i)
        if (rows->GetVariantValue(i).ToTypeInt64() == int64_t(label))
          return i;
      return vtkIdType(-1);
    };
    auto selectedRowsOf = [](pqPipelineSource* t) {
      std::vector<vtkIdType> out;
      const std::vector<vtkIdType> ids = selectedTableRows(t);
      for (size_t i = 1; i < ids.size(); i += 2)
        out.push_back(ids[i]);
      return out;
    };
    auto selectedRows = [table, selectedRowsOf]() { return selectedRowsOf(table); };

    // ParaView's rectangle tool: the region event of the view proxy, in selection mode.
    const std::vector<uint32_t> shown = pqCSGV::labelsInRectangle(proxy, 0, 0, 159, 159);
    QVERIFY2(shown.size() >= 2, "the view shows labels");
    const std::vector<uint32_t> corner = pqCSGV::labelsInRectangle(proxy, 60, 60, 100, 100);
    QVERIFY(!corner.empty());
    pqActiveObjects::instance().setActiveSource(source);
    vtkSMRenderViewProxy* rmp = view->getRenderViewProxy();
    vtkSMPropertyHelper(rmp, "InteractionMode").Set(vtkPVRenderView::INTERACTION_MODE_SELECTION);
    rmp->UpdateVTKObjects();
    int region[4] = { 60, 60, 100, 100 };
    rmp->InvokeEvent(vtkCommand::SelectionChangedEvent, region);
    vtkSMPropertyHelper(rmp, "InteractionMode").Set(vtkPVRenderView::INTERACTION_MODE_3D);
    rmp->UpdateVTKObjects();
    QTRY_VERIFY2(pqCSGV::selectedLabels(proxy) == corner, "a rectangle selects the labels shown in it");
    QCOMPARE(QString(core->getUndoStack()->undoLabel()), QString("Select labels"));
    // The table's rows follow.
    std::vector<vtkIdType> want;
    for (uint32_t l : corner)
      if (rowOf(l) >= 0)
        want.push_back(rowOf(l));
    QVERIFY(!want.empty());
    QTRY_VERIFY2(selectedRows() == want, "the label table's rows follow the 3D selection");
    QVERIFY2(pqActiveObjects::instance().activeSource() == source, "a 3D selection leaves the active source");
    // A table made after the selection takes it at its first update (it stayed empty until the
    // next selection).
    pqPipelineSource* later = builder->createFilter("filters", "CSGVLabelTable", source);
    QVERIFY(later);
    vtkSMSourceProxy::SafeDownCast(later->getProxy())->UpdatePipeline();
    QTRY_VERIFY2(selectedRowsOf(later) == want, "a label table made after the selection shows it");
    builder->destroy(later);
    pqActiveObjects::instance().setActiveSource(source);

    // Drawn highlighted: the colour query gives the selection colour for a selected label only.
    const QJsonObject colors = pqCSGV::queryJson(proxy, "colors 100000");
    int magenta = 0, selectedSeen = 0;
    for (const QJsonValue& e : colors.value("labels").toArray())
    {
      const QJsonArray c = e.toArray();
      const bool isSelected = std::binary_search(corner.begin(), corner.end(), uint32_t(c.at(0).toDouble()));
      const bool isMagenta = c.at(1).toDouble() == 1 && c.at(2).toDouble() == 0 && c.at(3).toDouble() == 1;
      selectedSeen += isSelected;
      magenta += isMagenta;
      QVERIFY2(isSelected == isMagenta, "the selected labels, and only they, are drawn in the highlight colour");
    }
    QVERIFY(selectedSeen == int(corner.size()) && magenta > 0);

    // Rows selected in the table (the Spreadsheet's clicks) select their labels in 3D.
    selectTableRows(table, { 0, 1, 0, 2 });
    const std::vector<uint32_t> fromRows{ uint32_t(rows->GetVariantValue(1).ToTypeInt64()),
      uint32_t(rows->GetVariantValue(2).ToTypeInt64()) };
    QVERIFY2(pqCSGV::selectedLabels(proxy) == fromRows, "selected rows select their labels");
    // A query over the rows (Find Data's kind): labels in a range of the label column.
    vtkSmartPointer<vtkSMSourceProxy> query;
    query.TakeReference(vtkSMSourceProxy::SafeDownCast(
      table->getProxy()->GetSessionProxyManager()->NewProxy("sources", "ThresholdSelectionSource")));
    vtkSMPropertyHelper(query, "FieldType").Set(vtkSelectionNode::ROW);
    vtkSMPropertyHelper(query, "ArrayName").Set("label");
    const double range[] = { double(rows->GetVariantValue(3).ToTypeInt64()), double(rows->GetVariantValue(5).ToTypeInt64()) };
    vtkSMPropertyHelper(query, "Thresholds").Set(range, 2);
    query->UpdateVTKObjects();
    selectTable(table, query);
    QCOMPARE(pqCSGV::selectedLabels(proxy).size(), size_t(3));
    QCOMPARE(pqCSGV::selectedLabels(proxy).front(), uint32_t(range[0]));
    // Undo gives back the selection before.
    core->getUndoStack()->undo();
    QVERIFY2(pqCSGV::selectedLabels(proxy) == fromRows, "undo gives back the previous selection");
    {
      // A click on a row of the Spreadsheet view, as a user makes it: its selection model turns
      // the row into a ParaView selection of the table (GUI pass 10: the 3D selection stayed).
      pqView* sheet = builder->createView("SpreadSheetView", core->getActiveServer());
      QVERIFY(sheet);
      QVERIFY(builder->createDataRepresentation(table->getOutputPort(0), sheet));
      vtkSMPropertyHelper(sheet->getProxy(), "FieldAssociation").Set(vtkDataObject::FIELD_ASSOCIATION_ROWS);
      sheet->getProxy()->UpdateVTKObjects();
      sheet->widget()->resize(600, 400);
      sheet->widget()->show();
      sheet->forceRender();
      auto* tableView = sheet->widget()->findChild<QTableView*>();
      QVERIFY(tableView && tableView->model() && tableView->selectionModel());
      QTRY_VERIFY(tableView->model()->rowCount() == rows->GetNumberOfTuples());
      const int labelColumn = [&] {
        for (int c = 0; c < tableView->model()->columnCount(); ++c)
          if (tableView->model()->headerData(c, Qt::Horizontal).toString() == "label")
            return c;
        return -1;
      }();
      QVERIFY(labelColumn >= 0);
      const QModelIndex cell = tableView->model()->index(4, labelColumn);
      QTRY_VERIFY(tableView->model()->data(cell).isValid() && !tableView->model()->data(cell).toString().isEmpty());
      const uint32_t rowLabel = uint32_t(tableView->model()->data(cell).toString().toULongLong());
      tableView->selectionModel()->select(
        cell, QItemSelectionModel::ClearAndSelect | QItemSelectionModel::Rows);
      QTRY_VERIFY2(pqCSGV::selectedLabels(proxy) == std::vector<uint32_t>{ rowLabel },
        qPrintable(QString("a click on the row of label %1 selects it in 3D (%2 selected)")
                     .arg(rowLabel).arg(pqCSGV::selectedLabels(proxy).size())));
      // The pick panel says so while the table is the active source (it said "No label selected").
      {
        pqActiveObjects::instance().setActiveSource(table);
        pqCSGVPickPanel sheetPanel;
        sheetPanel.show();
        QVERIFY2(sheetPanel.findChild<QLabel*>("selectionInfo")->text().startsWith("1 label selected"),
          qPrintable(sheetPanel.findChild<QLabel*>("selectionInfo")->text()));
        // ... and Show all acts on the table's volume there.
        QVERIFY(sheetPanel.findChild<QPushButton*>("showAllLabels")->isEnabled());
      }
      // And while the volume's reader is active with the Spreadsheet view (GUI pass 14: it said
      // "No label selected", the selection still drawn).
      {
        pqActiveObjects::instance().setActiveView(sheet);
        pqActiveObjects::instance().setActiveSource(source);
        pqCSGVPickPanel readerPanel;
        readerPanel.show();
        QVERIFY2(readerPanel.findChild<QLabel*>("selectionInfo")->text().startsWith("1 label selected"),
          qPrintable(readerPanel.findChild<QLabel*>("selectionInfo")->text()));
      }
      core->getUndoStack()->undo();
      builder->destroy(sheet);
      pqActiveObjects::instance().setActiveView(view);
      pqActiveObjects::instance().setActiveSource(source);
    }

    // The pick panel: a click selects, Ctrl+click adds, Shift+click removes.
    pqCSGVPickPanel panel;
    panel.show();
    view->forceRender();
    const QPoint centre(80, 80);
    QTest::mouseClick(view->widget(), Qt::LeftButton, Qt::NoModifier, centre);
    QVERIFY(panel.lastPick().value("hit").toBool());
    const auto picked = uint32_t(panel.lastPick().value("label").toDouble());
    QVERIFY(pqCSGV::selectedLabels(proxy) == std::vector<uint32_t>{ picked });
    QVERIFY(panel.findChild<QLabel*>("selectionInfo")->text().startsWith("1 label selected"));
    pqCSGVLabelSelection::edit(proxy, fromRows, csgv::SelectionEdit::Add, "Select labels");
    view->forceRender();
    QTest::mouseClick(view->widget(), Qt::LeftButton, Qt::ShiftModifier, centre);
    std::vector<uint32_t> rest = fromRows;
    rest.erase(std::remove(rest.begin(), rest.end(), picked), rest.end());
    QVERIFY2(pqCSGV::selectedLabels(proxy) == rest, "Shift+click removes the picked label");
    QTest::mouseClick(view->widget(), Qt::LeftButton, Qt::ControlModifier, centre);
    std::vector<uint32_t> back = rest;
    back.push_back(picked);
    std::sort(back.begin(), back.end());
    QVERIFY2(pqCSGV::selectedLabels(proxy) == back, "Ctrl+click adds it");
    // The query box: the labels whose attributes make the SQL condition true (the table's rows
    // are the oracle); a condition SQLite refuses says why and leaves the selection.
    {
      std::vector<uint32_t> wanted;
      vtkAbstractArray* voxels = tableData->GetColumnByName("voxels");
      vtkAbstractArray* kind = tableData->GetColumnByName("kind");
      QVERIFY(voxels && kind);
      for (vtkIdType i = 0; i < rows->GetNumberOfTuples(); ++i)
        if (voxels->GetVariantValue(i).ToDouble() > 5000 && kind->GetVariantValue(i).ToInt() == 2)
          wanted.push_back(uint32_t(rows->GetVariantValue(i).ToTypeInt64()));
      QVERIFY(!wanted.empty());
      auto* queryBox = panel.findChild<QLineEdit*>("selectQuery");
      QVERIFY(queryBox);
      queryBox->setText("voxels > 5000 and kind = 2");
      QTest::keyClick(queryBox, Qt::Key_Return);
      QVERIFY2(pqCSGV::selectedLabels(proxy) == wanted, "the query box selects the labels that match");
      queryBox->setText("voxels >");
      QTest::keyClick(queryBox, Qt::Key_Return);
      QVERIFY2(pqCSGV::selectedLabels(proxy) == wanted, "a bad condition leaves the selection");
      QVERIFY(panel.findChild<QTextBrowser*>("pickResult")->toPlainText().contains("selects nothing"));
      pqCSGVLabelSelection::edit(proxy, back, csgv::SelectionEdit::Replace, "Select labels");
    }
    // Dim style, then Extract selection: a CSGV Extract Labels of the selected labels.
    auto* style = panel.findChild<QComboBox*>("selectionStyle");
    style->setCurrentIndex(1);
    QMetaObject::invokeMethod(style, "activated", Q_ARG(int, 1));
    QVERIFY(QString(vtkSMPropertyHelper(proxy, "CSGVMaterials").GetAsString()).contains("\"selectionStyle\":\"dim\""));
    // Label 0 (the background, no material takes it) is left out of the extraction.
    pqCSGVLabelSelection::edit(proxy, { 0 }, csgv::SelectionEdit::Add, "Select labels");
    QTest::mouseClick(panel.findChild<QPushButton*>("extractSelection"), Qt::LeftButton);
    pqPipelineSource* extract = pqActiveObjects::instance().activeSource();
    QVERIFY(extract && QString(extract->getProxy()->GetXMLName()) == "CSGVExtractLabels");
    QCOMPARE(QString(vtkSMPropertyHelper(extract->getProxy(), "Labels").GetAsString()), pqCSGV::labelsText(back));
    // Clear selection empties it, and the rows' selection with it; the keyboard focus does not
    // land in the SQL box (it took the view's shortcut keys: found by a GUI pass).
    QPushButton* clear = panel.findChild<QPushButton*>("clearSelection");
    QApplication::setActiveWindow(&panel);
    clear->setFocus();
    QTRY_VERIFY(clear->hasFocus());
    QTest::mouseClick(clear, Qt::LeftButton);
    QVERIFY(pqCSGV::selectedLabels(proxy).empty());
    QVERIFY2(!panel.findChild<QLineEdit*>("selectQuery")->hasFocus(), "the SQL box did not take the focus");
    QTRY_VERIFY(table->getOutputPort(0)->getSelectionInput() == nullptr);

    builder->destroy(extract);
    builder->destroy(table);
    builder->destroy(source);
    builder->destroy(view);
    links.shutdown();
  }

  /// Colouring by the label array (as the colour toolbar does it: the coloring, then the legend)
  /// shows one legend, the volume's own (the shared table's was left showing beside it), and is
  /// one undo step: the legend's own edits follow it, and redo stays possible.
  /// A volume with labels beyond 32 bits is drawn by ids (README, "Labels beyond 32 bits"; docs
  /// pass 11): a Label Table row selects its csgv_id, not its original label (a row of label 1
  /// selected id 1, another label), and a 3D selection of an id selects that id's row.
  void tableRowsOfAVolumeDrawnByIdsSelectTheirIds()
  {
    const QByteArray tool = qgetenv("CSGV_TOOL");
    QVERIFY2(!tool.isEmpty(), "CSGV_TOOL names the csgv tool");
    QTemporaryDir dir;
    QVERIFY(dir.isValid());
    // 24^3 int32 voxels in six slabs along x: -3, -2, 1, 2, -1, 7 (1 and 2 fit 32 bits, and are
    // also ids of other labels).
    const int n = 24;
    const int32_t slabs[6] = { -3, -2, 1, 2, -1, 7 };
    QByteArray voxels;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
        {
          const int32_t v = slabs[std::min(i / 4, 5)];
          voxels.append(reinterpret_cast<const char*>(&v), 4); // little-endian, as the hosts here
        }
    const QString nrrd = dir.filePath("neg.nrrd"), csgv = dir.filePath("neg.csgv");
    {
      QFile f(nrrd);
      QVERIFY(f.open(QIODevice::WriteOnly));
      f.write("NRRD0004\ntype: int32\ndimension: 3\nsizes: 24 24 24\nencoding: raw\nendian: little\n\n");
      f.write(voxels);
    }
    QVERIFY(QProcess::execute(QString::fromLocal8Bit(tool), { "compress", "--quiet", nrrd, csgv }) == 0);

    this->ensureUndoStack();
    pqCSGVLabelSelection links;
    links.startup();
    pqObjectBuilder* builder = pqApplicationCore::instance()->getObjectBuilder();
    pqPipelineSource* source = nullptr;
    pqRenderView* view = nullptr;
    vtkSMProxy* proxy = this->shownInNewView(source, view, { csgv });
    QVERIFY(proxy);
    pqPipelineSource* table = nullptr;
    vtkTable* tableData = newLabelTable(source, table);
    QVERIFY(tableData);
    vtkAbstractArray* labels = tableData->GetColumnByName("label");
    vtkAbstractArray* ids = tableData->GetColumnByName("csgv_id");
    QVERIFY(labels && ids);
    vtkIdType rowOfOne = -1;
    for (vtkIdType i = 0; i < labels->GetNumberOfTuples(); ++i)
      if (labels->GetVariantValue(i).ToTypeInt64() == 1)
        rowOfOne = i;
    QVERIFY(rowOfOne >= 0);
    const auto idOfOne = uint32_t(ids->GetVariantValue(rowOfOne).ToTypeInt64());
    QVERIFY2(idOfOne != 1, "label 1 is drawn by another id (the test needs them to differ)");

    // The row of label 1, selected as the Spreadsheet selects rows: its id is selected in 3D.
    selectTableRows(table, { 0, rowOfOne });
    QVERIFY2(pqCSGV::selectedLabels(proxy) == std::vector<uint32_t>{ idOfOne },
      qPrintable(QString("the row of label 1 selects its id %1 (%2 selected, first %3)")
                   .arg(idOfOne)
                   .arg(pqCSGV::selectedLabels(proxy).size())
                   .arg(pqCSGV::selectedLabels(proxy).empty() ? -1 : qint64(pqCSGV::selectedLabels(proxy).front()))));
    // A 3D selection of that id selects that row.
    pqActiveObjects::instance().setActiveSource(source);
    QVERIFY(pqCSGVLabelSelection::edit(proxy, { idOfOne }, csgv::SelectionEdit::Replace, "Select labels"));
    const std::vector<vtkIdType> wantRows{ 0, rowOfOne };
    QTRY_VERIFY2(selectedTableRows(table) == wantRows, "a 3D selection of the id selects the row of its label");
    builder->destroy(table);
    builder->destroy(source);
    builder->destroy(view);
  }

  void colouringByLabelsShowsOneLegendAndIsOneUndoStep()
  {
    pqApplicationCore* core = pqApplicationCore::instance();
    this->ensureUndoStack();
    pqCSGVColorLegend legends; // (the plugin's own instance runs too: the same edits)
    legends.startup();
    pqObjectBuilder* builder = core->getObjectBuilder();
    pqPipelineSource* source = nullptr;
    pqRenderView* view = nullptr;
    vtkSMProxy* proxy = this->shownInNewView(source, view);
    QVERIFY(proxy);
    const QString array = pqCSGV::labelArrayOf(proxy);
    QVERIFY(!array.isEmpty());
    core->getUndoStack()->clear();

    core->getUndoStack()->beginUndoSet("Colour by labels");
    QVERIFY(vtkSMPVRepresentationProxy::SetScalarColoring(proxy, array.toUtf8().constData(), vtkDataObject::CELL));
    vtkSMPVRepresentationProxy::SetScalarBarVisibility(proxy, view->getProxy(), true);
    core->getUndoStack()->endUndoSet();
    QTest::qWait(100); // the legend follows from the event loop
    view->forceRender();

    vtkNew<vtkSMTransferFunctionManager> mgr;
    vtkSMProxy* shared = mgr->GetColorTransferFunction(array.toUtf8().constData(), proxy->GetSessionProxyManager());
    vtkSMProxy* own = vtkSMPropertyHelper(proxy, "LookupTable").GetAsProxy();
    QVERIFY(shared && own && own != shared);
    auto visible = [&](vtkSMProxy* lut) {
      vtkSMProxy* bar = vtkSMTransferFunctionProxy::FindScalarBarRepresentation(lut, view->getProxy());
      return bar && vtkSMPropertyHelper(bar, "Visibility").GetAsInt() != 0;
    };
    QVERIFY2(visible(own), "the volume's own legend shows");
    QVERIFY2(!visible(shared), "the shared table's legend is hidden (nothing else uses it)");

    QCOMPARE(QString(core->getUndoStack()->undoLabel()), QString("Colour by labels"));
    core->getUndoStack()->undo();
    QTest::qWait(100);
    QVERIFY2(core->getUndoStack()->canRedo(), "one undo reverts it and redo stays possible");
    const char* colored = vtkSMPropertyHelper(proxy, "ColorArrayName").GetInputArrayNameToProcess();
    QVERIFY2(!colored || !*colored, "one undo: the display is not coloured by the labels any more");
    QVERIFY2(!visible(own) && !visible(shared), "no legend stays after the undo");
    // A selection edit of a display coloured by its labels is traced as the edit alone: the legend
    // made again after it is no trace item (each edit traced the whole table, its colours and
    // legend: found by a GUI pass).
    core->getUndoStack()->redo();
    QTest::qWait(100);
    std::vector<uint32_t> shown = pqCSGV::labelsInRectangle(proxy, 0, 0, 159, 159);
    shown.erase(std::remove(shown.begin(), shown.end(), 0u), shown.end());
    QVERIFY(!shown.empty());
    QVERIFY(vtkSMTrace::StartTrace());
    QVERIFY(pqCSGVLabelSelection::edit(proxy, { shown[0] }, csgv::SelectionEdit::Replace, "Select labels"));
    QTest::qWait(200); // the legend follows from the event loop
    const std::string traced = vtkSMTrace::StopTrace();
    QVERIFY2(traced.find("CSGVMaterials") != std::string::npos, traced.c_str());
    // (ParaView's trace still names the tables of coloured displays at its end.)
    QVERIFY2(traced.find("IndexedColors") == std::string::npos &&
        traced.find("SetScalarBarVisibility") == std::string::npos, traced.c_str());
    legends.shutdown();
    builder->destroy(source);
    builder->destroy(view);
  }

  /// Export colours gives a Slice of the data the table of its own and hides the legend of the
  /// label array's shared table it was coloured by (it stayed on screen: found by a GUI pass).
  void exportReplacesTheSharedLegend()
  {
    pqPipelineSource* source = nullptr;
    pqRenderView* view = nullptr;
    vtkSMProxy* volume = this->shownInNewView(source, view);
    QVERIFY(volume);
    pqObjectBuilder* builder = pqApplicationCore::instance()->getObjectBuilder();
    pqPipelineSource* slice = builder->createFilter("filters", "Cut", source);
    QVERIFY(slice);
    pqDataRepresentation* shown = builder->createDataRepresentation(slice->getOutputPort(0), view);
    QVERIFY(shown);
    const QString array = pqCSGV::labelArrayOf(volume);
    QVERIFY(vtkSMPVRepresentationProxy::SetScalarColoring(shown->getProxy(), array.toUtf8().constData(), vtkDataObject::CELL));
    QVERIFY(vtkSMPVRepresentationProxy::SetScalarBarVisibility(shown->getProxy(), view->getProxy(), true));
    vtkSMProxy* shared = vtkSMPropertyHelper(shown->getProxy(), "LookupTable").GetAsProxy();
    QVERIFY(shared);
    auto visible = [&](vtkSMProxy* lut) {
      vtkSMProxy* bar = vtkSMTransferFunctionProxy::FindScalarBarRepresentation(lut, view->getProxy());
      return bar && vtkSMPropertyHelper(bar, "Visibility").GetAsInt() != 0;
    };
    QVERIFY(visible(shared));
    const QString message = pqCSGV::exportLabelColors(volume);
    vtkSMProxy* own = vtkSMPropertyHelper(shown->getProxy(), "LookupTable").GetAsProxy();
    QVERIFY2(own && own != shared, qPrintable(message));
    QVERIFY2(visible(own), "the exported table's legend shows");
    QVERIFY2(!visible(shared), "the shared table's legend is hidden (nothing else uses it)");
    builder->destroy(slice);
    builder->destroy(source);
    builder->destroy(view);
  }

  /// Found by a GUI pass: a view made after a label selection drew the data without it (the
  /// selection of a data set is the same in every view that shows it).
  void aNewViewShowsTheSelection()
  {
    pqCSGVLabelSelection links;
    links.startup();
    pqPipelineSource* source = nullptr;
    pqRenderView* view = nullptr;
    vtkSMProxy* first = this->shownInNewView(source, view);
    QVERIFY(first);
    std::vector<uint32_t> shown = pqCSGV::labelsInRectangle(first, 0, 0, 159, 159);
    shown.erase(std::remove(shown.begin(), shown.end(), 0u), shown.end());
    QVERIFY(shown.size() >= 2);
    // The edit is in the Python trace, as the Properties panel's edits are (found by the same
    // pass: a traced selection was lost on replay).
    QVERIFY(vtkSMTrace::StartTrace());
    QVERIFY(pqCSGVLabelSelection::edit(first, { shown[0], shown[1] }, csgv::SelectionEdit::Replace, "Select labels"));
    const std::string traced = vtkSMTrace::StopTrace();
    const std::vector<uint32_t> selected = pqCSGV::selectedLabels(first);
    QCOMPARE(selected.size(), size_t(2));
    QVERIFY2(traced.find("CSGVMaterials") != std::string::npos &&
        traced.find(std::to_string(selected[1])) != std::string::npos, traced.c_str());

    pqServer* server = pqActiveObjects::instance().activeServer();
    pqObjectBuilder* builder = pqApplicationCore::instance()->getObjectBuilder();
    pqView* other = builder->createView("RenderView", server);
    QVERIFY(other);
    pqDataRepresentation* second = builder->createDataRepresentation(source->getOutputPort(0), other);
    QVERIFY(second);
    QTRY_VERIFY2(pqCSGV::selectedLabels(second->getProxy()) == selected, "the new view shows the selection");
    builder->destroy(source);
    builder->destroy(other);
    builder->destroy(view);
    links.shutdown();
  }

  /// Found by a GUI pass: the material editor's data range stayed the first time step's after
  /// the view moved to a step of other labels (the representation's data update does not fire
  /// for a change of time).
  void materialEditorRangeFollowsTheTimeStep()
  {
    QTemporaryDir dir;
    QStringList files;
    for (const char* name : { "synthA_b32_rans2.csgv", "denseB_b32_rans1.csgv" })
    {
      files << dir.filePath(QString("s_%1.csgv").arg(files.size()));
      QVERIFY(QFile::copy(gFixtures + "/" + name, files.last()));
    }
    pqPipelineSource* source = nullptr;
    pqRenderView* view = nullptr;
    vtkSMProxy* proxy = this->shownInNewView(source, view, files);
    QVERIFY(proxy);
    pqTimeKeeper* time = pqActiveObjects::instance().activeServer()->getTimeKeeper();
    pqObjectBuilder* builder = pqApplicationCore::instance()->getObjectBuilder();
    time->setTime(0.0);
    view->forceRender();

    pqCSGVMaterialEditor editor(proxy, nullptr);
    editor.show();
    QVERIFY(QTest::qWaitForWindowExposed(&editor));
    QTest::qWait(50);
    auto* range = editor.findChild<QLabel*>("filterRange");
    QVERIFY(range);
    // The label range each step reports (the query asks the rendering process, at its time).
    auto reported = [&]() {
      for (const QJsonValue& v : pqCSGV::queryJson(proxy, "summary").value("attributes").toArray())
      {
        if (v.toObject().value("name").toString() == "label")
        {
          return QString("data range: %1 .. %2")
            .arg(v.toObject().value("min").toDouble(), 0, 'g', 12)
            .arg(v.toObject().value("max").toDouble(), 0, 'g', 12);
        }
      }
      return QString();
    };
    const QString first = reported();
    QVERIFY(!first.isEmpty());
    QCOMPARE(range->text(), first);
    time->setTime(1.0);
    view->forceRender();
    const QString second = reported();
    QVERIFY2(second != first, qPrintable(first + " at both steps: the fixtures should differ"));
    QTRY_COMPARE_WITH_TIMEOUT(range->text(), second, 2000);
    time->setTime(0.0);
    view->forceRender();
    QTRY_COMPARE_WITH_TIMEOUT(range->text(), first, 2000);
    builder->destroy(source);
    builder->destroy(view);
  }
};

int main(int argc, char** argv)
{
  return pvqttest::run<TestLabelPanel>(argc, argv, gPlugin, gFixtures);
}

#include "test_label_panel.moc"
