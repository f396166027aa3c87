# SPDX-License-Identifier: MIT
"""Shared helpers of the pvpython tests: plugin loading, fixtures and their source volumes,
error capture through vtkLogger, fetching labels as numpy arrays."""
import gzip
import os
import shutil
import sys
import tempfile

import numpy as np
from paraview import servermanager as sm
from paraview import simple
from vtkmodules.numpy_interface import dataset_adapter as dsa  # noqa: F401 (numpy support loaded)
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkLogger

PLUGIN = os.environ.get("CSGV_PLUGIN", "")
FIXTURES = os.environ.get("CSGV_FIXTURES", "")
AAL = "/usr/share/mricron/templates/aal.nii.gz"

_failures = []


def log(*args):
    # pvpython's stdout is not line buffered; ctest shows only what was flushed.
    print(*args)
    sys.stdout.flush()


def check(cond, what):
    if cond:
        log("ok   " + what)
    else:
        log("FAIL " + what)
        _failures.append(what)


def finish():
    # ParaView 5.11 crashes in Python's teardown when render views are still alive (SIGSEGV after
    # sys.exit); closing the session first ends cleanly.
    try:
        simple.Disconnect()
    except Exception:
        pass
    if _failures:
        log("%d check(s) failed:" % len(_failures))
        for f in _failures:
            log("  " + f)
        sys.exit(1)
    log("all checks passed")
    sys.exit(0)


def load_plugin(ns):
    if not PLUGIN or not os.path.isfile(PLUGIN):
        log("FAIL plugin file not found: %r" % PLUGIN)
        sys.exit(1)
    simple.LoadPlugin(PLUGIN, remote=False, ns=ns)


def connect_to_server(ns):
    """Connects to the pvserver clientserver_driver.py started (CSGV_SERVER_PORT) and loads the
    plugin there and here."""
    simple.Connect("localhost", int(os.environ["CSGV_SERVER_PORT"]))
    simple.LoadPlugin(PLUGIN, remote=True, ns=ns)
    load_plugin(ns)


def temp_dir():
    d = tempfile.mkdtemp(prefix="csgv-pv-")
    import atexit
    atexit.register(shutil.rmtree, d, True)
    return d


def fixture_names():
    return sorted(n for n in os.listdir(FIXTURES) if n.endswith(".csgv"))


_sources = {}


def source_volume(fixture_name):
    """The uncompressed volume a fixture was written from, read with numpy (x fastest), shaped
    (D, H, W) so that it ravels in VTK's order."""
    stem = fixture_name.split("_")[0]
    if stem not in _sources:
        with gzip.open(os.path.join(FIXTURES, stem + ".vraw.gz"), "rb") as f:
            data = f.read()
        first = data.index(b"\n")
        second = data.index(b"\n", first + 1)
        w, h, d = (int(v) for v in data[:first].split())
        kind = data[first + 1:second].decode()
        dtype = {"uint8": "<u1", "uint16": "<u2", "uint32": "<u4"}[kind]
        vol = np.frombuffer(data, dtype=dtype, offset=second + 1).reshape(d, h, w)
        _sources[stem] = vol
    return _sources[stem]


def fetch(proxy):
    proxy.UpdatePipeline()
    return sm.Fetch(proxy)


def labels_at(proxy, time=None):
    """A reader's output at `time` (None: no time asked): (dimensions in cells, labels x fastest
    as uint64 or None, the output's DATA_TIME_STEP or None)."""
    if time is None:
        proxy.UpdatePipeline()
    else:
        proxy.UpdatePipeline(time)
    img = proxy.GetClientSideObject().GetOutput()
    dims = tuple(d - 1 for d in img.GetDimensions())
    labels = cell_labels(img)
    info = img.GetInformation()
    step = info.Get(img.DATA_TIME_STEP()) if info.Has(img.DATA_TIME_STEP()) else None
    return dims, (None if labels is None else labels.astype(np.uint64)), step


def cell_labels(image, name="Labels"):
    arr = image.GetCellData().GetArray(name)
    return None if arr is None else vtk_to_numpy(arr)


def point_labels(image, name="Labels"):
    arr = image.GetPointData().GetArray(name)
    return None if arr is None else vtk_to_numpy(arr)


