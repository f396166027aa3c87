// SPDX-License-Identifier: MIT
// QtTest of the Properties panel (pqProxyWidget) of image data shown as "Segmentation Volume",
// in a builtin session with ParaView's standard property widgets and the plugin's interfaces
// (loaded from CSGV.so as the GUI loads them): the composite representation's controls that do
// nothing for it are hidden and come back for Surface, typing "opacity" in the search finds the
// material editor, and Shading, Label Array and Clip Box show names and ranges a user reads while
// writing what pvpython writes; Save Data's CSGV Writer offers its label arrays in the same
// drop-down. Usage: csgv_property_panel_test PLUGIN.so FIXTURES_DIR
#include "PvQtTestMain.h"
#include <pqApplicationCore.h>
#include <pqInterfaceTracker.h>
#include <pqObjectBuilder.h>
#include <pqPVApplicationCore.h>
#include <pqPropertyWidget.h>
#include <pqProxyWidget.h>
#include <pqServer.h>
#include <pqServerResource.h>
#include <pqStandardPropertyWidgetInterface.h>
#include <vtkSMPluginManager.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxyManager.h>
#include <vtkSMSessionProxyManager.h>
#include <vtkSMSourceProxy.h>
#include <vtkSmartPointer.h>

#include <QApplication>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QFile>
#include <QSlider>
#include <QSpinBox>
#include <QTemporaryDir>
#include <QtTest>

#include <memory>

namespace
{
QString gPlugin, gFixtures;
}

class TestPropertyPanel : public QObject
{
  Q_OBJECT

  vtkSmartPointer<vtkSMSourceProxy> Reader;
  vtkSmartPointer<vtkSMProxy> Display;
  std::unique_ptr<pqProxyWidget> Panel;

  pqPropertyWidget* widget(const char* name) const
  {
    auto* w = this->Panel->findChild<pqPropertyWidget*>(name);
    if (!w)
    {
      qWarning("no property widget named %s", name);
    }
    return w;
  }
  bool shown(const char* name) const
  {
    pqPropertyWidget* w = this->widget(name);
    return w && w->isVisibleTo(this->Panel.get());
  }
  /// What the panel shows with "Advanced" on, after the representation type is `type`.
  void chooseRepresentation(const char* type)
  {
    vtkSMPropertyHelper(this->Display, "Representation").Set(type);
    this->Display->UpdateVTKObjects();
    this->Panel->filterWidgets(true);
  }
  const char* text(const char* property) const
  {
    return vtkSMPropertyHelper(this->Display, property).GetAsString();
  }

private Q_SLOTS:
  void initTestCase()
  {
    QVERIFY(vtkSMProxyManager::GetProxyManager()->GetPluginManager()->LoadLocalPlugin(
      gPlugin.toUtf8().constData()));
    vtkSMSessionProxyManager* pxm =
      vtkSMProxyManager::GetProxyManager()->GetActiveSessionProxyManager();
    this->Reader.TakeReference(
      vtkSMSourceProxy::SafeDownCast(pxm->NewProxy("sources", "CSGVReader")));
    QVERIFY(this->Reader);
    vtkSMPropertyHelper(this->Reader, "FileName")
      .Set((gFixtures + "/synthA_b32_rans2.csgv").toUtf8().constData());
    this->Reader->UpdateVTKObjects();
    this->Reader->UpdatePipeline();
    this->Display.TakeReference(pxm->NewProxy("representations", "UniformGridRepresentation"));
    QVERIFY(this->Display);
    vtkSMPropertyHelper(this->Display, "Input").Set(this->Reader);
    vtkSMPropertyHelper(this->Display, "Representation").Set("Segmentation Volume");
    this->Display->UpdateVTKObjects();
    this->Panel.reset(new pqProxyWidget(this->Display));
    // Display properties apply at once in the Properties panel.
    this->Panel->setApplyChangesImmediately(true);
    this->Panel->show();
    this->Panel->filterWidgets(true);
  }

  void cleanupTestCase()
  {
    this->Panel.reset();
    this->Display = nullptr;
    this->Reader = nullptr;
  }

