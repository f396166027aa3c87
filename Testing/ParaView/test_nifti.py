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

# An atlas's label names beside it (MRIcron's `aal.nii.txt`, "index name code" lines) are the
# Segmentation Volume's attributes without Load attributes: names in picks and the legend. A
# `.txt` beside that is not a table adds nothing and says nothing (it is not the user's file).
import json
import sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools as ct  # noqa: E402
view = t.render_view(96, 72)


def attribute_names(reader):
    d = Show(reader, view)
    d.SetRepresentationType("Segmentation Volume")
    d.CSGVFramesPerStillRender = 1
    view.ResetCamera()
    Render(view)
    names = [a["name"] for a in json.loads(ct.query(d, "summary"))["attributes"]]
    Hide(reader, view)
    return names


TABLE = os.path.splitext(t.AAL)[0] + ".txt"  # aal.nii.gz -> aal.nii.txt
if os.path.exists(TABLE):
    t.check(attribute_names(r) == ["label", "name", "code"],
            "aal.nii.gz with aal.nii.txt beside it: its columns are attributes (%s)" % attribute_names(r))
    names = {int(line.split()[0]): line.split()[1] for line in open(TABLE) if line.strip()}
    colors = json.loads(ct.query(GetDisplayProperties(r, view), "colors 4096"))
    named = {e[0]: e[4] for e in colors["labels"]}
    t.check(colors.get("text") == "name" and all(named[k] == names[k] for k in named if k in names) and len(named) == 116,
            "the legend's colours carry the region names (%d labels, %s)" % (len(named), list(named.items())[:2]))
t.check(attribute_names(r2) == ["label"], "a .nii without a table beside it: the label alone")
with_table = os.path.join(tmp, "atlas.nii")
shutil.copyfile(nii, with_table)
with open(with_table[:-4] + ".nii.txt", "w") as f:
    f.write("1 first 10\n2 second 20\n")
r3 = OpenDataFile(with_table)
t.check(attribute_names(r3) == ["label", "name", "code"], "a .nii with a table beside it (%s)" % attribute_names(r3))
garbage = os.path.join(tmp, "garbage.nii")
shutil.copyfile(nii, garbage)
with open(garbage + ".txt", "wb") as f:
    f.write(bytes(range(256)) * 64)
with t.ErrorLog() as log:
    r4 = OpenDataFile(garbage)
    got = attribute_names(r4)
t.check(got == ["label"] and log.text.strip() == "", "a .txt beside that is not a table: nothing added, nothing said (%s, %s)"
        % (got, log.text.strip()[:200]))
Delete(r3)
Delete(r4)

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
