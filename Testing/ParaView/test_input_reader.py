# SPDX-License-Identifier: MIT
"""The "Segmentation (CSGV)" reader (vtkCSGVInputReader) on NRRD inputs: it compresses once to a
cached .csgv with progress, shows the result like a .csgv (labels, geometry, Segmentation Volume),
reuses the cache while the input is unchanged, compresses again when the input or the encoding
options change, falls back to the cache folder beside a read-only input, reports bad inputs and
cancellation cleanly, and the session goes on."""
import os
import shutil
import time

import numpy as np

import csgv_pvtest as t
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as SDDP
from paraview import servermanager as sm
from paraview.simple import *

t.load_plugin(globals())
tmp = t.temp_dir()
os.chmod(tmp, 0o755)  # the read-only case below reads it as another user
xdg = os.path.join(tmp, "xdg")
os.makedirs(xdg)
os.chmod(xdg, 0o777)
os.environ["XDG_CACHE_HOME"] = xdg


def make_volume(seed, shape=(11, 17, 23)):
    """Blobs of labels (0 background), shaped (D, H, W) so that it ravels x fastest."""
    rng = np.random.default_rng(seed)
    d, h, w = shape
    z, y, x = np.meshgrid(np.arange(d), np.arange(h), np.arange(w), indexing="ij")
    vol = ((x // 5) + 7 * (y // 6) + 31 * (z // 4) + 1).astype(np.uint16)
    vol[rng.random(shape) < 0.1] = 0
    vol[0, 0, 0] = 0
    vol[-1, -1, -1] = 900 + seed
    return vol


def write_nrrd(path, vol, spacing=(0.5, 1.0, 2.0), origin=(10.0, 20.0, 30.0)):
    d, h, w = vol.shape
    header = ("NRRD0004\ntype: uint16\ndimension: 3\nsizes: %d %d %d\nspace dimension: 3\n"
              "space directions: (%g,0,0) (0,%g,0) (0,0,%g)\nspace origin: (%g,%g,%g)\n"
              "endian: little\nencoding: raw\n\n") % ((w, h, d) + tuple(spacing) + tuple(origin))
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(vol.astype("<u2").tobytes())


class Progress:
    """Records the reader's progress events (a ProgressEvent observer on the server-side object
    of this builtin session); optionally aborts at the first one."""

    def __init__(self, proxy, abort=False):
        self.values = []
        self.algo = proxy.GetClientSideObject()
        self.abort = abort  # False, True (at once) or "during" (once Core reports progress)
        self.tag = self.algo.AddObserver("ProgressEvent", self.on_progress)

    def on_progress(self, obj, event):
        p = obj.GetProgress()
        self.values.append(p)
        if self.abort is True or (self.abort == "during" and 0.0 < p < 0.9):
            obj.SetAbortExecute(1)
            self.abort = False  # a user cancels once

    def close(self):
        self.algo.RemoveObserver(self.tag)


def open_input(path, abort=False, **props):
    """A new reader on `path`, updated; returns (reader, image, progress values, compressed?)."""
    r = SegmentationCSGV(FileName=path, **props)
    p = Progress(r, abort)
    img = t.fetch(r)
    p.close()
    return r, img, p.values, compressed_flag(r)


def compressed_flag(r):
    r.UpdatePropertyInformation()
    return r.GetPropertyValue("Compressed")


def cached_name(r):
    r.UpdatePropertyInformation()
    return r.GetPropertyValue("CachedFileName")


def mtime_ns(path):
    return os.stat(path).st_mtime_ns


def check_labels(img, vol, tag):
    d, h, w = vol.shape
    t.check(img.GetDimensions() == (w + 1, h + 1, d + 1), tag + ": dims + 1 points (cell data)")
    labels = t.cell_labels(img)
    t.check(labels is not None and np.array_equal(labels, vol.ravel()), tag + ": every label equal")
    t.check(img.GetFieldData().GetArray("CSGVEncoding") is not None, tag + ": encoding in FieldData")
    rng = img.GetFieldData().GetArray("CSGVLabelRange")
    t.check(rng is not None and tuple(rng.GetTuple1(i) for i in range(2)) == (int(vol.min()), int(vol.max())),
            tag + ": label range %s" % ((int(vol.min()), int(vol.max())),))


src = os.path.join(tmp, "src")
os.makedirs(src)
nrrd = os.path.join(src, "vol.nrrd")
vol = make_volume(1)
write_nrrd(nrrd, vol)
beside = nrrd + ".csgv"

# --- First open: compressed beside the input, with progress, shown as a .csgv is ---------------
r, img, progress, compressed = open_input(nrrd)
t.check(compressed == 1, "first open compresses")
t.check(cached_name(r) == beside, "cache beside a writable input: %s" % cached_name(r))
t.check(os.path.isfile(beside) and os.path.isfile(beside + ".stamp") and os.path.isfile(beside + ".json"),
        "the .csgv, its stamp and its metadata exist")
check_labels(img, vol, "NRRD")
t.check(np.allclose(img.GetSpacing(), (0.5, 1.0, 2.0)), "spacing from the NRRD: %s" % (img.GetSpacing(),))
t.check(np.allclose(img.GetOrigin(), (9.75, 19.5, 29.0)), "origin = corner of voxel 0: %s" % (img.GetOrigin(),))
t.check(len(progress) >= 2 and progress[-1] == 1.0 and all(b >= a for a, b in zip(progress, progress[1:])),
        "progress events rise to 1 (%d events)" % len(progress))
t.check(any(0.0 < p < 1.0 for p in progress), "progress between 0 and 1 reported")

# A label that does not fit in the last slice restarts the optimistic pass with relabelling:
# the progress bar still only rises (the restarted passes share what was left), up to 1.
restart = os.path.join(src, "restart.nrrd")
wide = vol.astype(np.int32)
wide[-1, -1, -1] = -5
with open(restart, "wb") as f:
    d, h, w = wide.shape
    f.write(("NRRD0004\ntype: int32\ndimension: 3\nsizes: %d %d %d\nendian: little\nencoding: raw\n\n"
             % (w, h, d)).encode())
    f.write(wide.astype("<i4").tobytes())
rr, rimg, rprogress, rcompressed = open_input(restart)
t.check(rcompressed == 1 and rimg.GetNumberOfCells() == wide.size, "a restarted compression gives the volume")
t.check(len(rprogress) >= 2 and rprogress[-1] == 1.0 and all(b >= a for a, b in zip(rprogress, rprogress[1:])),
        "progress rises to 1 across the restart (%d events)" % len(rprogress))
Delete(rr)

# Output identical to the .csgv reader on the cached file.
ref = CSGVReader(FileName=beside)
ref_img = t.fetch(ref)
t.check(np.array_equal(t.cell_labels(ref_img), t.cell_labels(img)) and ref_img.GetExtent() == img.GetExtent()
        and np.allclose(ref_img.GetOrigin(), img.GetOrigin()), "same output as CSGVReader on the cache")
Delete(ref)

# The reader's default representation is the Segmentation Volume (when the plugin has it).
view = t.render_view(96, 96)
display = Show(r, view)
reprs = display.GetProperty("Representation").SMProperty.GetDomain("list")
names = [reprs.GetString(i) for i in range(reprs.GetNumberOfStrings())] if reprs else []
if "Segmentation Volume" in names:
    t.check(display.Representation == "Segmentation Volume", "shown as Segmentation Volume: %s" % display.Representation)
else:
    t.log("skip representation check: this build has no Segmentation Volume representation")
Delete(display)
Delete(view)
Delete(r)
stamp_text = open(beside + ".stamp").read()
t.check('"input": "%s"' % nrrd in stamp_text, "the stamp names the input")
csgv_mtime = mtime_ns(beside)

# --- Second open: the cache is reused ------------------------------------------------------------
time.sleep(0.05)
r, img, progress, compressed = open_input(nrrd)
t.check(compressed == 0, "second open reuses the cache")
t.check(mtime_ns(beside) == csgv_mtime and open(beside + ".stamp").read() == stamp_text,
        "the .csgv and its stamp are untouched")
check_labels(img, vol, "cached")
t.check(len(progress) >= 1 and progress[-1] == 1.0, "progress reaches 1 when reading the cache")
# Reading the cache is the whole bar, not its last tenth (the GUI sat at 98% while it decoded).
t.check(any(0.0 < p < 0.9 for p in progress),
        "reading the cache reports progress below 90%% (%s)" % ", ".join("%.2f" % p for p in progress[:8]))
Delete(r)

# OpenDataFile's factory offers the reader for .nrrd.
factory = sm.vtkSMProxyManager.GetProxyManager().GetReaderFactory()
readers = factory.GetReaders(nrrd, sm.ActiveConnection.Session)
names = [readers.GetString(i) for i in range(readers.GetLength())]
t.check("CSGVInputReader" in names, "the reader factory offers Segmentation (CSGV) for .nrrd")

# --- Touching the input, then changing it: compressed again ------------------------------------
st = os.stat(nrrd)
os.utime(nrrd, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))
r, img, _, compressed = open_input(nrrd)
t.check(compressed == 1, "a touched input is compressed again")
check_labels(img, vol, "touched")
Delete(r)
vol2 = make_volume(2)
write_nrrd(nrrd, vol2)
st = os.stat(nrrd)
os.utime(nrrd, ns=(st.st_atime_ns, st.st_mtime_ns + 4_000_000_000))
r, img, _, compressed = open_input(nrrd)
t.check(compressed == 1 and mtime_ns(beside) != csgv_mtime, "a modified input is compressed again")
check_labels(img, vol2, "modified")
Delete(r)

# --- Files the input names: their changes make the cache stale too --------------------------------
# A detached NRRD header and its data file: the header stays as it is, the data change.
nhdr = os.path.join(src, "detached.nhdr")
raw = os.path.join(src, "detached.raw")
d, h, w = vol.shape
with open(nhdr, "w") as f:
    f.write("NRRD0004\ntype: uint32\ndimension: 3\nsizes: %d %d %d\nendian: little\nencoding: raw\n"
            "data file: detached.raw\n" % (w, h, d))
vol.astype("<u4").tofile(raw)
r, img, _, compressed = open_input(nhdr)
t.check(compressed == 1, "a detached NRRD is compressed")
t.check('named: ' in open(nhdr + ".csgv.stamp").read() and raw in open(nhdr + ".csgv.stamp").read(),
        "its stamp lists the data file")
Delete(r)
r, img, _, compressed = open_input(nhdr)
t.check(compressed == 0, "unchanged, the detached NRRD's cache is reused")
Delete(r)
# A stamp whose named lines are gone (written before inputs named files, or cut) never matches.
stamp_path = nhdr + ".csgv.stamp"
stamp_text = open(stamp_path).read()
with open(stamp_path, "w") as f:
    f.write("".join(l for l in stamp_text.splitlines(True) if not l.startswith("named")))
r, img, _, compressed = open_input(nhdr)
t.check(compressed == 1, "a stamp without its named lines: compressed again")
Delete(r)
vol2.astype("<u4").tofile(raw)
st = os.stat(raw)
os.utime(raw, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))
r, img, _, compressed = open_input(nhdr)
t.check(compressed == 1, "a changed data file is compressed again (the header is unchanged)")
check_labels(img, vol2, "new data file")
Delete(r)