  void controlsThatDoNothingAreHidden()
  {
    const char* generic[] = {
      "ColorEditor",           "Opacity", "Specular", "PointSize", "LineWidth", "Interpolation",
      "BackfaceRepresentation"
    };
    this->chooseRepresentation("Surface");
    for (const char* name : generic)
    {
      QVERIFY2(this->shown(name), name);
    }
    // ... and the Segmentation Volume's own controls only for it.
    QVERIFY(!this->shown("CSGVShading"));
    QVERIFY(!this->shown("csgv_material_editor"));
    this->chooseRepresentation("Segmentation Volume");
    for (const char* name : generic)
    {
      QVERIFY2(!this->shown(name), name);
    }
    QVERIFY(this->shown("CSGVShading"));
    QVERIFY(this->shown("csgv_material_editor"));
  }

  void panelFollowsTheRepresentationType()
  {
    // Without an explicit filterWidgets(): the decorators ask the panel to update itself.
    vtkSMPropertyHelper(this->Display, "Representation").Set("Surface");
    this->Display->UpdateVTKObjects();
    QTRY_VERIFY(this->shown("Opacity") && this->shown("ColorEditor"));
    vtkSMPropertyHelper(this->Display, "Representation").Set("Segmentation Volume");
    this->Display->UpdateVTKObjects();
    QTRY_VERIFY(!this->shown("Opacity") && !this->shown("ColorEditor"));
  }

  void searchFindsMaterialOpacity()
  {
    this->chooseRepresentation("Segmentation Volume");
    this->Panel->filterWidgets(false, "opacity");
    QVERIFY(this->shown("csgv_material_editor"));
    QVERIFY(!this->shown("Opacity"));
    this->Panel->filterWidgets(false, "color");
    QVERIFY(this->shown("csgv_material_editor"));
    // The attribute files, derived and computed attributes live in the same section.
    this->Panel->filterWidgets(false, "attrib");
    QVERIFY(this->shown("csgv_material_editor"));
    this->Panel->filterWidgets(true);
  }

  void shadingShowsFullNames()
  {
    this->chooseRepresentation("Segmentation Volume");
    auto* combo = this->widget("CSGVShading")->findChild<QComboBox*>();
    QVERIFY(combo);
    QStringList names;
    for (int i = 0; i < combo->count(); ++i)
    {
      names << combo->itemText(i);
    }
    QCOMPARE(names, QStringList({ "Local", "Shadow", "Ambient occlusion", "Path tracing" }));
    QCOMPARE(combo->currentText(), QString("Local"));
    // A person picks the last entry with the keyboard.
    combo->setFocus();
    QTest::keyClick(combo, Qt::Key_End);

    QCOMPARE(combo->currentText(), QString("Path tracing"));
    // The panel applies display properties once the widget reports a finished change (queued).
    QTRY_COMPARE(vtkSMPropertyHelper(this->Display, "CSGVShading").GetAsInt(), 3);
    // pvpython's short names set the same property, and the widget follows.
    vtkSMPropertyHelper(this->Display, "CSGVShading").Set(2);
    this->Display->UpdateVTKObjects();
    QTRY_COMPARE(combo->currentText(), QString("Ambient occlusion"));
    vtkSMPropertyHelper(this->Display, "CSGVShading").Set(0);
    this->Display->UpdateVTKObjects();
  }

  void labelArrayIsADropDown()
  {
    auto* combo = this->widget("CSGVLabelArray")->findChild<QComboBox*>();
    QVERIFY(combo);
    QStringList names;
    for (int i = 0; i < combo->count(); ++i)
    {
      names << combo->itemText(i);
    }
    QCOMPARE(names, QStringList({ "(automatic)", "Labels" }));
    QCOMPARE(combo->currentIndex(), 0);
    QCOMPARE(QString(this->text("CSGVLabelArray")), QString());
    combo->setFocus();
    QTest::keyClick(combo, Qt::Key_Down);
    QTRY_COMPARE(QString(this->text("CSGVLabelArray")), QString("Labels"));
    QTest::keyClick(combo, Qt::Key_Up);
    QTRY_COMPARE(QString(this->text("CSGVLabelArray")), QString()); // automatic again
    // A name set from pvpython that the input lacks stays shown, not silently replaced.
    vtkSMPropertyHelper(this->Display, "CSGVLabelArray").Set("elsewhere");
    this->Display->UpdateVTKObjects();
    QTRY_VERIFY(combo->currentText().startsWith("elsewhere"));
    QCOMPARE(QString(this->text("CSGVLabelArray")), QString("elsewhere"));
    vtkSMPropertyHelper(this->Display, "CSGVLabelArray").Set("");
    this->Display->UpdateVTKObjects();
  }

