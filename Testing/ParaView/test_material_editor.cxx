// SPDX-License-Identifier: MIT
// QtTest of pqCSGVMaterialEditor in a builtin ParaView session (no main window): the widget
// edits the representation's CSGVMaterials property (add / remove / duplicate / reorder, details,
// colour), follows the property when pvpython-style code sets it, loads attribute names and
// ranges from the representation (the db3 fixture), and the hide / show-only edits of the pick
// panel. Typing tests send key events at a person's pace, with the editor applied the way the
// Properties panel applies display properties (on its queued changeFinished). Usage:
// csgv_material_editor_test PLUGIN.so FIXTURES_DIR
#include "PvQtTestMain.h"
#include "pqCSGVMaterialDocument.h"
#include "pqCSGVMaterialEditor.h"

#include <pqActiveObjects.h>
#include <pqApplicationCore.h>
#include <pqDataRepresentation.h>
#include <pqPipelineSource.h>
#include <pqView.h>
#include <pqObjectBuilder.h>
#include <pqUndoStack.h>
#include <pqPVApplicationCore.h>
#include <pqServer.h>
#include <pqServerResource.h>
#include <vtkSMPluginManager.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMRepresentationProxy.h>
#include <vtkSMProxy.h>
#include <vtkSMProxyManager.h>
#include <vtkSMSessionProxyManager.h>
#include <vtkSmartPointer.h>

#include <QApplication>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QTemporaryDir>
#include <QtTest>
#include <QWheelEvent>

#include <array>
#include <cmath>

namespace
{
QString gPlugin, gFixtures;

/// A CSGVMaterials text as Qt JSON after Core has read it, with every key Core writes; an empty
/// object (failing the comparisons) when Core refuses it.
QJsonObject documentOf(const QString& text)
{
  QString error;
  const csgv::MaterialDocument doc = pqCSGV::parseDocument(text, &error);
  if (!error.isEmpty())
  {
    qWarning("Core refuses the material document: %s", qPrintable(error));
    return QJsonObject();
  }
  return QJsonDocument::fromJson(pqCSGV::serialize(doc).toUtf8()).object();
}

/// What a label looks like under a document as the renderer draws it (drawableMaterials):
/// invisible, or colour, opacity and emission. Labels only (the fixtures' documents filter on
/// `label`).
QList<QList<double>> looks(const QString& text, uint32_t labels)
{
  const csgv::MaterialDocument doc = csgv::drawableMaterials(pqCSGV::parseDocument(text), nullptr, nullptr);
  const csgv::MaterialEvaluator e(doc, [](const std::string&, uint32_t) { return std::nan(""); });
  QList<QList<double>> out;
  for (uint32_t l = 0; l < labels; ++l)
  {
    const int m = e.materialOf(l);
    if (m < 0 || doc.materials[m].opacity == 0)
    {
      out << QList<double>{};
      continue;
    }
    const std::array<float, 3> c = e.colorOf(l, m);
    out << QList<double>{ c[0], c[1], c[2], doc.materials[m].opacity, doc.materials[m].emission };
  }
  return out;
}

/// A person's pace between keystrokes (ms): the event loop runs, so anything an editor would do
/// after a keystroke (queued applies, timers) happens before the next one.
constexpr int kKeyDelay = 120;
}

class TestMaterialEditor : public QObject
{
  Q_OBJECT

  vtkSmartPointer<vtkSMProxy> Reader, Repr;
  pqCSGVMaterialEditor* Editor = nullptr;

