# SPDX-License-Identifier: MIT
"""Run by test_mpi_pieces.py under `pvbatch --symmetric` (every rank runs it), with 1 rank and
with N: each rank writes what its reader gave it (extent, encoding bytes) to OUT/rank<r>.json, and
the composited images of three views go to OUT/<mode>.png (rank 0's; the others write their own
copy, unused). SaveData to .csgv from every rank writes OUT/written/*: the driver compares the
files byte for byte with one rank's. Usage: mpi_pieces.py OUT"""
import json
import os
import sys

from paraview import servermanager as sm
from paraview.simple import *

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

LoadPlugin(os.environ["CSGV_PLUGIN"], remote=False, ns=globals())
out = sys.argv[1]
pm = sm.vtkProcessModule.GetProcessModule()
rank, ranks = pm.GetPartitionId(), pm.GetNumberOfLocalPartitions()
# A relabelled fixture (dense stored ids: attribute arrays can be indexed by them).
path = os.path.join(os.environ["CSGV_FIXTURES"], "synthA_b32_rans2_attr.csgv")
r = CSGVReader(FileName=path, DecodeLabels=0)  # rendered from the encoding alone
r.UpdatePipeline()
img = r.GetClientSideObject().GetOutputDataObject(0)
enc = img.GetFieldData().GetArray("CSGVEncoding")
facts = {"rank": rank, "ranks": ranks, "extent": list(img.GetExtent()),
         "encodingBytes": enc.GetNumberOfTuples() if enc else 0, "fileBytes": os.path.getsize(path)}
# The piece's labels decoded at level 1 (a second reader): the driver compares them with the box
# of one rank's.
coarse = CSGVReader(FileName=path, DecodeLabels=1, Level=1)
coarse.UpdatePipeline()
cimg = coarse.GetClientSideObject().GetOutputDataObject(0)
ce = cimg.GetExtent()
facts["level1Extent"] = list(ce)
vtk_to_numpy(cimg.GetCellData().GetArray("Labels")).reshape(ce[5] - ce[4], ce[3] - ce[2], ce[1] - ce[0]).dump(
    os.path.join(out, "level1.rank%d.npy" % rank))
Delete(coarse)

def segmentation_view(source, position, focal=(66, 35, 97)):
    """A 160x120 view showing `source` as a Segmentation Volume, one sample a pixel."""
    view = CreateRenderView()
    view.ViewSize = [160, 120]
    view.OrientationAxesVisibility = 0
    view.Background = [0, 0, 0]
    # ParaView smooths the image IceT composites in ordered compositing with FXAA (on by
    # default), while one rank's volume image is not: off, translucent images of N ranks are one
    # rank's.
    view.UseFXAA = 0
    display = Show(source, view)
    display.Representation = "Segmentation Volume"
    display.CSGVFramesPerStillRender = 1
    display.CSGVStillRenderTimeBudget = 60
    view.CameraPosition = list(position)
    view.CameraFocalPoint = list(focal)
    view.CameraViewUp = [0, 0, 1]
    return view, display


v, d = segmentation_view(r, (-60, 130, 160))
glass = json.dumps({"version": 1, "materials": [
    {"name": "glass", "filter": {"attribute": "label", "min": 1, "max": 4294967294}, "opacity": 0.4}]})
# Computed attributes are the whole volume's on every rank (summed over the ranks): a material
# that keeps the labels of more than 3000 voxels draws what one rank draws.
big = json.dumps({"version": 1, "materials": [
    {"name": "big", "filter": {"attribute": "voxel_count", "min": 3000, "max": 1e12}}]})
# The clip box is in the volume's voxels on every rank (each draws its piece in the volume's index
# space): a box across the pieces' boundaries cuts every rank's piece where it cuts one rank's.
# Shadow, ambient-occlusion and path-tracing rays meet other ranks' bricks at their level of
# detail (the whole volume's coarse levels, shared by the ranks); the denoiser is off (it filters
# across the screen, and each rank's image has holes where the others draw).
# With the denoiser (ao_denoised) each rank filters its own image, whose neighbours end at the
# piece's edge on the screen.
def record_picks(suffix):
    picks = {}
    for y in range(4, 120, 12):
        for x in range(4, 160, 12):
            p = csgv_tools.pick(d, x, y)
            picks["%d %d" % (x, y)] = [p.get("hit"), p.get("label"), p.get("voxel"), p.get("translucent")]
    facts["picks" + suffix] = picks
    facts["labels" + suffix] = csgv_tools.query(d, "labels")


