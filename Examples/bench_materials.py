# SPDX-License-Identifier: MIT
"""Render-time cost of the number of materials through the Segmentation Volume representation:
the AAL atlas with 1, 8 and 64 materials (each a label interval, colour by the `code` attribute of
aal.nii.txt through a ParaView preset, alternating with random and constant colours), median
still-render time over a small orbit, one sample per pixel, local shading.

    xvfb-run -a -s "-screen 0 1280x1024x24" pvpython --force-offscreen-rendering \\
        Examples/bench_materials.py [--plugin PATH/CSGV.so] [--size 400x300] [--frames 12]
"""
import argparse
import json
import os
import statistics
import sys
import time

from paraview.simple import *

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from render_aal import find_plugin  # noqa: E402

AAL = "/usr/share/mricron/templates/aal.nii.gz"
TXT = "/usr/share/mricron/templates/aal.nii.txt"


def document(n):
    mats = []
    step = 116.0 / n
    for i in range(n):
        lo, hi = int(round(i * step)) + 1, int(round((i + 1) * step))
        mode = i % 3
        color = ({"mode": "colormap", "attribute": "code", "min": 2000, "max": 9200, "colormap": "Turbo"}
                 if mode == 0 else {"mode": "random"} if mode == 1 else
                 {"mode": "constant", "rgb": [0.2 + 0.6 * i / n, 0.5, 0.8]})
        mats.append({"name": "m%d" % i, "filter": {"attribute": "label", "min": lo, "max": hi}, "color": color})
    return json.dumps({"version": 1, "materials": mats})


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--plugin")
    ap.add_argument("--size", default="400x300")
    ap.add_argument("--frames", type=int, default=12)
    args = ap.parse_args()
    w, h = (int(x) for x in args.size.split("x"))
    LoadPlugin(find_plugin(args.plugin), remote=False, ns=globals())
    r = OpenDataFile(AAL)
    v = CreateRenderView()
    v.ViewSize = [w, h]
    v.OrientationAxesVisibility = 0
    d = Show(r, v)
    d.Representation = "Segmentation Volume"
    d.CSGVFramesPerStillRender = 1
    d.CSGVAttributeFiles = [TXT]
    v.ResetCamera()
    Render(v)
    for n in (1, 8, 64):
        t0 = time.perf_counter()
        d.CSGVMaterials = document(n)
        Render(v)
        first = time.perf_counter() - t0
        times = []
        for _ in range(args.frames):
            v.GetActiveCamera().Azimuth(3)
            t0 = time.perf_counter()
            Render(v)
            times.append(time.perf_counter() - t0)
        print("materials %2d: first render after the change %.1f ms, median still render %.1f ms (min %.1f)"
              % (n, 1000 * first, 1000 * statistics.median(times), 1000 * min(times)))
        sys.stdout.flush()
    Disconnect()


if __name__ == "__main__":
    main()