# A data file whose name is not UTF-8 (names are bytes): the stamp keeps its exact name, so the
# cache is reused (a JSON name turned the byte into U+FFFD, a file that does not exist).
latin = os.path.join(src, "latin.nhdr")
with open(latin, "wb") as f:
    f.write(b"NRRD0004\ntype: uint32\ndimension: 3\nsizes: %d %d %d\nendian: little\nencoding: raw\n"
            b"data file: donn\xe9es.raw\n" % (w, h, d))
with open(os.path.join(os.fsencode(src), b"donn\xe9es.raw"), "wb") as f:
    f.write(vol.astype("<u4").tobytes())
r, img, _, compressed = open_input(latin)
t.check(compressed == 1, "a data file named in Latin-1 is compressed")
Delete(r)
r, img, _, compressed = open_input(latin)
t.check(compressed == 0, "and its cache is reused")
check_labels(img, vol, "Latin-1 data file")
Delete(r)

# An HDF5 file whose dataset is an external link to another file beside it.
try:
    import h5py
except ImportError:
    h5py = None
if h5py is None:
    t.log("skip HDF5 external link case: no h5py")
else:
    target, linking = os.path.join(src, "target.h5"), os.path.join(src, "linking.h5")
    with h5py.File(target, "w") as f:
        f["labels"] = vol.astype(np.uint32)
    with h5py.File(linking, "w") as f:
        f["d"] = h5py.ExternalLink("target.h5", "/labels")
    r, img, _, compressed = open_input(linking + ":/d")
    t.check(compressed == 1, "an HDF5 external link is compressed")
    check_labels(img, vol, "HDF5 external link")
    Delete(r)
    with h5py.File(target, "w") as f:
        f["labels"] = vol2.astype(np.uint32)
    st = os.stat(target)
    os.utime(target, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))
    r, img, _, compressed = open_input(linking + ":/d")
    t.check(compressed == 1, "a changed link target is compressed again (the linking file is unchanged)")
    check_labels(img, vol2, "new link target")
    Delete(r)

    # A link to a file outside the input's folder: refused in ParaView's words; read when the
    # reader allows it; and refused again when it no longer does (not read from the cache made
    # while it did).
    away = os.path.join(tmp, "away")
    os.makedirs(away)
    with h5py.File(os.path.join(away, "far.h5"), "w") as f:
        f["labels"] = vol.astype(np.uint32)
    outlinked = os.path.join(src, "outlinked.h5")
    with h5py.File(outlinked, "w") as f:
        f["d"] = h5py.ExternalLink(os.path.join(away, "far.h5"), "/labels")
    with t.ErrorLog() as errors:
        r, img, _, compressed = open_input(outlinked + ":/d")
    t.check(img.GetNumberOfCells() == 0 and "turn on the reader's Allow Outside Paths property" in errors.text
            and "--allow-outside-paths" not in errors.text,
            "a link outside the folder: refused, naming the property (%s)" % errors.text.strip()[:300])
    Delete(r)
    r, img, _, compressed = open_input(outlinked + ":/d", AllowOutsidePaths=1)
    t.check(compressed == 1, "allowed: compressed")
    check_labels(img, vol, "allowed outside link")
    Delete(r)
    with t.ErrorLog() as errors:
        r, img, _, compressed = open_input(outlinked + ":/d")
    t.check(img.GetNumberOfCells() == 0 and "Allow Outside Paths" in errors.text,
            "no longer allowed: refused again, not read from the cache made while allowed")
    Delete(r)
    # A time series whose later step lies outside: its extent, refused at first, is held once
    # outside paths are allowed (the series' header cache kept the refusal).
    small = os.path.join(src, "small.h5")
    with h5py.File(small, "w") as f:
        f["labels"] = np.ones((2, 3, 4), dtype=np.uint32)
    r = SegmentationCSGV(FileNames=[small, outlinked + ":/d"])
    with t.ErrorLog():
        r.UpdatePipelineInformation()
    whole = lambda: tuple(r.GetClientSideObject().GetOutputInformation(0).Get(SDDP.WHOLE_EXTENT()))
    t.check(whole() == (0, 4, 0, 3, 0, 2), "a series with a step outside: the first step's extent (%s)" % (whole(),))
    r.AllowOutsidePaths = 1
    r.UpdatePipelineInformation()
    d, h, w = vol.shape
    t.check(whole() == (0, max(w, 4), 0, max(h, 3), 0, max(d, 2)),
            "outside paths allowed: the series' extent holds the step outside (%s)" % (whole(),))
    Delete(r)

