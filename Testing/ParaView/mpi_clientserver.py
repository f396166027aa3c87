# SPDX-License-Identifier: MIT
"""Client of test_mpi_clientserver.py, run by clientserver_driver.py against a pvserver of 1 or of
N ranks: a .csgv opened on the server renders there, each rank its own bricks (DecodeLabels off),
IceT composites; the client saves the opaque image (one sample a pixel), the label image, picks,
the attribute summary and a file written by SaveData from the server's ranks into CSGV_OUT."""
import json
import os
import sys

import csgv_pvtest as t
from paraview.simple import *

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools  # noqa: E402

out = os.environ["CSGV_OUT"]
t.connect_to_server(globals())
path = os.path.join(t.FIXTURES, "synthA_b16_nibble.csgv")
r = CSGVReader(FileName=path, DecodeLabels=0)
v = t.render_view(160, 120)
v.OrientationAxesVisibility = 0
v.Background = [0, 0, 0]
d = Show(r, v)
d.Representation = "Segmentation Volume"
d.CSGVFramesPerStillRender = 1
d.CSGVStillRenderTimeBudget = 60
v.CameraPosition = [-60, 130, 160]
v.CameraFocalPoint = [66, 35, 97]
v.CameraViewUp = [0, 0, 1]
Render(v)
SaveScreenshot(os.path.join(out, "opaque.png"), v, ImageResolution=[160, 120], TransparentBackground=0)
facts = {"ranks": servermanager.ActiveConnection.GetNumberOfDataPartitions()}
picks = {}
for y in range(4, 120, 12):
    for x in range(4, 160, 12):
        p = csgv_tools.pick(d, x, y)
        picks["%d %d" % (x, y)] = [p.get("hit"), p.get("label"), p.get("voxel")]
facts["picks"] = picks
facts["labels"] = csgv_tools.query(d, "labels")
summary = csgv_tools.attribute_summary(d)
facts["summary_error"] = summary.get("error", "")
facts["match"] = csgv_tools.labels_matching(d, "label % 3 = 0")  # every rank's labels united
labels = CSGVReader(FileName=path, DecodeLabels=1)
SaveData(os.path.join(out, "written.csgv"), proxy=labels, BrickSize=32)
with open(os.path.join(out, "facts.json"), "w") as f:
    json.dump(facts, f)
Delete(d)
del v
t.finish()