class ErrorLog:
    """Collects vtkErrorMacro output (ParaView routes it through vtkLogger) while active."""

    def __init__(self):
        self.path = os.path.join(temp_dir(), "errors.log")

    def __enter__(self):
        vtkLogger.LogToFile(self.path, vtkLogger.TRUNCATE, vtkLogger.VERBOSITY_WARNING)
        return self

    def __exit__(self, *exc):
        vtkLogger.EndLogToFile(self.path)
        with open(self.path) as f:
            self.text = "".join(l for l in f if "ERR|" in l or "WARN|" in l)
        return False


# --- Segmentation Volume representation helpers ------------------------------------------------

def render_view(width, height, background=(0.0, 0.0, 0.0)):
    """A render view of a fixed size without orientation axes, on a plain background."""
    v = simple.CreateRenderView()
    v.ViewSize = [width, height]
    v.OrientationAxesVisibility = 0
    if "UseColorPaletteForBackground" in v.ListProperties():
        v.UseColorPaletteForBackground = 0
    v.Background = list(background)
    return v


def read_png(path):
    """An image file as a (rows, columns, 3) uint8 array, row 0 at the top."""
    from vtkmodules.vtkIOImage import vtkPNGReader
    r = vtkPNGReader()
    r.SetFileName(path)
    r.Update()
    img = r.GetOutput()
    w, h, _ = img.GetDimensions()
    a = vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)
    return np.ascontiguousarray(a[::-1, :, :3])


def screenshot(view, width, height, name="shot.png"):
    path = os.path.join(temp_dir(), name)
    simple.SaveScreenshot(path, view, ImageResolution=[width, height], TransparentBackground=0)
    return read_png(path)


def repr_info(display):
    """(frames the last render accumulated, fewest samples of any pixel) of a Segmentation Volume
    display, read from the rendering process."""
    display.SMProxy.UpdatePropertyInformation()
    return (display.SMProxy.GetProperty("CSGVFramesLastRender").GetElement(0),
            display.SMProxy.GetProperty("CSGVMinSamples").GetElement(0))


def repr_memory(display):
    """(brick cache MiB, device MiB, device-memory budget MiB) of a Segmentation Volume
    display's renderer."""
    display.SMProxy.UpdatePropertyInformation()
    return tuple(display.SMProxy.GetProperty(name).GetElement(0)
                 for name in ("CSGVCacheMiB", "CSGVDeviceMiB", "CSGVDeviceBudgetMiB"))


def content_mask(image, background=(0, 0, 0), tol=8):
    return np.abs(image.astype(int) - np.array(background, int)).max(axis=2) > tol


def block_vti(n, origin=(0.0, 0.0, 0.0), name="block.vti"):
    """A .vti of n^3 cells, every cell label 1 (uint8 cell array "block"), its corner at `origin`
    (compressed on the fly when shown as a Segmentation Volume); returns its path."""
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkIOXML import vtkXMLImageDataWriter
    img = vtkImageData()
    img.SetDimensions(n + 1, n + 1, n + 1)
    img.SetOrigin(*origin)
    labels = numpy_to_vtk(np.ones(n * n * n, dtype=np.uint8), deep=1)
    labels.SetName("block")
    img.GetCellData().AddArray(labels)
    path = os.path.join(temp_dir(), name)
    w = vtkXMLImageDataWriter()
    w.SetFileName(path)
    w.SetInputData(img)
    w.Write()
    return path


def constant_materials(rgb, opacity=1.0):
    import json
    return json.dumps({"version": 1, "materials": [
        {"name": "all", "filter": {"attribute": "label", "min": 1, "max": 4294967294},
         "color": {"mode": "constant", "rgb": list(rgb)}, "opacity": opacity}]})


def check_drawn_and_red(view, display, drawn_what, red_what, width=160, height=120):
    """The view shows the display's volume (over 5 % of the pixels), and after its materials turn
    constant red the shown pixels are red: a drawing, and a property change, that reach the
    screenshot (client/server tests)."""
    img = screenshot(view, width, height)
    check(content_mask(img).mean() > 0.05, "%s (%.1f%% of the view)" % (drawn_what, 100 * content_mask(img).mean()))
    display.CSGVMaterials = constant_materials([1, 0, 0])
    red = screenshot(view, width, height, "red.png")
    m = content_mask(red)
    check(m.mean() > 0.05 and (red[m][:, 0].astype(int) > red[m][:, 2].astype(int) + 40).mean() > 0.95, red_what)
