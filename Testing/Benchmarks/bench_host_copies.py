# SPDX-License-Identifier: MIT
"""How many copies of a `.csgv`'s encoding ParaView holds in host memory (issue 40; a benchmark:
it prints figures, asserts nothing).

    xvfb-run -a pvpython Testing/Benchmarks/bench_host_copies.py PLUGIN.so FILE.csgv [--size 640x360]

Private memory (Private_Clean + Private_Dirty of /proc/self/smaps_rollup: what this process
alone holds; pages of a file only this process maps count too) and its anonymous part (what
only swap could take back) before opening, after the reader's update,
after the first Segmentation Volume render and after a still render, each with its growth over
the start as a multiple of the file's size, plus the times to open and to the first image.
"""
import argparse
import os
import time

from paraview import simple


def rollup():
    fields = {}
    with open("/proc/self/smaps_rollup") as f:
        for line in f:
            parts = line.split()
            if len(parts) >= 2 and parts[0].endswith(":"):
                fields[parts[0][:-1]] = int(parts[1])
    return fields


def private_mib():
    f = rollup()
    return (f.get("Private_Clean", 0) + f.get("Private_Dirty", 0)) / 1024.0


def anonymous_mib():
    """Memory only swap could take back (a mapped file's clean pages are not in it)."""
    return rollup().get("Anonymous", 0) / 1024.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("plugin")
    ap.add_argument("csgv")
    ap.add_argument("--size", default="640x360")
    a = ap.parse_args()
    simple.LoadPlugin(a.plugin, remote=False, ns=globals())
    w, h = (int(x) for x in a.size.split("x"))
    file_mib = os.path.getsize(a.csgv) / 2.0 ** 20
    view = simple.CreateRenderView()
    view.ViewSize = [w, h]
    simple.Render(view)  # the view's own memory, before the volume
    start = private_mib()
    start_anon = anonymous_mib()
    print("file_mib: %.1f" % file_mib)
    print("private_start_mib: %.0f" % start)

    def report(what, d=None):
        now = private_mib()
        anon = anonymous_mib() - start_anon
        print("private_%s_mib: %.0f (growth %.0f MiB, %.2fx the file; anonymous growth %.0f MiB, %.2fx)"
              % (what, now, now - start, (now - start) / file_mib, anon, anon / file_mib))
        if d is not None:
            # On CPU devices (lavapipe) the renderer's device memory (brick cache, images, tables)
            # is host memory too: what is left is the encoding's copies and the rest of ParaView.
            d.UpdatePropertyInformation()
            device = d.GetPropertyValue("CSGVDeviceMiB")
            print("  renderer_device_mib: %.0f (cache %.0f); growth besides it: %.0f MiB, %.2fx the file"
                  % (device, d.GetPropertyValue("CSGVCacheMiB"), now - start - device, (now - start - device) / file_mib))

    t0 = time.time()
    r = simple.OpenDataFile(a.csgv)
    r.UpdatePipeline()
    print("open_seconds: %.2f" % (time.time() - t0))
    report("after_open")
    d = simple.Show(r, view)
    d.SetRepresentationType("Segmentation Volume")
    d.CSGVFramesPerStillRender = 1
    view.ResetCamera()
    simple.Render(view)
    print("open_to_first_image_seconds: %.2f" % (time.time() - t0))
    report("after_first_image", d)
    d.CSGVFramesPerStillRender = 8
    simple.Render(view)
    report("after_still", d)


if __name__ == "__main__":
    main()
