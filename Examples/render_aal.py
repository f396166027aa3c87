# SPDX-License-Identifier: MIT
"""The CSGV demo in pvpython: the AAL brain atlas from NIfTI to .csgv to a Segmentation Volume
with an opaque slice through it, rendered with local shading and with path tracing.

    xvfb-run -a -s "-screen 0 1280x1024x24" pvpython --force-offscreen-rendering \\
        Examples/render_aal.py OUTPUT_DIR [--plugin PATH/CSGV.so] [--size 800x600] [--pt-frames 32]

Steps: the plugin's NIfTI reader opens the atlas in world space (sform applied); SaveData writes
it as .csgv (with .csgv.json geometry); the .csgv opens as Segmentation Volume (the reader's
default); the right hemisphere is clipped away (voxel clip box) and an opaque Slice through the
mid-sagittal plane, coloured by label, fills the cut; the view is saved with local shading and
with path tracing. Prints what it wrote and how long each step took."""
import argparse
import glob
import os
import sys
import time

from paraview.simple import *

AAL = "/usr/share/mricron/templates/aal.nii.gz"


def find_plugin(given):
    if given:
        return given
    if os.environ.get("CSGV_PLUGIN"):
        return os.environ["CSGV_PLUGIN"]
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    found = sorted(glob.glob(os.path.join(root, "build*", "lib", "paraview-*", "plugins", "CSGV", "CSGV.so")),
                   key=os.path.getmtime, reverse=True)
    if not found:
        sys.exit("CSGV.so not found: build the plugin or pass --plugin")
    return found[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("output", help="folder for aal.csgv and the PNGs")
    ap.add_argument("--plugin", help="path of CSGV.so (default: $CSGV_PLUGIN or the newest build*/ folder)")
    ap.add_argument("--input", default=AAL, help="NIfTI label volume (default: the AAL atlas)")
    ap.add_argument("--size", default="800x600", help="image size WxH")
    ap.add_argument("--local-frames", type=int, default=8, help="samples per pixel, local shading")
    ap.add_argument("--pt-frames", type=int, default=32, help="samples per pixel, path tracing")
    ap.add_argument("--pt-budget", type=float, default=120.0, help="seconds the path-traced render may take")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    os.makedirs(args.output, exist_ok=True)

    plugin = find_plugin(args.plugin)
    LoadPlugin(plugin, remote=False, ns=globals())
    print("plugin:", plugin)

    t0 = time.time()
    nifti = NIfTILabelReader(FileName=args.input)
    csgv_path = os.path.join(os.path.abspath(args.output), "aal.csgv")
    SaveData(csgv_path, proxy=nifti)
    print("wrote %s (%.1f KiB, %.1f s)" % (csgv_path, os.path.getsize(csgv_path) / 1024, time.time() - t0))
    Delete(nifti)

    volume = OpenDataFile(csgv_path)
    view = CreateRenderView()
    view.ViewSize = [width, height]
    view.OrientationAxesVisibility = 0
    if "UseColorPaletteForBackground" in view.ListProperties():
        view.UseColorPaletteForBackground = 0
    view.Background = [1.0, 1.0, 1.0]
    display = Show(volume, view)
    print("representation:", display.Representation)
    volume.UpdatePipeline()
    info = volume.GetDataInformation()
    b = info.GetBounds()
    ext = info.GetExtent()
    centre = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]

    # Cut away the right hemisphere (x > centre in RAS world space) and fill the cut with a slice.
    cells_x = ext[1] - ext[0]
    display.CSGVClipBox = [0, cells_x // 2 - 1, 0, 2147483647, 0, 2147483647]
    # The slice lies half a voxel beyond the cut face, through the first removed column of voxels,
    # so that it is neither inside the volume nor on a cell boundary; label 0 is thresholded away.
    spacing_x = (b[1] - b[0]) / cells_x
    slice_ = Slice(Input=volume)
    slice_.SliceType = "Plane"
    slice_.SliceType.Origin = [b[0] + (cells_x // 2 + 0.5) * spacing_x, centre[1], centre[2]]
    slice_.SliceType.Normal = [1, 0, 0]
    labelled = Threshold(Input=slice_, Scalars=["CELLS", "Labels"])
    if "LowerThreshold" in labelled.ListProperties():
        labelled.LowerThreshold, labelled.UpperThreshold = 1, 1e9
    else:
        labelled.ThresholdRange = [1, 1e9]
    slice_display = Show(labelled, view)
    ColorBy(slice_display, ("CELLS", "Labels"))
    label_range = volume.CellData["Labels"].GetRange()
    lut = GetColorTransferFunction("Labels")
    lut.ApplyPreset("Rainbow Uniform", True)
    lut.RescaleTransferFunction(1.0, max(label_range[1], 2.0))
    slice_display.SetScalarBarVisibility(view, False)

    diag = ((b[1] - b[0]) ** 2 + (b[3] - b[2]) ** 2 + (b[5] - b[4]) ** 2) ** 0.5
    view.CameraFocalPoint = centre
    view.CameraPosition = [centre[0] + 0.75 * diag, centre[1] + 0.6 * diag, centre[2] + 0.45 * diag]
    view.CameraViewUp = [0, 0, 1]
    view.CameraViewAngle = 30

    outputs = []
    for name, shading, frames, budget in (("local", "local", args.local_frames, 60.0),
                                          ("pathtraced", "pt", args.pt_frames, args.pt_budget)):
        display.CSGVShading = shading
        display.CSGVFramesPerStillRender = frames
        display.CSGVStillRenderTimeBudget = budget
        png = os.path.join(os.path.abspath(args.output), "aal_%s.png" % name)
        t1 = time.time()
        SaveScreenshot(png, view, ImageResolution=[width, height], TransparentBackground=0)
        display.SMProxy.UpdatePropertyInformation()
        samples = display.SMProxy.GetProperty("CSGVMinSamples").GetElement(0)
        print("wrote %s (%s shading, %d samples per pixel, %.1f s)" % (png, shading, samples, time.time() - t1))
        outputs.append(png)
    Disconnect()  # ParaView 5.11 may crash in Python's teardown while views are alive
    return 0


if __name__ == "__main__":
    sys.exit(main())