for mode in ("opaque", "translucent", "shadow", "ao", "pt", "ao_denoised", "computed", "clipped"):
    d.CSGVMaterials = glass if mode == "translucent" else big if mode == "computed" else ""
    d.CSGVShading = mode if mode in ("shadow", "ao", "pt") else "ao" if mode == "ao_denoised" else "local"
    d.CSGVDenoise = 1 if mode == "ao_denoised" else 0
    d.CSGVComputedAttributes = 1 if mode == "computed" else 0
    d.CSGVClipBox = [20, 100, 5, 60, 50, 150] if mode == "clipped" else [0, 2147483647] * 3
    Render(v)
    facts["ordered_" + mode] = bool(v.GetClientSideObject().GetUseOrderedCompositing())
    name = mode + (".png" if rank == 0 else ".rank%d.png" % rank)
    SaveScreenshot(os.path.join(out, name), v, ImageResolution=[160, 120], TransparentBackground=0)
    if mode in ("opaque", "translucent"):
        # Queries answered by all ranks together (vtkCSGVQuery): picks on a grid of pixels and
        # the label image of this render (translucent: the first semi-transparent surfaces).
        record_picks("" if mode == "opaque" else "_" + mode)
    if mode == "computed":
        # The attributes of picked labels: whole-volume values on every rank.
        computed = {}
        for y in range(4, 120, 12):
            for x in range(4, 160, 12):
                p = csgv_tools.pick(d, x, y)
                if p.get("hit"):
                    a = p.get("attributes", {})
                    computed[str(p["label"])] = [a.get(k) for k in ("voxel_count", "surface_area", "bbox_min_x",
                                                                    "bbox_max_z", "centroid_y")]
        facts["computed"] = computed
        # The summary (attribute ranges, label count) and the drawn labels' colours over all ranks.
        facts["summary"] = csgv_tools.attribute_summary(d)
        facts["colors"] = json.loads(csgv_tools.query(d, "colors 100000"))
# Half the labels semi-transparent, half opaque: where a rank's semi-transparent surface lies in
# front of another rank's opaque one, the opaque one is the pixel's hit, as at one rank.
# (A constant: under pvbatch --symmetric only rank 0's query answer is the combined one, so a
# bound computed from it would differ between ranks, and so would their materials.)
middle = 2 ** 31
d.CSGVMaterials = json.dumps({"version": 1, "materials": [
    {"name": "glass", "filter": {"attribute": "label", "min": 1, "max": middle}, "opacity": 0.4},
    {"name": "solid", "filter": {"attribute": "label", "min": middle + 1, "max": 4294967294}}]})
d.CSGVComputedAttributes = 0
d.CSGVClipBox = [0, 2147483647] * 3
d.CSGVShading = "local"
d.CSGVDenoise = 0
Render(v)
record_picks("_mixed")
# ParaView's defaults: the representation's samples a pixel for a still render and the view's
# FXAA on, opaque and translucent. The ranks' images of several samples a pixel are blended in
# visibility order (a pixel on a piece's silhouette holds that piece's share of the samples).
frames = d.GetProperty("CSGVFramesPerStillRender")
frames.SMProperty.ResetToDefault()
d.UpdateVTKObjects()
facts["default_frames"] = d.CSGVFramesPerStillRender
d.CSGVMaterials = ""
d.CSGVClipBox = [0, 2147483647] * 3
d.CSGVShading = "local"
v.UseFXAA = 1
# With another display in the view (ParaView redistributes its geometry by the pieces' bounds).
box = Show(Outline(Input=r), v)
box.AmbientColor = box.DiffuseColor = [1, 1, 0]
for mode in ("defaults_opaque", "defaults_translucent"):
    d.CSGVMaterials = glass if mode == "defaults_translucent" else ""
    Render(v)
    facts["ordered_" + mode] = bool(v.GetClientSideObject().GetUseOrderedCompositing())
    SaveScreenshot(os.path.join(out, mode + (".png" if rank == 0 else ".rank%d.png" % rank)), v,
                   ImageResolution=[160, 120], TransparentBackground=0)
    if mode == "defaults_opaque":  # the statistics of every rank together (the `render` query)
        facts["render_stats"] = csgv_tools.render_stats(d)
Hide(box.Input, v)
d.CSGVMaterials = ""
d.CSGVFramesPerStillRender = 1
# Off again, and set anew (see the second view below).
v.UseFXAA = 1
v.UseFXAA = 0
Render(v)

# A plain label image (a source's integer point data, no .csgv): each rank asks for its whole
# bricks of the whole image, compresses them and draws them in the whole image's index space.
Hide(r, v)
wave = Wavelet(WholeExtent=[0, 80, 0, 60, 0, 100])