  /// The property after the panel's apply (pqProxyWidget applies display properties at once;
  /// until then the links hold the edit as the unchecked value).
  QString property() const
  {
    this->Editor->apply();
    return vtkSMPropertyHelper(this->Repr, "CSGVMaterials").GetAsString();
  }
  QJsonArray materials() const
  {
    return documentOf(this->property()).value("materials").toArray();
  }
  template <class T>
  T* child(const char* name) const
  {
    T* w = this->Editor->findChild<T*>(name);
    if (!w)
    {
      qWarning("no widget named %s", name);
    }
    return w;
  }
  void setLine(const char* name, const QString& text)
  {
    QLineEdit* e = this->child<QLineEdit>(name);
    e->setText(text);
    Q_EMIT e->editingFinished();
  }
  /// Sets the property as pvpython does and lets the editor follow it.
  void setDocument(const QString& text)
  {
    vtkSMPropertyHelper(this->Repr, "CSGVMaterials").Set(text.toUtf8().constData());
    this->Repr->UpdateVTKObjects();
    QCoreApplication::processEvents();
  }
  QJsonObject material(int i) const { return this->materials()[i].toObject(); }
  /// Clicks into a box, selects its text and types `text` one key at a time.
  void typeInto(QWidget* box, const QString& text)
  {
    QTest::mouseClick(box, Qt::LeftButton);
    box->setFocus(Qt::MouseFocusReason);
    QTest::keyClick(box, Qt::Key_A, Qt::ControlModifier);
    QTest::keyClicks(box, text, Qt::NoModifier, kKeyDelay);
    QTest::qWait(kKeyDelay);
  }
  /// The data range the representation reports for an attribute.
  QPair<double, double> range(const QString& attribute) const
  {
    for (const QJsonValue& v : pqCSGV::queryJson(this->Repr, "summary").value("attributes").toArray())
    {
      if (v.toObject().value("name").toString() == attribute)
      {
        return qMakePair(v.toObject().value("min").toDouble(), v.toObject().value("max").toDouble());
      }
    }
    return qMakePair(std::nan(""), std::nan(""));
  }

private Q_SLOTS:
  void initTestCase()
  {
    QVERIFY(pvqttest::segmentationVolume(
      gPlugin, gFixtures + "/synthA_b32_rans2_attr.csgv", this->Reader, this->Repr));
    this->Editor = new pqCSGVMaterialEditor(this->Repr, nullptr);
    // As the Properties panel does for display properties: apply each change it finishes.
    connect(this->Editor, &pqPropertyWidget::changeFinished, this->Editor, &pqPropertyWidget::apply);
    this->Editor->show();
    QVERIFY(QTest::qWaitForWindowExposed(this->Editor));
    QApplication::setActiveWindow(this->Editor); // key focus without a window manager
  }

  void cleanupTestCase()
  {
    delete this->Editor;
    this->Repr = nullptr;
    this->Reader = nullptr;
  }

  void defaultDocumentShown()
  {
    QListWidget* list = this->child<QListWidget>("materialList");
    QCOMPARE(list->count(), 1);
    QCOMPARE(this->child<QComboBox>("colorMode")->currentText(), QString("random"));
    QVERIFY(this->property().isEmpty()); // nothing written before an edit
    QVERIFY(this->Editor->findChild<QPushButton*>("loadAttributes"));
    QVERIFY(this->Editor->findChild<QPushButton*>("choosePreset"));
    QVERIFY(this->Editor->findChild<QPushButton*>("exportColors"));
    // It fits the Properties panel at its default width (about 470 pixels with its margins).
    QVERIFY2(this->Editor->minimumSizeHint().width() <= 440,
      qPrintable(QString("minimum width %1").arg(this->Editor->minimumSizeHint().width())));
  }

  void addRemoveDuplicateReorder()
  {
    QListWidget* list = this->child<QListWidget>("materialList");
    this->child<QPushButton>("addMaterial")->click();
    QCOMPARE(this->materials().size(), 2);
    QCOMPARE(list->count(), 2);
    QCOMPARE(list->currentRow(), 0); // inserted before the selection: it takes labels first
    QCOMPARE(this->materials()[0].toObject()["name"].toString(), QString("material 1"));
    this->child<QPushButton>("duplicateMaterial")->click();
    QCOMPARE(this->materials().size(), 3);
    QCOMPARE(this->materials()[1].toObject()["name"].toString(),
      this->materials()[0].toObject()["name"].toString() + " copy");
    QCOMPARE(list->currentRow(), 1);
    this->child<QPushButton>("moveMaterialDown")->click();
    QCOMPARE(this->materials()[2].toObject()["name"].toString().endsWith(" copy"), true);
    QCOMPARE(this->materials()[1].toObject()["name"].toString(), QString("all"));
    this->child<QPushButton>("moveMaterialUp")->click();
    QCOMPARE(this->materials()[1].toObject()["name"].toString().endsWith(" copy"), true);
    this->child<QPushButton>("removeMaterial")->click();
    QCOMPARE(this->materials().size(), 2);
    QCOMPARE(this->materials()[1].toObject()["name"].toString(), QString("all"));
  }

