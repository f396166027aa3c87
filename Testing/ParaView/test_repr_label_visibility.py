# SPDX-License-Identifier: MIT
"""The label-visibility overlay of the material document ("hidden", "only"; Materials.h) as the
Segmentation Volume draws it: hiding a label removes exactly that label from the label image (the
last G-buffer, read through misc/CSGVQuery) while the user's materials stay as written, "only"
leaves just that label, and clearing the overlay ("Show all") gives back the first image.
Needs the representation to draw csgv::effectiveMaterials of its document (vtkCSGVVolumeProp)."""
import json
import os
import sys

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools as ct  # noqa: E402

INVALID = 0xFFFFFFFF
W, H = 160, 120
t.load_plugin(globals())

r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(W, H)
d = Show(r, v)
d.CSGVFramesPerStillRender = 1
v.ResetCamera()


def labels(name):
    t.screenshot(v, W, H, name)
    return ct.label_image(d)


# The user's own material (not the default document), which every edit must keep.
user = {"materials": [{"name": "mine", "filter": {"attribute": "label", "min": 1, "max": 4294967294},
                       "color": {"mode": "constant", "rgb": [1, 0.5, 0]}}]}
d.CSGVMaterials = json.dumps(user)
before = labels("user.png")
values, counts = np.unique(before[before != INVALID], return_counts=True)
t.check(len(values) >= 3, "several labels visible (%d)" % len(values))
hidden = int(values[np.argmax(counts)])

d.CSGVMaterials = json.dumps(dict(user, hidden=[hidden]))
after = labels("hidden.png")
t.check(not np.any(after == hidden), "hidden label %d is gone from the label image" % hidden)
keep = before != hidden
t.check(np.array_equal(after[keep], before[keep]), "every pixel that showed another label is unchanged")
t.check(np.any(after[before == hidden] != hidden), "what was behind the hidden label shows through")

d.CSGVMaterials = json.dumps(dict(user, only=[hidden]))
only = labels("only.png")
t.check(set(np.unique(only[only != INVALID]).tolist()) == {hidden}, "only: just label %d" % hidden)

d.CSGVMaterials = json.dumps(user)
t.check(np.array_equal(labels("all.png"), before), "without the overlay: the first image again")
t.finish()
