# SPDX-License-Identifier: MIT
"""Client/server: the plugin loads on both sides, a .csgv opens on the server and shows as
Segmentation Volume; the server renders (the labels never travel to the client) and the client's
screenshot holds the volume. Run by clientserver_driver.py, which starts pvserver on
CSGV_SERVER_PORT."""
import os

import csgv_pvtest as t
from paraview.simple import *

Connect("localhost", int(os.environ["CSGV_SERVER_PORT"]))
LoadPlugin(t.PLUGIN, remote=True, ns=globals())
LoadPlugin(t.PLUGIN, remote=False, ns=globals())
r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(160, 120)
d = Show(r, v)
t.check(d.Representation == "Segmentation Volume", "default representation on a server")
d.CSGVFramesPerStillRender = 2
v.ResetCamera()
img = t.screenshot(v, 160, 120)
t.check(t.content_mask(img).mean() > 0.05, "the server-rendered volume reaches the client (%.1f%%)"
        % (100 * t.content_mask(img).mean()))
d.CSGVMaterials = t.constant_materials([1, 0, 0])
red = t.screenshot(v, 160, 120, "red.png")
m = t.content_mask(red)
t.check(m.mean() > 0.05 and (red[m][:, 0].astype(int) > red[m][:, 2].astype(int) + 40).mean() > 0.95,
        "a property change reaches the server")
# ParaView preset names resolve on the server too.
import json
d.CSGVMaterials = json.dumps({"version": 1, "materials": [
    {"color": {"mode": "colormap", "attribute": "label", "min": 0, "max": 200, "colormap": "Jet"}}]})
t.check(t.content_mask(t.screenshot(v, 160, 120, "jet.png")).mean() > 0.05, "a ParaView preset resolves on the server")
t.finish()
