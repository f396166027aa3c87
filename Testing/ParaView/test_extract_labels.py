# SPDX-License-Identifier: MIT
"""CSGV Extract Labels (issue 41): surface meshes of selected labels, checked against the
volume the fixture was written from. Every vertex lies on a face between voxels (one coordinate
on a voxel boundary, the other two at voxel centres), each triangle's face separates a voxel of
its label from a voxel of another, each label's mesh spans exactly its voxels' bounding box, only
bricks holding a selected label are decoded, the same at a coarser level and through a Query;
bad selections give an empty output and an error, never a crash. Also CSGV Extract on a
reader that has not run yet."""
import os

import numpy as np

import csgv_pvtest as t
from paraview.simple import *
from paraview import servermanager as sm
from vtkmodules.util.numpy_support import vtk_to_numpy

t.load_plugin(globals())
name = "synthA_b32_rans2.csgv"
src = t.source_volume(name)  # (D, H, W), x fastest
D, H, W = src.shape
r = OpenDataFile(os.path.join(t.FIXTURES, name))
img = t.fetch(r)
origin = np.array(img.GetOrigin())
spacing = np.array(img.GetSpacing())

values, counts = np.unique(src, return_counts=True)
nonzero = [(int(c), int(v)) for v, c in zip(values, counts) if v != 0]
nonzero.sort()
chosen = [nonzero[-1][1], nonzero[-2][1], nonzero[len(nonzero) // 2][1]]  # two common, one middling


def mesh_of(f):
    f.UpdatePipeline()
    poly = sm.Fetch(f)
    pts = vtk_to_numpy(poly.GetPoints().GetData()) if poly.GetNumberOfPoints() else np.zeros((0, 3))
    labels = poly.GetCellData().GetArray("Label")
    cells = []
    ids = poly.GetPolys()
    ids.InitTraversal()
    from vtkmodules.vtkCommonCore import vtkIdList
    l = vtkIdList()
    while ids.GetNextCell(l):
        cells.append([l.GetId(k) for k in range(l.GetNumberOfIds())])
    return pts, (vtk_to_numpy(labels) if labels is not None else np.zeros(0)), cells


def check_mesh(pts, labels, cells, vol, scale, what):
    """vol: the label image at this level, (D, H, W); scale: voxels of level 0 per node."""
    q = (pts - origin) / (spacing * scale)  # corner index coordinates of the level's nodes
    frac = np.abs(q - np.round(q))
    on_boundary = frac < 1e-4
    at_centre = np.abs(frac - 0.5) < 1e-4
    t.check(len(pts) > 0 and bool(np.all(on_boundary.sum(axis=1) == 1) and np.all(at_centre.sum(axis=1) == 2)),
            "%s: every vertex lies on a voxel face (one coordinate on a boundary, two at centres; %d vertices)"
            % (what, len(pts)))
    # Each triangle's vertices lie on faces; its centroid's boundary axis (the one with an integer
    # coordinate common to the face) separates a voxel of its label from one of another label.
    bad = 0
    checked = 0
    shape = vol.shape
    for cell, lab in zip(cells, labels):
        c = q[cell].mean(axis=0)
        v = q[cell[0]]
        axis = int(np.argmax(on_boundary[cell[0]]))
        # The voxel on each side of the face the first vertex lies on.
        idx = np.floor(v).astype(int)
        lo = idx.copy()
        lo[axis] = int(round(v[axis])) - 1
        hi = idx.copy()
        hi[axis] = int(round(v[axis]))
        side = []
        for p in (lo, hi):
            x, y, z = p
            inside = 0 <= x < shape[2] and 0 <= y < shape[1] and 0 <= z < shape[0]
            side.append(int(vol[z, y, x]) if inside else None)
        checked += 1
        if not ((side[0] == lab) != (side[1] == lab)):
            bad += 1
    t.check(checked > 0 and bad == 0, "%s: each triangle's face separates its label from another (%d of %d wrong)"
            % (what, bad, checked))
    for lab in set(int(x) for x in labels):
        z, y, x = np.nonzero(vol == lab)
        want_lo = np.array([x.min(), y.min(), z.min()], dtype=float)
        want_hi = np.array([x.max(), y.max(), z.max()], dtype=float) + 1
        mine = q[np.unique(np.array([p for cell, l in zip(cells, labels) if int(l) == lab for p in cell]))]
        got_lo, got_hi = mine.min(axis=0), mine.max(axis=0)
        t.check(np.allclose(got_lo, want_lo) and np.allclose(got_hi, want_hi),
                "%s: label %d's mesh spans its voxels' box (%s..%s, mesh %s..%s)"
                % (what, lab, want_lo, want_hi, got_lo, got_hi))


# Level 0, three labels.
e = CSGVExtractLabels(Input=r)
e.Labels = " ".join(str(v) for v in chosen)
pts, labels, cells = mesh_of(e)
t.check(sorted(set(int(x) for x in labels)) == sorted(chosen), "labels of the meshes are the selected ones (%s)"
        % sorted(set(int(x) for x in labels)))
check_mesh(pts, labels, cells, src, 1, "level 0")
e.UpdatePropertyInformation()
decoded, total = e.GetPropertyValue("BricksDecoded"), e.GetPropertyValue("BricksTotal")
t.check(0 < decoded < total, "only bricks holding a selected label are decoded (%d of %d)" % (decoded, total))

# A value outside a property's range, set from Python (the Properties panel enforces the range,
# pvpython does not), is held to it with a warning naming it (found by an attack pass: Smoothing
# 2^31-1 meshed for minutes in silence; MaxLabels 0 said "more than MaxLabels (1)").
with t.ErrorLog() as held:
    e.Smoothing = 2147483647
    e.Decimation = float("nan")
    e.MaxLabels = 0
    e.UpdatePipeline()
t.check("Smoothing 2147483647 is outside [0, 200]: 200 is used" in held.text and
        "Decimation nan is outside [0, 0.95]: 0 is used" in held.text and
        "MaxLabels 0 is outside [1, 2147483647]: 1 is used" in held.text,
        "out-of-range filter properties are held with a warning (%s)" % held.text[-600:])
e.Smoothing, e.Decimation, e.MaxLabels = 0, 0, 1000000

# A box: the meshes stay inside it (in voxels).
e.VOI = [0, W // 2 - 1, 0, H - 1, 0, D - 1]
pts_box, labels_box, cells_box = mesh_of(e)
qb = (pts_box - origin) / spacing
t.check(len(pts_box) > 0 and qb[:, 0].max() <= W // 2 + 1e-6, "a VOI keeps the meshes inside it (x <= %d)" % (W // 2))
e.VOI = [0, 2147483647, 0, 2147483647, 0, 2147483647]

# Level 1: the label image one level coarser, as Core's decoder makes it (CSGV Extract's output
# at level 1 is the oracle).
e.Level = 1
pts1, labels1, cells1 = mesh_of(e)
x1 = CSGVExtract(Input=r)
x1.Level = 1
lvl = t.fetch(x1)
dims = [lvl.GetExtent()[2 * a + 1] - lvl.GetExtent()[2 * a] for a in range(3)]
vol1 = t.cell_labels(lvl).reshape(dims[2], dims[1], dims[0])
check_mesh(pts1, labels1, cells1, vol1, 2, "level 1")
e.Level = 0

# Smoothing keeps every triangle and its label, moving vertices off the voxel faces by less than a
# voxel; decimation removes about the asked fraction of triangles, each label keeping a mesh.
e.Smoothing = 20
pts_s, labels_s, cells_s = mesh_of(e)
t.check(len(cells_s) == len(cells) and np.array_equal(labels_s, labels), "smoothing keeps the triangles and their labels")
moved = np.abs(pts_s - pts).max(axis=1) / spacing.min()
t.check(moved.max() < 1.0 and moved.max() > 0.05, "smoothing moves vertices, by less than a voxel (max %.3f)" % moved.max())
e.Smoothing = 0
e.Decimation = 0.5
pts_d, labels_d, cells_d = mesh_of(e)
t.check(0.3 * len(cells) < len(cells_d) <= 0.6 * len(cells), "decimation 0.5 halves the triangles (%d of %d)" % (len(cells_d), len(cells)))
t.check(sorted(set(int(x) for x in labels_d)) == sorted(chosen), "decimated: every label keeps a mesh, labelled")
for lab in chosen:
    a, b = pts[np.unique(np.array(cells)[labels == lab])], pts_d[np.unique(np.array(cells_d)[labels_d == lab])]
    t.check(np.all(b.min(axis=0) >= a.min(axis=0) - spacing) and np.all(b.max(axis=0) <= a.max(axis=0) + spacing),
            "decimated label %d stays within its voxels' box" % lab)
e.Decimation = 0

# Output Type Mask and Label image: one image of the selection's bounding box, cell for cell on
# the volume (the source volume is the oracle), at level 0, in a box and at level 1.
def image_of(f):
    f.UpdatePipeline()
    mb = sm.Fetch(f)
    t.check(mb.IsA("vtkMultiBlockDataSet") and mb.GetNumberOfBlocks() == 1 and mb.GetBlock(0).IsA("vtkImageData"),
            "an image output is one vtkImageData block (%s)" % mb.GetClassName())
    im = mb.GetBlock(0)
    ext = im.GetExtent()
    dims = [ext[2 * a + 1] - ext[2 * a] for a in range(3)]
    arr = im.GetCellData().GetScalars()
    vals = vtk_to_numpy(arr).reshape(dims[2], dims[1], dims[0]) if arr is not None else None
    return im, ext, vals, (arr.GetName() if arr is not None else None)


def check_image(f, vol, what, box=None):
    """vol: the label image at the filter's level, (D, H, W); box: [x0, x1, y0, y1, z0, z1) nodes."""
    sel = np.isin(vol, chosen)
    if box is not None:
        inside = np.zeros_like(sel)
        inside[box[4]:box[5], box[2]:box[3], box[0]:box[1]] = True
        sel &= inside
    zs, ys, xs = np.nonzero(sel)
    want_ext = [xs.min(), xs.max() + 1, ys.min(), ys.max() + 1, zs.min(), zs.max() + 1]
    for mode, name in ((1, "Mask"), (2, "Label")):
        f.OutputType = mode
        im, ext, vals, arr = image_of(f)
        t.check(list(ext) == [int(v) for v in want_ext], "%s, %s: the extent is the selection's bounding box (%s, want %s)"
                % (what, name, list(ext), want_ext))
        crop = vol[ext[4]:ext[5], ext[2]:ext[3], ext[0]:ext[1]]
        csel = sel[ext[4]:ext[5], ext[2]:ext[3], ext[0]:ext[1]]
        want = csel.astype(np.uint8) if mode == 1 else np.where(csel, crop, 0)
        t.check(arr == name and vals is not None and np.array_equal(vals, want),
                "%s, %s: equals the decoded volume's voxels of the selected labels" % (what, name))
        lvl_img = t.fetch(x1) if f.Level else img
        t.check(np.allclose(im.GetSpacing(), lvl_img.GetSpacing()) and np.allclose(im.GetOrigin(), lvl_img.GetOrigin()),
                "%s, %s: the volume's spacing and origin (cell for cell on it)" % (what, name))
    f.UpdatePropertyInformation()
    t.check(0 < f.GetPropertyValue("BricksDecoded") < f.GetPropertyValue("BricksTotal"),
            "%s: only bricks holding a selected label decoded (%d of %d)"
            % (what, f.GetPropertyValue("BricksDecoded"), f.GetPropertyValue("BricksTotal")))
    f.OutputType = 0


e.Labels = " ".join(str(v) for v in chosen)
check_image(e, src, "level 0")
e.VOI = [W // 4, W // 2 - 1, 0, H - 1, 2, D - 1]
check_image(e, src, "a VOI", [W // 4, W // 2, 0, H, 2, D])
e.VOI = [0, 2147483647, 0, 2147483647, 0, 2147483647]
e.Level = 1
check_image(e, vol1, "level 1")
e.Level = 0
# Back to meshes: polygonal data again.
pts2, labels2, cells2 = mesh_of(e)
t.check(len(cells2) == len(cells), "switching Output Type back gives the same meshes (%d triangles)" % len(cells2))

# Bad selections: an error, an empty output, no crash.
for bad_labels, what in (("99999999", "an unknown label"), ("3 x", "a word that is not a label"), ("", "nothing")):
    e.Labels = bad_labels
    e.Query = ""
    p, l, c = mesh_of(e)
    t.check(len(c) == 0, "%s: empty output" % what)
# An unknown label among known ones is counted among all selected (found by an attack pass: the
# labels meshed one by one each said "1 of the 1 selected labels").
e.Labels = " ".join(str(v) for v in chosen) + " 99999999"
with t.ErrorLog() as said:
    p, l, c = mesh_of(e)
t.check(len(c) == 0 and "1 of the %d selected labels occur nowhere in the volume" % (len(chosen) + 1) in said.text,
        "an unknown label among %d is counted among all of them (%s)" % (len(chosen) + 1, said.text[-300:]))
e.Labels = str(chosen[0])
e.Query = "label > 0"
p, l, c = mesh_of(e)
t.check(len(c) == 0, "Labels and a Query together: refused, empty output")

# A Query over a relabelled file's attribute database.
ra = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2_attr.csgv"))
ea = CSGVExtractLabels(Input=ra)
ea.Query = "label = %d" % chosen[0]
pa, la, ca = mesh_of(ea)
t.check(len(ca) > 0 and set(int(x) for x in la) == {chosen[0]}, "a Query selects its labels (%s)" % set(int(x) for x in la))
ea.Query = "no_such_column > 1"
pa, la, ca = mesh_of(ea)
t.check(len(ca) == 0, "a Query naming no column: refused, empty output")

# CSGV Extract applied to a reader that has not run yet (a pvpython script's first lines): it
# must find the reader's volume information behind ParaView's post filter (before, it reported
# "the input carries no CSGV volume" and stayed empty).
fresh = OpenDataFile(os.path.join(t.FIXTURES, name))
xf = CSGVExtract(Input=fresh)
xf.Level = 1
lf = t.fetch(xf)
t.check(lf.GetNumberOfCells() == vol1.size and np.array_equal(t.cell_labels(lf), vol1.ravel()),
        "CSGV Extract on a reader that has not run: the level-1 labels (%d cells)" % lf.GetNumberOfCells())

# `csgv extract OUT.vtp` (Core's writer, no VTK) is read by VTK's own XML reader: the counts it
# printed, the selected labels as cell data, vertices on voxel corners (voxel-face meshes).
csgv_tool = os.environ.get("CSGV_TOOL", "")
if csgv_tool and os.path.exists(csgv_tool):
    import subprocess
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    out = os.path.join(t.temp_dir(), "labels.vtp")
    run = subprocess.run([csgv_tool, "extract", os.path.join(t.FIXTURES, name), out, "--labels",
                          ",".join(str(v) for v in chosen[:2])], capture_output=True, text=True)
    keys = dict(l.split(": ", 1) for l in run.stdout.splitlines() if ": " in l)
    rd = vtkXMLPolyDataReader()
    rd.SetFileName(out)
    rd.Update()
    pv = rd.GetOutput()
    lab = pv.GetCellData().GetArray("Label")
    qv = (vtk_to_numpy(pv.GetPoints().GetData()) - origin) / spacing if pv.GetNumberOfPoints() else np.zeros((0, 3))
    t.check(run.returncode == 0 and pv.GetNumberOfPoints() == int(keys.get("vertices", -1)) and
            pv.GetNumberOfPolys() == int(keys.get("triangles", -1)) and lab is not None and
            sorted(set(vtk_to_numpy(lab).tolist())) == sorted(chosen[:2]) and
            bool(np.all(np.abs(qv - np.round(qv)) < 1e-6)),
            "csgv extract .vtp: VTK reads %d points and %d triangles (csgv said %s and %s), labels and voxel corners"
            % (pv.GetNumberOfPoints(), pv.GetNumberOfPolys(), keys.get("vertices"), keys.get("triangles")))
    # `csgv extract OUT.vti` equals CSGV Extract Labels' image, cell for cell (extent, origin,
    # spacing, values), for a mask and a label image, at level 0 and 1.
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader
    e.Query = ""
    e.Labels = " ".join(str(v) for v in chosen)
    for level in (0, 1):
        for mask, mode, arr_name in ((True, 1, "Mask"), (False, 2, "Label")):
            out = os.path.join(t.temp_dir(), "sel%d%s.vti" % (level, arr_name))
            args = [csgv_tool, "extract", os.path.join(t.FIXTURES, name), out, "--labels",
                    ",".join(str(v) for v in chosen), "--level", str(level)] + (["--mask"] if mask else [])
            run = subprocess.run(args, capture_output=True, text=True)
            rd = vtkXMLImageDataReader()
            rd.SetFileName(out)
            rd.Update()
            got = rd.GetOutput()
            e.Level = level
            e.OutputType = mode
            im = image_of(e)[0]
            ga, wa = got.GetCellData().GetArray(arr_name), im.GetCellData().GetArray(arr_name)
            t.check(run.returncode == 0 and ga is not None and wa is not None and
                    list(got.GetExtent()) == list(im.GetExtent()) and
                    np.allclose(got.GetOrigin(), im.GetOrigin()) and np.allclose(got.GetSpacing(), im.GetSpacing()) and
                    np.array_equal(vtk_to_numpy(ga), vtk_to_numpy(wa)),
                    "csgv extract .vti, level %d, %s: equals CSGV Extract Labels' image (extent %s, %s)"
                    % (level, arr_name, list(got.GetExtent()), run.stderr.strip()[:200]))
    e.Level, e.OutputType = 0, 0
else:
    t.check(False, "the csgv tool (CSGV_TOOL=%r)" % csgv_tool)

t.finish()
