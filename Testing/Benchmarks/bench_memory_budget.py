# SPDX-License-Identifier: MIT
"""The Segmentation Volume under device-memory budgets in ParaView (a benchmark: it prints
figures, asserts nothing).

pvpython bench_memory_budget.py PLUGIN.so VOLUME [--size 640x360] [--budgets 0,128,96]
                                [--orbit 20] [--samples 16] [--paletting 2] [--decoding 0]

Per budget (CSGVDeviceMemoryMiB; 0 is automatic), in a view of its own with the same camera:
- first_s: the first still render (one sample a pixel; the upload counts only for the first
  budget: views share it);
- orbit_ms: median of --orbit interactive renders, the camera turning 2 degrees between them;
- converge_s: from the end of the orbit until every pixel holds --samples samples (still renders);
- device, budget and cache MiB, cache bits per voxel (cache paletting), whether the finest level
  stays in host memory (GPU decoding, CSGVDecoding 1) and the MiB of it streamed, the process's
  peak RSS;
- image_diff: mean absolute difference (0..255) of the converged image to the first budget's.
"""
import argparse
import resource
import statistics
import sys
import time

import numpy as np
from paraview import simple
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader


def info(d, name):
    d.SMProxy.UpdatePropertyInformation()
    return d.SMProxy.GetProperty(name).GetElement(0)


def screenshot(view, w, h, path):
    simple.SaveScreenshot(path, view, ImageResolution=[w, h], TransparentBackground=0)
    r = vtkPNGReader()
    r.SetFileName(path)
    r.Update()
    return vtk_to_numpy(r.GetOutput().GetPointData().GetScalars()).astype(np.int32)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("plugin")
    ap.add_argument("volume")
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--budgets", default="0,128,96")
    ap.add_argument("--orbit", type=int, default=20)
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--paletting", type=int, default=2)
    ap.add_argument("--decoding", type=int, default=0, help="CSGVDecoding: 0 automatic, 1 GPU, 2 host")
    a = ap.parse_args()
    w, h = (int(x) for x in a.size.split("x"))
    simple.LoadPlugin(a.plugin, remote=False, ns=globals())
    t0 = time.perf_counter()
    src = simple.OpenDataFile(a.volume)
    src.UpdatePipeline()
    print("load_s: %.2f" % (time.perf_counter() - t0))
    print("budget_mib first_s orbit_ms converge_s device_mib budget_mib cache_mib cache_bits separated "
          "streamed_mib peak_rss_mib image_diff")
    reference = None
    for budget in (int(b) for b in a.budgets.split(",")):
        view = simple.CreateRenderView()
        view.ViewSize = [w, h]
        view.OrientationAxesVisibility = 0
        d = simple.Show(src, view)
        d.SetRepresentationType("Segmentation Volume")
        d.CSGVDeviceMemoryMiB = budget
        d.CSGVCachePaletting = a.paletting
        d.CSGVDecoding = a.decoding
        d.CSGVFramesPerStillRender = 1
        d.CSGVStillRenderTimeBudget = 120
        simple.ResetCamera(view)
        cam = view.GetActiveCamera()
        cam.Azimuth(30)
        cam.Elevation(20)
        cam.Dolly(1.5)
        t0 = time.perf_counter()
        simple.Render(view)
        first = time.perf_counter() - t0
        times = []
        for _ in range(a.orbit):
            cam.Azimuth(2)
            t = time.perf_counter()
            view.SMProxy.InteractiveRender()
            times.append((time.perf_counter() - t) * 1000)
        d.CSGVFramesPerStillRender = a.samples
        t0 = time.perf_counter()
        for _ in range(200):
            simple.Render(view)
            if info(d, "CSGVMinSamples") >= a.samples:
                break
        converge = time.perf_counter() - t0
        image = screenshot(view, w, h, "/tmp/csgv-bench-budget-%d.png" % budget)
        if reference is None:
            reference = image
        diff = float(np.abs(image - reference).mean())
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print("%10d %7.2f %8.1f %10.2f %10.1f %10.1f %9.1f %10d %9d %12.2f %12.0f %10.3f" % (
            budget, first, statistics.median(times), converge, info(d, "CSGVDeviceMiB"),
            info(d, "CSGVDeviceBudgetMiB"), info(d, "CSGVCacheMiB"), info(d, "CSGVCacheBits"),
            info(d, "CSGVDetailSeparated"), info(d, "CSGVDetailStreamedMiB"), rss, diff))
        sys.stdout.flush()
        simple.Hide(src, view)
        simple.Delete(view)
    simple.Disconnect()


main()
