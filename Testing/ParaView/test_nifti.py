# SPDX-License-Identifier: MIT
"""NIfTI through the plugin: OpenDataFile finds the reader for .nii.gz, the AAL atlas lands in
world space as cell data (first voxel spans (-90.5,-125.5,-71.5)..(-89.5,-124.5,-70.5), its
centre (-90, -125, -71) where the file puts it), values equal VTK's own NIfTI reader, the .csgv
that `csgv compress` writes of the same atlas has equal bounds and equal cell labels, and
AAL -> ParaView's .csgv writer -> reader keeps every label."""
import os
import shutil
import gzip
import subprocess

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
t.check(img.GetDimensions() == (182, 218, 182), "AAL: 181x217x181 voxels as cells (%s points)" % (img.GetDimensions(),))
t.check(np.allclose(img.GetOrigin(), (-90.5, -125.5, -71.5)),
        "AAL: origin at the corner of the first voxel (%s)" % (img.GetOrigin(),))
t.check(np.allclose(img.GetSpacing(), (1, 1, 1)), "AAL spacing 1 mm")


def first_cell_centre(image):
    b = image.GetCell(0).GetBounds()
    return [(b[2 * a] + b[2 * a + 1]) / 2 for a in range(3)]


t.check(np.allclose(first_cell_centre(img), (-90, -125, -71)), "AAL: first voxel centred where the file puts it")
t.check(img.GetPointData().GetNumberOfArrays() == 0, "AAL: no point data (voxels are cells)")
labels = t.cell_labels(img)
vtk_reader = vtkNIFTIImageReader()
vtk_reader.SetFileName(t.AAL)
vtk_reader.Update()
reference = vtk_to_numpy(vtk_reader.GetOutput().GetPointData().GetScalars())
t.check(labels is not None and labels.dtype == reference.dtype and np.array_equal(labels, reference),
        "labels equal vtkNIFTIImageReader's (%s, %d labels)" % (None if labels is None else labels.dtype,
                                                               len(np.unique(reference))))

# The .csgv that Core's `csgv compress` writes of the same atlas overlays it exactly: same points,
# same bounds, same cell labels.
tool = os.environ.get("CSGV_TOOL", "")
t.check(os.path.isfile(tool), "csgv tool found (CSGV_TOOL=%r)" % tool)
if os.path.isfile(tool):
    compressed = os.path.join(tmp, "aal_tool.csgv")
    subprocess.run([tool, "compress", t.AAL, compressed], check=True, stdout=subprocess.DEVNULL)
    timg = t.fetch(CSGVReader(FileName=compressed))
    t.check(timg.GetDimensions() == img.GetDimensions() and np.allclose(timg.GetOrigin(), img.GetOrigin())
            and np.allclose(timg.GetSpacing(), img.GetSpacing()),
            "csgv compress: same grid as the NIfTI reader's (%s %s)" % (timg.GetDimensions(), timg.GetOrigin()))
    t.check(np.allclose(timg.GetBounds(), img.GetBounds()),
            "csgv compress: equal bounds (%s vs %s)" % (timg.GetBounds(), img.GetBounds()))
    tl = t.cell_labels(timg)
    t.check(tl is not None and np.array_equal(tl, labels), "csgv compress: equal cell labels")

# An uncompressed .nii is found too.
nii = os.path.join(tmp, "aal.nii")
with gzip.open(t.AAL, "rb") as f, open(nii, "wb") as g:
    shutil.copyfileobj(f, g)
r2 = OpenDataFile(nii)
t.check(r2 is not None and r2.GetXMLName() == "CSGVNIfTIReader", ".nii opened by the plugin's NIfTI reader")
t.check(np.array_equal(t.cell_labels(t.fetch(r2)), labels), ".nii labels equal the .nii.gz ones")

# AAL -> ParaView's .csgv writer -> reader.
out = os.path.join(tmp, "aal.csgv")
SaveData(out, proxy=r)
c = OpenDataFile(out)
cimg = t.fetch(c)
t.check(cimg.GetDimensions() == img.GetDimensions(), "csgv: the same dims")
t.check(np.allclose(cimg.GetOrigin(), img.GetOrigin()), "csgv: the same origin (%s)" % (cimg.GetOrigin(),))
got = t.cell_labels(cimg)
t.check(got is not None and got.dtype == labels.dtype and np.array_equal(got, labels), "csgv: AAL labels equal")
t.log("AAL: %d bytes as .csgv, %d voxels, %.3f bits per voxel" % (
    os.path.getsize(out), labels.size, 8.0 * os.path.getsize(out) / labels.size))
# An intensity image (float T1) is not a label volume: VTK's reader takes over, with a warning,
# and it lands on the grid of the atlas drawn in the same space (read through Core).
T1 = "/usr/share/mricron/templates/inia19-t1-brain.nii.gz"
ATLAS = "/usr/share/mricron/templates/inia19-NeuroMaps.nii.gz"
if os.path.exists(T1) and os.path.exists(ATLAS):
    # The header decides which reader proxy opens a file (and so its default representation):
    # a float image without the label intent gets the image reader, a float atlas with it the
    # label reader.
    with t.ErrorLog() as log:
        t1_reader = OpenDataFile(T1)
        ti = t.fetch(t1_reader)
    atlas_reader = OpenDataFile(ATLAS)
    t.check(t1_reader.GetXMLName() == "CSGVNIfTIImageReader", "float T1: opened by the NIfTI Image Reader")
    t.check(atlas_reader.GetXMLName() == "CSGVNIfTIReader", "atlas with the label intent: opened by the label reader")
    atlas = t.fetch(atlas_reader)
    sc = ti.GetPointData().GetArray("Scalars")
    t.check(sc is not None and sc.GetDataType() == 10 and not log.text,
            "float T1: read as intensity 'Scalars', without warnings (%s)" % log.text)
    # The label reader, asked for it explicitly, reads it the same way and says why.
    with t.ErrorLog() as log:
        tl = t.fetch(NIfTILabelReader(FileName=T1))
    t.check(tl.GetPointData().GetArray("Scalars") is not None and "not a label volume" in log.text
            and "ERR|" not in log.text, "float T1 through the label reader: intensity, with a warning")
    # Intensities stay point data (voxel centres): on the cell centres of the atlas.
    same = tuple(n + 1 for n in ti.GetDimensions()) == atlas.GetDimensions() and \
        np.allclose(ti.GetSpacing(), atlas.GetSpacing())
    md, ma = ti.GetDirectionMatrix(), atlas.GetDirectionMatrix()
    same = same and all(abs(md.GetElement(i, j) - ma.GetElement(i, j)) < 1e-6 for i in range(3) for j in range(3))
    centre = first_cell_centre(atlas)
    same = same and np.allclose(ti.GetPoint(0), centre)
    t.check(same, "float T1: its points on the cell centres of its atlas (%s vs %s)" % (ti.GetPoint(0), centre))
# An 8-bit image without the label intent is not told apart from a segmentation by its header:
# integer voxels count as labels.
CH2 = "/usr/share/mricron/templates/ch2.nii.gz"
if os.path.exists(CH2):
    t.check(OpenDataFile(CH2).GetXMLName() == "CSGVNIfTIReader", "uint8 without intent: the label reader")
t.finish()
