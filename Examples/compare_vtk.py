# SPDX-License-Identifier: MIT
"""Segmentation Volume next to ParaView's own "Volume" representation (vtkSmartVolumeMapper,
nearest interpolation), on the same data, camera and resolution, over inputs x sizes x shadings.

    xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" pvbatch --force-offscreen-rendering \\
        Examples/compare_vtk.py --input DATA[,DATA...] [--input DATA ...] [--size 640x360,1280x720] \\
        [--shadings local,shadow,ao,pt] [--drawn 1,0.05] [--frames 20] [--repeat N] [--output DIR] [--json FILE]
        [--demos]

DATA is a .csgv (VTK's side gets the reader's decoded labels; ours keeps them compressed,
DecodeLabels off), a NIfTI label volume (the plugin's NIfTI reader, point data; ours compresses
it on the fly), any image file ParaView opens, or synth:WxHxD[:seed], a procedural volume that
`csgv compress` writes to DIR/synth_WxHxD[_seed].csgv before any measurement; a later run with
the same --output reuses that file. The tool is --csgv-tool, else $CSGV_TOOL, else build*/bin/csgv
of this repository (the newest), else csgv on PATH.

--drawn F[,F...] draws the smallest ceil(F n) of the input's n labels alone on both sides (VTK's
opacity 0 above the last, ours a material for [1, last]): most objects hidden, as when a user
shows a few of them, and rays cross much empty space (default 1: every label but 0).

VTK's representation has no shading modes: it is measured once per input, size and --drawn
fraction; ours once per input, size, fraction and shading (CSGVShading local, shadow, ao or pt; FramesPerStillRender 1: one
frame per render). Each measurement runs in a child pvbatch of its own (so memory peaks do not
mix; --timeout bounds it; one killed by a signal is run once more) and prints: read time, time to first frame
(Show to the end of the first render, data already read), the median of N frame times (the
camera turns 1 degree before each render), peak resident memory and, for ours, device memory
(the base of an empty session is printed too). For each input, size and shading it saves VTK's
image (left) and ours (right) side by side: DIR/<input>_<WxH>_<shading>_side_by_side.png.
--repeat N measures each side N times, VTK's and ours in turn, and the table takes the median of
their times (this machine is noisy: single runs of the same row differ by 10 % and more).

At the end it prints a table, one row per (input, size, shading): median frame ms and time to
first frame of both sides with the ratios VTK / ours, and peak memory. Part of every frame is
ParaView's own (clearing, compositing and reading back the view, the Python call): the VTK child
also times the same view showing only the data's outline ("view ms"), and "net VTK/ours" is the
ratio of the frame times less that part, the renderers' own cost; --json FILE writes the
same rows as a JSON list (null for a missing value). A measurement that fails (a missing file,
a child that exits with an error or runs past --timeout) gives "-" cells, and the script exits
with status 1 after printing everything it could.

VTK's transfer function shows the same labels: opacity 0 for label 0 and 1 for every other
label (a step), colours from one control point a label (flat colours, no shading); building that function is
quadratic in VTK, so it is timed apart (not in VTK's time to first frame).
VTK volume-renders labels as float textures and samples its transfer functions into a texture
of limited width, so it goes wrong where labels do not survive float32 (above 2^24) or where the
label range holds more labels than the transfer-function texture has texels. --demos builds two
small volumes that show both (at the first --size, local shading), with odd labels red and even
labels blue in both renderers, and prints how many volume pixels VTK colours like the exact
renderer.
"""
import argparse
import glob
import json
import os
import re
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


