# SPDX-License-Identifier: MIT
"""A series of .csgv files (ParaView's file dialog groups s_0.csgv ... s_2.csgv into one entry):
the CSGV Reader's repeatable FileNames takes the whole group, as the dialog and OpenDataFile hand
it, and reads it as a time series, file i at time i, each step with its own dimensions and labels.
FileName alone still reads one file (scripts, old state files); both set is an error naming them;
a series survives a state file; a damaged step says so and the other steps still read."""
import os
import shutil

import numpy as np

import csgv_pvtest as t
from paraview import servermanager as sm
from paraview.simple import *

t.load_plugin(globals())
tmp = t.temp_dir()

fixtures = ["synthA_b32_rans2.csgv", "denseB_b32_rans1.csgv", "synthA_b16_nibble.csgv"]
files = []
for i, name in enumerate(fixtures):
    files.append(os.path.join(tmp, "s_%d.csgv" % i))
    shutil.copy(os.path.join(t.FIXTURES, name), files[-1])
expected = [t.source_volume(name) for name in fixtures]
t.check(expected[0].shape != expected[1].shape, "the steps differ in dimensions (%s, %s)"
        % (expected[0].shape, expected[1].shape))


def shows(r, time, i, tag):
    dims, labels, step = t.labels_at(r, time)
    d, h, w = expected[i].shape
    t.check(dims == (w, h, d) and labels is not None and np.array_equal(labels, expected[i].ravel().astype(np.uint64)),
            "%s: time %s shows s_%d.csgv (%s)" % (tag, time, i, dims))
    return step


# --- What the file dialog relies on -------------------------------------------------------------
proto = sm.ProxyManager().GetPrototypeProxy("sources", "CSGVReader")
pname = sm.vtkSMCoreUtilities.GetFileNameProperty(proto)
t.check(pname == "FileNames", "the file dialog and OpenDataFile set FileNames (got %r)" % pname)
prop = proto.GetProperty(pname) if pname else None
t.check(prop is not None and prop.GetRepeatCommand() == 1,
        "FileNames repeats, so pqObjectBuilder::createReader hands it the whole group")

# --- The series, opened as the dialog does --------------------------------------------------------
r = OpenDataFile(files)
t.check(r.GetXMLName() == "CSGVReader", "OpenDataFile picks the CSGV Reader (%s)" % r.GetXMLName())
t.check(list(r.FileNames) == files and r.FileName == "", "OpenDataFile set FileNames to the 3 files")
t.check(list(r.TimestepValues) == [0.0, 1.0, 2.0], "time steps 0, 1, 2 (%s)" % list(r.TimestepValues))
for time, i in ((1.0, 1), (2.0, 2), (0.0, 0), (1.5, 1), (7.0, 2)):
    step = shows(r, time, i, "series")
    t.check(step == float(i), "the output says it is step %d (%s)" % (i, step))

