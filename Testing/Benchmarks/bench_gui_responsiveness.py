# SPDX-License-Identifier: MIT
"""What a GUI user waits for with a Segmentation Volume (a benchmark: it prints figures, asserts
nothing). Issue 15's table, measured in pvpython on one view of the GUI's size:

    pvpython bench_gui_responsiveness.py PLUGIN.so VOLUME [--size 1050x930] [--rotations 10]

- first image: Show to the end of the first still render (local shading, defaults);
- rotation frame: the camera turns 2 degrees, then an interactive render (what the GUI does while
  the mouse drags; ParaView asks for 5 frames a second), median of --rotations, with the size the
  volume was rendered at;
- path-traced still render: one still render after switching to path tracing (the budget is
  CSGVStillRenderTimeBudget, 3 s by default);
- time to converge: still renders one after another (what the GUI's progressive refinement does)
  until every pixel holds CSGVFramesPerStillRender samples;
- unchanged after a change without effect: attribute files loaded that no material names, then a
  render: its time and whether the samples stayed.
Compare two builds in one run (machines here are noisy) and report ratios.
"""
import argparse
import os
import statistics
import sys
import tempfile
import time

from paraview import simple

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools  # noqa: E402  (the query helper of the examples)


def timed(fn):
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("plugin")
    ap.add_argument("volume")
    ap.add_argument("--size", default="1050x930")
    ap.add_argument("--rotations", type=int, default=10)
    a = ap.parse_args()
    w, h = (int(x) for x in a.size.split("x"))
    simple.LoadPlugin(a.plugin, remote=False, ns=globals())
    src = simple.OpenDataFile(a.volume)
    src.UpdatePipeline()
    view = simple.CreateRenderView()
    view.ViewSize = [w, h]
    view.OrientationAxesVisibility = 0

    def show():
        d = simple.Show(src, view)
        d.SetRepresentationType("Segmentation Volume")
        simple.ResetCamera(view)
        simple.Render(view)
        return d

    t = time.perf_counter()
    d = show()
    first = time.perf_counter() - t
    cam = view.GetActiveCamera()
    samples = lambda: (d.UpdatePropertyInformation(), d.GetPropertyValue("CSGVMinSamples"))[1]

    def converge(limit_s=120):
        t0, renders = time.perf_counter(), 0
        while samples() < d.CSGVFramesPerStillRender and time.perf_counter() - t0 < limit_s:
            simple.Render(view)
            renders += 1
        return time.perf_counter() - t0, renders

    converge()
    rotations, sizes = [], set()
    for _ in range(a.rotations):
        cam.Azimuth(2)
        rotations.append(timed(lambda: view.SMProxy.InteractiveRender()))
        sizes.add("x".join(csgv_tools.query(d, "labels").split()[:2]))
    simple.Render(view)
    converge()

    d.CSGVShading = "pt"
    pt_still = timed(lambda: simple.Render(view))
    pt_converge, pt_renders = converge()

    csv = os.path.join(tempfile.mkdtemp(), "unused.csv")
    with open(csv, "w") as f:
        f.write("label,unused\n1,5\n2,7\n")
    before = samples()
    d.CSGVAttributeFiles = [csv]
    unchanged = timed(lambda: simple.Render(view))
    after = samples()

    print("view %dx%d, %s" % (w, h, os.path.basename(a.volume)))
    print("first_image_s %.2f" % first)
    print("rotation_frame_ms %.0f (median of %d; rendered at %s)" % (1000 * statistics.median(rotations),
                                                                      len(rotations), ", ".join(sorted(sizes))))
    print("pt_still_render_s %.2f (budget %.1f s)" % (pt_still, d.CSGVStillRenderTimeBudget))
    print("pt_time_to_converge_s %.1f (%d still renders to %d samples)" % (pt_converge, pt_renders,
                                                                          d.CSGVFramesPerStillRender))
    print("attribute_load_without_effect_ms %.0f (min samples %d -> %d)" % (1000 * unchanged, before, after))
    sys.stdout.flush()


main()
