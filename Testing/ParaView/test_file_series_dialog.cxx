// SPDX-License-Identifier: MIT
// QtTest of File > Open on a TIFF stack (issue 38, item 3: the stack opened as its first slice),
// in a builtin session with ParaView's own dialog code: pqFileDialog lists slice_0000.tif ...
// slice_0005.tif as one entry "slice_..tif", choosing it gives one group of the six files in
// order, and pqLoadDataReaction::loadData with the reader "Segmentation (CSGV)" (where every
// route of the dialog ends once a reader is chosen: the dialog's file-type list or its "Open Data
// With..." prompt; pqObjectBuilder::createReader sets the group) makes one reader whose FileNames
// holds all six and whose output is one 23 x 17 x 6 volume equal to the slices. Then the same for
// three .csgv files (copies of FIXTURES_DIR's), which the CSGV Reader makes three time steps.
// Usage: csgv_file_series_dialog_test PLUGIN.so FIXTURES_DIR
#include "PvQtTestMain.h"

#include <pqApplicationCore.h>
#include <pqFileDialog.h>
#include <pqLoadDataReaction.h>
#include <pqPipelineSource.h>
#include <pqServer.h>
#include <pqServerManagerModel.h>
#include <vtkAlgorithm.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkSMPluginManager.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxyManager.h>
#include <vtkSMSourceProxy.h>

#include <QDir>
#include <QFile>
#include <QProcess>
#include <QTemporaryDir>
#include <QtTest>

#include <cstdint>
#include <vector>

namespace
{
QString gPlugin, gFixtures;
constexpr int kW = 23, kH = 17, kN = 6;
}

class TestFileSeriesDialog : public QObject
{
  Q_OBJECT

  QTemporaryDir Dir;
  QStringList Slices;          ///< slice_0000.tif ... in z order
  std::vector<uint32_t> Labels; ///< what the slices hold, x fastest
  QList<QStringList> Chosen;   ///< what the dialog returned

  pqServer* server() const
  {
    QList<pqServer*> servers =
      pqApplicationCore::instance()->getServerManagerModel()->findItems<pqServer*>();
    return servers.isEmpty() ? nullptr : servers[0];
  }

private Q_SLOTS:
  void initTestCase()
  {
    QVERIFY(vtkSMProxyManager::GetProxyManager()->GetPluginManager()->LoadLocalPlugin(
      gPlugin.toUtf8().constData()));
    QVERIFY(this->Dir.isValid());
    // Debian's python3 has tifffile; the labels go beside the slices as raw little-endian uint32.
    QProcess writer;
    writer.start("/usr/bin/python3",
      { "-c",
        "import sys, numpy as np, tifffile\n"
        "d = sys.argv[1]\n"
        "z, y, x = np.meshgrid(np.arange(6), np.arange(17), np.arange(23), indexing='ij')\n"
        "v = ((x // 4) + 9 * (y // 5) + 97 * z + 1).astype(np.uint32)\n"
        "v[(x + 3 * y + 5 * z) % 11 == 0] = 0\n"
        "v[-1, -1, -1] = 70000\n"
        "for i, s in enumerate(v):\n"
        "    tifffile.imwrite('%s/slice_%04d.tif' % (d, i), s)\n"
        "open(d + '/labels.u32', 'wb').write(v.astype('<u4').tobytes())\n",
        this->Dir.path() });
    QVERIFY(writer.waitForFinished(60000));
    QCOMPARE(writer.exitCode(), 0);
    QFile raw(this->Dir.filePath("labels.u32"));
    QVERIFY(raw.open(QIODevice::ReadOnly));
    const QByteArray bytes = raw.readAll();
    QCOMPARE(bytes.size(), kW * kH * kN * 4);
    this->Labels.resize(size_t(kW) * kH * kN);
    for (size_t i = 0; i < this->Labels.size(); ++i)
    {
      const auto* b = reinterpret_cast<const unsigned char*>(bytes.constData()) + 4 * i;
      this->Labels[i] = uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
    }
    for (int i = 0; i < kN; ++i)
    {
      this->Slices << this->Dir.filePath(QString("slice_%1.tif").arg(i, 4, 10, QChar('0')));
    }
  }

  void dialogHandsOverTheGroup()
  {
    QVERIFY(this->server());
    pqFileDialog dialog(this->server(), nullptr, "Open File:", this->Dir.path(), "All Files (*)");
    dialog.setFileMode(pqFileDialog::ExistingFilesAndDirectories);
    // What a user does: picks the grouped entry and presses OK.
    QVERIFY(dialog.selectFile(this->Dir.filePath("slice_..tif")));
    this->Chosen = dialog.getAllSelectedFiles();
    QCOMPARE(this->Chosen.size(), 1);
    QCOMPARE(this->Chosen[0], this->Slices);
  }

