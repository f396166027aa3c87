# SPDX-License-Identifier: MIT
"""The query protocol of the Segmentation Volume (Representation/CSGVQueryProtocol.h), one check
per command: summary, pick X Y, labels, colors N, defaults, stats, and an unknown command. The
`defaults` reply is compared with the server-manager XML's defaults: each default lives in the
XML and is mirrored once in C++ (csgvrep::RepresentationProperties); this keeps them equal."""
import base64
import json
import os
import sys

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools as ct  # noqa: E402

W, H = 96, 72
INVALID = 0xFFFFFFFF
t.load_plugin(globals())
r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(W, H)
d = Show(r, v)
d.SetRepresentationType("Segmentation Volume")

# defaults: before any property is changed, the proxy holds the XML defaults.
defaults = json.loads(ct.query(d, "defaults"))
from paraview import servermanager as sm
for name, value in sorted(defaults.items()):
    helper = sm.vtkSMPropertyHelper(d.SMProxy, name)
    xml = [helper.GetAsDouble(i) for i in range(helper.GetNumberOfElements())]
    same = np.allclose(np.array(xml, dtype=float), np.array(value, dtype=float).ravel())
    t.check(same, "default of %s: XML %r, C++ %r" % (name, xml, value))
t.check(len(defaults) >= 11, "defaults lists every property (%d)" % len(defaults))
t.check(json.loads(ct.query(d, "stats")).get("compressions") == 0, "stats: a .csgv is never compressed again")

d.CSGVFramesPerStillRender = 1
v.ResetCamera()
t.screenshot(v, W, H)
# The read-only statistics, read now (csgv_tools.render_stats: paraview.simple has no attributes
# for information properties, and GetPropertyValue gives the last information update's value).
rs = ct.render_stats(d)
frames, fewest = t.repr_info(d)
t.check(len(rs) >= 11 and rs.get("CSGVMinSamples") == fewest >= 1 and rs.get("CSGVFramesLastRender") == frames
        and rs.get("CSGVCacheMiB", 0) > 0, "render_stats: every read-only statistic, current (%s)" % rs)
stats = json.loads(ct.query(d, "stats"))
# One copy of the encoding in this process (issue 40): the representation's parse views the
# bytes the reader read, it does not copy them.
t.check(stats.get("parses") == 1 and stats.get("sharedParses") == 1,
        "stats: the representation's parse shares the reader's bytes (%r)" % stats)

# summary
s = json.loads(ct.query(d, "summary"))
t.check(s.get("labelArray") == "Labels" and s.get("labels", 0) > 0 and "attributes" in s and s.get("empty") is False,
        "summary: label array, label count, attributes, not empty (%r)"
        % {k: s.get(k) for k in ("labelArray", "labels", "empty")})

# labels: "W H BASE64", decodable with Python's base64 into W*H uint32 values
w, h, data = ct.query(d, "labels").split(" ", 2)
raw = base64.b64decode(data, validate=True)
t.check((int(w), int(h)) == (W, H) and len(raw) == 4 * W * H, "labels: W H and W*H*4 bytes of base64")
img = np.frombuffer(raw, dtype="<u4").reshape(H, W)
t.check(np.any(img != INVALID) and np.any(img == INVALID), "labels: hits and misses")

