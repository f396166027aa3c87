# SPDX-License-Identifier: MIT
"""Host cost of the Segmentation Volume in ParaView (a benchmark: it prints figures, asserts nothing).

pvpython bench_repr_frames.py PLUGIN.so VOLUME [--size 640x360] [--renders 30] [--shading local]

Three figures, each the median of --renders calls of Render() on one view:
- unchanged: the camera and everything else as before (the image is final): what a render costs
  when nothing is drawn anew (change detection, depth read-back, compositing);
- orbit: the camera turns 1 degree between renders, one frame a render (FramesPerStillRender 1);
- still: the camera turns, then a still render accumulates 8 frames.
Compare two builds in one run (machines here are noisy) and report ratios.
"""
import argparse
import statistics
import sys
import time

from paraview import simple


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("plugin")
    ap.add_argument("volume")
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--renders", type=int, default=30)
    ap.add_argument("--shading", default="local")
    a = ap.parse_args()
    w, h = (int(x) for x in a.size.split("x"))
    simple.LoadPlugin(a.plugin, remote=False, ns=globals())
    src = simple.OpenDataFile(a.volume)
    view = simple.CreateRenderView()
    view.ViewSize = [w, h]
    view.OrientationAxesVisibility = 0
    d = simple.Show(src, view)
    d.SetRepresentationType("Segmentation Volume")
    d.CSGVShading = a.shading
    d.CSGVFramesPerStillRender = 1
    d.CSGVStillRenderTimeBudget = 60
    simple.ResetCamera(view)
    cam = view.GetActiveCamera()
    cam.Azimuth(30)
    cam.Elevation(20)
    t0 = time.perf_counter()
    simple.Render(view)
    first = time.perf_counter() - t0
    for _ in range(5):  # warm: bricks decoded, pipelines compiled
        simple.Render(view)

    def timed(step):
        ts = []
        for _ in range(a.renders):
            step()
            t = time.perf_counter()
            simple.Render(view)
            ts.append((time.perf_counter() - t) * 1000)
        return statistics.median(ts)

    unchanged = timed(lambda: None)
    orbit = timed(lambda: cam.Azimuth(1))
    d.CSGVFramesPerStillRender = 8
    simple.Render(view)
    still = timed(lambda: cam.Azimuth(1))
    print("first_render_ms %.1f" % (first * 1000))
    print("unchanged_ms %.2f" % unchanged)
    print("orbit_1frame_ms %.2f" % orbit)
    print("still_8frames_ms %.2f" % still)
    sys.stdout.flush()
    simple.Disconnect()


main()
