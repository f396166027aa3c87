# SPDX-License-Identifier: MIT
"""A state file keeps every Segmentation Volume property: set them, save a .pvsm, reset the
session, load the state, read them back; the loaded display still renders."""
import os

import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
fixture = os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv")
materials = t.constant_materials([0.2, 0.7, 0.3], 0.8)
values = {
    "CSGVLabelArray": "Labels",
    "CSGVShading": "ao",
    "CSGVShadingBlend": 0.5,
    "CSGVFramesPerStillRender": 3,
    "CSGVStillRenderTimeBudget": 7.5,
    "CSGVLODBias": -1.0,
    "CSGVSubsampling": 2,
    "CSGVDenoise": 0,
    "CSGVLightDirection": [0.1, 0.2, 0.9],
    "CSGVCacheSizeMiB": 64,
    "CSGVClipBox": [2, 40, 3, 50, 4, 60],
    "CSGVMaterials": materials,
}

r = OpenDataFile(fixture)
RenameSource("volume", r)
v = t.render_view(120, 90)
d = Show(r, v)
for k, val in values.items():
    setattr(d, k, val)
v.ResetCamera()
Render(v)
state = os.path.join(t.temp_dir(), "state.pvsm")
SaveState(state)
text = open(state).read()
t.check("CSGVMaterials" in text and "CSGVShading" in text, "the state file names the properties")

ResetSession()
LoadState(state)
src = FindSource("volume")
views = GetRenderViews()
t.check(src is not None and len(views) == 1, "state loaded: the source and its view")
d2 = GetDisplayProperties(src, views[0])
t.check(d2.Representation == "Segmentation Volume", "representation kept")


def same(a, b):
    if isinstance(b, list):
        return len(a) == len(b) and all(abs(float(x) - float(y)) < 1e-9 for x, y in zip(a, b))
    if isinstance(b, float):
        return abs(float(a) - b) < 1e-9
    return a == b


for k, val in values.items():
    got = getattr(d2, k)
    if k in ("CSGVShading", "CSGVSubsampling"):  # enumerations: compare the stored values
        got = d2.SMProxy.GetProperty(k).GetElement(0)
        val = {"ao": 2}.get(val, val)
    elif hasattr(got, "__len__") and not isinstance(got, str):
        got = list(got)
    t.check(same(got, val), "%s kept (%r)" % (k, got if k != "CSGVMaterials" else got[:40]))
views[0].ViewSize = [120, 90]
img = t.screenshot(views[0], 120, 90)
t.check(t.content_mask(img).mean() > 0.02, "the loaded display renders")
t.finish()
