// SPDX-License-Identifier: MIT
// QtTest of issue 38, item 7, in a builtin ParaView session with two render views: attribute
// files, derived attributes and computed attributes belong to the data (pqCSGVSharedAttributes:
// a second view of the same data takes them, and a change in either view reaches the other),
// while materials stay per view and the editor copies them from the other view in one click
// (undoable); the editor's colour export makes a table of the data's own that a Slice of it takes
// (item 6). Usage: csgv_shared_attributes_test PLUGIN.so FIXTURES_DIR
#include "PvQtTestMain.h"
#include "pqCSGVMaterialDocument.h"
#include "pqCSGVMaterialEditor.h"
#include "pqCSGVSharedAttributes.h"

#include <pqApplicationCore.h>
#include <pqDataRepresentation.h>
#include <pqObjectBuilder.h>
#include <pqPipelineSource.h>
#include <pqServerManagerModel.h>
#include <pqUndoStack.h>
#include <pqUndoStackBuilder.h>
#include <pqView.h>
#include <vtkDataObject.h>
#include <vtkNew.h>
#include <vtkSMPVRepresentationProxy.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>
#include <vtkSMTransferFunctionManager.h>
#include <vtkSMTransferFunctionProxy.h>

#include <QFileInfo>
#include <QLabel>
#include <QPushButton>
#include <QtTest>

namespace
{
QString gPlugin, gFixtures;

void setStrings(vtkSMProxy* proxy, const char* name, const QStringList& values)
{
  vtkSMPropertyHelper h(proxy, name);
  h.SetNumberOfElements(unsigned(values.size()));
  for (int i = 0; i < values.size(); ++i)
  {
    h.Set(unsigned(i), values[i].toUtf8().constData());
  }
  proxy->UpdateVTKObjects();
}

QStringList strings(vtkSMProxy* proxy, const char* name)
{
  QStringList out;
  vtkSMPropertyHelper h(proxy, name);
  for (unsigned int i = 0; i < h.GetNumberOfElements(); ++i)
  {
    out << QString::fromUtf8(h.GetAsString(i));
  }
  return out;
}
}

class TestSharedAttributes : public QObject
{
  Q_OBJECT

  pqCSGVSharedAttributes* Shared = nullptr;
  pqPipelineSource* Reader = nullptr;
  pqView *View1 = nullptr, *View2 = nullptr;
  vtkSMProxy *Repr1 = nullptr, *Repr2 = nullptr;

  vtkSMProxy* show(pqView* view)
  {
    pqObjectBuilder* builder = pqApplicationCore::instance()->getObjectBuilder();
    pqDataRepresentation* r = builder->createDataRepresentation(this->Reader->getOutputPort(0), view);
    if (!r)
    {
      return nullptr;
    }
    vtkSMPropertyHelper(r->getProxy(), "Representation").Set("Segmentation Volume");
    r->getProxy()->UpdateVTKObjects();
    QCoreApplication::processEvents(); // pqCSGVSharedAttributes links it from the event loop
    return r->getProxy();
  }

private Q_SLOTS:
  void initTestCase()
  {
    vtkSMProxyManager* manager = vtkSMProxyManager::GetProxyManager();
    // The GUI's undo stack, made as pqUndoRedoBehavior makes it.
    if (!pqApplicationCore::instance()->getUndoStack())
    {
      vtkNew<pqUndoStackBuilder> builder;
      manager->SetUndoStackBuilder(builder);
      pqApplicationCore::instance()->setUndoStack(new pqUndoStack(builder, this));
    }
    QVERIFY(manager->GetPluginManager()->LoadLocalPlugin(gPlugin.toUtf8().constData()));
    // (The plugin's own pqCSGVSharedAttributes runs too: LoadLocalPlugin starts its auto-starts;
    // a second instance links the same properties again, harmlessly.)
    this->Shared = new pqCSGVSharedAttributes(this);
    this->Shared->startup();
    pqApplicationCore* core = pqApplicationCore::instance();
    pqServer* server = core->getServerManagerModel()->findItems<pqServer*>().front();
    pqObjectBuilder* builder = core->getObjectBuilder();
    this->Reader = builder->createReader(
      "sources", "CSGVReader", { gFixtures + "/synthA_b32_rans2_attr.csgv" }, server);
    QVERIFY(this->Reader);
    this->View1 = builder->createView("RenderView", server);
    this->View2 = builder->createView("RenderView", server);
    QVERIFY(this->View1 && this->View2);
    this->Repr1 = this->show(this->View1);
    QVERIFY(this->Repr1);
  }