  void detailsEditTheProperty()
  {
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    this->setLine("materialName", "tumour");
    this->child<QComboBox>("colorMode")->setCurrentText("constant");
    this->setLine("filterMin", "5");
    this->setLine("filterMax", "40");
    this->setLine("colorHex", "#ff0000");
    this->child<QDoubleSpinBox>("opacity")->setValue(0.5);
    this->child<QDoubleSpinBox>("emission")->setValue(2);
    QJsonObject m = this->materials()[0].toObject();
    QCOMPARE(m["name"].toString(), QString("tumour"));
    QCOMPARE(m["filter"].toObject()["min"].toDouble(), 5.0);
    QCOMPARE(m["filter"].toObject()["max"].toDouble(), 40.0);
    QCOMPARE(m["color"].toObject()["rgb"].toArray()[0].toDouble(), 1.0);
    QCOMPARE(m["color"].toObject()["rgb"].toArray()[1].toDouble(), 0.0);
    QCOMPARE(m["opacity"].toDouble(), 0.5);
    QCOMPARE(m["emission"].toDouble(), 2.0);

    this->child<QComboBox>("colorMode")->setCurrentText("colormap");
    this->setLine("colormapName", "Cool to Warm");
    this->child<QComboBox>("wrapMode")->setCurrentText("repeat");
    this->setLine("colorMin", "0");
    this->setLine("colorMax", "3");
    m = this->materials()[0].toObject();
    const QJsonObject c = m["color"].toObject();
    QCOMPARE(c["mode"].toString(), QString("colormap"));
    QCOMPARE(c["colormap"].toString(), QString("Cool to Warm"));
    QCOMPARE(c["wrap"].toString(), QString("repeat"));
    QCOMPARE(c["max"].toDouble(), 3.0);
    QVERIFY(!c.contains("rgb"));
  }

  void propertyDrivesTheWidget()
  {
    // What pvpython sets shows in the editor (pqPropertyLinks).
    const QString doc = R"({"version":1,"materials":[{"name":"a","filter":{"attribute":"kind","min":2,"max":2},)"
                        R"("color":{"mode":"colormap","attribute":"score","min":0,"max":1,"colormap":"Turbo"}},)"
                        R"({"name":"b"},{"name":"c","opacity":0.25}]})";
    vtkSMPropertyHelper(this->Repr, "CSGVMaterials").Set(doc.toUtf8().constData());
    this->Repr->UpdateVTKObjects();
    QCoreApplication::processEvents();
    QCOMPARE(this->child<QListWidget>("materialList")->count(), 3);
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    QCOMPARE(this->child<QComboBox>("filterAttribute")->currentText(), QString("kind"));
    QCOMPARE(this->child<QComboBox>("colorAttribute")->currentText(), QString("score"));
    QCOMPARE(this->child<QLineEdit>("colormapName")->text(), QString("Turbo"));
    this->child<QListWidget>("materialList")->setCurrentRow(2);
    QCOMPARE(this->child<QDoubleSpinBox>("opacity")->value(), 0.25);
  }

  /// A new editor of the same display (the Properties panel makes one whenever it rebuilds the
  /// display's section) shows the material
  /// the last one showed, not material 1 (GUI pass 11: the Opacity the user was editing then
  /// belonged to another material); a selection edit keeps it too.
  void aNewEditorOfTheDisplayKeepsTheMaterialShown()
  {
    const QByteArray before = vtkSMPropertyHelper(this->Repr, "CSGVMaterials").GetAsString();
    const QString doc = R"({"version":1,"materials":[{"name":"a"},{"name":"b"},{"name":"c","opacity":0.25}]})";
    vtkSMPropertyHelper(this->Repr, "CSGVMaterials").Set(doc.toUtf8().constData());
    this->Repr->UpdateVTKObjects();
    QCoreApplication::processEvents();
    this->child<QListWidget>("materialList")->setCurrentRow(2);
    {
      pqCSGVMaterialEditor again(this->Repr, nullptr);
      QCoreApplication::processEvents();
      auto* list = again.findChild<QListWidget*>("materialList");
      QVERIFY(list && list->count() == 3);
      QCOMPARE(list->currentRow(), 2);
      QCOMPARE(again.findChild<QDoubleSpinBox*>("opacity")->value(), 0.25);
      // A selection edit (the overlay of the same document) keeps the material shown.
      const QString selected = R"({"version":1,"materials":[{"name":"a"},{"name":"b"},{"name":"c","opacity":0.25}],"selected":[7]})";
      vtkSMPropertyHelper(this->Repr, "CSGVMaterials").Set(selected.toUtf8().constData());
      this->Repr->UpdateVTKObjects();
      QCoreApplication::processEvents();
      QCOMPARE(list->currentRow(), 2);
    }
    QCOMPARE(this->child<QListWidget>("materialList")->currentRow(), 2);
    vtkSMPropertyHelper(this->Repr, "CSGVMaterials").Set(before.constData()); // as the next tests expect
    this->Repr->UpdateVTKObjects();
    QCoreApplication::processEvents();
  }

