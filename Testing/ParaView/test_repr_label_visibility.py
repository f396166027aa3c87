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

# The label selection ("selected", issue 41): highlighted, the same labels are seen, the selected
# one in the selection colour; dimmed, the others are translucent, so only the selected label is
# hit opaque (the label image), and where it was seen before it still is.
d.CSGVMaterials = ct.select_labels(json.dumps(user), [hidden])
t.check(ct.selected_labels(d.CSGVMaterials) == [hidden], "select_labels sets the selection")
shot = t.screenshot(v, W, H, "selected.png")
sel = ct.label_image(d)
t.check(np.array_equal(sel, before), "highlighted: the same labels are seen")
mine = shot[::-1][sel == hidden].astype(int)  # row 0 at the bottom, as the label image
rest = shot[::-1][(sel != hidden) & (sel != INVALID)].astype(int)
t.check(len(mine) > 0 and np.median(mine[:, 1]) < 0.25 * np.median(mine[:, 0]) and abs(np.median(mine[:, 0]) - np.median(mine[:, 2])) <= 2,
        "the selected label is drawn magenta (median rgb %s)" % (np.median(mine, axis=0),))
t.check(len(rest) > 0 and np.median(rest[:, 1]) > 0.3 * np.median(rest[:, 0]),
        "the other labels keep the user's orange (median rgb %s)" % (np.median(rest, axis=0),))
d.CSGVMaterials = ct.select_labels(d.CSGVMaterials, [], style="dim")
t.check(np.array_equal(labels("unselected.png"), before), "an empty selection draws as none")
d.CSGVMaterials = ct.select_labels(d.CSGVMaterials, [hidden], style="dim")
dim = labels("dim.png")
# Only the selected label is opaque: elsewhere the label image holds the first (dimmed, translucent)
# surface, or the selected label behind it.
t.check(np.all((dim == before) | (dim == hidden)) and np.any((dim == hidden) & (before != hidden)),
        "dimmed: only the selected label is opaque (seen behind %d dimmed pixels)"
        % int(np.count_nonzero((dim == hidden) & (before != hidden))))
t.check(np.all(dim[before == hidden] == hidden), "dimmed: the selected label is seen wherever it was")
t.check(json.loads(d.CSGVMaterials)["materials"] == user["materials"], "the user's materials stay as written")
# The selection as CSGV Extract Labels' input: a mask of exactly the selected label's voxels.
e = CSGVExtractLabels(Input=r, Labels=" ".join(str(x) for x in ct.selected_labels(d.CSGVMaterials)), OutputType="Mask")
m = t.fetch(e).GetBlock(0)
src = t.source_volume("synthA_b32_rans2.csgv")
t.check(int(m.GetCellData().GetArray("Mask").GetRange()[1]) == 1 and
        int(sum(m.GetCellData().GetArray("Mask").GetValue(i) for i in range(m.GetNumberOfCells()))) == int(np.sum(src == hidden)),
        "Extract Labels of the selection: a mask of its voxels")

d.CSGVMaterials = json.dumps(user)
t.check(np.array_equal(labels("all.png"), before), "without the overlay: the first image again")
t.finish()