# The animation scene follows the reader's steps, and the Segmentation Volume draws each.
scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
t.check(list(GetTimeKeeper().TimestepValues) == [0.0, 1.0, 2.0], "the time keeper has the 3 steps")
view = t.render_view(96, 96)
display = Show(r, view)
reprs = display.GetProperty("Representation").SMProperty.GetDomain("list")
if "Segmentation Volume" in [reprs.GetString(i) for i in range(reprs.GetNumberOfStrings())]:
    t.check(display.Representation == "Segmentation Volume", "shown as Segmentation Volume")
    for time in (0.0, 1.0, 2.0):
        view.ViewTime = time
        Render(view)
        bounds = display.GetRepresentedDataInformation().GetBounds()
        d, h, w = expected[int(time)].shape
        shot = t.content_mask(t.screenshot(view, 96, 96, "series_%d.png" % time))
        t.check(tuple(bounds[1::2]) == (w, h, d) and shot.any(),
                "time %d: drawn, with its own bounds (%s)" % (time, bounds))
    # A later step larger than the first (found by an attack pass: it was drawn cropped to the
    # first step's extent, by the Segmentation Volume and by ParaView's own Outline and Slice,
    # which keep the whole extent they saw first and ask for it at every step).
    grow = OpenDataFile([files[1], files[0]])  # denseB 77x61x45, then synthA 133x70x194
    gview = t.render_view(96, 96)
    gvol = Show(grow, gview)
    gvol.SetRepresentationType("Segmentation Volume")
    gslice = Show(Slice(Input=grow), gview)
    for time, i in ((0.0, 1), (1.0, 0), (0.0, 1), (1.0, 0)):
        gview.ViewTime = time
        Render(gview)
        d, h, w = expected[i].shape
        vb = gvol.GetRepresentedDataInformation().GetBounds()
        sb = gslice.GetRepresentedDataInformation().GetBounds()
        t.check(tuple(vb[1::2]) == (w, h, d) and (sb[3], sb[5]) == (h, d),  # the Slice: x = 38.5
                "a larger later step, time %d: the volume's bounds %s and the Slice's %s are the step's"
                % (time, vb, sb))
else:
    t.log("skip the view: this build has no Segmentation Volume representation")

# A state file keeps the series.
state = os.path.join(tmp, "series.pvsm")
SaveState(state)
Delete(display)
Delete(view)
Delete(r)
LoadState(state)
r = FindSource("s_..csgv") or next(iter(GetSources().values()), None)
t.check(r is not None and list(r.FileNames) == files, "a state file keeps FileNames")
if r is not None:
    shows(r, 2.0, 2, "from the state file")
for s in list(GetSources().values()):
    Delete(s)

# --- FileName: scripts and old state files ---------------------------------------------------------
r = CSGVReader(FileName=files[1])
dims, labels, step = t.labels_at(r)
t.check(len(r.TimestepValues) == 0 and step is None, "FileName alone: no time steps")
shows(r, None, 1, "FileName")
with t.ErrorLog() as errors:
    r.FileNames = files
    dims, labels, _ = t.labels_at(r)
t.check("set only one of them" in errors.text and (labels is None or labels.size == 0),
        "FileName and FileNames both set: an error, not one of them silently (%s)" % errors.text.strip()[:200])
Delete(r)

# OpenDataFile makes FileNames of one file; a script that then sets FileName means that file.
r = OpenDataFile(files[0])
shows(r, None, 0, "OpenDataFile of one file")
r.FileName = files[1]
shows(r, None, 1, "then FileName set by a script")
Delete(r)

# --- A damaged step: said, empty; the other steps still read ----------------------------------------
with open(files[1], "r+b") as f:
    f.truncate(1000)
r = CSGVReader(FileNames=files)
shows(r, 0.0, 0, "before the damaged step")
with t.ErrorLog() as errors:
    dims, labels, step = t.labels_at(r, 1.0)
t.check("s_1.csgv" in errors.text and (labels is None or labels.size == 0) and step == 1.0,
        "the damaged step is named and empty (%s)" % errors.text.strip()[:200])
shows(r, 2.0, 2, "after the damaged step")
Delete(r)

# A damaged first step hides nothing after it: the others read, the first is named.
r = CSGVReader(FileNames=[files[1], files[0], files[2]])
t.check(list(r.TimestepValues) == [0.0, 1.0, 2.0], "a damaged first step: still 3 time steps")
shows(r, 1.0, 0, "after a damaged first step")
shows(r, 2.0, 2, "after a damaged first step")
with t.ErrorLog() as errors:
    dims, labels, step = t.labels_at(r, 0.0)
t.check("s_1.csgv" in errors.text and (labels is None or labels.size == 0),
        "the damaged first step is named and empty (%s)" % errors.text.strip()[:200])
shows(r, 1.0, 0, "back after the damaged first step")
Delete(r)

t.finish()
