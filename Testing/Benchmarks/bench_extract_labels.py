# SPDX-License-Identifier: MIT
"""CSGV Extract Labels on a large volume (issue 41; a benchmark: it prints figures, asserts
nothing).

    pvpython Testing/Benchmarks/bench_extract_labels.py PLUGIN.so FILE.csgv [--labels 10] [--level 0]
        [--output meshes|mask|labels] [--smoothing N] [--decimation F]

Picks the N most frequent labels of a coarse level (CSGV Extract at level 4), extracts them as
meshes (or a mask or label image of their bounding box) at the given level and prints the time,
the bricks decoded of all, the triangles (or cells) and the peak RSS of the process.
"""
import argparse
import resource
import time

import numpy as np
from paraview import simple
from paraview import servermanager as sm
from vtkmodules.util.numpy_support import vtk_to_numpy


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("plugin")
    ap.add_argument("csgv")
    ap.add_argument("--labels", type=int, default=10)
    ap.add_argument("--level", type=int, default=0)
    ap.add_argument("--output", choices=["meshes", "mask", "labels"], default="meshes")
    ap.add_argument("--smoothing", type=int, default=0)
    ap.add_argument("--decimation", type=float, default=0.0)
    a = ap.parse_args()
    simple.LoadPlugin(a.plugin, remote=False, ns=globals())
    r = simple.OpenDataFile(a.csgv)
    coarse = globals()["CSGVExtract"](Input=r)
    coarse.Level = 4
    coarse.UpdatePipeline()
    img = sm.Fetch(coarse)
    cd = img.GetCellData()
    labels = vtk_to_numpy(cd.GetArray("Labels") or cd.GetArray(0))
    values, counts = np.unique(labels[labels != 0], return_counts=True)
    chosen = [int(v) for v in values[np.argsort(counts)[::-1][: a.labels]]]
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    e = globals()["CSGVExtractLabels"](Input=r, Labels=" ".join(map(str, chosen)), Level=a.level,
                                       OutputType={"meshes": 0, "mask": 1, "labels": 2}[a.output],
                                       Smoothing=a.smoothing, Decimation=a.decimation)
    t0 = time.time()
    e.UpdatePipeline()
    secs = time.time() - t0
    e.UpdatePropertyInformation()
    info = e.GetDataInformation()
    print("labels: %d (%s)" % (len(chosen), " ".join(map(str, chosen))))
    print("level: %d" % a.level)
    print("seconds: %.2f" % secs)
    print("bricks_decoded: %d of %d" % (e.GetPropertyValue("BricksDecoded"), e.GetPropertyValue("BricksTotal")))
    print("output: %s (smoothing %d, decimation %.2f)" % (a.output, a.smoothing, a.decimation))
    print("%s: %d" % ("triangles" if a.output == "meshes" else "cells", info.GetNumberOfCells()))
    print("peak_rss_mib: %.0f (before the extraction %.0f)" % (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, rss0))


if __name__ == "__main__":
    main()
