# SPDX-License-Identifier: MIT
"""Segmentation Volume next to ParaView's own "Volume" representation (vtkSmartVolumeMapper,
nearest interpolation), on the same data, camera and resolution.

    xvfb-run -a -s "-screen 0 1280x1024x24" pvbatch --force-offscreen-rendering \\
        Examples/compare_vtk.py --input DATA [--size 640x360] [--frames 20] [--output DIR] [--demos]

DATA is a .csgv (VTK's side gets the reader's decoded labels; ours keeps them compressed,
DecodeLabels off), a NIfTI label volume (the plugin's NIfTI reader, point data; ours compresses
it on the fly) or any image file ParaView opens. For each representation the script prints:
read time, time to first frame (Show to the end of the first render, data already read), the
median of N frame times (the camera turns 1 degree before each render; ours renders one frame
per render: FramesPerStillRender 1, local shading), and peak resident memory (each side runs in a
child pvbatch of its own, so peaks do not mix; the base of an empty session is printed too). It
saves VTK's image (left) and ours (right) side by side.

VTK's transfer function shows the same labels: opacity 0 for label 0 and 1 for every other
label (a step), colours from one control point a label (flat colours, no shading); building that function is
quadratic in VTK, so it is timed apart (not in VTK's time to first frame).
VTK volume-renders labels as float textures and samples its transfer functions into a texture
of limited width, so it goes wrong where labels do not survive float32 (above 2^24) or where the
label range holds more labels than the transfer-function texture has texels. --demos builds two
small volumes that show both, with odd labels red and even labels blue in both renderers, and
prints how many volume pixels VTK colours like the exact renderer.
"""
import argparse
import glob
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def find_plugin(given):
    if given:
        return given
    if os.environ.get("CSGV_PLUGIN"):
        return os.environ["CSGV_PLUGIN"]
    found = sorted(glob.glob(os.path.join(os.path.dirname(HERE), "build*", "lib", "paraview-*", "plugins",
                                          "CSGV", "CSGV.so")), key=os.path.getmtime, reverse=True)
    if not found:
        sys.exit("CSGV.so not found: build the plugin or pass --plugin")
    return found[0]


def memory_kib():
    out = {}
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(("VmRSS:", "VmHWM:")):
                out[line.split(":")[0]] = int(line.split()[1])
    return out


# --------------------------------------------------------------------------------------------
# Child: one representation, timed


def label_hash_colour(label):
    """A stable pseudo-random colour per label for VTK's table (not the same colours as ours)."""
    h = (label * 2654435761) & 0xFFFFFFFF
    h ^= h >> 15
    h = (h * 2246822519) & 0xFFFFFFFF
    h ^= h >> 13
    return [0.2 + 0.8 * ((h >> s) & 255) / 255.0 for s in (0, 8, 16)]