  /// "Read As Image Stack" shows for a series of TIFF files only (found by GUI passes: it was
  /// offered for one .h5 file, and for a series of .h5 volumes, where it means nothing). The
  /// panel reads no file: the names need not exist.
  void imageStackOptionOnlyForASeries()
  {
    vtkSMSessionProxyManager* pxm =
      vtkSMProxyManager::GetProxyManager()->GetActiveSessionProxyManager();
    vtkSmartPointer<vtkSMProxy> reader;
    reader.TakeReference(pxm->NewProxy("sources", "CSGVInputReader"));
    QVERIFY(reader);
    vtkSMPropertyHelper(reader, "FileNames").Set("/nowhere/volume.h5");
    pqProxyWidget panel(reader);
    panel.show();
    panel.filterWidgets(true);
    auto* stack = panel.findChild<pqPropertyWidget*>("ReadAsImageStack");
    auto* relabel = panel.findChild<pqPropertyWidget*>("Relabel");
    QVERIFY(stack && relabel);
    QVERIFY2(relabel->isVisibleTo(&panel), "the reader's other options show");
    QVERIFY2(!stack->isVisibleTo(&panel), "one file: no image stack option");
    vtkSMPropertyHelper(reader, "FileNames").Set(1, "/nowhere/volume_1.h5");
    QApplication::processEvents();
    QVERIFY2(!stack->isVisibleTo(&panel), "a series of HDF5 volumes (always a time series): no image stack option");
    vtkSMPropertyHelper(reader, "FileNames").Set(0, "/nowhere/s_0.TIF");
    vtkSMPropertyHelper(reader, "FileNames").Set(1, "/nowhere/s_1.tif");
    QTRY_VERIFY2(stack->isVisibleTo(&panel), "a series of TIFF files: the image stack option shows");
    vtkSMPropertyHelper(reader, "FileNames").SetNumberOfElements(1);
    QTRY_VERIFY2(!stack->isVisibleTo(&panel), "back to one file: hidden again");
  }

  void writerLabelArrayIsADropDown()
  {
    // Save Data's dialog shows the writer's properties in a pqProxyWidget of the writer proxy.
    vtkSMSessionProxyManager* pxm =
      vtkSMProxyManager::GetProxyManager()->GetActiveSessionProxyManager();
    auto itemsOf = [](QComboBox* combo) {
      QStringList names;
      for (int i = 0; i < combo->count(); ++i)
      {
        names << combo->itemText(i);
      }
      return names;
    };
    vtkSmartPointer<vtkSMProxy> writer;
    writer.TakeReference(pxm->NewProxy("writers", "CSGVWriter"));
    QVERIFY(writer);
    vtkSMPropertyHelper(writer, "Input").Set(this->Reader);
    writer->UpdateVTKObjects();
    {
      pqProxyWidget panel(writer);
      panel.setApplyChangesImmediately(true);
      panel.show();
      auto* combo = panel.findChild<QComboBox*>("LabelArrayCombo");
      QVERIFY(combo);
      QCOMPARE(itemsOf(combo), QStringList({ "(automatic)", "Labels" }));
      QCOMPARE(combo->currentIndex(), 0);
      QVERIFY(combo->itemData(0, Qt::ToolTipRole).toString().contains("float"));
      combo->setFocus();
      QTest::keyClick(combo, Qt::Key_Down);
      QTRY_COMPARE(QString(vtkSMPropertyHelper(writer, "LabelArrayName").GetAsString()),
                   QString("Labels"));
    }
    // The writer takes floats that hold integers: a float array is offered too.
    vtkSmartPointer<vtkSMSourceProxy> wavelet;
    wavelet.TakeReference(
      vtkSMSourceProxy::SafeDownCast(pxm->NewProxy("sources", "RTAnalyticSource")));
    QVERIFY(wavelet);
    wavelet->UpdateVTKObjects();
    wavelet->UpdatePipeline();
    vtkSMPropertyHelper(writer, "Input").Set(wavelet);
    vtkSMPropertyHelper(writer, "LabelArrayName").Set("");
    writer->UpdateVTKObjects();
    {
      pqProxyWidget panel(writer);
      panel.show();
      auto* combo = panel.findChild<QComboBox*>("LabelArrayCombo");
      QVERIFY(combo);
      QCOMPARE(itemsOf(combo), QStringList({ "(automatic)", "RTData" }));
    }
  }

