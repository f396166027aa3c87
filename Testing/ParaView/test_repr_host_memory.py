# SPDX-License-Identifier: MIT
"""Host memory in ParaView (issue 40). The reader maps a .csgv (no private copy of the encoding).
CSGVHostMemoryMiB: a budget the encoding exceeds keeps the coarse levels in memory and reads the
finest level from the file (CSGVLevelsOnDisk 1), a budget the coarse levels exceed reads every
level from the file (2); either draws the image of the whole encoding, by host and by GPU decoding,
and the automatic budget holds it whole again. A file with corrupt bricks in view draws the rest,
counts them (CSGVBadBricks) and warns once, naming a brick; one whose bricks have wrong header
words opens (the open reads no brick) and does the same."""
import os
import struct
import subprocess

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
path = os.path.join(t.temp_dir(), "synth384.csgv")
subprocess.run([os.environ["CSGV_TOOL"], "compress", "synth:384x384x384", path], check=True, stdout=subprocess.DEVNULL)
file_mib = os.path.getsize(path) / 2**20


def mapped_in_this_process(p):
    with open("/proc/self/maps") as f:
        return any(line.rstrip().endswith(p) for line in f)


def differs(a, b):
    return np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 2


def show(p):
    src = OpenDataFile(p)
    view = t.render_view(160, 120)
    disp = Show(src, view)
    disp.CSGVFramesPerStillRender = 1
    disp.CSGVStillRenderTimeBudget = 60
    disp.CSGVLODBias = -3  # the finest level for the bricks in view: what is read from the file
    view.ResetCamera()
    return src, view, disp


def info(disp, name):
    disp.SMProxy.UpdatePropertyInformation()
    return disp.SMProxy.GetProperty(name).GetElement(0)


s, v, d = show(path)
whole = t.screenshot(v, 160, 120, "whole.png")
t.check(t.content_mask(whole).mean() > 0.1, "the %.1f MiB encoding draws" % file_mib)
t.check(mapped_in_this_process(path), "the reader maps the file instead of reading a copy")
t.check(info(d, "CSGVLevelsOnDisk") == 0, "the automatic budget holds it whole")

for decoding, name in ((2, "host"), (1, "GPU")):
    d.CSGVDecoding = decoding
    ref = t.screenshot(v, 160, 120, "ref_%s.png" % name)
    t.check(differs(ref, whole).mean() == 0, "%s decoding: the same image as automatic decoding" % name)
    for budget, levels in ((2, 1), (1, 2)):
        d.CSGVHostMemoryMiB = budget
        got = t.screenshot(v, 160, 120, "budget%d_%s.png" % (budget, name))
        on_disk, read = info(d, "CSGVLevelsOnDisk"), info(d, "CSGVFileReadMiB")
        t.check(on_disk == levels, "%s decoding, %d MiB of a %.1f MiB encoding: levels on disk %d (want %d)"
                % (name, budget, file_mib, on_disk, levels))
        t.check(read > 0, "%s decoding, %d MiB: %.2f MiB read from the file on demand" % (name, budget, read))
        t.check(differs(got, whole).mean() == 0, "%s decoding, %d MiB: the same image (%.2f%% of pixels differ)"
                % (name, budget, 100 * differs(got, whole).mean()))
    d.CSGVHostMemoryMiB = 0
    again = t.screenshot(v, 160, 120, "again_%s.png" % name)
    t.check(info(d, "CSGVLevelsOnDisk") == 0 and differs(again, whole).mean() == 0,
            "%s decoding: the automatic budget holds it whole again, the same image" % name)
# Two views of one volume with budgets of their own: the same image.
d.CSGVDecoding = 0
d.CSGVHostMemoryMiB = 1
vb = t.render_view(160, 120)
db = Show(s, vb)
db.CSGVFramesPerStillRender = 1
db.CSGVStillRenderTimeBudget = 60
db.CSGVLODBias = -3
db.CSGVHostMemoryMiB = 2
vb.CameraPosition, vb.CameraFocalPoint, vb.CameraViewUp = v.CameraPosition, v.CameraFocalPoint, v.CameraViewUp
for rnd in range(2):
    one = t.screenshot(v, 160, 120, "two_views_a%d.png" % rnd)
    two = t.screenshot(vb, 160, 120, "two_views_b%d.png" % rnd)
