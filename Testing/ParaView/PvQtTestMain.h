// SPDX-License-Identifier: MIT
/**
 * @file PvQtTestMain.h
 * @brief The main() of the plugin's QtTest executables: `TEST PLUGIN.so FIXTURES_DIR [QtTest
 * options]` runs a QtTest object in a builtin ParaView session (pqPVApplicationCore, no main
 * window), with ParaView's own property widgets registered first as the GUI does.
 */
#ifndef PvQtTestMain_h
#define PvQtTestMain_h

#include <pqInterfaceTracker.h>
#include <pqObjectBuilder.h>
#include <pqPVApplicationCore.h>
#include <pqServer.h>
#include <pqServerResource.h>
#include <pqStandardPropertyWidgetInterface.h>
#include <pqUndoStack.h>
#include <pqUndoStackBuilder.h>
#include <vtkSMPluginManager.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>
#include <vtkNew.h>
#include <vtkSMProxyManager.h>
#include <vtkSMSessionProxyManager.h>
#include <vtkSmartPointer.h>

#include <QApplication>
#include <QString>
#include <QtTest>

#include <cstdio>
#include <vector>

namespace pvqttest
{
/// Loads the plugin and makes a CSGV reader of `file` shown by a bare Segmentation Volume
/// representation proxy (no view); false when a step fails.
inline bool segmentationVolume(const QString& plugin, const QString& file, vtkSmartPointer<vtkSMProxy>& reader,
  vtkSmartPointer<vtkSMProxy>& repr)
{
  vtkSMProxyManager* manager = vtkSMProxyManager::GetProxyManager();
  if (!manager->GetPluginManager()->LoadLocalPlugin(plugin.toUtf8().constData()))
  {
    return false;
  }
  vtkSMSessionProxyManager* pxm = manager->GetActiveSessionProxyManager();
  reader.TakeReference(pxm->NewProxy("sources", "CSGVReader"));
  repr.TakeReference(pxm->NewProxy("representations", "CSGVSegmentationVolumeRepresentation"));
  if (!reader || !repr)
  {
    return false;
  }
  vtkSMPropertyHelper(reader, "FileName").Set(file.toUtf8().constData());
  reader->UpdateVTKObjects();
  vtkSMPropertyHelper(repr, "Input").Set(reader);
  repr->UpdateVTKObjects();
  return true;
}

/// Runs `Test` (constructed inside the session) and returns the number of failed checks; the
/// plugin path and the fixtures folder go to `plugin` and `fixtures` before it is constructed.
template <class Test>
int run(int argc, char** argv, QString& plugin, QString& fixtures)
{
  if (argc < 3)
  {
    std::fprintf(stderr, "usage: %s PLUGIN.so FIXTURES_DIR [QtTest options]\n", argv[0]);
    return 2;
  }
  plugin = argv[1];
  fixtures = argv[2];
  QApplication app(argc, argv);
  int pvArgc = 1;
  char* pvArgv[] = { argv[0], nullptr }; // ParaView's logger wants argv[argc] == nullptr
  pqPVApplicationCore core(pvArgc, pvArgv);
  // The GUI registers ParaView's own widgets (ColorEditor, decorators) before any plugin.
  core.interfaceTracker()->addInterface(new pqStandardPropertyWidgetInterface(&core));
  pqServer* server = core.getObjectBuilder()->createServer(pqServerResource("builtin:"));
  if (!server)
  {
    std::fprintf(stderr, "no builtin session\n");
    return 1;
  }
  int failed = 0;
  {
    Test test;
    std::vector<char*> rest{ argv[0] }; // QtTest sees only its own options
    for (int i = 3; i < argc; ++i)
    {
      rest.push_back(argv[i]);
    }
    failed = QTest::qExec(&test, int(rest.size()), rest.data());
  }
  core.getObjectBuilder()->removeServer(server);
  return failed;
}
/// The application's undo stack, made as the GUI makes it when there is none (owned by `parent`).
inline pqUndoStack* ensureUndoStack(QObject* parent)
{
  pqApplicationCore* core = pqApplicationCore::instance();
  if (!core->getUndoStack())
  {
    vtkNew<pqUndoStackBuilder> undoBuilder;
    vtkSMProxyManager::GetProxyManager()->SetUndoStackBuilder(undoBuilder);
    core->setUndoStack(new pqUndoStack(undoBuilder, parent));
  }
  return core->getUndoStack();
}

} // namespace pvqttest

#endif