  void clipBoxShowsTheExtent()
  {
    pqPropertyWidget* clip = this->widget("CSGVClipBox");
    QVERIFY(clip);
    auto* maxX = clip->findChild<QSpinBox*>("maxX");
    auto* maxZ = clip->findChild<QSpinBox*>("maxZ");
    auto* minY = clip->findChild<QSpinBox*>("minY");
    QVERIFY(maxX && maxZ && minY);
    // synthA is 133 x 70 x 194 voxels.
    QCOMPARE(maxX->text(), QString("132"));
    QCOMPARE(maxZ->text(), QString("193"));
    QCOMPARE(maxX->maximum(), 132);
    QCOMPARE(minY->text(), QString("0"));
    // Typing a value applies it when the user presses Enter, not on each keystroke.
    maxX->setFocus();
    maxX->selectAll();
    QTest::keyClicks(maxX, "40");
    QTest::qWait(100);
    QCOMPARE(vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(1), 2147483647);
    QTest::keyClick(maxX, Qt::Key_Return);
    QTRY_COMPARE(vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(1), 40);
    minY->setFocus();
    minY->selectAll();
    QTest::keyClicks(minY, "5");
    QTest::keyClick(minY, Qt::Key_Return);
    QTRY_COMPARE(vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(2), 5);
    // Back to the last voxel: stored as "the whole volume" again.
    maxX->setFocus();
    maxX->selectAll();
    QTest::keyClicks(maxX, "132");
    QTest::keyClick(maxX, Qt::Key_Return);
    QTRY_COMPARE(vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(1), 2147483647);
  }

  // A file that fails to read has no voxels: the boxes show "-", disabled (not 2147483647, the
  // property's "last voxel"), and the property keeps its values; the extent comes back with the
  // data.
  void clipBoxOfAnEmptyInput()
  {
    pqPropertyWidget* clip = this->widget("CSGVClipBox");
    QVERIFY(clip);
    auto* maxX = clip->findChild<QSpinBox*>("maxX");
    auto* minY = clip->findChild<QSpinBox*>("minY");
    QVERIFY(maxX && minY);
    QTemporaryDir dir;
    QVERIFY(dir.isValid());
    const QString good = gFixtures + "/synthA_b32_rans2.csgv";
    const QString broken = dir.filePath("broken.csgv");
    {
      QFile in(good);
      QFile out(broken);
      QVERIFY(in.open(QIODevice::ReadOnly) && out.open(QIODevice::WriteOnly));
      out.write(in.read(in.size() / 2));
    }
    auto load = [&](const QString& file)
    {
      vtkSMPropertyHelper(this->Reader, "FileName").Set(file.toUtf8().constData());
      this->Reader->UpdateVTKObjects();
      this->Reader->UpdatePipeline();
      // What the GUI's pqPipelineSource::dataUpdated does (this raw proxy has none).
      QVERIFY(QMetaObject::invokeMethod(clip, "updateExtent"));
    };
    const int before[6] = { vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(0),
      vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(1),
      vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(2),
      vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(3),
      vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(4),
      vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(5) };
    load(broken);
    QTRY_COMPARE(maxX->text(), QString("-"));
    QCOMPARE(minY->text(), QString("-"));
    QVERIFY(!maxX->isEnabled());
    for (int i = 0; i < 6; ++i)
    {
      QCOMPARE(vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(i), before[i]);
    }
    load(good);
    QTRY_COMPARE(maxX->text(), QString("132"));
    QVERIFY(maxX->isEnabled());
    QCOMPARE(maxX->maximum(), 132);
    for (int i = 0; i < 6; ++i)
    {
      QCOMPARE(vtkSMPropertyHelper(this->Display, "CSGVClipBox").GetAsInt(i), before[i]);
    }
  }