# --- Encoding options are part of the stamp -----------------------------------------------------
r, img, _, compressed = open_input(nrrd, BrickSize=16)
t.check(compressed == 1, "another brick size compresses again")
check_labels(img, vol2, "brick size 16")
Delete(r)
r, img, _, compressed = open_input(nrrd, BrickSize=16)
t.check(compressed == 0, "the same brick size reuses the cache")
Delete(r)
r, img, _, compressed = open_input(nrrd, BrickSize=16, Relabel=1)
t.check(compressed == 1, "Relabel compresses again")
check_labels(img, vol2, "relabelled")
Delete(r)

# --- A damaged cache: overwritten, it is compressed again at once; truncated, it is reported once
# and compressed again at the next open -----------------------------------------------------------
with open(beside, "wb") as f:
    f.write(b"not a csgv file")
with t.ErrorLog() as errors:
    r, img, _, compressed = open_input(nrrd, BrickSize=16, Relabel=1)
t.check(compressed == 1 and "ERR|" not in errors.text, "an overwritten cache is compressed again silently")
check_labels(img, vol2, "after an overwritten cache")
Delete(r)
# Another writer's .csgv (a whole, valid one) in place of ours: the stamp names the cache it was
# written for (inode, size, mtime), so it no longer vouches and the input is compressed again.
other = os.path.join(os.path.dirname(beside), "other-writer.csgv")
shutil.copyfile(beside, other)
os.replace(other, beside)
r, img, _, compressed = open_input(nrrd, BrickSize=16, Relabel=1)
t.check(compressed == 1, "another writer's .csgv under the cache's name is compressed again")
check_labels(img, vol2, "after another writer's cache")
Delete(r)
with open(beside, "rb") as f:
    whole = f.read()