  /// A question to the representation is no edit: nothing on the undo stack (the GUI pass saw a
  /// second undo step, "Changed 'vtkSMProxy'", after each shading change: the editor's queries).
  void queriesLeaveNoUndoStep()
  {
    pqUndoStack* undo = pqApplicationCore::instance()->getUndoStack();
    if (!undo)
    {
      QSKIP("no undo stack in this session");
    }
    undo->clear();
    QVERIFY(!undo->canUndo());
    pqCSGV::queryJson(this->Repr1, "summary");
    pqCSGV::queryJson(this->Repr1, "colors 16");
    QVERIFY2(!undo->canUndo(), qPrintable(undo->undoLabel()));
  }

  void attributeDialogStartsBesideTheData()
  {
    QCOMPARE(pqCSGV::dataFolder(this->Repr1), QFileInfo(gFixtures + "/x").absolutePath());
  }

  void secondViewTakesTheAttributes()
  {
    vtkSMPropertyHelper(this->Repr1, "CSGVAttributeFiles").Set(0, "/data/regions.csv");
    setStrings(this->Repr1, "CSGVDerivedAttributes", { "double_kind", "kind * 2" });
    vtkSMPropertyHelper(this->Repr1, "CSGVComputedAttributes").Set(1);
    this->Repr1->UpdateVTKObjects();
    this->Repr2 = this->show(this->View2);
    QVERIFY(this->Repr2);
    QCOMPARE(strings(this->Repr2, "CSGVAttributeFiles"), QStringList{ "/data/regions.csv" });
    QCOMPARE(strings(this->Repr2, "CSGVDerivedAttributes"), (QStringList{ "double_kind", "kind * 2" }));
    QCOMPARE(vtkSMPropertyHelper(this->Repr2, "CSGVComputedAttributes").GetAsInt(), 1);
    QCOMPARE(pqCSGVSharedAttributes::siblings(this->Repr2).size(), 1);
  }

  void aChangeInEitherViewReachesTheOther()
  {
    setStrings(this->Repr2, "CSGVDerivedAttributes", { "half_kind", "kind / 2.0" });
    this->Repr2->UpdateVTKObjects();
    QCOMPARE(strings(this->Repr1, "CSGVDerivedAttributes"), (QStringList{ "half_kind", "kind / 2.0" }));
    vtkSMPropertyHelper(this->Repr1, "CSGVAttributeFiles").SetNumberOfElements(0);
    this->Repr1->UpdateVTKObjects();
    QCOMPARE(strings(this->Repr2, "CSGVAttributeFiles"), QStringList{});
  }

