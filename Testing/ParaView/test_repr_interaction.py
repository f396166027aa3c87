# SPDX-License-Identifier: MIT
"""How the Segmentation Volume uses its frames in a session (issue 15, responsiveness):
- an interactive render (the mouse drags: ParaView's InteractiveRender) draws one frame at a
  resolution reduced by a whole factor, chosen from the measured cost of a pixel, and the still
  render after it is at full resolution again;
- a change that does not change the image keeps the accumulated samples: attribute files that no
  material names, the same material document set again, a higher sample target (it goes on
  from the samples taken);
- a change that does change the image starts anew.
Nothing here is timed: the figures come from Testing/Benchmarks/bench_gui_responsiveness.py."""
import json
import os
import subprocess
import sys

import csgv_pvtest as t
from paraview.simple import *

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools  # noqa: E402

t.load_plugin(globals())
r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
W, H = 960, 720
v = t.render_view(W, H)
d = Show(r, v)
d.SetRepresentationType("Segmentation Volume")
d.CSGVFramesPerStillRender = 4
d.CSGVStillRenderTimeBudget = 60
v.ResetCamera()


def size():
    w, h = csgv_tools.query(d, "labels").split()[:2]
    return int(w), int(h)


def converge():
    for _ in range(40):
        Render(v)
        if t.repr_info(d)[1] >= d.CSGVFramesPerStillRender:
            return True
    return False


t.check(converge(), "still renders reach the sample target")
t.check(size() == (W, H), "a still render is at full resolution")

# Interactive: one frame at W/f x H/f for a whole factor f.
cam = v.GetActiveCamera()
sizes = []
for _ in range(3):
    cam.Azimuth(3)
    v.SMProxy.InteractiveRender()
    sizes.append(size())
ok = all(any(s == ((W + f - 1) // f, (H + f - 1) // f) for f in range(1, 9)) for s in sizes)
t.check(ok, "interactive frames are the view reduced by a whole factor (%s)" % sizes)
# On a CPU device (lavapipe, as in CI) a path-traced frame of a 2560x1920 view takes several times
# the tenth of a second an interactive frame may (0.4 s on a 2-core machine of 2026-12; at 1280x960
# it took 0.1 s there, and the view was drawn whole as often as not): it must be reduced there once
# a frame's cost is known, whatever local-shading frames cost (the cost is kept per shading mode:
# averaged with local shading's, a CI run once drew the first one whole). A GPU may draw it whole.
device = subprocess.run([os.environ["CSGV_TOOL"], "render", os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"),
                         os.path.join(t.temp_dir(), "probe.png"), "--size", "8x8", "--frames", "1"],
                        capture_output=True, text=True).stdout
if "(cpu)" in device:
    PW, PH = 2560, 1920
    v.ViewSize = [PW, PH]
    d.CSGVShading = "pt"
    Render(v)  # a path-traced still render: the cost of its frames is measured
    pt_sizes = []
    for _ in range(2):
        cam.Azimuth(3)
        v.SMProxy.InteractiveRender()
        pt_sizes.append(size())
    t.check(all(s[0] < PW and s[1] < PH for s in pt_sizes),
            "on a CPU device path-traced interactive frames are reduced (%s)" % pt_sizes)
    v.ViewSize = [W, H]
    d.CSGVShading = "local"
Render(v)
t.check(size() == (W, H), "the still render after the interaction is at full resolution")
t.check(converge(), "and converges")

# Changes without effect keep the samples.
csv = os.path.join(t.temp_dir(), "unused.csv")
with open(csv, "w") as f:
    f.write("label,unused\n1,5\n2,7\n")
d.CSGVAttributeFiles = [csv]
Render(v)
t.check(t.repr_info(d) == (0, 4), "attribute files no material names: nothing rendered, samples kept (%r)" % (t.repr_info(d),))
d.CSGVMaterials = json.dumps({"version": 1, "materials": [{"name": "all"}]})  # the default, written out
Render(v)
t.check(t.repr_info(d) == (0, 4), "the same materials written anew: nothing rendered, samples kept (%r)" % (t.repr_info(d),))
d.CSGVFramesPerStillRender = 6
Render(v)
frames, samples = t.repr_info(d)
t.check(samples == 6 and frames <= 3, "a higher target goes on from the samples taken (%d frames)" % frames)

# A change of the image starts anew.
d.CSGVMaterials = json.dumps({"version": 1, "materials": [{"name": "half", "opacity": 0.5}]})
Render(v)
frames, samples = t.repr_info(d)
t.check(frames >= 6, "other materials start anew (%d frames)" % frames)
t.finish()