  void readerGetsOneVolume()
  {
    QVERIFY(!this->Chosen.isEmpty());
    pqPipelineSource* source =
      pqLoadDataReaction::loadData(this->Chosen, "sources", "CSGVInputReader", this->server());
    QVERIFY(source);
    vtkSMSourceProxy* proxy = vtkSMSourceProxy::SafeDownCast(source->getProxy());
    QVERIFY(proxy);
    QCOMPARE(QString(proxy->GetXMLName()), QString("CSGVInputReader"));
    vtkSMPropertyHelper names(proxy, "FileNames");
    QCOMPARE(int(names.GetNumberOfElements()), kN);
    for (int i = 0; i < kN; ++i)
    {
      QCOMPARE(QString(names.GetAsString(i)), this->Slices[i]);
    }
    proxy->UpdatePipeline();
    auto* algorithm = vtkAlgorithm::SafeDownCast(proxy->GetClientSideObject());
    QVERIFY(algorithm);
    vtkImageData* image = vtkImageData::SafeDownCast(algorithm->GetOutputDataObject(0));
    QVERIFY(image);
    int dims[3];
    image->GetDimensions(dims);
    QCOMPARE(dims[0], kW + 1); // cell data: one more point than voxels per axis
    QCOMPARE(dims[1], kH + 1);
    QCOMPARE(dims[2], kN + 1); // was 2: the first slice only
    vtkDataArray* labels = image->GetCellData()->GetArray("Labels");
    QVERIFY(labels);
    QCOMPARE(size_t(labels->GetNumberOfTuples()), this->Labels.size());
    for (vtkIdType i = 0; i < labels->GetNumberOfTuples(); ++i)
    {
      if (uint32_t(labels->GetTuple1(i)) != this->Labels[size_t(i)])
      {
        QFAIL(qPrintable(QString("voxel %1 is %2, its slice holds %3")
                           .arg(i)
                           .arg(labels->GetTuple1(i))
                           .arg(this->Labels[size_t(i)])));
      }
    }
  }

  void csgvSeriesIsATimeSeries()
  {
    // s_0.csgv ... s_2.csgv are one entry of the dialog; the CSGV Reader gets all three (it had
    // no FileNames and opened the first alone) and makes them time steps, each with its own size.
    const QStringList fixtures = { "synthA_b32_rans2.csgv", "denseB_b32_rans1.csgv", "synthA_b16_nibble.csgv" };
    QStringList series;
    for (int i = 0; i < fixtures.size(); ++i)
    {
      series << this->Dir.filePath(QString("s_%1.csgv").arg(i));
      QVERIFY(QFile::copy(QDir(gFixtures).filePath(fixtures[i]), series.back()));
    }
    pqFileDialog dialog(this->server(), nullptr, "Open File:", this->Dir.path(), "All Files (*)");
    dialog.setFileMode(pqFileDialog::ExistingFilesAndDirectories);
    QVERIFY(dialog.selectFile(this->Dir.filePath("s_..csgv")));
    const QList<QStringList> chosen = dialog.getAllSelectedFiles();
    QCOMPARE(chosen.size(), 1);
    QCOMPARE(chosen[0], series);
    pqPipelineSource* source = pqLoadDataReaction::loadData(chosen, "sources", "CSGVReader", this->server());
    QVERIFY(source);
    vtkSMSourceProxy* proxy = vtkSMSourceProxy::SafeDownCast(source->getProxy());
    QVERIFY(proxy);
    QCOMPARE(int(vtkSMPropertyHelper(proxy, "FileNames").GetNumberOfElements()), 3);
    proxy->UpdatePipelineInformation();
    QCOMPARE(int(vtkSMPropertyHelper(proxy, "TimestepValues").GetNumberOfElements()), 3);
    int sizes[3][3];
    for (int step = 0; step < 3; ++step)
    {
      proxy->UpdatePipeline(double(step));
      auto* image = vtkImageData::SafeDownCast(
        vtkAlgorithm::SafeDownCast(proxy->GetClientSideObject())->GetOutputDataObject(0));
      QVERIFY(image);
      image->GetDimensions(sizes[step]);
    }
    QVERIFY(sizes[0][0] != sizes[1][0]); // synthA, then denseB
    QCOMPARE(sizes[0][0], sizes[2][0]);
  }
};

int main(int argc, char** argv)
{
  return pvqttest::run<TestFileSeriesDialog>(argc, argv, gPlugin, gFixtures);
}

#include "test_file_series_dialog.moc"