  /// Each edit is one undo step named after it, also where the Properties panel applies the edit
  /// after it was made (a queued apply: every step read "Undo Property Changed", GUI pass 11).
  void editsAreUndoStepsNamedAfterThem()
  {
    pqApplicationCore* core = pqApplicationCore::instance();
    pvqttest::ensureUndoStack(this);
    // A display the proxy manager knows (the undo stack records registered proxies only).
    pqServer* server = pqActiveObjects::instance().activeServer();
    pqObjectBuilder* builder = core->getObjectBuilder();
    pqPipelineSource* source =
      builder->createReader("sources", "CSGVReader", { gFixtures + "/synthA_b32_rans2_attr.csgv" }, server);
    pqView* view = source ? builder->createView("RenderView", server) : nullptr;
    pqDataRepresentation* shown = view ? builder->createDataRepresentation(source->getOutputPort(0), view) : nullptr;
    QVERIFY(shown);
    vtkSMProxy* display = shown->getProxy();
    vtkSMPropertyHelper(display, "Representation").Set("Segmentation Volume");
    display->UpdateVTKObjects();
    const QByteArray before = vtkSMPropertyHelper(display, "CSGVMaterials").GetAsString();
    {
      pqCSGVMaterialEditor queued(display, nullptr);
      connect(&queued, &pqPropertyWidget::changeFinished, &queued, &pqPropertyWidget::apply, Qt::QueuedConnection);
      queued.show();
      QCoreApplication::processEvents();
      queued.findChild<QPushButton*>("addMaterial")->click();
      QTRY_VERIFY(QByteArray(vtkSMPropertyHelper(display, "CSGVMaterials").GetAsString()) != before);
      QCOMPARE(core->getUndoStack()->undoLabel(), QString("Add material"));
      core->getUndoStack()->undo();
      QCoreApplication::processEvents();
    }
    QCOMPARE(QByteArray(vtkSMPropertyHelper(display, "CSGVMaterials").GetAsString()), before);
    builder->destroy(source);
    builder->destroy(view);
  }

  void attributesFromTheRepresentation()
  {
    this->Editor->refreshAttributes();
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    QComboBox* attrs = this->child<QComboBox>("filterAttribute");
    QStringList names;
    for (int i = 0; i < attrs->count(); ++i)
    {
      names << attrs->itemText(i);
    }
    QVERIFY2(names.contains("label") && names.contains("kind") && names.contains("voxels"),
      qPrintable(names.join(",")));
    QCOMPARE(this->child<QLabel>("filterRange")->text(), QString("data range: 0 .. 3"));
  }

  void propertyIsCoresText()
  {
    // Edits write Core's serialisation (one compact line), so what the editor writes is what
    // Core, csgv render and the backend read.
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    this->setLine("materialName", "written by Core");
    const QString text = this->property();
    QVERIFY(!text.contains('\n'));
    QCOMPARE(text, pqCSGV::serialize(pqCSGV::parseDocument(text)));
    QCOMPARE(this->materials()[0].toObject()["name"].toString(), QString("written by Core"));
  }

  void refusedDocumentShowsCoresMessage()
  {
    // A document Core refuses (here an unknown key) is named in the status line, and editing
    // starts from Core's default document.
    vtkSMPropertyHelper(this->Repr, "CSGVMaterials").Set(R"({"materials":[{"name":"x","opacty":1}]})");
    this->Repr->UpdateVTKObjects();
    QCoreApplication::processEvents();
    QVERIFY2(this->child<QLabel>("status")->text().contains("unknown key 'opacty'"),
      qPrintable(this->child<QLabel>("status")->text()));
    QCOMPARE(this->child<QListWidget>("materialList")->count(), 1);
    QCOMPARE(this->child<QLineEdit>("materialName")->text(), QString("all"));
  }

