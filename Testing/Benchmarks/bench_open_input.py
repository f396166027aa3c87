# SPDX-License-Identifier: MIT
"""What a ParaView user sees when opening a large segmentation through the "Segmentation (CSGV)"
reader (a benchmark: it prints figures, asserts nothing).

    xvfb-run -a pvpython Testing/Benchmarks/bench_open_input.py PLUGIN.so INPUT [--cache-dir D]
        [--size 640x360]

Prints: time to compress (first open, Apply), progress events (how many, and the longest gap
between two), peak RSS of the pvpython process, the first rendered frame, then a second open of
the same input (the cached `.csgv` is reused) and its time.
"""
import argparse
import os
import resource
import shutil
import tempfile
import time

from paraview import simple


def peak_rss_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def open_once(path, cache_dir):
    r = globals()["SegmentationCSGV"](FileName=path, CacheDirectory=cache_dir)  # from LoadPlugin
    algo = r.GetClientSideObject()
    stamps = []
    tag = algo.AddObserver("ProgressEvent", lambda o, e: stamps.append((time.time(), o.GetProgress())))
    t0 = time.time()
    r.UpdatePipeline()
    secs = time.time() - t0
    algo.RemoveObserver(tag)
    gaps = [b[0] - a[0] for a, b in zip(stamps, stamps[1:])]
    return r, secs, stamps, max(gaps) if gaps else 0.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("plugin")
    ap.add_argument("input")
    ap.add_argument("--cache-dir", default="")
    ap.add_argument("--size", default="640x360")
    a = ap.parse_args()
    simple.LoadPlugin(a.plugin, remote=False, ns=globals())
    cache = a.cache_dir or tempfile.mkdtemp(prefix="csgv-open-")
    w, h = (int(x) for x in a.size.split("x"))
    print("input: %s" % a.input)
    print("rss_before_open_mib: %.0f" % peak_rss_mib())
    r, secs, stamps, gap = open_once(a.input, cache)
    r.UpdatePropertyInformation()
    cached = r.GetPropertyValue("CachedFileName")
    print("first_open_seconds: %.1f" % secs)
    print("progress_events: %d (last %.2f, longest gap %.1f s)" % (len(stamps), stamps[-1][1] if stamps else 0, gap))
    print("peak_rss_after_open_mib: %.0f" % peak_rss_mib())
    print("cached_csgv: %s (%.1f MiB)" % (cached, os.path.getsize(cached) / 2 ** 20 if cached else 0))
    view = simple.CreateRenderView()
    view.ViewSize = [w, h]
    d = simple.Show(r, view)
    print("representation: %s" % d.Representation)
    simple.ResetCamera(view)
    t0 = time.time()
    simple.Render(view)
    print("first_render_seconds: %.2f" % (time.time() - t0))
    print("peak_rss_after_render_mib: %.0f" % peak_rss_mib())
    simple.Delete(r)
    _, secs2, _, _ = open_once(a.input, cache)
    print("second_open_seconds (cache reused): %.2f" % secs2)
    if not a.cache_dir:
        shutil.rmtree(cache, ignore_errors=True)


if __name__ == "__main__":
    main()