with open(beside, "wb") as f:
    f.write(whole[: len(whole) // 2])
r, img, _, compressed = open_input(nrrd, BrickSize=16, Relabel=1)
t.check(compressed == 1, "a truncated cache (its size changed) is compressed again at once")
check_labels(img, vol2, "after a truncated cache")
Delete(r)
# Damage the stamp cannot see (the stamp rewritten to vouch for a truncated cache): reported once,
# the stamp dropped, compressed again at the next open.
with open(beside, "rb") as f:
    whole = f.read()
with open(beside, "wb") as f:
    f.write(whole[: len(whole) // 2])
cst = os.stat(beside)
stamp_lines = open(beside + ".stamp").read().splitlines(True)
t.check(stamp_lines[-1].startswith("cache: "), "the stamp ends with the cache's identity")
stamp_lines[-1] = "cache: %d %d %d\n" % (cst.st_ino, cst.st_size, cst.st_mtime_ns)
with open(beside + ".stamp", "w") as f:
    f.write("".join(stamp_lines))
with t.ErrorLog() as errors:
    r, img, _, compressed = open_input(nrrd, BrickSize=16, Relabel=1)
t.check(img.GetNumberOfCells() == 0 and "ERR|" in errors.text and not os.path.exists(beside + ".stamp"),
        "a truncated cache the stamp vouches for: error, empty output, stamp dropped")
Delete(r)
r, img, _, compressed = open_input(nrrd, BrickSize=16, Relabel=1)
t.check(compressed == 1, "a truncated cache is compressed again at the next open")
check_labels(img, vol2, "after a truncated cache")
Delete(r)

# --- Level of detail: what RequestInformation announces before compressing (from the input's
# header) is what the .csgv gives --------------------------------------------------------------
lod = os.path.join(src, "lod.nrrd")
write_nrrd(lod, make_volume(5))
r = SegmentationCSGV(FileName=lod, Level=1, BrickSize=8)
r.UpdatePipelineInformation()
img = t.fetch(r)
ref = CSGVReader(FileName=lod + ".csgv", Level=1)
ref.UpdatePipelineInformation()
ref_img = t.fetch(ref)
t.check(compressed_flag(r) == 1 and img.GetExtent() == ref_img.GetExtent() and
        np.allclose(img.GetSpacing(), ref_img.GetSpacing()) and np.allclose(img.GetOrigin(), ref_img.GetOrigin()),
        "Level 1 before compressing: extent %s spacing %s as the .csgv reader's" % (img.GetExtent(), img.GetSpacing()))
t.check(np.array_equal(t.cell_labels(img), t.cell_labels(ref_img)), "Level 1: the same labels")
wi_new = r.GetClientSideObject().GetOutputInformation(0).Get(SDDP.WHOLE_EXTENT())
wi_ref = ref.GetClientSideObject().GetOutputInformation(0).Get(SDDP.WHOLE_EXTENT())
t.check(tuple(wi_new) == tuple(wi_ref), "Level 1: the same whole extent (%s, %s)" % (wi_new, wi_ref))
Delete(ref)
Delete(r)

# --- An explicit CacheDirectory -----------------------------------------------------------------
explicit = os.path.join(tmp, "explicit")
r, img, _, compressed = open_input(nrrd, CacheDirectory=explicit)
name = cached_name(r)
t.check(compressed == 1 and os.path.dirname(name) == explicit and name.endswith(".csgv") and os.path.isfile(name),
        "CacheDirectory holds the cache: %s" % name)
check_labels(img, vol2, "explicit cache folder")
Delete(r)

# --- A read-only input folder: the cache goes to $XDG_CACHE_HOME/csgv-paraview ------------------
ro = os.path.join(tmp, "readonly")
os.makedirs(ro)
ro_nrrd = os.path.join(ro, "vol3.nrrd")
vol3 = make_volume(3)
write_nrrd(ro_nrrd, vol3)
os.chmod(ro_nrrd, 0o644)
os.chmod(ro, 0o555)
def unprivileged(fn):
    """Runs fn as an unprivileged user when this test runs as root (root writes anywhere)."""
    if os.geteuid() != 0:
        return fn()
    os.setegid(65534)
    os.seteuid(65534)
    try:
        return fn()
    finally:
        os.seteuid(0)
        os.setegid(0)


def open_readonly():
    r, img, _, compressed = open_input(ro_nrrd)
    name = cached_name(r)
    Delete(r)
    return img, compressed, name


img, compressed, name = unprivileged(open_readonly)
t.check(compressed == 1 and os.path.dirname(name) == os.path.join(xdg, "csgv-paraview") and os.path.isfile(name),
        "read-only input folder: cache in XDG_CACHE_HOME: %s" % name)
t.check(sorted(os.listdir(ro)) == ["vol3.nrrd"], "nothing written beside the read-only input")
check_labels(img, vol3, "read-only input")
img, compressed, name2 = unprivileged(open_readonly)
t.check(compressed == 0 and name2 == name, "the cache folder's copy is reused")

# --- Bad inputs: one error naming the file, an empty output, no cache left ---------------------
bad = os.path.join(src, "bad.nrrd")
with open(bad, "wb") as f:
    f.write(b"NRRD0004\ntype: uint16\ndimension: 3\nsizes: 10 10\nencoding: raw\n\n" + bytes(100))
with t.ErrorLog() as errors:
    r, img, _, _ = open_input(bad)
t.check(img.GetNumberOfCells() == 0 and "bad.nrrd" in errors.text, "malformed NRRD: error naming it, empty output")
t.check(errors.text.count("ERR|") == 1, "malformed NRRD: reported once (%d)" % errors.text.count("ERR|"))
t.log("   error: " + errors.text.strip()[:300])
t.check(not os.path.exists(bad + ".csgv") and not os.path.exists(bad + ".csgv.stamp"), "no cache for a bad input")
Delete(r)

short = os.path.join(src, "short.nrrd")
with open(nrrd, "rb") as f:
    data = f.read()
with open(short, "wb") as f:
    f.write(data[: len(data) // 2])
with t.ErrorLog() as errors:
    r, img, _, _ = open_input(short)
t.check(img.GetNumberOfCells() == 0 and "short.nrrd" in errors.text, "truncated NRRD: error naming it, empty output")
t.check(errors.text.count("ERR|") == 1, "truncated NRRD: reported once (%d)" % errors.text.count("ERR|"))
t.check(not os.path.exists(short + ".csgv") and not os.path.exists(short + ".csgv.stamp"), "no cache for a truncated input")
Delete(r)

with t.ErrorLog() as errors:
    r, img, _, _ = open_input(os.path.join(src, "none.nrrd"))
t.check(img.GetNumberOfCells() == 0 and "none.nrrd" in errors.text, "missing input: error naming it")
Delete(r)

with open(os.path.join(src, "notes.txt"), "w") as f:
    f.write("not a volume\n")
with t.ErrorLog() as errors:
    r, img, _, _ = open_input(os.path.join(src, "notes.txt"))
t.check(img.GetNumberOfCells() == 0 and "notes.txt" in errors.text, "unsupported input: error naming it")
Delete(r)

# --- Cancelling (AbortExecute from a progress observer): nothing cached -------------------------
cancel = os.path.join(src, "abort.nrrd")
write_nrrd(cancel, vol)
with t.ErrorLog() as errors:
    r, img, _, compressed = open_input(cancel, abort=True)
t.check(img.GetNumberOfCells() == 0 and "cancelled" in errors.text, "cancelled: error and empty output")
t.check(errors.text.count("ERR|") == 1, "cancelled: reported once, not run again (%d)" % errors.text.count("ERR|"))
t.check(not os.path.exists(cancel + ".csgv.stamp") and not os.path.exists(cancel + ".csgv"),
        "cancelled: no .csgv and no stamp")
Delete(r)

# Cancelling while Core compresses (its progress callback returns false): the same outcome.
during = os.path.join(src, "during.nrrd")
write_nrrd(during, make_volume(4, shape=(40, 48, 56)))
with t.ErrorLog() as errors:
    r, img, progress, compressed = open_input(during, abort="during")
if any(0.0 < p < 0.9 for p in progress):
    t.check(img.GetNumberOfCells() == 0 and "cancel" in errors.text.replace(during, ""),
            "cancelled during compression: error and empty output")
    t.check(errors.text.count("ERR|") == 1, "cancelled during compression: reported once (%d)" % errors.text.count("ERR|"))
    t.check(not os.path.exists(during + ".csgv.stamp") and not os.path.exists(during + ".csgv")
            and not [n for n in os.listdir(src) if n.startswith("during.nrrd.csgv")],
            "cancelled during compression: no .csgv, no stamp, no temporary file")
else:
    t.log("skip cancelling during compression: Core reports no progress while compressing yet")
Delete(r)

# --- The session goes on -------------------------------------------------------------------------
r, img, _, compressed = open_input(cancel)
t.check(compressed == 1, "after errors, a valid input still compresses")
check_labels(img, vol, "after errors")
Delete(r)

t.finish()
