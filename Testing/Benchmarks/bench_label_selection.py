# SPDX-License-Identifier: MIT
"""The cost of a label selection in ParaView (issue 41; a benchmark: it prints figures, asserts
nothing).

    pvpython Testing/Benchmarks/bench_label_selection.py PLUGIN.so FILE.csgv [--counts 10,10000,100000]

Shows FILE as a Segmentation Volume at 640x360 (one frame per still render), then for each count N
selects N labels present in the volume, spread over its label range (csgv_tools.select_labels),
and prints the seconds of the render that applies the selection (the materials built and
uploaded, one frame) against a render without a change, for highlight and dim.
"""
import argparse
import base64
import os
import sys
import time

import numpy as np
from paraview import simple

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools as ct  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("plugin")
    ap.add_argument("csgv")
    ap.add_argument("--counts", default="10,10000,100000")
    a = ap.parse_args()
    simple.LoadPlugin(a.plugin, remote=False, ns=globals())
    r = simple.OpenDataFile(a.csgv)
    v = simple.CreateRenderView()
    v.ViewSize = [640, 360]
    d = simple.Show(r, v)
    d.SetRepresentationType("Segmentation Volume")
    d.CSGVFramesPerStillRender = 1
    v.ResetCamera()
    t0 = time.time()
    simple.Render(v)
    print("first image: %.2f s" % (time.time() - t0))
    labels = np.frombuffer(base64.b64decode(ct.query(d, "labelset 10000000")), dtype="<i8")
    labels = labels[labels > 0]
    print("labels present: %d" % len(labels))
    plain = d.CSGVMaterials
    for n in [int(x) for x in a.counts.split(",")]:
        chosen = labels[np.linspace(0, len(labels) - 1, min(n, len(labels))).astype(np.int64)]
        for style in ("highlight", "dim"):
            d.CSGVMaterials = ct.select_labels(plain, chosen.tolist(), style=style)
            t0 = time.time()
            simple.Render(v)
            applied = time.time() - t0
            v.CameraPosition = [p * 1.0001 for p in v.CameraPosition]  # another frame, no edit
            t0 = time.time()
            simple.Render(v)
            again = time.time() - t0
            print("selected %7d labels, %-9s: the render applying it %.3f s, a render after it %.3f s"
                  % (len(chosen), style, applied, again))
        d.CSGVMaterials = plain
        simple.Render(v)


if __name__ == "__main__":
    main()