  // Issue 15 (1): typing "0.5" at a person's pace sets 0.5 on Enter, not 0 at the first key.
  void typedOpacityAppliesOnEnter()
  {
    this->setDocument(R"({"materials":[{"name":"a","filter":{"min":1,"max":2}},{"name":"b"}]})");
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    QDoubleSpinBox* opacity = this->child<QDoubleSpinBox>("opacity");
    QTest::mouseClick(opacity, Qt::LeftButton);
    opacity->setFocus(Qt::MouseFocusReason);
    QTest::keyClick(opacity, Qt::Key_A, Qt::ControlModifier);
    for (const QChar c : QString("0.5"))
    {
      QTest::keyClicks(opacity, QString(c), Qt::NoModifier, kKeyDelay);
      QTest::qWait(kKeyDelay);
      QCOMPARE(this->material(0)["opacity"].toDouble(), 1.0); // nothing applied mid-word
    }
    QCOMPARE(opacity->text(), QString("0.5")); // and the box not reformatted under the cursor
    QTest::keyClick(opacity, Qt::Key_Return);
    QTest::qWait(kKeyDelay);
    QCOMPARE(this->material(0)["opacity"].toDouble(), 0.5);
    QCOMPARE(this->material(1)["opacity"].toDouble(), 1.0);
  }

  // Issue 38 (5): the wheel over an unfocused number box or combo box scrolls, never edits.
  void wheelEditsOnlyAFocusedField()
  {
    this->setDocument(R"({"materials":[{"name":"a","filter":{"min":1,"max":2}},{"name":"b"}]})");
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    QDoubleSpinBox* opacity = this->child<QDoubleSpinBox>("opacity");
    QComboBox* wrap = this->child<QComboBox>("colorMode");
    this->child<QLineEdit>("materialName")->setFocus(Qt::OtherFocusReason);
    QTest::qWait(kKeyDelay);
    const int wrapIndex = wrap->currentIndex();
    auto wheel = [](QWidget* w) {
      const QPoint at = w->rect().center();
      QWheelEvent e(at, w->mapToGlobal(at), QPoint(), QPoint(0, -120), Qt::NoButton, Qt::NoModifier,
        Qt::NoScrollPhase, false);
      QCoreApplication::sendEvent(w, &e);
      QCoreApplication::processEvents();
    };
    for (int i = 0; i < 3; ++i)
    {
      wheel(opacity);
      wheel(wrap);
    }
    QCOMPARE(opacity->value(), 1.0);
    QCOMPARE(this->material(0)["opacity"].toDouble(), 1.0);
    QCOMPARE(wrap->currentIndex(), wrapIndex);
    // Clicked into, the box takes the wheel as any spin box does.
    opacity->setFocus(Qt::MouseFocusReason);
    QTest::qWait(kKeyDelay);
    wheel(opacity);
    QVERIFY2(opacity->value() < 1.0, qPrintable(QString::number(opacity->value())));
  }

  // ... and the emission box on focus out.
  void typedEmissionAppliesOnFocusOut()
  {
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    QDoubleSpinBox* emission = this->child<QDoubleSpinBox>("emission");
    this->typeInto(emission, "2.5");
    QCOMPARE(this->material(0)["emission"].toDouble(), 0.0);
    QTest::mouseClick(this->child<QLineEdit>("materialName"), Qt::LeftButton);
    this->child<QLineEdit>("materialName")->setFocus(Qt::MouseFocusReason);
    QTest::qWait(kKeyDelay);
    QCOMPARE(this->material(0)["emission"].toDouble(), 2.5);
  }

  // A refresh (attributes pushed, a property set elsewhere) does not rewrite a box being typed in.
  void typingSurvivesARefresh()
  {
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    QLineEdit* max = this->child<QLineEdit>("filterMax");
    this->typeInto(max, "12");
    this->Editor->refreshAttributes();
    QCOMPARE(max->text(), QString("12"));
    QCOMPARE(this->material(0)["filter"].toObject()["max"].toDouble(), 2.0);
    QTest::keyClick(max, Qt::Key_Return);
    QTest::qWait(kKeyDelay);
    QCOMPARE(this->material(0)["filter"].toObject()["max"].toDouble(), 12.0);
  }