def show_labels(function, name):
    """A Calculator's integer point data `name` = `function` of the wavelet, shown in v."""
    labels = Calculator(Input=wave, ResultArrayName=name, ResultArrayType="Int", Function=function)
    display = Show(labels, v)
    display.Representation = "Segmentation Volume"
    display.CSGVLabelArray = name
    display.CSGVFramesPerStillRender = 1
    display.CSGVStillRenderTimeBudget = 60
    display.CSGVDenoise = 0
    return display


def shot(mode, display, shading, lowest, opacity):
    """Renders v with one material from label `lowest` up and saves it as OUT/<mode>.png."""
    display.CSGVShading = shading
    display.CSGVMaterials = json.dumps({"version": 1, "materials": [
        {"name": "m", "filter": {"attribute": "label", "min": lowest, "max": 4294967294}, "opacity": opacity}]})
    Render(v)
    SaveScreenshot(os.path.join(out, mode + (".png" if rank == 0 else ".rank%d.png" % rank)), v,
                   ImageResolution=[160, 120], TransparentBackground=0)


p = show_labels("floor(abs(RTData)/25)", "lab")
v.CameraFocalPoint = [40, 30, 50]
shot("plain", p, "shadow", 4, 1)
shot("plain_translucent", p, "local", 3, 0.4)
# A plain image whose labels are negative: relabelled to dense ids, the same ids on every rank as
# one rank gives the whole image (the ranks agree on them in the data phase); materials filter on
# those ids (the originals do not fit 32 bits), so any rank numbering its labels apart would draw
# other labels.
Hide(p, v)
q = show_labels("floor(abs(RTData)/25) - 4", "neg")
shot("plain_relabelled", q, "shadow", 3, 1)
Hide(q, v)
# A second view of the same reader (its own renderer and cache on every rank, one upload): its
# image equals one rank's too (1 of 19200 pixels beyond 16/255 at 4 ranks). It comes last:
# pvbatch's views share one render window, and after a second view is made and deleted the
# first one's composited images are smoothed by FXAA again although its UseFXAA stays off (a
# translucent render then differed from one rank's in 1.3 % of pixels; setting UseFXAA again, on
# then off, mends it: each rank's framebuffer was the same either way).
d.CSGVShading = "local"
d.CSGVMaterials = ""
d.CSGVClipBox = [0, 2147483647] * 3
v2, d2 = segmentation_view(r, (200, -90, 40))
d2.CSGVShading = "shadow"
Render(v2)
SaveScreenshot(os.path.join(out, "view2" + (".png" if rank == 0 else ".rank%d.png" % rank)), v2,
               ImageResolution=[160, 120], TransparentBackground=0)
# A label image where ranks drew nothing (attack pass 8: a rank without a label image aborted the
# job in the gather): the display hidden, then one rank's piece off the screen.
Hide(r, v2)
Render(v2)
hidden = csgv_tools.label_image(d2)
facts["hidden_label_image"] = list(hidden.shape)
Show(r, v2)
v2.CameraFocalPoint = [66, 35, 20]  # from the side, near z = 0: the pieces beyond z = 48 are off the screen
v2.CameraPosition = [-100, 35, 20]
v2.CameraViewUp = [0, 0, 1]
v2.CameraParallelScale = 12
v2.CameraParallelProjection = 1
Render(v2)
corner = csgv_tools.label_image(d2)
facts["corner_labels"] = int((corner != 0xFFFFFFFF).sum()) if corner.size else -1
Delete(d2)
del d2
Delete(v2)
del v2

# The filters of the whole encoding under MPI (attack pass 8): a piece encoding is a volume of its
# own, so the Label Table listed labels once a piece (bounding boxes in the piece's coordinates),
# Extract Labels meshed each piece (walls where pieces meet, nothing where a label was missing),
# and CSGV Extract refused every piece. Rank 0 makes the table and the meshes from the whole
# volume, the other ranks nothing; CSGV Extract's pieces are the one rank's image's parts.
def local(proxy):
    proxy.UpdatePipeline()
    return proxy.GetClientSideObject().GetOutputDataObject(0)


table = local(CSGVLabelTable(Input=r, ComputedAttributes=1))
rows = []
for i in range(table.GetNumberOfRows()):
    rows.append([str(table.GetValue(i, c)) for c in range(table.GetNumberOfColumns())])
facts["table_rows"] = sorted(rows)
meshes = local(CSGVExtractLabels(Input=r, Query="label % 7 = 0"))
facts["mesh"] = [meshes.GetNumberOfPoints(), meshes.GetNumberOfCells(), list(meshes.GetBounds())] \
    if meshes.GetNumberOfCells() else [0, 0, []]