  void materialsStayPerViewAndCopyInOneClick()
  {
    const QString mine = R"({"version":1,"materials":[{"name":"red","color":{"mode":"constant","rgb":[1,0,0]}}]})";
    vtkSMPropertyHelper(this->Repr1, "CSGVMaterials").Set(mine.toUtf8().constData());
    this->Repr1->UpdateVTKObjects();
    QVERIFY(QString(vtkSMPropertyHelper(this->Repr2, "CSGVMaterials").GetAsString()).isEmpty());

    pqCSGVMaterialEditor editor(this->Repr2, nullptr);
    connect(&editor, &pqPropertyWidget::changeFinished, &editor, &pqPropertyWidget::apply);
    QPushButton* copy = editor.findChild<QPushButton*>("copyMaterials");
    QVERIFY(copy);
    pqUndoStack* undo = pqApplicationCore::instance()->getUndoStack();
    copy->click();
    editor.apply();
    const QString copied = vtkSMPropertyHelper(this->Repr2, "CSGVMaterials").GetAsString();
    QVERIFY2(copied.contains("\"red\""), qPrintable(copied));
    const QString status = editor.findChild<QLabel*>("status")->text();
    QVERIFY2(status.startsWith("Copied 1 material(s) from "), qPrintable(status));
    if (undo)
    {
      QVERIFY(undo->canUndo());
    }
    // And back: the other view's materials are its own.
    vtkSMPropertyHelper(this->Repr2, "CSGVMaterials").Set("");
    this->Repr2->UpdateVTKObjects();
    QCOMPARE(QString(vtkSMPropertyHelper(this->Repr1, "CSGVMaterials").GetAsString()), mine);
  }

  /// "Export colours" in the editor: a table of this data's own, taken by a Slice of it coloured
  /// by the label array (with a legend that fits), and not by other data (issue 38, item 6).
  void exportedColoursReachASliceOfThisDataOnly()
  {
    pqObjectBuilder* builder = pqApplicationCore::instance()->getObjectBuilder();
    pqPipelineSource* slice = builder->createFilter("filters", "Cut", this->Reader);
    QVERIFY(slice);
    pqPipelineSource* other = builder->createReader(
      "sources", "CSGVReader", { gFixtures + "/synthA_b32_rans2.csgv" }, this->Reader->getServer());
    QVERIFY(other);
    auto shown = [&](pqPipelineSource* s) {
      pqDataRepresentation* r = builder->createDataRepresentation(s->getOutputPort(0), this->View1);
      vtkSMPVRepresentationProxy::SetScalarColoring(r->getProxy(), "Labels", vtkDataObject::CELL);
      r->getProxy()->UpdateVTKObjects();
      return r->getProxy();
    };
    vtkSMProxy* sliceRepr = shown(slice);
    vtkSMProxy* otherRepr = shown(other);
    vtkSMPropertyHelper(otherRepr, "Representation").Set("Surface");
    otherRepr->UpdateVTKObjects();
    vtkSMProxy* sharedBefore = vtkSMPropertyHelper(otherRepr, "LookupTable").GetAsProxy();
    QVERIFY(sharedBefore);

    pqCSGVMaterialEditor editor(this->Repr1, nullptr);
    QPushButton* button = editor.findChild<QPushButton*>("exportColors");
    QVERIFY(button);
    button->click();
    const QString status = editor.findChild<QLabel*>("status")->text();
    vtkNew<vtkSMTransferFunctionManager> mgr;
    vtkSMProxy* lut = mgr->GetColorTransferFunction(
      pqCSGV::labelColorTableName("Labels", this->Reader->getSMName()).toUtf8().constData(),
      this->Repr1->GetSessionProxyManager());
    QVERIFY2(vtkSMPropertyHelper(sliceRepr, "LookupTable").GetAsProxy() == lut, qPrintable(status));
    QVERIFY2(status.contains("applied to " + slice->getSMName()), qPrintable(status));
    QCOMPARE(vtkSMPropertyHelper(otherRepr, "LookupTable").GetAsProxy(), sharedBefore);
    QCOMPARE(vtkSMPropertyHelper(sharedBefore, "IndexedLookup").GetAsInt(), 0);
    const int labels = vtkSMPropertyHelper(lut, "Annotations").GetNumberOfElements() / 2;
    QVERIFY(labels > 0);
    vtkSMProxy* bar = vtkSMTransferFunctionProxy::FindScalarBarRepresentation(lut, this->View1->getProxy());
    QVERIFY(bar);
    QCOMPARE(vtkSMPropertyHelper(bar, "DrawAnnotations").GetAsInt(), labels <= pqCSGV::kLegendLabels ? 1 : 0);
    QCOMPARE(vtkSMPropertyHelper(bar, "Visibility").GetAsInt(), 1);
    // A title that fits along a vertical legend (a third of the view's height).
    QCOMPARE(QString(vtkSMPropertyHelper(bar, "Title").GetAsString()),
      labels <= pqCSGV::kLegendLabels ? QString("Labels") : QString("Labels (%1 labels)").arg(labels));
  }