  // Issue 15 (2): a half-finished interval keeps its material, marks its row with the reason and
  // leaves the rest drawable.
  void invalidMaterialIsMarkedAndKept()
  {
    this->setDocument(R"({"materials":[{"name":"a","filter":{"min":1,"max":2},"color":{"mode":"constant","rgb":[1,0,0]}},)"
                      R"({"name":"b","filter":{"min":3,"max":10}},{"name":"rest"}]})");
    const QJsonObject a = this->material(0), rest = this->material(2);
    QListWidget* list = this->child<QListWidget>("materialList");
    list->setCurrentRow(1);
    QLineEdit* min = this->child<QLineEdit>("filterMin");
    QLineEdit* max = this->child<QLineEdit>("filterMax");
    const QPoint minAt = min->mapTo(this->Editor, QPoint()), maxAt = max->mapTo(this->Editor, QPoint());
    this->typeInto(min, "20");
    QTest::keyClick(min, Qt::Key_Return);
    QTest::qWait(kKeyDelay);
    // Issue 38 (5): the reason appears without moving the fields under the pointer.
    QCOMPARE(min->mapTo(this->Editor, QPoint()), minAt);
    QCOMPARE(max->mapTo(this->Editor, QPoint()), maxAt);
    QCOMPARE(this->materials().size(), 3); // the document still holds it, as typed
    QCOMPARE(this->material(1)["filter"].toObject()["min"].toDouble(), 20.0);
    QCOMPARE(this->material(1)["filter"].toObject()["max"].toDouble(), 10.0);
    QCOMPARE(this->material(0), a);
    QCOMPARE(this->material(2), rest);
    QVERIFY2(list->item(1)->text().contains("not drawn: filter min 20 is greater than max 10"),
      qPrintable(list->item(1)->text()));
    QVERIFY(!list->item(0)->text().contains("not drawn"));
    QVERIFY(!list->item(2)->text().contains("not drawn"));
    QLabel* problem = this->child<QLabel>("materialProblem");
    QVERIFY(problem->isVisible());
    QVERIFY2(problem->text().contains("filter min 20 is greater than max 10"), qPrintable(problem->text()));
    // What the renderer is given: the other two materials.
    std::vector<std::string> skipped;
    const csgv::MaterialDocument drawn =
      csgv::drawableMaterials(pqCSGV::parseDocument(this->property()), nullptr, &skipped);
    QCOMPARE(int(drawn.materials.size()), 2);
    QCOMPARE(QString::fromStdString(skipped.at(0)),
      QString("material 2 ('b'): filter min 20 is greater than max 10; not drawn"));
    // Finishing the edit clears the mark.
    this->typeInto(min, "4");
    QTest::keyClick(min, Qt::Key_Return);
    QTest::qWait(kKeyDelay);
    QVERIFY(!list->item(1)->text().contains("not drawn"));
    QVERIFY(!problem->isVisible());
  }

  // Another filter attribute brings its own data range, not the old interval.
  void filterAttributeTakesItsDataRange()
  {
    this->child<QListWidget>("materialList")->setCurrentRow(1);
    this->child<QComboBox>("filterAttribute")->setCurrentText("kind");
    // (A "hidden 0" material may come first where the new interval takes label 0: the edited
    // material stays the current one.)
    const int row = this->child<QListWidget>("materialList")->currentRow();
    QJsonObject f = this->material(row)["filter"].toObject();
    QCOMPARE(f["attribute"].toString(), QString("kind"));
    QCOMPARE(f["min"].toDouble(), 0.0); // kind's data range, shown as "data range: 0 .. 3"
    QCOMPARE(f["max"].toDouble(), 3.0);
    this->child<QComboBox>("filterAttribute")->setCurrentText("label");
    f = this->material(row)["filter"].toObject();
    QCOMPARE(f["min"].toDouble(), std::max(1.0, this->range("label").first)); // 0 stays empty space
    QCOMPARE(f["max"].toDouble(), this->range("label").second);
  }

  // Issue 38 (5): a material that takes some labels keeps them when its filter attribute changes:
  // the new interval spans those labels' values (labels 109072276, 109823955, 109832614 and
  // 119517298 have kind 1, 0, 0, 1), not the attribute's whole data range (0 .. 3), which showed
  // every label in this material's colour until the user typed an interval.
  void filterAttributeKeepsTheMaterialsLabels()
  {
    this->setDocument(R"({"version":1,"materials":[{"name":"some","filter":{"attribute":"label","min":109000000,"max":120000000},)"
                      R"("color":{"mode":"constant","rgb":[1,0,0]}},{"name":"rest"}]})");
    this->Editor->refreshAttributes();
    QTest::qWait(2 * kKeyDelay);
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    this->child<QComboBox>("filterAttribute")->setCurrentText("kind");
    QTest::qWait(kKeyDelay);
    const QJsonObject f = this->material(0)["filter"].toObject();
    QCOMPARE(f["attribute"].toString(), QString("kind"));
    QCOMPARE(f["min"].toDouble(), 0.0);
    QCOMPARE(f["max"].toDouble(), 1.0);
  }