voi = local(CSGVExtract(Input=r, VOI=[10, 90, 0, 69, 20, 150]))
voi_labels = voi.GetCellData().GetArray("Labels") if voi.GetNumberOfCells() else None
facts["voi"] = [list(voi.GetExtent()), int(voi_labels.GetNumberOfTuples()) if voi_labels else 0,
                int(sum(int(voi_labels.GetTuple1(i)) for i in range(voi_labels.GetNumberOfTuples()))) if voi_labels else 0]
# A reader that fails on one rank only (attack pass 8: the others' pieces passed for the whole
# volume, the failure on that rank's stderr alone): the last brick's start out of order fails the
# last rank's piece (and one rank's whole file); the combined summary names the rank.
import struct
bad = os.path.join(out, "bad_last_start.csgv")
if rank == 0:
    raw = bytearray(open(path, "rb").read())
    mode = struct.unpack_from("<i", raw, 28)[0]
    at = 41 + {1: 64, 2: 128}.get(mode, 0) + 4  # the encoder section, bricks per array
    n = struct.unpack_from("<Q", raw, at)[0]
    struct.pack_into("<I", raw, at + 8 + 4 * (n - 2), 5)  # start of the last brick
    with open(bad, "wb") as f:
        f.write(bytes(raw))
sm.vtkProcessModule.GetProcessModule().GetGlobalController().Barrier()
badReader = CSGVReader(FileName=bad)
vb = CreateRenderView()
vb.ViewSize = [64, 48]
db = Show(badReader, vb)
db.Representation = "Segmentation Volume"
Render(vb)
facts["bad_summary"] = csgv_tools.attribute_summary(db)
# Fewer bricks than ranks (one), at the default samples a pixel: the ranks without a piece took
# no part in ordered compositing and the job hung at the first render.
one = os.path.join(out, "one_brick.csgv")
if rank == 0:
    import subprocess
    subprocess.run([os.environ["CSGV_TOOL"], "compress", "synth:20x20x20", one], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
sm.vtkProcessModule.GetProcessModule().GetGlobalController().Barrier()
oneReader = CSGVReader(FileName=one)
d1 = Show(oneReader, vb)
d1.Representation = "Segmentation Volume"
d1.CSGVFramesPerStillRender = 4
Hide(badReader, vb)
vb.ResetCamera()
Render(vb)
facts["one_brick_labels"] = int((csgv_tools.label_image(d1) != 0xFFFFFFFF).sum())
Delete(d1)
del d1
Delete(db)
del db
Delete(vb)
del vb
with open(os.path.join(out, "rank%d.json" % rank), "w") as f:
    json.dump(facts, f)

# Parallel SaveData: every rank encodes its bricks, rank 0 writes one file. The reader's labels
# with other brick sizes and encodings than the file's; a plain image's point data whose labels
# are negative (relabelled with the ids of one rank) and the same forced; one brick for all ranks
# (the others hold none); a float array that is not integer in one place (an error on every
# rank, no file).
written = os.path.join(out, "written")
if rank == 0:
    os.makedirs(written, exist_ok=True)
sm.vtkProcessModule.GetProcessModule().GetGlobalController().Barrier()
labels = CSGVReader(FileName=path, DecodeLabels=1)
for brick, encoding in ((16, 0), (32, 2), (8, 1)):
    SaveData(os.path.join(written, "synthA_b%d_e%d.csgv" % (brick, encoding)), proxy=labels, BrickSize=brick,
             Encoding=encoding)
wavelet = Wavelet(WholeExtent=[0, 40, 0, 30, 0, 20])
negative = Calculator(Input=wavelet, ResultArrayName="lab", ResultArrayType="Int", Function="floor(RTData/20)")
SaveData(os.path.join(written, "negative.csgv"), proxy=negative, BrickSize=8, LabelArrayName="lab")
SaveData(os.path.join(written, "forced.csgv"), proxy=labels, BrickSize=32, Relabel=1)
# A CSGV reader's volume of one brick: ranks without bricks get images without arrays (every rank
# failed when rank 0 was one of them: attack pass 8).
SaveData(os.path.join(written, "one_brick.csgv"), proxy=CSGVReader(FileName=one, DecodeLabels=1))
SaveData(os.path.join(written, "onebrick.csgv"), proxy=negative, BrickSize=64, LabelArrayName="lab", Encoding=1)
fraction = Calculator(Input=wavelet, ResultArrayName="f", ResultArrayType="Float",
                      Function="floor(RTData/20) + 0.5*(coordsX==35)*(coordsY==25)*(coordsZ==15)")
SaveData(os.path.join(written, "fraction.csgv"), proxy=fraction, BrickSize=8, LabelArrayName="f")
