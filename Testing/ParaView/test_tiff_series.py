# SPDX-License-Identifier: MIT
"""A file series through "Segmentation (CSGV)" (issue 38, item 3: a TIFF stack opened from File >
Open was its first slice). ParaView's file dialog groups slice_0000.tif ... slice_0011.tif into one
entry and pqObjectBuilder::createReader hands the whole group to the reader's file-name property
only when that property repeats (otherwise just the first file). This test checks that the
property the dialog and OpenDataFile pick (vtkSMCoreUtilities::GetFileNameProperty) is the
repeatable FileNames, then opens the series the way the dialog does (OpenDataFile with the list)
and as scripts do (FileNames=[...]): one W x H x N volume whose labels equal the slices in the
given order, compressed with progress to slice_0000-0011.csgv and reused; a slice of another size
is an error naming it; a series of 3D files, or 2D slices with ReadAsImageStack off, is a time
series; FileName alone still works, also from a state file written before FileNames existed."""
import os
import re
import subprocess

import numpy as np

import csgv_pvtest as t
from paraview import servermanager as sm
from paraview.simple import *

t.load_plugin(globals())
tmp = t.temp_dir()
os.environ["XDG_CACHE_HOME"] = os.path.join(tmp, "xdg")

N, H, W = 12, 17, 23  # W != H: a transposed slice would not match
z, y, x = np.meshgrid(np.arange(N), np.arange(H), np.arange(W), indexing="ij")
stack = ((x // 4) + 9 * (y // 5) + 97 * z + 1).astype(np.uint32)
stack[(x + 3 * y + 5 * z) % 11 == 0] = 0
stack[-1, -1, -1] = 70000  # wider than 16 bits
np.save(os.path.join(tmp, "stack.npy"), stack)
vols = [((x[:4] // 3) + 11 * (y[:4] // 4) + 100 * t_ + 7 * z[:4] + 1).astype(np.uint16) for t_ in range(3)]
np.save(os.path.join(tmp, "vols.npy"), np.stack(vols))

# Debian's python3 has tifffile (pvpython's interpreter may not find it).
subprocess.run(["/usr/bin/python3", "-c", """
import os, sys, numpy as np, tifffile
tmp = sys.argv[1]
stack = np.load(tmp + '/stack.npy')
for sub in ('good', 'bad'):
    os.makedirs(tmp + '/' + sub)
    for i, s in enumerate(stack):
        if sub == 'bad' and i == 7:
            s = s[:, :-1]  # one column short
        tifffile.imwrite('%s/%s/slice_%04d.tif' % (tmp, sub, i), s)
os.makedirs(tmp + '/vols')
for i, v in enumerate(np.load(tmp + '/vols.npy')):
    tifffile.imwrite('%s/vols/vol_t%d.tif' % (tmp, i), v, photometric='minisblack')  # multi-page: 3D
os.makedirs(tmp + '/grow')
v = np.load(tmp + '/vols.npy')
tifffile.imwrite(tmp + '/grow/g_t0.tif', np.ascontiguousarray(v[0][:3, :10, :12]), photometric='minisblack')
tifffile.imwrite(tmp + '/grow/g_t1.tif', v[1], photometric='minisblack')  # larger on every axis
""", tmp], check=True)
good = [os.path.join(tmp, "good", "slice_%04d.tif" % i) for i in range(N)]
bad = [os.path.join(tmp, "bad", "slice_%04d.tif" % i) for i in range(N)]
three_d = [os.path.join(tmp, "vols", "vol_t%d.tif" % i) for i in range(3)]


class Progress:
    """The reader's progress events (builtin session: the server-side object is local)."""

    def __init__(self, proxy):
        self.values = []
        self.algo = proxy.GetClientSideObject()
        self.tag = self.algo.AddObserver("ProgressEvent", lambda o, e: self.values.append(o.GetProgress()))

    def close(self):
        self.algo.RemoveObserver(self.tag)


def labels_of(r, time=None):
    """The reader's output at `time` as (dimensions in cells, labels x fastest)."""
    return t.labels_at(r, time)[:2]


def compressed(r):
    r.UpdatePropertyInformation()
    return r.GetPropertyValue("Compressed")


def series_mode(r):
    r.UpdatePropertyInformation()
    return r.GetPropertyValue("SeriesMode")


# --- What the file dialog relies on --------------------------------------------------------------
proto = sm.ProxyManager().GetPrototypeProxy("sources", "CSGVInputReader")
pname = sm.vtkSMCoreUtilities.GetFileNameProperty(proto)
t.check(pname == "FileNames", "the file dialog and OpenDataFile set FileNames (got %r)" % pname)
prop = proto.GetProperty(pname) if pname else None
t.check(prop is not None and prop.GetRepeatCommand() == 1,
        "FileNames repeats, so pqObjectBuilder::createReader hands it the whole group")
factory = sm.vtkSMProxyManager.GetProxyManager().GetReaderFactory()
readers = factory.GetReaders(good[0], sm.ActiveConnection.Session)
names = [readers.GetString(i) for i in range(readers.GetLength())]
t.check("CSGVInputReader" in names, "the reader factory offers Segmentation (CSGV) for a slice (%s)" % names)

# --- The series as the dialog hands it: one volume, with progress, cached ----------------------------
r = OpenDataFile(good)
t.check(r.GetXMLName() == "CSGVInputReader", "OpenDataFile picks Segmentation (CSGV) (%s)" % r.GetXMLName())
t.check(list(r.FileNames) == good and r.FileName == "", "OpenDataFile set FileNames to the %d files" % N)
p = Progress(r)
dims, labels = labels_of(r)
p.close()
t.check(dims == (W, H, N), "a series of %d slices of %dx%d is %dx%dx%d (got %s)" % (N, W, H, W, H, N, dims))
t.check(labels is not None and np.array_equal(labels, stack.ravel().astype(np.uint64)),
        "every voxel equals its slice's pixel, slice i at z = i")
t.check(series_mode(r) == 2 and len(r.TimestepValues) == 0, "an image stack, no time steps")
cache = os.path.join(tmp, "good", "slice_0000-0011.csgv")
r.UpdatePropertyInformation()
t.check(r.GetPropertyValue("CachedFileName") == cache and os.path.isfile(cache),
        "cached as %s (got %s)" % (cache, r.GetPropertyValue("CachedFileName")))
t.check(compressed(r) == 1, "the first open compressed the stack")
t.check(len(p.values) >= 3 and any(0.0 < v < 0.9 for v in p.values) and p.values[-1] == 1.0 and
        all(a <= b for a, b in zip(p.values, p.values[1:])),
        "progress rises from compression to 1 (%s)" % [round(v, 3) for v in p.values[:8]])
stamp = open(cache + ".stamp").read()
t.check(all(('"%s"' % f) in stamp for f in good), "the stamp lists every slice")
Delete(r)

r = OpenDataFile(good)
dims, labels = labels_of(r)
t.check(compressed(r) == 0 and np.array_equal(labels, stack.ravel().astype(np.uint64)),
        "opening the series again reuses the cache")
Delete(r)

# A changed slice is seen.
stack2 = stack.copy()
stack2[5] = stack2[5] + 1000
np.save(os.path.join(tmp, "stack.npy"), stack2)
subprocess.run(["/usr/bin/python3", "-c", "import sys, numpy as np, tifffile\n"
                "tifffile.imwrite(sys.argv[2], np.load(sys.argv[1])[5])",
                os.path.join(tmp, "stack.npy"), good[5]], check=True)
st = os.stat(good[5])
os.utime(good[5], ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))
r = OpenDataFile(good)
dims, labels = labels_of(r)
t.check(compressed(r) == 1 and np.array_equal(labels, stack2.ravel().astype(np.uint64)),
        "a rewritten slice compresses the stack again")
Delete(r)

# Scripts: FileNames in another order is another volume, in that order.
r = SegmentationCSGV(FileNames=good[::-1])
dims, labels = labels_of(r)
t.check(dims == (W, H, N) and np.array_equal(labels, stack2[::-1].ravel().astype(np.uint64)),
        "FileNames in reverse order: z follows the list")
Delete(r)

# --- A slice of another size: a clear error naming it, no volume -------------------------------
with t.ErrorLog() as errors:
    r = OpenDataFile(bad)
    dims, labels = labels_of(r)
expected = "slice %s (z 7) is 22 x 17 uint32 but the first page is 23 x 17 uint32" % bad[7]
t.check(expected in errors.text, "the slice of another size is named: %s" % errors.text.strip()[:400])
t.check("ReadAsImageStack" in errors.text, "the error says how to read the files as time steps instead")
t.check(labels is None or labels.size == 0, "no volume from a mismatched series")
Delete(r)

# --- A series of 3D files: a time series, file i at time i -----------------------------------------
r = OpenDataFile(three_d)
t.check(series_mode(r) == 3 and list(r.TimestepValues) == [0.0, 1.0, 2.0],
        "3D files are time steps 0, 1, 2 (%s)" % list(r.TimestepValues))
for step in (1, 2, 0):
    dims, labels = labels_of(r, float(step))
    t.check(dims == (W, H, 4) and labels is not None and
            np.array_equal(labels, vols[step].ravel().astype(np.uint64)),
            "time %d shows %s (%s)" % (step, os.path.basename(three_d[step]), dims))
t.check(os.path.isfile(three_d[1] + ".csgv"), "each time step has its own cache")
Delete(r)

# A later step larger than the first is shown whole (found by an attack pass on .csgv series:
# consumers kept the first step's extent and cropped later ones to it).
grow = [os.path.join(tmp, "grow", "g_t%d.tif" % i) for i in range(2)]
r = SegmentationCSGV(FileNames=grow)
gview = t.render_view(64, 64)
gshow = Show(r, gview)
gshow.SetRepresentationType("Segmentation Volume")
for time, dims in ((0.0, (12, 10, 3)), (1.0, (W, H, 4)), (0.0, (12, 10, 3)), (1.0, (W, H, 4))):
    gview.ViewTime = time
    Render(gview)
    bounds = gshow.GetRepresentedDataInformation().GetBounds()
    t.check(tuple(int(round(bounds[2 * a + 1] - bounds[2 * a])) for a in range(3)) == dims,
            "a larger later step, time %d: the volume's bounds %s are the step's %s" % (time, bounds, dims))
Delete(gview)
Delete(r)

# A first file that cannot be read does not hide the series: the next file that can decides.
broken = os.path.join(tmp, "vols", "broken_t0.tif")
with open(broken, "wb") as f:
    f.write(b"II*\0 not a tiff")
r = SegmentationCSGV(FileNames=[broken] + three_d[1:])
t.check(series_mode(r) == 3 and list(r.TimestepValues) == [0.0, 1.0, 2.0],
        "a broken first file: still a time series of 3 steps (%s)" % list(r.TimestepValues))
dims, labels = labels_of(r, 2.0)
t.check(labels is not None and np.array_equal(labels, vols[2].ravel().astype(np.uint64)), "time 2 still shows its file")
with t.ErrorLog() as errors:
    dims, labels = labels_of(r, 0.0)
t.check("broken_t0.tif" in errors.text and (labels is None or labels.size == 0),
        "time 0 names the broken file (%s)" % errors.text.strip()[:200])
Delete(r)

# 2D slices with ReadAsImageStack off: one slice per time step, as ParaView's TIFF Series Reader.
r = SegmentationCSGV(FileNames=good, ReadAsImageStack=0)
dims, labels = labels_of(r, 3.0)
t.check(series_mode(r) == 3 and len(r.TimestepValues) == N and dims == (W, H, 1) and
        np.array_equal(labels, stack2[3].ravel().astype(np.uint64)),
        "ReadAsImageStack off: time 3 is slice 3")
Delete(r)

# --- FileName: scripts and old state files ------------------------------------------------------
r = SegmentationCSGV(FileName=good[2])
dims, labels = labels_of(r)
t.check(dims == (W, H, 1) and np.array_equal(labels, stack2[2].ravel().astype(np.uint64)),
        "FileName alone opens one file as before")
with t.ErrorLog() as errors:
    r.FileNames = good
    dims, labels = labels_of(r)
t.check("set only one of them" in errors.text and (labels is None or labels.size == 0),
        "FileName and FileNames both set: an error, not one of them silently (%s)" % errors.text.strip()[:200])
Delete(r)

old = SegmentationCSGV(registrationName="old_reader", FileName=good[4])
state = os.path.join(tmp, "old.pvsm")
SaveState(state)
Delete(old)
text = open(state).read()
# The state a plugin without FileNames wrote: the reader's proxy with FileName only.
proxy = re.search(r'<Proxy group="sources" type="CSGVInputReader".*?</Proxy>', text, flags=re.S)
t.check(proxy is not None, "state: the reader's proxy")
old_proxy = proxy.group(0) if proxy else ""
for name in ("FileNames", "ReadAsImageStack", "TimestepValues", "SeriesMode"):
    old_proxy, n = re.subn(r'\s*<Property name="%s" id="[^"]*"[^>]*?(/>|>.*?</Property>)' % name, "", old_proxy,
                           flags=re.S)
    t.check(n <= 1 and (n == 1 or name in ("TimestepValues", "SeriesMode")), "state: removed %s" % name)
t.check('name="FileName"' in old_proxy, "state: FileName stays")
open(state, "w").write(text.replace(proxy.group(0), old_proxy) if proxy else text)
LoadState(state)
r = FindSource("old_reader")
dims, labels = labels_of(r) if r else (None, None)
t.check(r is not None and dims == (W, H, 1) and np.array_equal(labels, stack2[4].ravel().astype(np.uint64)),
        "a state file with FileName only still loads")

t.finish()