  // Issue 15 (4): colormap mode maps the colour attribute's data range, also after a change of
  // attribute.
  void colormapTakesTheDataRange()
  {
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    this->child<QComboBox>("colorMode")->setCurrentText("colormap");
    QJsonObject c = this->material(0)["color"].toObject();
    QCOMPARE(c["attribute"].toString(), QString("label"));
    QCOMPARE(c["min"].toDouble(), this->range("label").first);
    QCOMPARE(c["max"].toDouble(), this->range("label").second);
    const QPair<double, double> voxels = this->range("voxels");
    QVERIFY(voxels.first < voxels.second);
    this->child<QComboBox>("colorAttribute")->setCurrentText("voxels");
    c = this->material(0)["color"].toObject();
    QCOMPARE(c["min"].toDouble(), voxels.first);
    QCOMPARE(c["max"].toDouble(), voxels.second);
    QCOMPARE(this->child<QLabel>("colorRange")->text(),
      QString("data range: %1 .. %2").arg(voxels.first, 0, 'g', 12).arg(voxels.second, 0, 'g', 12));
  }

  // "Add" changes nothing visible until the new material is edited, wherever it goes.
  void addChangesNothingVisible()
  {
    const QString doc = R"({"materials":[{"name":"a","filter":{"min":1,"max":2},"color":{"mode":"constant","rgb":[1,0,0]}},)"
                        R"({"name":"b","filter":{"min":3,"max":10},"opacity":0.5}]})";
    for (int row : { 0, 1 })
    {
      this->setDocument(doc);
      const auto before = looks(this->property(), 16);
      this->child<QListWidget>("materialList")->setCurrentRow(row);
      this->child<QPushButton>("addMaterial")->click();
      QCOMPARE(this->materials().size(), 3);
      QCOMPARE(looks(this->property(), 16), before);
      QCOMPARE(this->material(row)["name"].toString(), QString("material %1").arg(row + 1));
    }
    this->setDocument(R"({"materials":[]})");
    this->child<QPushButton>("addMaterial")->click();
    QCOMPARE(this->materials().size(), 1);
    QCOMPARE(looks(this->property(), 16), looks(R"({"materials":[]})", 16));
  }

  // Issue 38 (5): choosing another filter attribute changes which labels the material takes, never
  // how they look: the colour (mode, colormap, attribute, interval) stays as it was.
  void filterAttributeKeepsTheLook()
  {
    for (const QString doc : { QString(R"({"version":1,"materials":[{"name":"all"}]})"),
           QString(R"({"version":1,"materials":[{"name":"c","color":{"mode":"colormap","attribute":"score","min":0,"max":1,"colormap":"Turbo"}}]})"),
           QString(R"({"version":1,"materials":[{"name":"k","color":{"mode":"constant","rgb":[0.2,0.4,0.6]}}]})") })
    {
      this->setDocument(doc);
      this->Editor->refreshAttributes();
      QTest::qWait(2 * kKeyDelay);
      this->child<QListWidget>("materialList")->setCurrentRow(0);
      const QJsonObject before = this->material(0);
      QComboBox* filter = this->child<QComboBox>("filterAttribute");
      QVERIFY(filter->findText("kind") >= 0);
      filter->setCurrentText("kind");
      QTest::qWait(kKeyDelay);
      const QJsonObject after = this->material(this->child<QListWidget>("materialList")->currentRow());
      QCOMPARE(after["filter"].toObject()["attribute"].toString(), QString("kind"));
      QVERIFY2(after["color"] == before["color"],
        qPrintable(QJsonDocument(before["color"].toObject()).toJson() + " became " +
          QJsonDocument(after["color"].toObject()).toJson()));
      QCOMPARE(after["opacity"], before["opacity"]);
    }
  }

  // A new attribute column is in the drop-downs as soon as the panel applied it (no Refresh).
  void newAttributeAppearsAtOnce()
  {
    this->setDocument(R"({"materials":[{"name":"a"}]})");
    QPlainTextEdit* derived = this->child<QPlainTextEdit>("derivedAttributes");
    derived->setFocus(Qt::MouseFocusReason);
    derived->selectAll();
    QTest::keyClicks(derived, "double_kind = kind * 2", Qt::NoModifier, 10);
    this->child<QPushButton>("applyDerived")->click();
    QTest::qWait(4 * kKeyDelay);
    QComboBox* attrs = this->child<QComboBox>("filterAttribute");
    QVERIFY2(attrs->findText("double_kind") >= 0, qPrintable(this->child<QLabel>("status")->text()));
    QVERIFY(this->child<QComboBox>("colorAttribute")->findText("double_kind") >= 0);
    // Issue 38 (8): applying says what the derived attribute became.
    const QString status = this->child<QLabel>("status")->text();
    QVERIFY2(status.startsWith("Derived attributes applied: double_kind ("), qPrintable(status));
  }

