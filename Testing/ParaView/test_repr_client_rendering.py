# SPDX-License-Identifier: MIT
"""Client/server where the server cannot render (Debian's pvserver without a display: "Server
DISPLAY not accessible! Remote rendering will be disabled"). ParaView then renders on the client
and moves every representation's piece there; the client's copy of a Segmentation Volume had no
piece to hand over, and the client aborted at the first render ("Wrong tag", GUI re-check 12).
Now the volume travels and the client draws it. Run by clientserver_driver.py with
CSGV_SERVER_NO_DISPLAY=1."""
import os

import csgv_pvtest as t
from paraview.simple import *

Connect("localhost", int(os.environ["CSGV_SERVER_PORT"]))
LoadPlugin(t.PLUGIN, remote=True, ns=globals())
LoadPlugin(t.PLUGIN, remote=False, ns=globals())
r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(160, 120)
d = Show(r, v)
d.SetRepresentationType("Segmentation Volume")
d.CSGVFramesPerStillRender = 2
v.ResetCamera()
with t.ErrorLog() as log:
    img = t.screenshot(v, 160, 120)
t.check(t.content_mask(img).mean() > 0.05, "the volume is drawn on the client (%.1f%% of the view)"
        % (100 * t.content_mask(img).mean()))
d.CSGVMaterials = t.constant_materials([1, 0, 0])
red = t.screenshot(v, 160, 120, "red.png")
m = t.content_mask(red)
t.check(m.mean() > 0.05 and (red[m][:, 0].astype(int) > red[m][:, 2].astype(int) + 40).mean() > 0.95,
        "a property change reaches the client's drawing")
t.finish()