def run_child(args):
    from paraview.simple import (CreateRenderView, Disconnect, GetColorTransferFunction, GetOpacityTransferFunction,
                                 LoadPlugin, OpenDataFile, Render, SaveScreenshot, Show)
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy

    base = memory_kib()
    LoadPlugin(find_plugin(args.plugin), remote=False, ns=globals())
    width, height = (int(v) for v in args.size.lower().split("x"))
    ours = args.only == "csgv"

    t0 = time.time()
    path = args.input
    if path.endswith((".nii", ".nii.gz")):
        reader = globals()["NIfTILabelReader"](FileName=path)
    else:
        reader = OpenDataFile(path)
        if reader is None:
            sys.exit("ParaView cannot open " + path)
        if ours and "DecodeLabels" in reader.ListProperties():
            reader.DecodeLabels = 0  # the representation uses the encoding itself
    reader.UpdatePipeline()
    read_s = time.time() - t0
    info = reader.GetDataInformation()
    b = info.GetBounds()

    view = CreateRenderView()
    view.ViewSize = [width, height]
    view.OrientationAxesVisibility = 0
    if "UseColorPaletteForBackground" in view.ListProperties():
        view.UseColorPaletteForBackground = 0
    view.Background = [1.0, 1.0, 1.0]
    centre = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
    diag = ((b[1] - b[0]) ** 2 + (b[3] - b[2]) ** 2 + (b[5] - b[4]) ** 2) ** 0.5
    view.CameraFocalPoint = centre
    view.CameraPosition = [centre[0] + 0.8 * diag, centre[1] - 1.2 * diag, centre[2] + 0.7 * diag]
    view.CameraViewUp = [0, 0, 1]
    view.CameraViewAngle = 30

    if not ours:
        # The label array and its distinct labels (set-up of the transfer function, untimed).
        image = reader.GetClientSideObject().GetOutputDataObject(0)
        arr = None
        for attrs, assoc in ((image.GetCellData(), "CELLS"), (image.GetPointData(), "POINTS")):
            for i in range(attrs.GetNumberOfArrays()):
                a = attrs.GetArray(i)
                if a is not None and a.GetNumberOfComponents() == 1 and not a.GetName().startswith("vtk"):
                    arr, association = a, assoc
                    break
            if arr is not None:
                break
        if arr is None:
            sys.exit("no label array for VTK's volume representation")
        labels = np.unique(vtk_to_numpy(arr)).astype(np.float64)
        labels = labels[labels != 0]
        if args.parity:
            colour = {True: [1.0, 0.0, 0.0], False: [0.0, 0.0, 1.0]}
            colours = [colour[int(l) % 2 == 1] for l in labels]
        else:
            colours = [label_hash_colour(int(l)) for l in labels]
        # One control point a label: exact at integer labels as long as the table has a texel
        # per label (VTK builds the function in O(n^2): ~20 s for 16384 labels here).
        points = []
        for l, c in zip(labels, colours):
            points += [l] + c
        t_tf = time.time()
        lut = GetColorTransferFunction(arr.GetName())
        lut.AutomaticRescaleRangeMode = "Never"
        lut.Discretize = 0
        lut.ColorSpace = "RGB"
        lut.RGBPoints = points
        pwf = GetOpacityTransferFunction(arr.GetName())
        hi = float(labels.max()) if len(labels) else 1.0
        pwf.Points = [0.0, 0.0, 0.5, 0.0, 0.5001, 1.0, 0.5, 0.0, max(hi, 1.0), 1.0, 0.5, 0.0]
        tf_setup_s = time.time() - t_tf
    t1 = time.time()
    if ours:
        display = Show(reader, view, "UniformGridRepresentation")
        display.SetRepresentationType("Segmentation Volume")
        display.CSGVShading = "local"
        display.CSGVFramesPerStillRender = 1
        if args.materials:
            display.CSGVMaterials = open(args.materials).read()
    else:
        display = Show(reader, view, "UniformGridRepresentation")
        display.SetRepresentationType("Volume")
        display.ColorArrayName = [association, arr.GetName()]
        display.LookupTable = lut
        display.ScalarOpacityFunction = pwf
        display.InterpolationType = "Nearest"
        display.Shade = 0
        display.ScalarOpacityUnitDistance = 1e-3 * diag
        display.SetScalarBarVisibility(view, False)
    Render(view)
    first_s = time.time() - t1
    png = os.path.join(args.output, "%s_%s.png" % (args.tag, args.only))
    SaveScreenshot(png, view, ImageResolution=[width, height], TransparentBackground=0)

    camera = view.GetActiveCamera()
    times = []
    for i in range(args.frames):
        camera.Azimuth(1.0)
        t = time.time()
        Render(view)
        times.append(time.time() - t)
    times.sort()
    device_mib = None
    if ours:
        display.SMProxy.UpdatePropertyInformation()
        device_mib = display.SMProxy.GetProperty("CSGVDeviceMiB").GetElement(0)
    mem = memory_kib()
    result = {
        "representation": "Segmentation Volume" if ours else "Volume (vtkSmartVolumeMapper)",
        "read_s": read_s,
        "tf_setup_s": None if ours else tf_setup_s,
        "first_frame_s": first_s,
        "median_frame_ms": 1000 * times[len(times) // 2] if times else None,
        "frames": len(times),
        "peak_rss_mib": mem["VmHWM"] / 1024.0,
        "device_mib": device_mib,
        "session_base_mib": base["VmRSS"] / 1024.0,
        "png": png,
    }
    print("RESULT " + json.dumps(result))
    sys.stdout.flush()
    Disconnect()
    return 0


# --------------------------------------------------------------------------------------------
# Parent: both sides, the side-by-side image, the demonstrations


def run_side(args, only, input_path, tag, materials=None, parity=False):
    cmd = [args.pvbatch, "--force-offscreen-rendering", os.path.abspath(__file__), "--only", only,
           "--input", input_path, "--size", args.size, "--frames", str(args.frames), "--output", args.output,
           "--tag", tag, "--plugin", find_plugin(args.plugin)]
    if materials:
        cmd += ["--materials", materials]
    if parity:
        cmd += ["--parity"]
    run = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    for line in run.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    sys.stdout.write(run.stdout)
    sys.exit("%s side failed (rc %d)" % (only, run.returncode))


def read_png(path):
    from vtkmodules.vtkIOImage import vtkPNGReader
    from vtkmodules.util.numpy_support import vtk_to_numpy
    r = vtkPNGReader()
    r.SetFileName(path)
    r.Update()
    img = r.GetOutput()
    w, h, _ = img.GetDimensions()
    return vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)[:, :, :3]


