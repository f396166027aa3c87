# SPDX-License-Identifier: MIT
"""Data-parallel Segmentation Volume per rank count (a benchmark: it prints figures, asserts
nothing). Runs itself under `mpiexec -np N pvbatch --symmetric` for each N and prints, per rank:
reader load time, first image, median of interactive orbit frames, device MiB (CSGVDeviceMiB),
the encoding bytes the rank holds, peak RSS; then how many pixels of each N's image differ from
one rank's. --images DIR keeps each N's image and a side-by-side PNG of them; --write also
times SaveData to .csgv from the N ranks (the labels decoded per rank, encoded per rank, written
by rank 0) and compares the files with one rank's byte for byte.

pvpython bench_mpi_ranks.py PLUGIN.so VOLUME.csgv [--ranks 1,2,4] [--size 640x360] [--orbit 6]
    [--images DIR] [--write] [--shading local|shadow|ao|pt]
"""
import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time


def rank_main(a):
    from paraview import servermanager as sm
    from paraview import simple
    simple.LoadPlugin(a.plugin, remote=False, ns=globals())
    pm = sm.vtkProcessModule.GetProcessModule()
    rank, ranks = pm.GetPartitionId(), pm.GetNumberOfLocalPartitions()
    w, h = (int(x) for x in a.size.split("x"))
    t0 = time.perf_counter()
    r = simple.OpenDataFile(a.volume)
    r.DecodeLabels = 0
    r.UpdatePipeline()
    load = time.perf_counter() - t0
    enc = r.GetClientSideObject().GetOutputDataObject(0).GetFieldData().GetArray("CSGVEncoding")
    v = simple.CreateRenderView()
    v.ViewSize = [w, h]
    v.OrientationAxesVisibility = 0
    d = simple.Show(r, v)
    d.SetRepresentationType("Segmentation Volume")
    d.CSGVFramesPerStillRender = 1
    d.CSGVStillRenderTimeBudget = 120
    d.CSGVShading = a.shading
    d.CSGVDenoise = 0
    v.UseFXAA = 0  # ParaView would smooth the composited image of N ranks, not one rank's
    simple.ResetCamera(v)
    cam = v.GetActiveCamera()
    cam.Azimuth(30)
    cam.Elevation(20)
    cam.Dolly(1.5)
    t0 = time.perf_counter()
    simple.Render(v)
    first = time.perf_counter() - t0
    times = []
    for _ in range(a.orbit):
        cam.Azimuth(2)
        t = time.perf_counter()
        v.SMProxy.InteractiveRender()
        times.append(1000 * (time.perf_counter() - t))
    for _ in range(a.orbit):  # back to the first view, converged, for the image comparison
        cam.Azimuth(-2)
    simple.Render(v)
    d.SMProxy.UpdatePropertyInformation()
    times.sort()
    facts = {"rank": rank, "ranks": ranks, "load_s": load, "first_s": first,
             "orbit_ms": times[len(times) // 2] if times else 0.0,
             "device_mib": d.SMProxy.GetProperty("CSGVDeviceMiB").GetElement(0),
             "encoding_bytes": enc.GetNumberOfTuples() if enc else 0,
             "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}
    with open(os.path.join(a.out, "rank%d.json" % rank), "w") as f:
        json.dump(facts, f)
    simple.SaveScreenshot(os.path.join(a.out, "image.png" if rank == 0 else "image.rank%d.png" % rank), v,
                          ImageResolution=[w, h], TransparentBackground=0)
    simple.Hide(r, v)
    simple.Delete(v)  # before the interpreter's teardown (which lost its GLX context otherwise)
    if a.write:
        labels = globals()["CSGVReader"](FileName=a.volume, DecodeLabels=1, DecodeThreshold=2**62)
        pm.GetGlobalController().Barrier()
        t0 = time.perf_counter()
        simple.SaveData(os.path.join(a.out, "written.csgv"), proxy=labels, BrickSize=32)
        pm.GetGlobalController().Barrier()
        facts["write_s"] = time.perf_counter() - t0
        facts["peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        with open(os.path.join(a.out, "rank%d.json" % rank), "w") as f:
            json.dump(facts, f)


def load_png(path):
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkPNGReader
    r = vtkPNGReader()
    r.SetFileName(path)
    r.Update()
    return vtk_to_numpy(r.GetOutput().GetPointData().GetScalars()).astype(int)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("plugin")
    ap.add_argument("volume")
    ap.add_argument("--ranks", default="1,2,4")
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--orbit", type=int, default=6)
    ap.add_argument("--images", help="keep the images and a side-by-side PNG here")
    ap.add_argument("--write", action="store_true", help="also time a parallel SaveData")
    ap.add_argument("--shading", default="local", choices=["local", "shadow", "ao", "pt"],
                    help="the shading mode (the denoiser is off: it filters across the screen)")
    ap.add_argument("--out", help=argparse.SUPPRESS)  # set when running as a rank
    a = ap.parse_args()
    if a.out:
        return rank_main(a)
    for key in list(os.environ):  # pvpython is an MPI singleton: its launcher's variables go
        if key.startswith(("OMPI_", "PMIX_", "OPAL_", "ORTE_")):
            del os.environ[key]
    os.environ.update({"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
                       "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMP_NUM_THREADS": "1"})
    here = os.path.dirname(os.path.abspath(__file__))
    top = tempfile.mkdtemp(prefix="csgv-bench-mpi-")
    print("ranks rank load_s first_s orbit_ms device_mib encoding_mib peak_rss_mib")
    images = {}
    for n in (int(x) for x in a.ranks.split(",")):
        out = os.path.join(top, "np%d" % n)
        os.makedirs(out)
        command = [shutil.which("pvbatch"), "--symmetric", "--force-offscreen-rendering", os.path.abspath(__file__),
                   a.plugin, a.volume, "--size", a.size, "--orbit", str(a.orbit), "--shading", a.shading, "--out", out] + \
                  (["--write"] if a.write else [])
        if n > 1:
            command = [shutil.which("mpiexec"), "-np", str(n)] + command
        run = subprocess.run(["/usr/bin/python3", os.path.join(here, "..", "ParaView", "xretry.py")] + command,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if run.returncode != 0:
            print(run.stdout[-3000:])
            return 1
        for r in range(n):
            f = json.load(open(os.path.join(out, "rank%d.json" % r)))
            print("%5d %4d %6.2f %7.2f %8.1f %10.1f %12.2f %12.0f%s" % (
                n, r, f["load_s"], f["first_s"], f["orbit_ms"], f["device_mib"], f["encoding_bytes"] / 2**20,
                f["peak_rss_mib"], "  write %.1f s" % f["write_s"] if "write_s" in f else ""))
        images[n] = load_png(os.path.join(out, "image.png"))
        sys.stdout.flush()
    base = min(images)
    if a.write:
        first = os.path.join(top, "np%d" % base, "written.csgv")
        for n in images:
            other = os.path.join(top, "np%d" % n, "written.csgv")
            same = os.path.isfile(other) and open(other, "rb").read() == open(first, "rb").read()
            print("%d ranks: SaveData wrote %d bytes, %s %d rank(s)'s" % (
                n, os.path.getsize(other) if os.path.isfile(other) else 0, "equal to" if same else "NOT equal to", base))
    if a.images:
        import numpy as np
        from vtkmodules.util.numpy_support import numpy_to_vtk
        from vtkmodules.vtkCommonDataModel import vtkImageData
        from vtkmodules.vtkIOImage import vtkPNGWriter
        os.makedirs(a.images, exist_ok=True)
        w, h = (int(x) for x in a.size.split("x"))
        for n in images:
            shutil.copy(os.path.join(top, "np%d" % n, "image.png"), os.path.join(a.images, "ranks%d.png" % n))
        side = np.concatenate([images[n].reshape(h, w, -1) for n in sorted(images)], axis=1)
        img = vtkImageData()
        img.SetDimensions(side.shape[1], side.shape[0], 1)
        img.GetPointData().SetScalars(numpy_to_vtk(side.reshape(-1, side.shape[2]).astype(np.uint8), deep=True))
        pw = vtkPNGWriter()
        pw.SetFileName(os.path.join(a.images, "side_by_side.png"))
        pw.SetInputData(img)
        pw.Write()
    for n, img in images.items():
        if n == base:
            continue
        import numpy as np
        diff = np.abs(img - images[base]).max(axis=1)
        print("%d ranks: %d of %d pixels differ from %d rank(s), %d by more than 16/255" % (
            n, int((diff > 0).sum()), diff.size, base, int((diff > 16).sum())))
    shutil.rmtree(top, ignore_errors=True)
    return 0


if __name__ == "__main__":
    code = main()
    if code:  # ranks end normally: pvbatch finalizes MPI only when its script returns
        sys.exit(code)
