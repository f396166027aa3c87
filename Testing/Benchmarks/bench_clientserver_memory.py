# SPDX-License-Identifier: MIT
"""Where a `.csgv` lives in client/server mode (issue 40; a benchmark: it prints figures, asserts
nothing). Run as the client script of clientserver_driver.py (it starts pvserver):

    CSGV_PLUGIN=PLUGIN.so CSGV_FILE=FILE.csgv xvfb-run -a python3 Testing/ParaView/clientserver_driver.py \
        --once pvserver pvpython Testing/Benchmarks/bench_clientserver_memory.py

Private memory (Private_Clean + Private_Dirty of /proc/PID/smaps_rollup) of the client and of the
server before opening, after the reader's update and after the first Segmentation Volume render,
as growth over the start and as a multiple of the file: the encoding stays on the server (mapped,
once) and the client holds only the image.
"""
import os
import time

from paraview.simple import Connect, LoadPlugin, OpenDataFile, Show, CreateRenderView, Render


def private_mib(pid="self"):
    fields = {}
    with open("/proc/%s/smaps_rollup" % pid) as f:
        for line in f:
            parts = line.split()
            if len(parts) >= 2 and parts[0].endswith(":"):
                fields[parts[0][:-1]] = int(parts[1])
    return (fields.get("Private_Clean", 0) + fields.get("Private_Dirty", 0)) / 1024.0


def server_pid(port):
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                args = f.read().split(b"\0")
        except OSError:
            continue
        if any(a.endswith(b"pvserver") for a in args) and ("--server-port=%d" % port).encode() in args:
            return pid
    return None


port = int(os.environ["CSGV_SERVER_PORT"])
path = os.environ["CSGV_FILE"]
Connect("localhost", port)
LoadPlugin(os.environ["CSGV_PLUGIN"], remote=True, ns=globals())
LoadPlugin(os.environ["CSGV_PLUGIN"], remote=False, ns=globals())
server = server_pid(port)
file_mib = os.path.getsize(path) / 2.0 ** 20
view = CreateRenderView()
view.ViewSize = [640, 360]
Render(view)
start = {"client": private_mib(), "server": private_mib(server)}
print("file_mib: %.1f" % file_mib)


def report(what):
    for side in ("client", "server"):
        now = private_mib() if side == "client" else private_mib(server)
        print("%s_private_%s_mib: %.0f (growth %.0f MiB, %.2fx the file)"
              % (side, what, now, now - start[side], (now - start[side]) / file_mib))


t0 = time.time()
r = OpenDataFile(path)
r.UpdatePipeline()
print("open_seconds: %.2f" % (time.time() - t0))
report("after_open")
d = Show(r, view)
d.SetRepresentationType("Segmentation Volume")
d.CSGVFramesPerStillRender = 1
view.ResetCamera()
Render(view)
print("open_to_first_image_seconds: %.2f" % (time.time() - t0))
report("after_first_image")