def write_side_by_side(left, right, path):
    import numpy as np
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkIOImage import vtkPNGWriter
    a, b = read_png(left), read_png(right)
    gap = np.full((a.shape[0], 8, 3), 128, np.uint8)
    both = np.ascontiguousarray(np.concatenate([a, gap, b], axis=1))
    img = vtkImageData()
    img.SetDimensions(both.shape[1], both.shape[0], 1)
    img.GetPointData().SetScalars(numpy_to_vtk(both.reshape(-1, 3), deep=1))
    w = vtkPNGWriter()
    w.SetFileName(path)
    w.SetInputData(img)
    w.Write()


def report(tag, vtk, ours, args):
    print("== %s (%s, %s, local shading, %d frames) ==" % (tag, args.input if tag == "data" else tag, args.size,
                                                          args.frames))
    print("%-32s %10s %12s %14s %12s" % ("representation", "read s", "1st frame s", "median ms", "peak MiB"))
    for r in (vtk, ours):
        print("%-32s %10.2f %12.2f %14.1f %12.1f" % (r["representation"], r["read_s"], r["first_frame_s"],
                                                      r["median_frame_ms"] or 0, r["peak_rss_mib"]))
    print("VTK transfer function set-up (one point a label, not in its first frame): %.2f s" % vtk["tf_setup_s"])
    print("session base (empty pvbatch with the plugin): %.1f MiB" % ours["session_base_mib"])
    if ours.get("device_mib") is not None:
        print("Segmentation Volume device memory (encoding, brick cache, buffers): %.1f MiB" % ours["device_mib"])
    if vtk["median_frame_ms"] and ours["median_frame_ms"]:
        print("frame time ratio VTK / Segmentation Volume: %.2f" % (vtk["median_frame_ms"] / ours["median_frame_ms"]))
    print("time to first frame ratio VTK / Segmentation Volume: %.2f" % (vtk["first_frame_s"] / ours["first_frame_s"]))
    side = os.path.join(args.output, "%s_side_by_side.png" % tag)
    write_side_by_side(vtk["png"], ours["png"], side)
    print("images: %s (left: VTK, right: Segmentation Volume)" % side)
    sys.stdout.flush()


def parity_agreement(vtk_png, ours_png):
    """Fraction of the exact renderer's volume pixels that VTK colours in the same class
    (red-dominant for odd labels, blue-dominant for even)."""
    import numpy as np
    a, b = read_png(vtk_png).astype(int), read_png(ours_png).astype(int)
    def cls(p):
        return np.where(p[..., 0] > p[..., 2] + 30, 1, np.where(p[..., 2] > p[..., 0] + 30, 2, 0))
    ca, cb = cls(a), cls(b)
    mask = cb > 0
    return float((ca[mask] == cb[mask]).mean()) if mask.any() else float("nan"), int(mask.sum())