  void wideRangesUseALogarithmicSlider()
  {
    this->chooseRepresentation("Segmentation Volume");
    pqPropertyWidget* frames = this->widget("CSGVFramesPerStillRender");
    QVERIFY(frames);
    auto* slider = frames->findChild<QSlider*>("LogSlider");
    auto* box = frames->findChild<QSpinBox*>("LogValue");
    QVERIFY(slider && box);
    QVERIFY(slider->isVisibleTo(this->Panel.get()));
    auto frameCount = [this]() {
      return vtkSMPropertyHelper(this->Display, "CSGVFramesPerStillRender").GetAsInt();
    };
    // The default, 16 of 1-4096, sits a third of the way along (ParaView's linear slider put it
    // at 0.4 %), and 64 half way.
    QCOMPARE(frameCount(), 16);
    QCOMPARE(box->value(), 16);
    QCOMPARE(slider->value(), 333);
    box->setFocus();
    box->selectAll();
    QTest::keyClicks(box, "64");
    QTest::qWait(100);
    QCOMPARE(frameCount(), 16); // typing alone applies nothing
    QTest::keyClick(box, Qt::Key_Return);
    QTRY_COMPARE(frameCount(), 64);
    QCOMPARE(slider->value(), 500);
    // The slider's keys: a page is a twelfth (a factor of two here); the ends are the range's.
    slider->setFocus();
    QTest::keyClick(slider, Qt::Key_PageUp);
    QTRY_COMPARE(frameCount(), 128);
    QTest::keyClick(slider, Qt::Key_End);
    QTRY_COMPARE(frameCount(), 4096);
    QCOMPARE(box->value(), 4096);
    QTest::keyClick(slider, Qt::Key_Home);
    QTRY_COMPARE(frameCount(), 1);
    // A value set from pvpython moves both.
    vtkSMPropertyHelper(this->Display, "CSGVFramesPerStillRender").Set(16);
    this->Display->UpdateVTKObjects();
    QTRY_COMPARE(box->value(), 16);
    QCOMPARE(slider->value(), 333);

    // A double: the time budget's 3 s of 0-600 s a fifth of the way; the left end is 0.
    pqPropertyWidget* budget = this->widget("CSGVStillRenderTimeBudget");
    QVERIFY(budget);
    auto* budgetSlider = budget->findChild<QSlider*>("LogSlider");
    auto* budgetBox = budget->findChild<QDoubleSpinBox*>("LogValue");
    QVERIFY(budgetSlider && budgetBox);
    auto seconds = [this]() {
      return vtkSMPropertyHelper(this->Display, "CSGVStillRenderTimeBudget").GetAsDouble();
    };
    QCOMPARE(seconds(), 3.0);
    QCOMPARE(budgetSlider->value(), 217);
    budgetSlider->setFocus();
    QTest::keyClick(budgetSlider, Qt::Key_Home);
    QTRY_COMPARE(seconds(), 0.0);
    budgetBox->setFocus();
    budgetBox->selectAll();
    QTest::keyClicks(budgetBox, "3");
    QTest::keyClick(budgetBox, Qt::Key_Return);
    QTRY_COMPARE(seconds(), 3.0);
    QCOMPARE(budgetSlider->value(), 217);

    // 0 of the cache size is automatic, and says so; every box has one width (the sliders' ends
    // line up).
    pqPropertyWidget* cache = this->widget("CSGVCacheSizeMiB");
    QVERIFY(cache);
    auto* cacheBox = cache->findChild<QSpinBox*>("LogValue");
    QVERIFY(cacheBox);
    QCOMPARE(vtkSMPropertyHelper(this->Display, "CSGVCacheSizeMiB").GetAsInt(), 0);
    QCOMPARE(cacheBox->text(), QString("automatic"));
    QCOMPARE(box->text(), QString("16")); // no such text where the minimum means no more than itself
    QCOMPARE(cacheBox->width(), box->width());
    QCOMPARE(budgetBox->width(), box->width());
  }
};

int main(int argc, char** argv)
{
  return pvqttest::run<TestPropertyPanel>(argc, argv, gPlugin, gFixtures);
}

#include "test_property_panel.moc"
