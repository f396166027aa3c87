# SPDX-License-Identifier: MIT
"""Labels beyond 32 bits (negative, 64-bit) in the Segmentation Volume (docs pass 11, HIGH: a pick
named the id the encoding gave, 5, for a voxel holding -1, and a selection made from the Label
Table's or a query's original labels drew other labels). Such a volume is drawn by its ids
(csgvrep::drawsIds): a pick's "label", the label image, materials and selections name ids, a pick
adds the voxel's "original" label, `labels_matching` answers ids, `label_colors` originals.
Checked for a relabelled .csgv (the reader's map) and a plain int32 / uint64 image that the
representation compresses (its own map)."""
import json
import os
import subprocess

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

import sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools as ct  # noqa: E402

W, H = 96, 72
INVALID = 0xFFFFFFFF
t.load_plugin(globals())
tmp = t.temp_dir()
tool = os.environ["CSGV_TOOL"]

N = 24
k, j, i = np.meshgrid(np.arange(N), np.arange(N), np.arange(N), indexing="ij")
# Six slabs along x, each one label; background 0 in the corner slab's first rows.
slab = np.minimum(i // 4, 5)
NEG = np.array([-3, -2, 1, 2, -1, 7], dtype=np.int32)[slab]
NEG[:, :2, :] = 0
WIDE = np.array([0, 7 + 2**40, 9, 5 + 2**41, 2**63 + 11, 3], dtype=np.uint64)[slab]


def write_nrrd(path, a, kind):
    with open(path, "wb") as f:
        f.write(("NRRD0004\ntype: %s\ndimension: 3\nsizes: %d %d %d\nencoding: raw\nendian: little\n\n"
                 % (kind, N, N, N)).encode())
        f.write(a.astype(a.dtype.newbyteorder("<")).tobytes())


def write_vti(path, a, vtk_type):
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkIOXML import vtkXMLImageDataWriter
    from vtkmodules.util.numpy_support import numpy_to_vtk
    img = vtkImageData()
    img.SetDimensions(N + 1, N + 1, N + 1)
    arr = numpy_to_vtk(a.ravel(), deep=1, array_type=vtk_type)
    arr.SetName("seg")
    img.GetCellData().AddArray(arr)
    w = vtkXMLImageDataWriter()
    w.SetFileName(path)
    w.SetInputData(img)
    w.Write()


def check_volume(name, source, values):
    """values: the voxels (z, y, x) as their original labels."""
    v = t.render_view(W, H)
    d = Show(source, v)
    d.SetRepresentationType("Segmentation Volume")
    d.CSGVFramesPerStillRender = 1
    v.CameraPosition = [N * 2.2, N * 1.6, N * 1.9]
    v.CameraFocalPoint = [N / 2.0] * 3
    v.CameraViewUp = [0, 0, 1]
    v.ResetCamera()
    Render(v)
    img = ct.label_image(d)
    drawn = sorted(set(img[img != INVALID].tolist()))
    originals = sorted(set(values.ravel().tolist()) - {0})
    t.check(len(drawn) >= 4, "%s: the label image shows several labels (%r)" % (name, drawn))
    # Every drawn label is an id: the picks there name the voxel's original label.
    seen = {}
    for label in drawn:
        ys, xs = np.nonzero(img == label)
        p = ct.pick(d, int(xs[len(xs) // 2]), int(ys[len(ys) // 2]))
        vx = p.get("voxel", [0, 0, 0])
        want = int(values[vx[2], vx[1], vx[0]])
        t.check(p.get("hit") and p.get("label") == label and p.get("original") == want
                and p.get("originalText") == str(want),
                "%s: the pick on id %d names the voxel's own label %d (%r)" % (name, label, want, p))
        seen[want] = label
    t.check(all(o in originals for o in seen) and len(set(seen.values())) == len(seen),
            "%s: one id per original label (%r)" % (name, seen))
    # A selection made from a pick's label draws that label alone, and its picks name the original.
    original, label = sorted(seen.items())[0]
    d.CSGVMaterials = ct.show_only_label("", label)
    Render(v)
    only = ct.label_image(d)
    t.check(sorted(set(only[only != INVALID].tolist())) == [label],
            "%s: show_only_label(pick's label %d) draws it alone (%r)" % (name, label, sorted(set(only.ravel().tolist()))))
    d.CSGVMaterials = ""
    Render(v)
    # A query by the original label answers the id that materials take.
    if -2**53 < original < 2**53:
        m = ct.labels_matching(d, "label = %d" % original)
        t.check(m == [label], "%s: labels_matching('label = %d') is its id [%d] (%r)" % (name, original, label, m))
    # Colours are listed by original label (what the label array, a Slice of it, holds).
    colors = ct.label_colors(d)
    listed = sorted(row[0] for row in colors.get("labels", []))
    t.check(listed == originals, "%s: label_colors lists the original labels (%r, want %r)" % (name, listed, originals))
    Delete(d)
    Delete(v)


# A relabelled .csgv (the reader's map).
neg_nrrd = os.path.join(tmp, "neg.nrrd")
write_nrrd(neg_nrrd, NEG, "int32")
neg_csgv = os.path.join(tmp, "neg.csgv")
subprocess.run([tool, "compress", "--quiet", neg_nrrd, neg_csgv], check=True)
check_volume("int32 .csgv", OpenDataFile(neg_csgv), NEG)

wide_nrrd = os.path.join(tmp, "wide.nrrd")
write_nrrd(wide_nrrd, WIDE, "uint64")
wide_csgv = os.path.join(tmp, "wide.csgv")
subprocess.run([tool, "compress", "--quiet", wide_nrrd, wide_csgv], check=True)
check_volume("uint64 .csgv", OpenDataFile(wide_csgv), WIDE)

# A plain image the representation compresses (its own map).
from vtkmodules.util.vtkConstants import VTK_INT, VTK_UNSIGNED_LONG_LONG
neg_vti = os.path.join(tmp, "neg.vti")
write_vti(neg_vti, NEG, VTK_INT)
check_volume("int32 image", OpenDataFile(neg_vti), NEG)
wide_vti = os.path.join(tmp, "wide.vti")
write_vti(wide_vti, WIDE, VTK_UNSIGNED_LONG_LONG)
check_volume("uint64 image", OpenDataFile(wide_vti), WIDE)

t.finish()