def make_demo_volume(path, base_label, size=96, block=2, anchor=False):
    """Labels base + block index (x fastest) in blocks of block^3 voxels, as cell data; with
    `anchor`, the first block holds label 1 instead, so the label range starts at 1 (as in real
    segmentations whose ids spread over the whole 32-bit range)."""
    import numpy as np
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkIOXML import vtkXMLImageDataWriter
    n = size // block
    k, j, i = np.meshgrid(np.arange(size), np.arange(size), np.arange(size), indexing="ij")
    labels = (base_label + (i // block) + n * (j // block) + n * n * (k // block)).astype(np.uint32)
    if anchor:
        labels[:block, :block, :block] = 1
    img = vtkImageData()
    img.SetDimensions(size + 1, size + 1, size + 1)
    arr = numpy_to_vtk(labels.ravel(), deep=1, array_type=7)  # VTK_UNSIGNED_INT
    arr.SetName("labels")
    img.GetCellData().AddArray(arr)
    w = vtkXMLImageDataWriter()
    w.SetFileName(path)
    w.SetInputData(img)
    w.Write()
    return sorted(int(v) for v in np.unique(labels)) if n ** 3 <= 4096 else None, n ** 3


def parity_materials(path):
    """Odd labels red, even labels blue, through a repeating colormap on the label."""
    doc = {"version": 1, "materials": [{
        "name": "parity", "filter": {"attribute": "label", "min": 1, "max": 4294967294},
        "color": {"mode": "colormap", "attribute": "label", "min": -0.5, "max": 1.5, "wrap": "repeat",
                  "colormap": [[0, 0, 0, 1], [0.45, 0, 0, 1], [0.55, 1, 0, 0], [1, 1, 0, 0]]}}]}
    with open(path, "w") as f:
        json.dump(doc, f)
    return path


def parity_materials_exact(path, labels):
    """Odd labels red, even labels blue, one constant material per label (no float arithmetic
    on the label anywhere)."""
    mats = [{"name": str(l), "filter": {"attribute": "label", "min": l, "max": l},
             "color": {"mode": "constant", "rgb": [1, 0, 0] if l % 2 else [0, 0, 1]}} for l in labels]
    with open(path, "w") as f:
        json.dump({"version": 1, "materials": mats}, f)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--input", help="a .csgv, NIfTI or other image file (default: the AAL atlas)",
                    default="/usr/share/mricron/templates/aal.nii.gz")
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--frames", type=int, default=20, help="frames timed per representation")
    ap.add_argument("--output", default=None, help="folder for the images (default: a temporary one)")
    ap.add_argument("--plugin", help="path of CSGV.so")
    ap.add_argument("--pvbatch", default=shutil.which("pvbatch") or "pvbatch")
    ap.add_argument("--demos", action="store_true", help="also show where VTK's volume mapper is wrong")
    ap.add_argument("--no-data", action="store_true", help="only the demonstrations")
    ap.add_argument("--only", choices=("vtk", "csgv"), help=argparse.SUPPRESS)
    ap.add_argument("--tag", default="data", help=argparse.SUPPRESS)
    ap.add_argument("--materials", help=argparse.SUPPRESS)
    ap.add_argument("--parity", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.output is None:
        args.output = tempfile.mkdtemp(prefix="csgv-compare-")
    os.makedirs(args.output, exist_ok=True)
    args.output = os.path.abspath(args.output)
    if args.only:
        return run_child(args)

    if not args.no_data:
        vtk = run_side(args, "vtk", args.input, "data")
        ours = run_side(args, "csgv", args.input, "data")
        report("data", vtk, ours, args)

    if args.demos:
        saved_frames = args.frames
        args.frames = 1
        demos = (
            ("wide_labels", 2 ** 31 + 1, 16, 4, True,
             "64 labels: 1 and 2^31+2 ... 2^31+64 (float32 holds every 256th integer there)"),
            ("many_labels", 1, 56, 2, False,
             "21952 labels 1 ... 21952: more than VTK's transfer-function texture holds (16384 texels here)"),
        )
        for tag, base, size, block, anchor, what in demos:
            vti = os.path.join(args.output, tag + ".vti")
            present, count = make_demo_volume(vti, base, size=size, block=block, anchor=anchor)
            if present is not None:
                mats = parity_materials_exact(os.path.join(args.output, tag + ".json"), present)
            else:
                mats = parity_materials(os.path.join(args.output, tag + ".json"))
            saved_input, args.input = args.input, vti
            vtk = run_side(args, "vtk", vti, tag, parity=True)
            ours = run_side(args, "csgv", vti, tag, materials=mats)
            args.input = saved_input
            agree, pixels = parity_agreement(vtk["png"], ours["png"])
            side = os.path.join(args.output, "%s_side_by_side.png" % tag)
            write_side_by_side(vtk["png"], ours["png"], side)
            print("== demo %s: %s ==" % (tag, what))
            print("VTK colours %.1f%% of %d volume pixels like the exact renderer (odd red, even blue); images: %s"
                  % (100 * agree, pixels, side))
        args.frames = saved_frames
    return 0


if __name__ == "__main__":
    sys.exit(main())