def find_csgv_tool(given):
    """The `csgv` command-line tool: --csgv-tool, else $CSGV_TOOL, else the newest build*/bin/csgv
    of this repository, else csgv on PATH. Exits with the reason when there is none."""
    def usable(path):
        return os.path.isfile(path) and os.access(path, os.X_OK)
    if given:
        if not usable(given):
            sys.exit("--csgv-tool %s: no such executable file" % given)
        return given
    if os.environ.get("CSGV_TOOL"):
        if not usable(os.environ["CSGV_TOOL"]):
            sys.exit("CSGV_TOOL=%s: no such executable file" % os.environ["CSGV_TOOL"])
        return os.environ["CSGV_TOOL"]
    pattern = os.path.join(os.path.dirname(HERE), "build*", "bin", "csgv")
    found = sorted((p for p in glob.glob(pattern) if usable(p)), key=os.path.getmtime, reverse=True)
    if found:
        return found[0]
    if shutil.which("csgv"):
        return shutil.which("csgv")
    sys.exit("the csgv tool (needed to generate synth: inputs) was not found: not given by --csgv-tool, "
             "CSGV_TOOL unset, no %s, no csgv on PATH; build the project or pass --csgv-tool PATH" % pattern)


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
    width, height = parse_size(args.size)
    ours = args.only == "csgv"

    t0 = time.time()
    path = args.input[0]
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
    if args.fxaa != "view":  # ParaView's FXAA (on by default) costs each side by its image's edges
        view.UseFXAA = 1 if args.fxaa == "on" else 0
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
        # --drawn F: the smallest ceil(F n) of the n labels alone (opacity 0 above the last);
        # ours draws the same labels (the parent passes that last label on as --label-max).
        label_max, cut_edge = None, None
        if args.drawn < 1 and len(labels):
            n = max(1, int(np.ceil(args.drawn * len(labels))))
            label_max = int(labels[n - 1])
            cut_edge = 0.5 * (labels[n - 1] + (labels[n] if n < len(labels) else labels[n - 1] + 1))
            labels = labels[:n]
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
        opacity = [0.0, 0.0, 0.5, 0.0, 0.5001, 1.0, 0.5, 0.0, max(hi, 1.0), 1.0, 0.5, 0.0]
        if cut_edge is not None:
            opacity += [cut_edge, 0.0, 0.5, 0.0, max(cut_edge + 1.0, float(arr.GetRange()[1])), 0.0, 0.5, 0.0]
        pwf.Points = opacity
        tf_setup_s = time.time() - t_tf
    t1 = time.time()
    if ours:
        display = Show(reader, view, "UniformGridRepresentation")
        display.SetRepresentationType("Segmentation Volume")
        display.CSGVShading = args.shadings
        display.CSGVFramesPerStillRender = 1
        if args.materials:
            display.CSGVMaterials = open(args.materials).read()
        elif args.label_max is not None:  # --drawn: the labels VTK's side draws, [1, label_max]
            display.CSGVMaterials = json.dumps({"version": 1, "materials": [{
                "name": "drawn", "filter": {"attribute": "label", "min": 1, "max": args.label_max},
                "color": {"mode": "random"}}]})
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

    def frame_times():
        """Sorted seconds of args.frames renders, the camera turning 1 degree before each."""
        times = []
        for i in range(args.frames):
            camera.Azimuth(1.0)
            t = time.time()
            Render(view)
            times.append(time.time() - t)
        return sorted(times)

    times = frame_times()
    # ParaView's own part of every frame (clearing, compositing, read-back of the view, Python):
    # the same view with only the outline of the data. Both sides pay it.
    view_ms = None
    if not ours:
        display.SetRepresentationType("Outline")
        Render(view)
        view_times = frame_times()
        view_ms = 1000 * view_times[len(view_times) // 2]
    device_mib = None
    if ours:
        display.SMProxy.UpdatePropertyInformation()
        device_mib = display.SMProxy.GetProperty("CSGVDeviceMiB").GetElement(0)
    mem = memory_kib()
    result = {
        "representation": ("Segmentation Volume, " + args.shadings) if ours else "Volume (vtkSmartVolumeMapper)",
        "read_s": read_s,
        "tf_setup_s": None if ours else tf_setup_s,
        "label_max": None if ours else label_max,
        "first_frame_s": first_s,
        "median_frame_ms": 1000 * times[len(times) // 2] if times else None,
        "view_frame_ms": view_ms,
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


def run_side(args, only, input_path, tag, size, shading="local", materials=None, parity=False, drawn=1.0,
             label_max=None):
    """One side in a child pvbatch: (its RESULT dict, None) or (None, why it failed)."""
    cmd = [args.pvbatch, "--force-offscreen-rendering", os.path.abspath(__file__), "--only", only,
           "--input", input_path, "--size", size, "--shadings", shading, "--frames", str(args.frames),
           "--output", args.output, "--tag", tag, "--plugin", find_plugin(args.plugin), "--drawn", repr(drawn),
           "--fxaa", args.fxaa]
    if label_max is not None:
        cmd += ["--label-max", str(label_max)]
    if materials:
        cmd += ["--materials", materials]
    if parity:
        cmd += ["--parity"]
    for attempt in (1, 2):
        try:
            run = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                 timeout=args.timeout)
            out, why = run.stdout, "rc %d" % run.returncode
        except subprocess.TimeoutExpired as e:
            run, out, why = None, e.output or "", "ran past --timeout %g s" % args.timeout
            if isinstance(out, bytes):
                out = out.decode(errors="replace")
        for line in out.splitlines():
            if line.startswith("RESULT "):
                return json.loads(line[7:]), None
        # A child killed by a signal gets one more try; an error it reports itself, or a timeout,
        # does not. Seen: vtkXOpenGLRenderWindow::CreateAWindow aborting (either side, 2-3 children
        # of 24) under an Xvfb started without -noreset. The likely cause: such a server resets
        # whenever its last client leaves, as each child does, and the next child may connect
        # during the reset; the command above keeps the server up.
        if attempt == 1 and run is not None and run.returncode < 0:
            print("%s side of %s: child pvbatch died by signal %d, trying once more; its last lines:" % (only, tag, -run.returncode))
            sys.stdout.write("".join("  | %s\n" % l for l in [l for l in out.splitlines() if l.strip()][-8:]))
            sys.stdout.flush()
            continue
        break
    lines = [l for l in out.splitlines() if l.strip()]
    sys.stdout.write("".join("  | %s\n" % l for l in lines[-20:]))
    last = lines[-1].strip()[:200] if lines else "no output"
    print("%s side of %s failed (%s): %s" % (only, tag, why, last))
    sys.stdout.flush()
    return None, "%s side failed (%s): %s" % (only, why, last)


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
    """Writes the two images side by side; returns False (nothing written) without numpy (plain
    python3 rather than pvpython or pvbatch)."""
    try:
        import numpy as np
    except ImportError:
        return False
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
    return True


def print_side(r, label):
    if r is None:
        print("%-36s %8s %12s %10s %10s %11s" % (label, "-", "-", "-", "-", "-"))
    else:
        print("%-36s %8s %12s %10s %10s %11s" % (r["representation"], fmt(r["read_s"], 2), fmt(r["first_frame_s"], 2),
                                                 fmt(r["median_frame_ms"], 1), fmt(r["peak_rss_mib"], 1),
                                                 fmt(r.get("device_mib"), 1)))
    sys.stdout.flush()


def combine(runs):
    """One side's measurement from its --repeat runs (None: a run that failed): the medians of the
    times over the runs that succeeded, the other figures (memory, images) of the last; None when
    none succeeded."""
    done = [r for r in runs if r]
    if not done:
        return None
    out = dict(done[-1])
    for key in ("read_s", "first_frame_s", "median_frame_ms", "view_frame_ms"):
        values = sorted(r[key] for r in done if r.get(key) is not None)
        if values:
            out[key] = values[len(values) // 2] if len(values) % 2 else 0.5 * (values[len(values) // 2 - 1] +
                                                                                values[len(values) // 2])
    out["repeats"] = len(done)
    return out


def fmt(value, digits):
    return "-" if value is None else "%.*f" % (digits, value)


def get(result, key):
    return result.get(key) if result else None


def net(result, view_ms):
    """A side's median frame time less ParaView's own part of a frame (None when unknown)."""
    frame = get(result, "median_frame_ms")
    return None if frame is None or view_ms is None else frame - view_ms


def ratio(a, b):
    return a / b if a is not None and b else None


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


SHADINGS = ("local", "shadow", "ao", "pt")


def parse_size(text):
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or int(m.group(1)) == 0 or int(m.group(2)) == 0:
        sys.exit("bad size %r: expected WxH, e.g. 640x360" % text)
    return int(m.group(1)), int(m.group(2))


def split_list(values):
    out = []
    for v in values:
        out += [x.strip() for x in v.split(",") if x.strip()]
    return out


def input_name(spec, taken):
    """A file-name-safe name for an input (image names), unique among `taken`."""
    if spec.startswith("synth:"):
        name = "synth_" + spec[6:]
    else:
        name = os.path.basename(spec.rstrip("/"))
        for ext in (".nii.gz", ".nii", ".csgv", ".vti", ".nrrd", ".mha", ".mhd", ".vtk"):
            if name.endswith(ext) and len(name) > len(ext):
                name = name[:-len(ext)]
                break
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", name) or "input"
    unique, n = name, 2
    while unique in taken:
        unique, n = "%s_%d" % (name, n), n + 1
    taken.add(unique)
    return unique


def resolve_input(spec, name, args):
    """(path for pvbatch, None) or (None, why not). A synth: spec is compressed once into
    DIR/<name>.csgv by the csgv tool and reused when that file is already there."""
    if not spec.startswith("synth:"):
        if not os.path.exists(spec):
            print("%s: no such file" % spec)
            return None, "no such file: %s" % spec
        return os.path.abspath(spec), None
    path = os.path.join(args.output, name + ".csgv")
    if os.path.exists(path):
        print("%s: reusing %s" % (spec, path))
        return path, None
    tool = find_csgv_tool(args.csgv_tool)
    print("%s: %s compress %s %s" % (spec, tool, spec, path))
    sys.stdout.flush()
    t = time.time()
    run = subprocess.run([tool, "compress", spec, path, "--quiet"], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    if run.returncode != 0 or not os.path.exists(path):
        lines = [l for l in run.stdout.splitlines() if l.strip()]
        why = "csgv compress %s failed (rc %d): %s" % (spec, run.returncode, lines[-1] if lines else "no output")
        print(why)
        return None, why
    print("%s: compressed in %.1f s" % (spec, time.time() - t))
    return path, None


def drawn_text(fraction):
    return "%g%%" % (100 * fraction)


def drawn_tag(fraction):
    """The image-name part of a --drawn fraction: none for all labels."""
    return "" if fraction >= 1 else "_drawn%g" % (100 * fraction)


COLUMNS = (("input", None), ("size", None), ("shading", None), ("drawn", None),
           ("vtk_median_frame_ms", 1), ("ours_median_frame_ms", 1), ("frame_ratio_vtk_over_ours", 2),
           ("view_frame_ms", 1), ("net_ratio_vtk_over_ours", 2),
           ("vtk_first_frame_s", 2), ("ours_first_frame_s", 2), ("first_frame_ratio_vtk_over_ours", 2),
           ("vtk_peak_rss_mib", 0), ("ours_peak_rss_mib", 0), ("ours_device_mib", 0))
HEADERS = ("input", "size", "shading", "drawn", "VTK ms", "ours ms", "VTK/ours", "view ms", "net VTK/ours", "VTK 1st s", "ours 1st s", "VTK/ours",
           "VTK MiB", "ours MiB", "ours dev MiB")


def print_summary(rows, frames):
    cells = [HEADERS]
    for r in rows:
        cells.append(tuple(r[k] if d is None else fmt(r[k], d) for k, d in COLUMNS))
    widths = [max(len(c[i]) for c in cells) for i in range(len(HEADERS))]
    print("== summary: median of %d frames (ms), time to first frame (s), peak RSS of each child pvbatch "
          "and ours on the device (MiB); ratios VTK / ours ==" % frames)
    for c in cells:
        print("  ".join(v.ljust(w) if i < 3 else v.rjust(w) for i, (v, w) in enumerate(zip(c, widths))))
    sys.stdout.flush()


def measure(args, spec, name, path, error, size, drawn, shadings, rows):
    """One input at one size and --drawn fraction: VTK's side and ours in every shading, --repeat
    times in turn; appends a row per shading to `rows`. Returns whether a measurement failed
    (`error`: the input could not be had, nothing is run)."""
    failed = False
    print("== %s, %s, %s drawn, %d frames ==" % (spec, size, drawn_text(drawn), args.frames))
    print("%-36s %8s %12s %10s %10s %11s" % ("representation", "read s", "1st frame s", "median ms",
                                             "peak MiB", "device MiB"))
    # Each side --repeat times, in turn (VTK, then ours in every shading, again ...):
    # a slow minute of a noisy machine falls on both.
    vtk_runs, ours_runs, vtk_error, ours_errors = [], {sh: [] for sh in shadings}, None, {}
    label_max = None  # --drawn below 1: the last label drawn, from VTK's side
    for _ in range(args.repeat):
        if error:
            run, run_error = None, error
        else:
            run, run_error = run_side(args, "vtk", path, "%s_%s%s" % (name, size, drawn_tag(drawn)), size, drawn=drawn)
            label_max = label_max if label_max is not None else get(run, "label_max")
        vtk_runs.append(run)
        vtk_error = vtk_error or run_error
        print_side(run, "Volume (vtkSmartVolumeMapper)")
        for shading in shadings:
            if error:
                run, run_error = None, error
            elif drawn < 1 and label_max is None:
                run, run_error = None, "no last label to draw for --drawn %g: VTK's side failed or found no labels" % drawn
            else:
                run, run_error = run_side(args, "csgv", path, "%s_%s%s_%s" % (name, size, drawn_tag(drawn), shading),
                                          size, shading, drawn=drawn, label_max=label_max)
            ours_runs[shading].append(run)
            ours_errors[shading] = ours_errors.get(shading) or run_error
            print_side(run, "Segmentation Volume, " + shading)
    vtk = combine(vtk_runs)
    if args.repeat > 1:
        print("(the summary takes the median of the %d runs of each side)" % args.repeat)
    base = None
    for shading in shadings:
        ours, ours_error = combine(ours_runs[shading]), ours_errors.get(shading)
        side = None
        if vtk and ours:
            side = os.path.join(args.output, "%s_%s%s_%s_side_by_side.png" % (name, size, drawn_tag(drawn), shading))
            if not write_side_by_side(vtk["png"], ours["png"], side):
                print("(no side-by-side image: numpy is missing; run with pvpython or pvbatch)")
                side = None
        base = base or (ours or {}).get("session_base_mib")
        errors = sorted(set(e for e in (vtk_error, ours_error) if e))
        failed = failed or bool(errors)
        rows.append({
            "input": spec, "input_path": path, "size": size, "shading": shading, "frames": args.frames,
            "drawn": drawn_text(drawn), "drawn_fraction": drawn, "label_max": label_max,
            "repeats": args.repeat,
            "vtk_read_s": get(vtk, "read_s"), "ours_read_s": get(ours, "read_s"),
            "vtk_median_frame_ms": get(vtk, "median_frame_ms"),
            "ours_median_frame_ms": get(ours, "median_frame_ms"),
            "frame_ratio_vtk_over_ours": ratio(get(vtk, "median_frame_ms"),
                                               get(ours, "median_frame_ms")),
            "view_frame_ms": get(vtk, "view_frame_ms"),
            "net_ratio_vtk_over_ours": ratio(net(vtk, get(vtk, "view_frame_ms")),
                                             net(ours, get(vtk, "view_frame_ms"))),
            "vtk_first_frame_s": get(vtk, "first_frame_s"), "ours_first_frame_s": get(ours, "first_frame_s"),
            "first_frame_ratio_vtk_over_ours": ratio(get(vtk, "first_frame_s"),
                                                     get(ours, "first_frame_s")),
            "vtk_tf_setup_s": get(vtk, "tf_setup_s"),
            "vtk_peak_rss_mib": get(vtk, "peak_rss_mib"), "ours_peak_rss_mib": get(ours, "peak_rss_mib"),
            "ours_device_mib": get(ours, "device_mib"),
            "side_by_side": side, "errors": errors or None})
    if vtk:
        print("VTK transfer function set-up (one point a label, not in its first frame): %.2f s"
              % vtk["tf_setup_s"])
    if base is not None:
        print("session base (empty pvbatch with the plugin): %.1f MiB" % base)
    if vtk and any(r["side_by_side"] for r in rows[-len(shadings):]):
        print("images: %s (left: VTK, right: Segmentation Volume)"
              % os.path.join(args.output, "%s_%s%s_<shading>_side_by_side.png" % (name, size, drawn_tag(drawn))))
    sys.stdout.flush()
    return failed


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--input", action="append",
                    help="a .csgv, NIfTI or other image file, or synth:WxHxD[:seed]; repeatable and/or "
                         "comma-separated (default: the AAL atlas)")
    ap.add_argument("--size", default="640x360,1280x720", help="comma-separated WxH list (default %(default)s)")
    ap.add_argument("--shadings", default=",".join(SHADINGS),
                    help="comma-separated list of our shadings from local,shadow,ao,pt (default %(default)s)")
    ap.add_argument("--frames", type=int, default=20, help="frames timed per measurement")
    ap.add_argument("--repeat", type=int, default=1,
                    help="measure each side this many times, VTK's and ours in turn (a noisy machine): the "
                         "table gives the median of their times")
    ap.add_argument("--output", default=None,
                    help="folder for images and generated synth volumes (default: a temporary one)")
    ap.add_argument("--json", help="also write the summary rows to this JSON file")
    ap.add_argument("--plugin", help="path of CSGV.so")
    ap.add_argument("--csgv-tool", help="the csgv command-line tool, for synth: inputs (default: $CSGV_TOOL, "
                                        "else build*/bin/csgv of this repository, else csgv on PATH)")
    ap.add_argument("--pvbatch", default=shutil.which("pvbatch") or "pvbatch")
    ap.add_argument("--timeout", type=float, default=1800, help="seconds one child pvbatch may take (%(default)s)")
    ap.add_argument("--demos", action="store_true", help="also show where VTK's volume mapper is wrong")
    ap.add_argument("--no-data", action="store_true", help="only the demonstrations")
    ap.add_argument("--fxaa", choices=("view", "on", "off"), default="view",
                    help="ParaView's FXAA in both views: the view's default (on in ParaView 5.11), on or off; it is "
                         "part of the frame time and costs more over sharp images (default %(default)s)")
    ap.add_argument("--only", choices=("vtk", "csgv"), help=argparse.SUPPRESS)
    ap.add_argument("--tag", default="data", help=argparse.SUPPRESS)
    ap.add_argument("--drawn", default="1",
                    help="comma-separated fractions of the input's labels both sides draw, the smallest labels "
                         "(0.05: the smallest 5 %%; default %(default)s: all): a segmentation with most objects "
                         "hidden, where rays cross much empty space")
    ap.add_argument("--label-max", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--materials", help=argparse.SUPPRESS)
    ap.add_argument("--parity", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    try:
        fractions = [float(v) for v in split_list([args.drawn])]
    except ValueError:
        sys.exit("--drawn expects comma-separated fractions in (0, 1], not %r" % args.drawn)
    if not fractions or any(not 0 < f <= 1 for f in fractions):
        sys.exit("--drawn expects comma-separated fractions in (0, 1], not %r" % args.drawn)
    args.drawn = fractions[0]  # a child measures one
    if args.output is None:
        args.output = tempfile.mkdtemp(prefix="csgv-compare-")
    os.makedirs(args.output, exist_ok=True)
    args.output = os.path.abspath(args.output)
    if args.only:
        return run_child(args)

    inputs = list(dict.fromkeys(split_list(args.input or ["/usr/share/mricron/templates/aal.nii.gz"])))
    sizes = split_list([args.size])
    for size in sizes:
        parse_size(size)
    shadings = split_list([args.shadings])
    for shading in shadings:
        if shading not in SHADINGS:
            sys.exit("unknown shading %r: choose from %s" % (shading, ",".join(SHADINGS)))
    if not inputs or not sizes or not shadings:
        sys.exit("--input, --size and --shadings each need at least one value")
    if args.frames < 1:
        sys.exit("--frames must be at least 1")
    if args.repeat < 1:
        sys.exit("--repeat must be at least 1")

    failed = False
    rows = []
    if not args.no_data:
        taken = set()
        resolved = []
        for spec in inputs:  # every synth: volume is ready before the first measurement
            name = input_name(spec, taken)
            resolved.append((spec, name) + resolve_input(spec, name, args))
        for spec, name, path, error in resolved:
            for size in sizes:
                for drawn in fractions:
                    failed = measure(args, spec, name, path, error, size, drawn, shadings, rows) or failed

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
            vtk, _ = run_side(args, "vtk", vti, tag, sizes[0], parity=True)
            ours, _ = run_side(args, "csgv", vti, tag, sizes[0], materials=mats)
            print("== demo %s: %s ==" % (tag, what))
            if not (vtk and ours):
                failed = True
                print("demo %s failed (see above)" % tag)
                continue
            agree, pixels = parity_agreement(vtk["png"], ours["png"])
            side = os.path.join(args.output, "%s_side_by_side.png" % tag)
            write_side_by_side(vtk["png"], ours["png"], side)
            print("VTK colours %.1f%% of %d volume pixels like the exact renderer (odd red, even blue); images: %s"
                  % (100 * agree, pixels, side))
        args.frames = saved_frames

    if rows:
        print_summary(rows, args.frames)
        for r in rows:
            for e in r["errors"] or []:
                print("failed: %s, %s, %s: %s" % (r["input"], r["size"], r["shading"], e))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
        print("rows: %s" % os.path.abspath(args.json))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
