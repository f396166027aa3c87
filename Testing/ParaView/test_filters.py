# SPDX-License-Identifier: MIT
"""A fixed list of ParaView filters and views on the reader's output (cell labels), each with an
assertion on what it produces: Slice, Threshold, Histogram, Contour, Python Calculator, Cell
Data to Point Data, fetching to numpy, the spreadsheet (CSV export), and rendering the image as
Outline, Surface and Slice. The log lists every result; the docstring of each block says what was
expected."""
import os

import numpy as np

import csgv_pvtest as t
from paraview.simple import *
from vtkmodules.util.numpy_support import vtk_to_numpy

t.load_plugin(globals())
tmp = t.temp_dir()
name = "synthA_b32_rans2.csgv"
src = t.source_volume(name)  # (D, H, W)
D, H, W = src.shape
r = OpenDataFile(os.path.join(t.FIXTURES, name))
r.UpdatePipeline()
results = {}


def record(filter_name, ok, detail):
    results[filter_name] = ok
    t.check(ok, "%s: %s" % (filter_name, detail))


# Fetch to the client and numpy.
img = t.fetch(r)
labels = t.cell_labels(img)
record("Fetch+numpy", labels is not None and np.array_equal(labels, src.ravel()), "labels as a numpy array")
values, counts = np.unique(src, return_counts=True)
common = int(values[np.argmax(counts[1:]) + 1])  # the most frequent non-zero label

# Slice through z = D/2 + 0.5 (a plane between voxel centres would be ambiguous; this one cuts
# voxel layer D/2 through its middle): the cut polygons carry that layer's labels.
s = Slice(Input=r)
s.SliceType = "Plane"
s.SliceType.Origin = [W / 2.0, H / 2.0, D // 2 + 0.5]
s.SliceType.Normal = [0, 0, 1]
s.Triangulatetheslice = 0  # one quad per voxel instead of two triangles
out = t.fetch(s)
sl = out.GetCellData().GetArray("Labels")
got = np.unique(vtk_to_numpy(sl)) if sl is not None else None
record("Slice", got is not None and out.GetNumberOfCells() == W * H and np.array_equal(got, np.unique(src[D // 2])),
       "%d cells with the labels of voxel layer %d" % (out.GetNumberOfCells(), D // 2))

# Threshold on the cell labels: exactly the voxels of one label.
th = Threshold(Input=r)
th.Scalars = ["CELLS", "Labels"]
th.LowerThreshold = common
th.UpperThreshold = common
out = t.fetch(th)
record("Threshold", out.GetNumberOfCells() == int(counts[values == common][0]),
       "label %d: %d cells (source has %d voxels)" % (common, out.GetNumberOfCells(), counts[values == common][0]))

# Histogram of the cell labels: counts add up to the voxel count.
hi = Histogram(Input=r)
hi.SelectInputArray = ["CELLS", "Labels"]
hi.BinCount = 64
out = t.fetch(hi)
bins = out.GetRowData().GetArray("bin_values")
total = int(vtk_to_numpy(bins).sum()) if bins is not None else -1
record("Histogram", total == W * H * D, "64 bins holding %d of %d voxels" % (total, W * H * D))

# Contour of the cell labels (ParaView 5.11 converts cell data to points for it).
c = Contour(Input=r)
c.ContourBy = ["CELLS", "Labels"]
c.Isosurfaces = [0.5]
out = t.fetch(c)
record("Contour", out.GetNumberOfCells() > 0, "iso-surface at 0.5 with %d triangles" % out.GetNumberOfCells())

# Python Calculator on cell data.
pc = PythonCalculator(Input=r)
pc.ArrayAssociation = "Cell Data"
pc.Expression = "Labels % 1000 + 1"
pc.ArrayName = "twice"
out = t.fetch(pc)
tw = out.GetCellData().GetArray("twice")
record("Python Calculator", tw is not None and np.array_equal(vtk_to_numpy(tw).astype(np.int64), src.ravel().astype(np.int64) % 1000 + 1),
       "Labels % 1000 + 1 equals numpy's")

# Cell Data to Point Data (what volume rendering of labels would need).
cp = CellDatatoPointData(Input=r)
out = t.fetch(cp)
record("Cell Data to Point Data", out.GetPointData().GetArray("Labels") is not None and out.GetNumberOfPoints() == (W + 1) * (H + 1) * (D + 1),
       "point labels on %d points" % out.GetNumberOfPoints())

# The spreadsheet: export the cell data of the CSGV Extract of a small box as CSV.
x = CSGVExtract(Input=r)
x.VOI = [0, 3, 0, 2, 0, 1]
view = CreateView("SpreadSheetView")
rep = Show(x, view)
view.FieldAssociation = "Cell Data"
view.Update()
csv = os.path.join(tmp, "sheet.csv")
ExportView(csv, view=view)
rows = open(csv).read().strip().splitlines() if os.path.exists(csv) else []
header = rows[0].split(",") if rows else []
col = [i for i, h in enumerate(header) if "Labels" in h]
sheet = [int(float(row.split(",")[col[0]])) for row in rows[1:]] if col else []
record("Spreadsheet", sheet == list(src[0:2, 0:3, 0:4].ravel()), "%d rows, Labels column equals the source" % len(sheet))
Delete(view)

# Rendering the image (ParaView's own representations; the Segmentation Volume one comes later).
rv = CreateView("RenderView")
rv.ViewSize = [200, 150]
d = Show(r, rv)
ok = True
for rep_type in ("Outline", "Surface", "Slice"):
    d.SetRepresentationType(rep_type)
    ColorBy(d, ("CELLS", "Labels"))
    Render(rv)
    png = os.path.join(tmp, rep_type + ".png")
    SaveScreenshot(png, rv, ImageResolution=[200, 150])
    ok = ok and os.path.getsize(png) > 0
record("Render Outline/Surface/Slice", ok, "rendered and saved screenshots")
Delete(d)
Delete(rv)

t.log("filters on the reader output: " + ", ".join("%s=%s" % (k, "works" if v else "FAILS") for k, v in results.items()))
t.finish()