  /// Colour by the label array on a Segmentation Volume: its display takes the data's own table
  /// (the materials' colours and names) and shows that legend, made again when the materials
  /// change (pqCSGVColorLegend; issue 38, item 6).
  void colourByLabelsShowsTheMaterialsLegend()
  {
    // The plugin's auto-starts run in this session (LoadLocalPlugin starts them): its own
    // pqCSGVColorLegend acts here.
    const QString red = R"({"version":1,"materials":[{"name":"r","color":{"mode":"constant","rgb":[1,0,0]}}]})";
    vtkSMPropertyHelper(this->Repr1, "CSGVMaterials").Set(red.toUtf8().constData());
    this->Repr1->UpdateVTKObjects();
    vtkSMPVRepresentationProxy::SetScalarColoring(this->Repr1, "Labels", vtkDataObject::CELL);
    this->Repr1->UpdateVTKObjects();
    QTest::qWait(200);
    vtkNew<vtkSMTransferFunctionManager> mgr;
    vtkSMProxy* own = mgr->GetColorTransferFunction(
      pqCSGV::labelColorTableName("Labels", this->Reader->getSMName()).toUtf8().constData(),
      this->Repr1->GetSessionProxyManager());
    QCOMPARE(vtkSMPropertyHelper(this->Repr1, "LookupTable").GetAsProxy(), own);
    vtkSMProxy* bar = vtkSMTransferFunctionProxy::FindScalarBarRepresentation(own, this->View1->getProxy());
    QVERIFY(bar);
    QCOMPARE(vtkSMPropertyHelper(bar, "Visibility").GetAsInt(), 1);
    vtkSMPropertyHelper colors(own, "IndexedColors");
    QVERIFY(colors.GetNumberOfElements() >= 3);
    QCOMPARE(colors.GetAsDouble(0), 1.0);
    QCOMPARE(colors.GetAsDouble(1), 0.0);
    // New materials, a new legend.
    const QString blue = R"({"version":1,"materials":[{"name":"b","color":{"mode":"constant","rgb":[0,0,1]}}]})";
    vtkSMPropertyHelper(this->Repr1, "CSGVMaterials").Set(blue.toUtf8().constData());
    this->Repr1->UpdateVTKObjects();
    QTest::qWait(200);
    QCOMPARE(vtkSMPropertyHelper(own, "IndexedColors").GetAsDouble(2), 1.0);
    QCOMPARE(vtkSMPropertyHelper(own, "IndexedColors").GetAsDouble(0), 0.0);
    vtkSMPVRepresentationProxy::SetScalarColoring(this->Repr1, nullptr, vtkDataObject::CELL);
    this->Repr1->UpdateVTKObjects();
  }

  void aRemovedViewLeavesTheOthersLinked()
  {
    pqObjectBuilder* builder = pqApplicationCore::instance()->getObjectBuilder();
    pqView* view3 = builder->createView("RenderView", this->View1->getServer());
    vtkSMProxy* repr3 = this->show(view3);
    QVERIFY(repr3);
    QCOMPARE(strings(repr3, "CSGVDerivedAttributes"), (QStringList{ "half_kind", "kind / 2.0" }));
    builder->destroy(this->View2);
    this->View2 = nullptr;
    setStrings(repr3, "CSGVDerivedAttributes", { "k3", "kind * 3" });
    repr3->UpdateVTKObjects();
    QCOMPARE(strings(this->Repr1, "CSGVDerivedAttributes"), (QStringList{ "k3", "kind * 3" }));
  }
};

int main(int argc, char** argv)
{
  return pvqttest::run<TestSharedAttributes>(argc, argv, gPlugin, gFixtures);
}

#include "test_shared_attributes.moc"
