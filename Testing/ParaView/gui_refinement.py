# SPDX-License-Identifier: MIT
"""GUI check of progressive refinement (run inside the ParaView client by
gui_refinement_driver.py): path tracing with a tiny time budget per still render, so the first
render ends far below FramesPerStillRender samples and the plugin's auto-start must keep
rendering until every pixel has them."""
import os

from paraview.simple import *

r = OpenDataFile(os.path.join(os.environ["CSGV_FIXTURES"], "synthA_b32_rans2.csgv"))
d = Show(r)
# The GUI's refinement slice reaches the representation as a property (internal: not in state
# files), set by the auto-start when the representation was added.
import sys
from paraview import servermanager as sm
sys.stderr.write("csgv slice: %g\n" % sm.vtkSMPropertyHelper(d.SMProxy, "CSGVRefinementSlice").GetAsDouble())
sys.stderr.flush()
d.CSGVShading = "pt"
d.CSGVFramesPerStillRender = 12
d.CSGVStillRenderTimeBudget = 0.05
ResetCamera()
Render()
# The mouse moves (interactive renders at reduced resolution), then is released (a still render
# that may end with as few samples as the interactive ones had): refinement goes on from there.
view = GetActiveView()
camera = GetActiveCamera()
for _ in range(4):
    camera.Azimuth(5)
    view.SMProxy.InteractiveRender()
Render()