# Views of one volume share its upload of a kind, as with device budgets: the second draws from
# the first's tiers while the first draws from them.
t.check(info(d, "CSGVLevelsOnDisk") == info(db, "CSGVLevelsOnDisk") == 2 and differs(one, whole).mean() == 0
        and differs(two, whole).mean() == 0, "two views, 1 and 2 MiB: one upload (levels on disk %d and %d), the same image"
        % (info(d, "CSGVLevelsOnDisk"), info(db, "CSGVLevelsOnDisk")))
Delete(db)
d.CSGVHostMemoryMiB = 0

# A script that writes into the encoding array (the reader's mapping of the file) changes this
# process's copy, never the file, and does not crash the session.
before = open(path, "rb").read()
enc = s.GetClientSideObject().GetOutputDataObject(0).GetFieldData().GetAbstractArray("CSGVEncoding")
enc.SetValue(enc.GetNumberOfValues() // 2, (enc.GetValue(enc.GetNumberOfValues() // 2) + 1) % 256)
t.check(open(path, "rb").read() == before, "a write into the mapped encoding array leaves the file unchanged")
Delete(s)

# Corrupt bricks in view (the top layer the default camera looks at, the deepest in the file):
# their finest streams overwritten. The rest draws; they are counted and named once.
bad = os.path.join(t.temp_dir(), "corrupt384.csgv")
b = bytearray(open(path, "rb").read())
off = 41 + 128 + 4
n = struct.unpack_from("<Q", b, off)[0]
off += 8
starts = struct.unpack_from("<%dI" % n, b, off)
base = off + 4 * n + 16
L = 6
for brick in [x + 12 * (y + 12 * 11) for x in range(3, 9) for y in range(3, 9)]:
    s0, e0 = starts[brick], starts[brick + 1]
    begin = struct.unpack_from("<I", b, base + 4 * (s0 + L - 1))[0] // 8
    pal = struct.unpack_from("<I", b, base + 4 * (s0 + L))[0]
    for w in range(s0 + begin, e0 - pal):
        struct.pack_into("<I", b, base + 4 * w, 0xFFFFFFFF)
open(bad, "wb").write(bytes(b))
for budget in (0, 1):
    s2, v2, d2 = show(bad)
    d2.CSGVHostMemoryMiB = budget
    with t.ErrorLog() as log:
        img = t.screenshot(v2, 160, 120, "corrupt%d.png" % budget)
        t.screenshot(v2, 160, 120, "corrupt%d_again.png" % budget)
    count = info(d2, "CSGVBadBricks")
    t.check(count > 0, "budget %d: %d bricks that fail to decode are counted" % (budget, count))
    t.check(log.text.count("failed to decode and are drawn empty") == 1 and "brick " in log.text,
            "budget %d: the representation warns once, naming a brick: %r" % (budget, log.text[-300:]))
    t.check(log.text.count("the Labels array is not loaded") <= 1,
            "budget %d: the reader's decode error is reported once at most" % budget)
    same = 1 - differs(img, whole).mean()
    t.check(0.8 < same < 1, "budget %d: the rest draws as before (%.1f%% of pixels the same)" % (budget, 100 * same))
    Delete(s2)

# Bricks whose header words are wrong (their palette sizes past the file's largest palette): the
# file opens without reading a brick (the open checks the header and brick starts), the bricks are
# named when the volume is uploaded, counted exactly, drawn empty, and the rest draws.
bad = os.path.join(t.temp_dir(), "badheaders384.csgv")
b = bytearray(open(path, "rb").read())
wrong = [x + 12 * (y + 12 * 11) for x in range(4, 8) for y in range(4, 8)]
for brick in wrong:
    struct.pack_into("<I", b, base + 4 * (starts[brick] + L), 0x7FFFFFFF)
open(bad, "wb").write(bytes(b))
for budget in (0, 1):
    with t.ErrorLog() as log:
        s2, v2, d2 = show(bad)
        s2.UpdatePipeline()
    fd = s2.GetClientSideObject().GetOutputDataObject(0).GetFieldData()
    named = ("brick %d: palette size" % wrong[0]) in log.text
    # It opens: the encoding is on the output; the one error, if any, is the reader's label
    # decode (under its DecodeThreshold) naming the first bad brick.
    t.check(fd.GetAbstractArray("CSGVEncoding") is not None and log.text.count("ERR") <= 1
            and ("ERR" not in log.text or named),
            "budget %d: a file with bad brick headers opens: %r" % (budget, log.text[-300:]))
    d2.CSGVHostMemoryMiB = budget
    with t.ErrorLog() as log:
        img = t.screenshot(v2, 160, 120, "badheaders%d.png" % budget)
        t.screenshot(v2, 160, 120, "badheaders%d_again.png" % budget)
    count = info(d2, "CSGVBadBricks")
    t.check(count == len(wrong), "budget %d: %d of the %d bricks with wrong headers counted" % (budget, count, len(wrong)))
    t.check(log.text.count("drawn empty") == 1 and ("brick %d: palette size" % wrong[0]) in log.text,
            "budget %d: the representation warns once, naming the first: %r" % (budget, log.text[-300:]))
    same = 1 - differs(img, whole).mean()
    t.check(0.8 < same < 1, "budget %d: the rest draws as before (%.1f%% of pixels the same)" % (budget, 100 * same))
    Delete(s2)

# A file cut short while it is open (mapped): the session survives, and says why.
for budget in (0, 1):
    cut = os.path.join(t.temp_dir(), "cut%d.csgv" % budget)
    with open(path, "rb") as f, open(cut, "wb") as g:
        g.write(f.read())
    s3, v3, d3 = show(cut)
    d3.CSGVHostMemoryMiB = budget
    d3.CSGVLODBias = 2  # coarse levels first: the finest are decoded after the cut
    t.screenshot(v3, 160, 120, "cut%d_before.png" % budget)
    os.truncate(cut, os.path.getsize(cut) // 3)
    with t.ErrorLog() as log:
        d3.CSGVLODBias = -3
        after = t.screenshot(v3, 160, 120, "cut%d_after.png" % budget)
    said = "changed on disk" in log.text or "truncated" in log.text or "changed while it was read" in log.text
    t.check(said, "budget %d: a file cut short while open is named, no crash: %r" % (budget, log.text[-300:]))
    Delete(s3)

# A file written over in place while it is open (the same inode, another volume's bytes): the
# renderer and CSGV Extract Labels say the file changed on disk (an attack pass saw "level 0 start
# is 3465706103" and Extract Labels' advice to apply it to the reader's output, which it was).
over = os.path.join(t.temp_dir(), "over.csgv")
with open(path, "rb") as f, open(over, "wb") as g:
    g.write(f.read())
s4, v4, d4 = show(over)
d4.CSGVLODBias = 2  # coarse levels first: the finest are decoded after the file is written over
t.screenshot(v4, 160, 120, "over_before.png")
with open(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"), "rb") as f:
    other = f.read()
with open(over, "r+b") as g:
    g.write(other)
    g.truncate(len(other))
with t.ErrorLog() as log:
    d4.CSGVLODBias = -3
    t.screenshot(v4, 160, 120, "over_after.png")
    ex = CSGVExtractLabels(Input=s4, Labels="1")
    ex.UpdatePipeline()
t.check(log.text.count("changed on disk") >= 2 and "reader's output" not in log.text,
        "a file written over while open is named by the renderer and Extract Labels: %r" % log.text[-400:])
Delete(ex)
Delete(s4)
t.finish()