# pick X Y: agrees with the label image
ys, xs = np.nonzero(img != INVALID)
x, y = int(xs[len(xs) // 2]), int(ys[len(ys) // 2])
p = json.loads(ct.query(d, "pick %d %d" % (x, y)))
t.check(p.get("hit") and p.get("label") == int(img[y, x]) and len(p.get("voxel", [])) == 3 and
        len(p.get("world", [])) == 3 and "attributes" in p, "pick: hit, label of the image, voxel, world")
p = json.loads(ct.query(d, "pick %d %d" % (W + 5, 0)))
t.check(p.get("hit") is False and "error" in p, "pick outside the image: no hit, an error")

# colors N
c = json.loads(ct.query(d, "colors 5"))
t.check(len(c.get("labels", [])) <= 5 and c.get("truncated") is True and
        all(len(e) == 5 for e in c["labels"]), "colors 5: at most 5 entries [label, r, g, b, name], truncated")
# Only the labels the volume shows: not those the visibility overlay hides, nor those of a fully
# transparent material, nor those outside "only".
shown = [e[0] for e in json.loads(ct.query(d, "colors 4096"))["labels"]]
a, b = shown[0], shown[1]
d.CSGVMaterials = json.dumps({"hidden": [a]})
t.check([e[0] for e in json.loads(ct.query(d, "colors 4096"))["labels"]] == shown[1:], "colors: hidden label %d left out" % a)
d.CSGVMaterials = json.dumps({"only": [a, b]})
t.check([e[0] for e in json.loads(ct.query(d, "colors 4096"))["labels"]] == [a, b], "colors: only %d and %d" % (a, b))
d.CSGVMaterials = json.dumps({"materials": [
    {"name": "clear", "filter": {"min": a, "max": a}, "opacity": 0}, {"name": "rest"}]})
t.check([e[0] for e in json.loads(ct.query(d, "colors 4096"))["labels"]] == shown[1:],
        "colors: a label of an opacity-0 material left out")
d.CSGVMaterials = ""

# span: the range of an attribute over the labels a filter holds; malformed requests (any client
# or script may send one) are an error answer, never the end of the session.
sp = json.loads(ct.query(d, 'span {"attribute": "label", "filter": "label", "min": %d, "max": %d}' % (a, b)))
t.check(sp.get("min") == min(a, b) and sp.get("max") == max(a, b) and sp.get("labels", 0) >= 1,
        "span: labels %d..%d span themselves (%s)" % (min(a, b), max(a, b), sp))
for bad in ('span', 'span {', 'span {"attribute": 5, "filter": "label", "min": 0, "max": 1}',
            'span {"attribute": "label", "filter": [1], "min": 0, "max": 1}',
            'span {"attribute": "label", "filter": "label", "min": "a", "max": 1}'):
    t.check("error" in json.loads(ct.query(d, bad)), "span: %r is an error answer" % bad[:60])

# stats: the encoding was parsed once; renders, camera moves and pipeline updates that keep the
# same encoding array parse nothing more, and nothing was compressed (the encoding is used as is).
before = json.loads(ct.query(d, "stats"))
cam = v.GetActiveCamera()
for i in range(4):
    d.CSGVLabelArray = "Labels" if i % 2 == 0 else ""
    cam.Azimuth(3.0)
    t.screenshot(v, W, H, "stats%d.png" % i)
after = json.loads(ct.query(d, "stats"))
t.check(after["parses"] == before["parses"] >= 1 and after["compressions"] == before["compressions"],
        "stats: no parse or compression on renders and updates of the same data (%r -> %r)" % (before, after))

# match: the labels whose attributes make an SQL condition true, against the CSGV Label Table's
# rows of the same file (its attribute database); conditions SQLite refuses, text results and
# empty conditions are error answers.
ra = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2_attr.csgv"))
da = Show(ra, v)
da.SetRepresentationType("Segmentation Volume")
Hide(r, v)
t.screenshot(v, W, H, "match.png")
tab = t.fetch(CSGVLabelTable(Input=ra))
col = lambda name: [tab.GetColumnByName(name).GetValue(i) for i in range(tab.GetNumberOfRows())]
want = sorted(int(l) for l, n, k in zip(col("label"), col("voxels"), col("kind")) if n > 5000 and k == 2)
got = ct.labels_matching(da, "voxels > 5000 and kind = 2")
t.check(len(want) > 0 and got == want, "match: the labels with voxels > 5000 and kind = 2 (%d, want %d)" % (len(got), len(want)))
for bad in ("voxels >", "no_such_column > 1", "'text'", "", "1; DROP TABLE t"):
    t.check("error" in json.loads(ct.query(da, "match " + bad)), "match: %r is an error answer" % bad)
t.check(json.loads(ct.query(da, "match 0")) == {"labels": [], "truncated": False}, "match: a false condition selects none")
# Label 0 is empty space: a condition it meets does not select it unless the materials draw it
# (GUI pass 11: "voxels > 10000" selected the background).
big = sorted(int(l) for l, n in zip(col("label"), col("voxels")) if n > 10000)
got = ct.labels_matching(da, "voxels > 10000")
t.check(0 in big and got == [l for l in big if l != 0],
        "match: label 0 (empty space) is not selected by a condition it meets (%r, rows %r)" % (got, big))
da.CSGVMaterials = '{"version": 1, "materials": [{"name": "all", "filter": {"min": 0, "max": 4294967294}}]}'
got = ct.labels_matching(da, "voxels > 10000")
t.check(got == big, "match: label 0 is selected where the materials draw it (%r)" % got)
da.CSGVMaterials = ""
Hide(ra, v)
Show(r, v)

# unknown
u = json.loads(ct.query(d, "frobnicate"))
t.check("unknown query" in u.get("error", ""), "unknown command: an error naming it")
u = ct.query(d, "x" * 100000)
t.check("unknown query" in json.loads(u).get("error", "") and len(u) < 300, "a huge unknown command: a short error (%d bytes)" % len(u))
# Arguments that are not whole numbers in range are refused, naming them (they were read as 0,
# as unlimited, or as another pixel).
for request, named in (("colors abc", "'abc'"), ("colors -1", "'-1'"), ("labelset 1.5", "'1.5'"),
                       ("pick 1.5e3 nan", "'1.5e3'"), ("pick 3 nan", "'nan'"), ("pick", "needs a whole number"),
                       ("summary extra args", "'extra'"), ("stats 1", "'1'"), ("colors 5 6", "'6'"),
                       ("pick 1 2 3", "'3'"), ("defaults x", "'x'")):
    e = json.loads(ct.query(d, request))  # labelset answers base64 when it answers, an error as JSON
    t.check(named in e.get("error", ""), "%s: refused, naming %s (%s)" % (request, named, e))

# A query answers for the label array set now, before any render (it answered for the array of
# the last render), and for the data the view updated last (a new file after the view's update).
labels_before = json.loads(ct.query(d, "summary")).get("labels")
d.CSGVLabelArray = "NoSuchArray"
missing = json.loads(ct.query(d, "summary"))
t.check("NoSuchArray" in missing.get("error", "") and missing.get("labels") == 0 and missing.get("empty") is False,
        "a missing label array set without a render: the answer names it, the input is not empty (%s)" % missing)
d.CSGVLabelArray = ""
t.check(json.loads(ct.query(d, "summary")).get("labels") == labels_before,
        "the automatic array again: the labels again (%d)" % labels_before)
r.FileName = os.path.join(t.FIXTURES, "denseB_b32_rans1.csgv")
v.Update()
dense = json.loads(ct.query(d, "summary")).get("labels")
t.check(dense != labels_before and dense > 0, "another file, after the view's update: its labels (%s, before %d)"
        % (dense, labels_before))
# A file that fails to read leaves an empty output: the summary says so with a flag (the
# material editor's "The input is empty" line reads it), whatever the error's words.
with open(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"), "rb") as f:
    head = f.read(4096)
truncated = os.path.join(t.temp_dir(), "truncated.csgv")
with open(truncated, "wb") as f:
    f.write(head)
with t.ErrorLog() as errors:
    r.FileName = truncated
    v.Update()
    empty = json.loads(ct.query(d, "summary"))
t.check(empty.get("empty") is True and empty.get("labels") == 0 and "truncated" in errors.text,
        "a file that failed to read: the summary says the input is empty (%s)" % empty)
r.FileName = os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv")
v.Update()
again = json.loads(ct.query(d, "summary"))
t.check(again.get("labels") == labels_before and again.get("empty") is False, "the first file again")

# A float image shown as Outline: the GUI's panels ask its (hidden) Segmentation Volume, whose
# input cannot be labels. The answer says why; nothing is logged as an error (a red Output
# Messages window popped up for any float image's Apply).
wavelet = Wavelet()
dw = Show(wavelet, v)
t.check(dw.Representation == "Outline", "the wavelet shows as Outline (%s)" % dw.Representation)
with t.ErrorLog() as errors:
    answer = json.loads(ct.query(dw, "summary"))
    Render(v)
t.check("not an integer label" in answer.get("error", "") and answer.get("empty") is False,
        "the answer names the problem; the input is not empty (%s)" % answer)
t.check(errors.text.strip() == "", "nothing logged for a display not shown as Segmentation Volume (%s)" % errors.text.strip()[:300])
# Shown as one, the problem is said.
with t.ErrorLog() as errors:
    dw.SetRepresentationType("Segmentation Volume")
    Render(v)
t.check("not an integer label" in errors.text, "shown as Segmentation Volume, the error is said (%s)" % errors.text.strip()[:300])

# A proxy of another kind given as the query's Representation (a view): the answer says there is
# none, and no "Aborting execution" from ParaView's wrapping (it printed one for a typed setter).
with t.ErrorLog() as errors:
    q = sm.ProxyManager().SMProxyManager.NewProxy("misc", "CSGVQuery")
    sm.vtkSMPropertyHelper(q, "Representation").Set(v.SMProxy)
    sm.vtkSMPropertyHelper(q, "Request").Set("summary")
    q.UpdateVTKObjects()
    q.UpdatePropertyInformation()
    wrong = json.loads(sm.vtkSMPropertyHelper(q, "Result").GetAsString())
t.check("no Segmentation Volume representation" in wrong.get("error", "") and "Abort" not in errors.text,
        "a view as the query's representation: %s, nothing alarming logged (%s)" % (wrong, errors.text.strip()[:200]))
# A deleted display answers that it was deleted (it answered its old data while Python held it).
Delete(dw)
gone = json.loads(ct.query(dw, "summary"))
t.check("deleted" in gone.get("error", ""), "a deleted display's query says so (%s)" % gone)
try:
    ct.label_image(dw)
    said = "no error"
except RuntimeError as e:
    said = str(e)
t.check("deleted" in said, "its label image says so too (%s)" % said)

# A render that draws nothing (an error) leaves no pixels to answer: picks and the label image
# answered the frame before (found by an attack pass), which the screen no longer showed.
Render(v)
shown = ct.label_image(d)
ys, xs = np.nonzero(shown != 0xFFFFFFFF)
x, y = int(xs[len(xs) // 2]), int(ys[len(ys) // 2])
t.check(ct.pick(d, x, y)["hit"], "a drawn frame: a hit at (%d, %d)" % (x, y))
for name, broken, fixed in (("Scale", [0, 1, 1], [1, 1, 1]), ("CSGVMaterials", "{oops", "")):
    with t.ErrorLog():
        setattr(d, name, broken)
        Render(v)
    p = ct.pick(d, x, y)
    t.check(p["hit"] is False and "nothing drawn" in p.get("error", "") and ct.label_image(d).size == 0,
            "%s %r drew nothing: no hit (%s), an empty label image" % (name, broken, p.get("error")))
    setattr(d, name, fixed)
    Render(v)
    t.check(ct.pick(d, x, y)["hit"] and np.array_equal(ct.label_image(d), shown), "drawn again: the same pixels")
Delete(wavelet)
t.finish()
