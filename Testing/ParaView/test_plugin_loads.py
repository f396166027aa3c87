# SPDX-License-Identifier: MIT
"""The plugin loads by absolute path, and its proxies are registered for the right files."""
import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
for name in ("CSGVReader", "VolcaniteRawReader", "NIfTILabelReader", "CSGVExtract"):
    t.check(name in globals(), "proxy constructor %s exists" % name)

pxm = servermanager.ProxyManager()
t.check(pxm.SMProxyManager.GetPrototypeProxy("writers", "CSGVWriter") is not None, "writer proxy CSGVWriter")

factory = servermanager.vtkSMProxyManager.GetProxyManager().GetReaderFactory()
session = servermanager.ActiveConnection.Session
fixture = t.FIXTURES + "/synthA_b32_rans2.csgv"
for path, expected in ((fixture, "CSGVReader"),
                       (t.FIXTURES + "/synthA.vraw.gz", "VolcaniteRawReader"),
                       (t.AAL, "CSGVNIfTIReader")):
    ok = factory.CanReadFile(path, session)
    t.check(ok and factory.GetReaderName() == expected,
            "reader factory picks %s for %s (got %s)" % (expected, path.split("/")[-1],
                                                        factory.GetReaderName() if ok else None))
t.finish()