  // The default material takes every label but 0 (empty space); in this volume label 0 (the
  // background, 928,090 voxels) has kind 3. Choosing "kind" as the filter attribute takes kind's
  // range over the labels the material took, 0 .. 3, which holds label 0 too: the background
  // filled the box. It stays empty: a "hidden 0" material first, said in the status line, one
  // undo step; every other label looks as before.
  void newFilterAttributeKeepsLabelZeroEmpty()
  {
    this->setDocument(R"({"version":1,"materials":[{"name":"all"}]})");
    this->Editor->refreshAttributes();
    QTest::qWait(2 * kKeyDelay);
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    const QList<QList<double>> before = looks(this->property(), 16);
    QVERIFY(before[0].isEmpty()); // label 0 invisible
    QComboBox* filter = this->child<QComboBox>("filterAttribute");
    QVERIFY(filter->findText("kind") >= 0);
    filter->setCurrentText("kind");
    QTest::qWait(kKeyDelay);
    const QJsonArray ms = this->materials();
    QCOMPARE(ms.size(), 2);
    QCOMPARE(ms[0].toObject()["name"].toString(), QString("hidden 0"));
    QCOMPARE(ms[1].toObject()["filter"].toObject()["attribute"].toString(), QString("kind"));
    QVERIFY2(this->child<QLabel>("status")->text().contains("Label 0 (empty space) has kind = 3"),
      qPrintable(this->child<QLabel>("status")->text()));
    QCOMPARE(this->child<QListWidget>("materialList")->currentRow(), 1); // still the edited one
    // A refresh (the view's update after the edit) keeps the message: only what a refresh said
    // is cleared by the next one.
    this->Editor->refreshAttributes();
    QVERIFY(this->child<QLabel>("status")->text().contains("Label 0 (empty space)"));
    // What the renderer draws for label 0: nothing (the representation's own colours, every
    // label: 0 is not among them).
    auto zeroDrawn = [this]() {
      for (const QJsonValue& e : pqCSGV::queryJson(this->Repr, "colors 100000").value("labels").toArray())
      {
        if (e.toArray()[0].toDouble() == 0)
        {
          return true;
        }
      }
      return false;
    };
    QVERIFY(!zeroDrawn());
    // Without it, the kind filter draws label 0 (what the user saw: the box filled).
    this->setDocument(R"({"version":1,"materials":[{"name":"k","filter":{"attribute":"kind","min":0,"max":3}}]})");
    QVERIFY(zeroDrawn());
  }

  // A file that fails to read leaves an empty output: the editor says there is nothing to draw,
  // and follows the data back when the file reads again (no Refresh, no new panel).
  void emptyInputIsSaidAndNewDataRefreshes()
  {
    QTemporaryDir dir;
    QVERIFY(dir.isValid());
    const QString good = gFixtures + "/synthA_b32_rans2_attr.csgv";
    const QString broken = dir.filePath("broken.csgv");
    {
      QFile in(good);
      QFile out(broken);
      QVERIFY(in.open(QIODevice::ReadOnly) && out.open(QIODevice::WriteOnly));
      out.write(in.read(in.size() / 2));
    }
    auto* repr = vtkSMRepresentationProxy::SafeDownCast(this->Repr);
    QVERIFY(repr);
    auto load = [&](const QString& file) {
      vtkSMPropertyHelper(this->Reader, "FileName").Set(file.toUtf8().constData());
      this->Reader->UpdateVTKObjects();
      repr->UpdatePipeline(); // as a view's update does after Apply
    };
    QLabel* status = this->child<QLabel>("status");
    QComboBox* filter = this->child<QComboBox>("filterAttribute");
    this->setDocument(R"({"materials":[{"name":"a"}]})");
    this->child<QListWidget>("materialList")->setCurrentRow(0);
    load(broken);
    QTRY_VERIFY2(status->text().startsWith("The input is empty"), qPrintable(status->text()));
    QVERIFY(filter->findText("kind") < 0);
    load(good);
    QTRY_VERIFY2(filter->findText("kind") >= 0, qPrintable(status->text()));
    QCOMPARE(status->text(), QString());
  }
};

int main(int argc, char** argv)
{
  return pvqttest::run<TestMaterialEditor>(argc, argv, gPlugin, gFixtures);
}

#include "test_material_editor.moc"
