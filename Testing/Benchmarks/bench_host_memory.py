# SPDX-License-Identifier: MIT
"""A `.csgv` under host- and device-memory budgets in ParaView (issue 40; a benchmark: it prints
figures, asserts nothing but prints whether the labels agree).

    xvfb-run -a pvpython Testing/Benchmarks/bench_host_memory.py PLUGIN.so FILE.csgv \
        [--host-mib 1024] [--device-mib 1024] [--size 640x360] [--views 8] [--compare]

Opens the file, shows it as a Segmentation Volume with CSGVHostMemoryMiB and CSGVDeviceMemoryMiB,
and orbits the camera through --views still renders (each converged: FramesPerStillRender 64).
Prints the time to open and to the first image, each view's seconds (one still render: to
converge), where the levels were read from (CSGVLevelsOnDisk) and how much of the file was read on
demand (CSGVFileReadMiB), the process's peak resident memory (getrusage), its private memory and
anonymous memory now (/proc/self/smaps_rollup), and the page faults that read the disk (major
faults). With --compare, the first view's first-hit labels are compared with those of the same
camera without budgets (a second display, rendered after the first's figures are taken).
"""
import argparse
import math
import os
import resource
import sys
import time

import numpy as np
from paraview import simple

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import csgv_tools as ct  # noqa: E402
from bench_host_copies import rollup  # noqa: E402 (/proc/self/smaps_rollup's fields, in KiB)


def memory_line(what):
    f = rollup()
    ru = resource.getrusage(resource.RUSAGE_SELF)
    print("%s: peak_rss_mib %.0f, rss_mib %.0f, private_mib %.0f, anonymous_mib %.0f, major_faults %d"
          % (what, ru.ru_maxrss / 1024.0, f.get("Rss", 0) / 1024.0,
             (f.get("Private_Clean", 0) + f.get("Private_Dirty", 0)) / 1024.0, f.get("Anonymous", 0) / 1024.0,
             ru.ru_majflt))
    sys.stdout.flush()


def info(d, name):
    d.UpdatePropertyInformation()
    return d.GetPropertyValue(name)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("plugin")
    ap.add_argument("csgv")
    ap.add_argument("--host-mib", type=int, default=1024)
    ap.add_argument("--device-mib", type=int, default=1024)
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--views", type=int, default=8)
    ap.add_argument("--compare", action="store_true")
    a = ap.parse_args()
    simple.LoadPlugin(a.plugin, remote=False, ns=globals())
    w, h = (int(x) for x in a.size.split("x"))
    print("file_mib: %.1f" % (os.path.getsize(a.csgv) / 2.0 ** 20))
    print("host_budget_mib: %d\ndevice_budget_mib: %d" % (a.host_mib, a.device_mib))
    view = simple.CreateRenderView()
    view.ViewSize = [w, h]
    view.OrientationAxesVisibility = 0
    simple.Render(view)
    memory_line("start")
    t0 = time.time()
    r = simple.OpenDataFile(a.csgv)
    r.UpdatePipeline()
    print("open_seconds: %.2f" % (time.time() - t0))
    memory_line("after_open")
    d = simple.Show(r, view)
    d.SetRepresentationType("Segmentation Volume")
    d.CSGVHostMemoryMiB = a.host_mib
    d.CSGVDeviceMemoryMiB = a.device_mib
    d.CSGVFramesPerStillRender = 1
    view.ResetCamera()
    simple.Render(view)
    print("open_to_first_image_seconds: %.2f" % (time.time() - t0))
    print("levels_on_disk: %d (0 all in memory, 1 finest level from the file, 2 every level)" % info(d, "CSGVLevelsOnDisk"))
    memory_line("after_first_image")
    d.CSGVFramesPerStillRender = 64
    d.CSGVStillRenderTimeBudget = 600
    first_labels = None
    eye0 = list(view.CameraPosition)
    focal = list(view.CameraFocalPoint)
    for i in range(a.views):
        # About the view-up axis through the focal point (ParaView's default camera looks along
        # -z with y up: an orbit about y).
        ang = 2 * math.pi * i / a.views
        dx, dz = eye0[0] - focal[0], eye0[2] - focal[2]
        view.CameraPosition = [focal[0] + dx * math.cos(ang) + dz * math.sin(ang), eye0[1],
                               focal[2] - dx * math.sin(ang) + dz * math.cos(ang)]
        t1 = time.time()
        simple.Render(view)
        seconds = time.time() - t1
        print("view %d: %.2f s to converge, %d frames, min samples %d, file read %.1f MiB"
              % (i, seconds, info(d, "CSGVFramesLastRender"), info(d, "CSGVMinSamples"), info(d, "CSGVFileReadMiB")))
        if i == 0 and a.compare:
            first_labels = ct.label_image(d)
    memory_line("after_orbit")
    print("bad_bricks: %d" % info(d, "CSGVBadBricks"))
    if a.compare:
        view.CameraPosition = eye0
        d.CSGVHostMemoryMiB = 1 << 20
        d.CSGVDeviceMemoryMiB = 0
        simple.Render(view)
        print("levels_on_disk_unconstrained: %d" % info(d, "CSGVLevelsOnDisk"))
        ref = ct.label_image(d)
        print("first_hit_labels_equal_unconstrained: %s (%d of %d pixels differ)"
              % ("yes" if np.array_equal(ref, first_labels) else "no", int((ref != first_labels).sum()), ref.size))
    simple.Disconnect()


main()
