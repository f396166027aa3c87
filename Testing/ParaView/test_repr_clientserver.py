# SPDX-License-Identifier: MIT
"""Client/server: the plugin loads on both sides, a .csgv opens on the server and shows as
Segmentation Volume; the server renders (the labels never travel to the client) and the client's
screenshot holds the volume. Run by clientserver_driver.py, which starts pvserver on
CSGV_SERVER_PORT."""
import os

import csgv_pvtest as t
from paraview.simple import *

t.connect_to_server(globals())
r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(160, 120)
d = Show(r, v)
t.check(d.Representation == "Segmentation Volume", "default representation on a server")
d.CSGVFramesPerStillRender = 2
v.ResetCamera()
t.check_drawn_and_red(v, d, "the server-rendered volume reaches the client", "a property change reaches the server")
# ParaView preset names resolve on the server too.
import json
d.CSGVMaterials = json.dumps({"version": 1, "materials": [
    {"color": {"mode": "colormap", "attribute": "label", "min": 0, "max": 200, "colormap": "Jet"}}]})
t.check(t.content_mask(t.screenshot(v, 160, 120, "jet.png")).mean() > 0.05, "a ParaView preset resolves on the server")

# Attributes in client/server: names and ranges come from the server (misc/CSGVQuery has no
# client part), the db3 beside the .csgv and files read there drive materials, picking reads the
# server's G-buffer.
import sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools as ct
import numpy as np
Delete(d)
ra = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2_attr.csgv"))
d = Show(ra, v)
d.CSGVFramesPerStillRender = 1
d.CSGVDerivedAttributes = ["big", "CASE WHEN voxels > 5000 THEN 1 ELSE 0 END"]
s = ct.attribute_summary(d)
names = {a["name"]: a for a in s["attributes"]}
t.check("kind" in names and names["kind"]["max"] == 3 and names.get("big", {}).get("max") == 1,
        "attribute names and ranges from the server: %s" % sorted(names))
d.CSGVMaterials = json.dumps({"version": 1, "materials": [{"filter": {"attribute": "big", "min": 1, "max": 1}}]})
t.screenshot(v, 160, 120, "big.png")
img = ct.label_image(d)
t.check(img.shape == (120, 160) and np.any(img != 0xFFFFFFFF), "the server's label image reaches the client")
ys, xs = np.nonzero(img != 0xFFFFFFFF)
p = ct.pick(d, int(xs[0]), int(ys[0]))
t.check(p["hit"] and p["label"] == int(img[ys[0], xs[0]]) and p["attributes"].get("voxels", 0) > 5000,
        "pick on the server: label %s with voxels %s" % (p.get("label"), p.get("attributes", {}).get("voxels")))
# The read-only statistics come from the server (GUI pass 10: the display's information
# properties read the client's copy of the representation, which never renders: all 0).
d.CSGVFramesPerStillRender = 3
t.screenshot(v, 160, 120, "three.png")
rs = ct.render_stats(d)
t.check(rs.get("CSGVMinSamples") == 3 and rs.get("CSGVFramesLastRender", 0) >= 1 and rs.get("CSGVCacheMiB", 0) > 0
        and rs.get("CSGVDeviceMiB", 0) > 0, "render_stats reads the server's statistics (%s)" % rs)
t.finish()
