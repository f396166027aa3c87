# SPDX-License-Identifier: MIT
"""Every Volcanite fixture opens through OpenDataFile and its labels equal the source volume;
the image has cell data with dims + 1 points; the FieldData carries the encoding and the palette
label range; Level, DecodeLabels and CSGV Extract behave as documented."""
import os

import numpy as np

import csgv_pvtest as t
from paraview.simple import *
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkAbstractArray

t.load_plugin(globals())

names = t.fixture_names()
t.check(len(names) >= 12, "found %d fixtures in %s" % (len(names), t.FIXTURES))
for name in names:
    src = t.source_volume(name)
    d, h, w = src.shape
    r = OpenDataFile(os.path.join(t.FIXTURES, name))
    t.check(r is not None and r.GetXMLName() == "CSGVReader", name + ": opened by CSGVReader")
    # The reader caches the encoding's range with the array (ParaView's data information asks
    # every array for its range; VTK's own scan of a multi-gigabyte encoding took minutes): its
    # first output, before anything asked for a range, holds it, the true one.
    own = r.GetClientSideObject()
    own.Update()
    fresh = own.GetOutputDataObject(0).GetFieldData().GetArray("CSGVEncoding")
    b = vtk_to_numpy(fresh)
    t.check(fresh.GetInformation().Has(vtkAbstractArray.PER_FINITE_COMPONENT()) and
            fresh.GetInformation().Has(vtkAbstractArray.PER_COMPONENT()) and
            tuple(fresh.GetFiniteRange(0)) == (b.min(), b.max()) and tuple(fresh.GetRange(0)) == (b.min(), b.max()),
            name + ": the encoding's byte range is cached by the reader and true")
    img = t.fetch(r)
    t.check(img.GetDimensions() == (w + 1, h + 1, d + 1), name + ": dims + 1 points (cell data)")
    labels = t.cell_labels(img)
    t.check(labels is not None and np.array_equal(labels, src.ravel()), name + ": labels equal the source")
    fd = img.GetFieldData()
    enc = fd.GetArray("CSGVEncoding")
    t.check(enc is not None and enc.GetNumberOfTuples() == os.path.getsize(os.path.join(t.FIXTURES, name)),
            name + ": CSGVEncoding holds the file's bytes")
    rng = fd.GetArray("CSGVLabelRange")
    t.check(rng is not None and (rng.GetValue(0), rng.GetValue(1)) == (src.min(), src.max()),
            name + ": palette label range equals the source's")
    if name.endswith("_attr.csgv"):
        t.check(fd.GetArray("CSGVLabelMap") is not None, name + ": CSGVLabelMap present (relabelled file)")
    # The plugin's own arrays are marked GUI_HIDE: ParaView's array lists (colour by, selection,
    # filters) leave them out (issue 38, item 6); the labels stay.
    internal = [fd.GetAbstractArray(i) for i in range(fd.GetNumberOfArrays())
                if fd.GetAbstractArray(i).GetName().startswith("CSGV")]
    t.check(internal and all(a.GetInformation().Get(vtkAbstractArray.GUI_HIDE()) == 1 for a in internal),
            name + ": the plugin's own arrays are hidden from ParaView's array lists (%s)"
            % ", ".join(a.GetName() for a in internal))
    if name == names[0]:
        view = CreateRenderView()
        domain = Show(r, view).GetProperty("ColorArrayName").SMProperty.GetDomain("array_list")
        listed = [domain.GetString(i) for i in range(domain.GetNumberOfStrings())]
        t.check(listed == ["Labels"], name + ": colour by lists the labels alone (%s)" % listed)
        Delete(view)
    Delete(r)

# The sources through the .vraw reader (Volcanite's raw format).
for stem in ("synthA", "denseB"):
    src = t.source_volume(stem + "_")
    r = OpenDataFile(os.path.join(t.FIXTURES, stem + ".vraw.gz"))
    img = t.fetch(r)
    t.check(np.array_equal(t.cell_labels(img), src.ravel()), stem + ".vraw.gz: labels equal")
    t.check(img.GetFieldData().GetArray("CSGVEncoding") is not None, stem + ".vraw.gz: carries an encoding")
    Delete(r)

# Levels, the decode switch and the Extract filter on the default fixture.
name = "synthA_b32_rans2.csgv"
src = t.source_volume(name)
d, h, w = src.shape
r = CSGVReader(FileName=os.path.join(t.FIXTURES, name))
progress = []
r.GetClientSideObject().AddObserver("ProgressEvent", lambda o, e: progress.append(o.GetProgress()))
r.Level = 1
img1 = t.fetch(r)
# One report per slab of bricks (194 / 2 / 16 -> 7 slabs at level 1), ending at 1.
t.check(len(progress) >= 7 and progress[-1] == 1.0 and progress == sorted(progress),
        "progress reported per brick slab (%d events)" % len(progress))
lw, lh, ld = (w - 1) // 2 + 1, (h - 1) // 2 + 1, (d - 1) // 2 + 1
t.check(img1.GetDimensions() == (lw + 1, lh + 1, ld + 1) and img1.GetSpacing() == (2.0, 2.0, 2.0),
        "Level 1: level image with spacing 2")
level1 = t.cell_labels(img1)
t.check(level1 is not None and level1.size == lw * lh * ld, "Level 1: labels decoded")
# Coarse labels are labels of the source (the mode of the children).
t.check(np.isin(level1, src).all(), "Level 1: every coarse label exists in the source")

r.Level = 0
r.DecodeLabels = 0
img = t.fetch(r)
t.check(img.GetCellData().GetNumberOfArrays() == 0 and img.GetNumberOfCells() == w * h * d,
        "DecodeLabels off: geometry only, no label array")
t.check(img.GetFieldData().GetArray("CSGVEncoding") is not None, "DecodeLabels off: encoding still carried")

x = CSGVExtract(Input=r)
x.VOI = [10, 40, 5, 30, 100, 150]
sub = t.fetch(x)
t.check(sub.GetExtent() == (10, 41, 5, 31, 100, 151), "Extract VOI: extent of the box (%s)" % (sub.GetExtent(),))
t.check(np.array_equal(t.cell_labels(sub), src[100:151, 5:31, 10:41].ravel()), "Extract VOI: labels equal the source box")
x.VOI = [0, 100000, 0, 100000, 0, 100000]
x.Level = 1
whole1 = t.fetch(x)
t.check(np.array_equal(t.cell_labels(whole1), level1), "Extract Level 1 equals the reader's Level 1")
t.check(whole1.GetSpacing() == (2.0, 2.0, 2.0) and whole1.GetOrigin() == (0.0, 0.0, 0.0), "Extract Level 1 geometry")
t.finish()
