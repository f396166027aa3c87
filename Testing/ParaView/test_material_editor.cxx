// SPDX-License-Identifier: MIT
// QtTest of pqCSGVMaterialEditor in a builtin ParaView session (no main window): the widget
// edits the representation's CSGVMaterials property (add / remove / duplicate / reorder, details,
// colour), follows the property when pvpython-style code sets it, loads attribute names and
// ranges from the representation (the db3 fixture), and the hide / show-only edits of the pick
// panel. Usage: csgv_material_editor_test PLUGIN.so FIXTURES_DIR
#include "pqCSGVMaterialDocument.h"
#include "pqCSGVMaterialEditor.h"

#include <pqObjectBuilder.h>
#include <pqPVApplicationCore.h>
#include <pqServer.h>
#include <pqServerResource.h>
#include <vtkSMPluginManager.h>
#include <vtkSMPropertyHelper.h>
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
#include <QPushButton>
#include <QtTest>

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

private Q_SLOTS:
  void initTestCase()
  {
    QVERIFY(vtkSMProxyManager::GetProxyManager()->GetPluginManager()->LoadLocalPlugin(
      gPlugin.toUtf8().constData()));
    vtkSMSessionProxyManager* pxm = vtkSMProxyManager::GetProxyManager()->GetActiveSessionProxyManager();
    this->Reader.TakeReference(pxm->NewProxy("sources", "CSGVReader"));
    QVERIFY(this->Reader);
    vtkSMPropertyHelper(this->Reader, "FileName")
      .Set((gFixtures + "/synthA_b32_rans2_attr.csgv").toUtf8().constData());
    this->Reader->UpdateVTKObjects();
    this->Repr.TakeReference(pxm->NewProxy("representations", "CSGVSegmentationVolumeRepresentation"));
    QVERIFY(this->Repr);
    vtkSMPropertyHelper(this->Repr, "Input").Set(this->Reader);
    this->Repr->UpdateVTKObjects();
    this->Editor = new pqCSGVMaterialEditor(this->Repr, nullptr);
    this->Editor->show();
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
  }

  void addRemoveDuplicateReorder()
  {
    QListWidget* list = this->child<QListWidget>("materialList");
    this->child<QPushButton>("addMaterial")->click();
    QCOMPARE(this->materials().size(), 2);
    QCOMPARE(list->count(), 2);
    QCOMPARE(list->currentRow(), 0); // inserted before the selection: it takes labels first
    QCOMPARE(this->materials()[0].toObject()["color"].toObject()["mode"].toString(), QString("constant"));
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

  void hideAndShowOnly()
  {
    // Label filters are split around the hidden label (order kept).
    QString doc = pqCSGV::hideLabel("", 7, QJsonObject());
    QJsonArray m = documentOf(doc).value("materials").toArray();
    QCOMPARE(m.size(), 2);
    QCOMPARE(m[0].toObject()["filter"].toObject()["max"].toDouble(), 6.0);
    QCOMPARE(m[1].toObject()["filter"].toObject()["min"].toDouble(), 8.0);
    // A material on another attribute holding the label: a first material hides it.
    const QString byKind = R"({"version":1,"materials":[{"filter":{"attribute":"kind","min":2,"max":2}}]})";
    m = documentOf(pqCSGV::hideLabel(byKind, 7, QJsonObject{ { "kind", 2 } }))
          .value("materials")
          .toArray();
    QCOMPARE(m.size(), 2);
    QCOMPARE(m[0].toObject()["opacity"].toDouble(), 0.0);
    // ... but not when its value lies outside every such filter.
    m = documentOf(pqCSGV::hideLabel(byKind, 7, QJsonObject{ { "kind", 1 } }))
          .value("materials")
          .toArray();
    QCOMPARE(m.size(), 1);
    // Show only: the material that takes it, restricted to the label.
    m = documentOf(pqCSGV::showOnlyLabel(byKind, 7, QJsonObject{ { "kind", 2 } }))
          .value("materials")
          .toArray();
    QCOMPARE(m.size(), 1);
    QCOMPARE(m[0].toObject()["filter"].toObject()["attribute"].toString(), QString("label"));
    QCOMPARE(m[0].toObject()["filter"].toObject()["min"].toDouble(), 7.0);
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
};

int main(int argc, char** argv)
{
  if (argc < 3)
  {
    fprintf(stderr, "usage: %s PLUGIN.so FIXTURES_DIR [QtTest options]\n", argv[0]);
    return 2;
  }
  gPlugin = argv[1];
  gFixtures = argv[2];
  QApplication app(argc, argv);
  int pvArgc = 1;
  char* pvArgv[] = { argv[0], nullptr }; // ParaView's logger wants argv[argc] == nullptr
  pqPVApplicationCore core(pvArgc, pvArgv);
  pqServer* server = core.getObjectBuilder()->createServer(pqServerResource("builtin:"));
  if (!server)
  {
    fprintf(stderr, "no builtin session\n");
    return 1;
  }
  TestMaterialEditor test;
  // QtTest sees only its own options.
  std::vector<char*> rest{ argv[0] };
  for (int i = 3; i < argc; ++i)
  {
    rest.push_back(argv[i]);
  }
  const int failed = QTest::qExec(&test, int(rest.size()), rest.data());
  core.getObjectBuilder()->removeServer(server);
  return failed;
}

#include "test_material_editor.moc"
