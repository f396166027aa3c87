# SPDX-License-Identifier: MIT
"""NIfTI through the plugin: OpenDataFile finds the reader for .nii.gz, the AAL atlas lands in
world space (first voxel centre at (-90, -125, -71)), values equal VTK's own NIfTI reader, and
AAL -> .csgv -> reader keeps every label with the half-voxel cell geometry."""
import os
import shutil
import gzip

import numpy as np

import csgv_pvtest as t
from paraview.simple import *
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkNIFTIImageReader

t.load_plugin(globals())
tmp = t.temp_dir()

r = OpenDataFile(t.AAL)
t.check(r is not None and r.GetXMLName() == "CSGVNIfTIReader", "aal.nii.gz opened by the plugin's NIfTI reader")
img = t.fetch(r)
t.check(img.GetDimensions() == (181, 217, 181), "AAL dims 181x217x181 (%s)" % (img.GetDimensions(),))
t.check(np.allclose(img.GetOrigin(), (-90, -125, -71)), "AAL first voxel centre at (-90,-125,-71) (%s)" % (img.GetOrigin(),))
t.check(np.allclose(img.GetSpacing(), (1, 1, 1)), "AAL spacing 1 mm")
labels = t.point_labels(img)
vtk_reader = vtkNIFTIImageReader()
vtk_reader.SetFileName(t.AAL)
vtk_reader.Update()
reference = vtk_to_numpy(vtk_reader.GetOutput().GetPointData().GetScalars())
t.check(labels is not None and labels.dtype == reference.dtype and np.array_equal(labels, reference),
        "labels equal vtkNIFTIImageReader's (%s, %d labels)" % (None if labels is None else labels.dtype,
                                                               len(np.unique(reference))))

# An uncompressed .nii is found too.
nii = os.path.join(tmp, "aal.nii")
with gzip.open(t.AAL, "rb") as f, open(nii, "wb") as g:
    shutil.copyfileobj(f, g)
r2 = OpenDataFile(nii)
t.check(r2 is not None and r2.GetXMLName() == "CSGVNIfTIReader", ".nii opened by the plugin's NIfTI reader")
t.check(np.array_equal(t.point_labels(t.fetch(r2)), labels), ".nii labels equal the .nii.gz ones")

# AAL -> .csgv -> reader.
out = os.path.join(tmp, "aal.csgv")
SaveData(out, proxy=r)
c = OpenDataFile(out)
cimg = t.fetch(c)
t.check(cimg.GetDimensions() == (182, 218, 182), "csgv: dims + 1 points")
t.check(np.allclose(cimg.GetOrigin(), (-90.5, -125.5, -71.5)), "csgv: origin at the corner of the first voxel (%s)" % (cimg.GetOrigin(),))
got = t.cell_labels(cimg)
t.check(got is not None and got.dtype == labels.dtype and np.array_equal(got, labels), "csgv: AAL labels equal")
t.log("AAL: %d bytes as .csgv, %d voxels, %.3f bits per voxel" % (
    os.path.getsize(out), labels.size, 8.0 * os.path.getsize(out) / labels.size))
# An intensity image (float T1) is not a label volume: VTK's reader takes over, with a warning,
# and it lands on the grid of the atlas drawn in the same space (read through Core).
T1 = "/usr/share/mricron/templates/inia19-t1-brain.nii.gz"
ATLAS = "/usr/share/mricron/templates/inia19-NeuroMaps.nii.gz"
if os.path.exists(T1) and os.path.exists(ATLAS):
    with t.ErrorLog() as log:
        ti = t.fetch(OpenDataFile(T1))
    atlas = t.fetch(OpenDataFile(ATLAS))
    sc = ti.GetPointData().GetArray("Scalars")
    t.check(sc is not None and sc.GetDataType() == 10 and "not a label volume" in log.text and "ERR|" not in log.text,
            "float T1: read as intensity 'Scalars' with a warning")
    same = ti.GetDimensions() == atlas.GetDimensions() and np.allclose(ti.GetOrigin(), atlas.GetOrigin()) and \
        np.allclose(ti.GetSpacing(), atlas.GetSpacing())
    md, ma = ti.GetDirectionMatrix(), atlas.GetDirectionMatrix()
    same = same and all(abs(md.GetElement(i, j) - ma.GetElement(i, j)) < 1e-6 for i in range(3) for j in range(3))
    t.check(same, "float T1: same grid as its atlas (origin %s vs %s)" % (ti.GetOrigin(), atlas.GetOrigin()))
t.finish()
