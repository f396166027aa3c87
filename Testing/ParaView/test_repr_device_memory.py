# SPDX-License-Identifier: MIT
"""Device memory in ParaView. Cache paletting (CSGVCachePaletting): off keeps 32-bit labels in
the brick cache, on packs palette indices and draws the same image, automatic stays off while the
cache holds what the view needs and turns on once the cache of labels runs full (under a tight
device-memory budget), then draws the same image as an unconstrained view. Detail separation
(GPU decoding, CSGVDecoding 1): a budget that the encoding would take more than half of keeps its
finest level in host memory (CSGVDetailSeparated), streamed to the device as the view needs it,
within the budget, with the same image; a larger budget uploads it whole again; decodes carried
over frames (CSGVDecodeStepsPerFrame) give the same image. Host decoding holds no encoding on the
device."""
import os
import subprocess

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
csgv = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(160, 120)
d = Show(csgv, v)
d.CSGVFramesPerStillRender = 1
d.CSGVStillRenderTimeBudget = 60
v.ResetCamera()
v.CameraPosition = [-60, 130, 160]
v.CameraFocalPoint = [66, 35, 97]
v.CameraViewUp = [0, 0, 1]


def cache_bits():
    d.SMProxy.UpdatePropertyInformation()
    return d.SMProxy.GetProperty("CSGVCacheBits").GetElement(0)


def differs(a, b):
    return np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 2


d.CSGVCachePaletting = 0
labels = t.screenshot(v, 160, 120, "off.png")
t.check(cache_bits() == 32, "off: the cache holds 32-bit labels (%d bits)" % cache_bits())
t.check(t.content_mask(labels).mean() > 0.1, "off: the volume draws")

d.CSGVCachePaletting = 1
packed = t.screenshot(v, 160, 120, "on.png")
t.check(0 < cache_bits() < 32, "on: the cache holds packed palette indices (%d bits)" % cache_bits())
t.check(differs(packed, labels).mean() == 0, "on: the same image as with labels (%.2f%% of pixels differ)"
        % (100 * differs(packed, labels).mean()))

d.CSGVCachePaletting = 2
auto = t.screenshot(v, 160, 120, "auto.png")
t.check(cache_bits() == 32, "automatic: labels while the cache holds the view (%d bits)" % cache_bits())
t.check(differs(auto, labels).mean() == 0, "automatic: the same image")

# A budget that leaves the cache far less than the view's bricks: the cache runs full, the next
# render packs it, and the image converges to the same one.
d.CSGVDeviceMemoryMiB = 3
t.screenshot(v, 160, 120, "tight1.png")
t.screenshot(v, 160, 120, "tight2.png")
tight = t.screenshot(v, 160, 120, "tight3.png")
t.check(0 < cache_bits() < 32, "automatic: packed once the cache of labels ran full (%d bits)" % cache_bits())
t.check(differs(tight, labels).mean() == 0, "automatic under a tight budget: the same image (%.2f%% of pixels differ)"
        % (100 * differs(tight, labels).mean()))
d.CSGVCachePaletting = 0
t.screenshot(v, 160, 120, "tight_off.png")
t.check(cache_bits() == 32, "off again: labels")
Delete(csgv)

# Detail separation: a synthetic volume whose encoding is a few MiB.
big = os.path.join(t.temp_dir(), "synth384.csgv")
subprocess.run([os.environ["CSGV_TOOL"], "compress", "synth:384x384x384", big], check=True, stdout=subprocess.DEVNULL)
encoding_mib = os.path.getsize(big) / 2**20
s = OpenDataFile(big)
v2 = t.render_view(160, 120)
d2 = Show(s, v2)
d2.CSGVFramesPerStillRender = 1
d2.CSGVStillRenderTimeBudget = 60
d2.CSGVLODBias = -3  # the finest level for the bricks in view: those are what streaming uploads
v2.ResetCamera()


def memory():
    d2.SMProxy.UpdatePropertyInformation()
    return tuple(d2.SMProxy.GetProperty(n).GetElement(0)
                 for n in ("CSGVDetailSeparated", "CSGVDeviceMiB", "CSGVDeviceBudgetMiB", "CSGVDetailStreamedMiB"))


whole = t.screenshot(v2, 160, 120, "whole.png")  # automatic decoding: the host's on CPU devices
t.check(t.content_mask(whole).mean() > 0.1, "the %.1f MiB encoding draws" % encoding_mib)
# GPU decoding: the automatic budget holds the encoding whole.
d2.CSGVDecoding = 1
gpu_whole = t.screenshot(v2, 160, 120, "gpu_whole.png")
separated, device_whole, _, _ = memory()
t.check(separated == 0 and differs(gpu_whole, whole).mean() == 0,
        "GPU decoding holds the encoding whole under the automatic budget, same image (%.2f%% of pixels differ)"
        % (100 * differs(gpu_whole, whole).mean()))
# Decodes carried over frames (CSGVDecodeStepsPerFrame, as on GPUs): the still render converges
# to the same image.
d2.CSGVDecodeStepsPerFrame = 300
carried = t.screenshot(v2, 160, 120, "gpu_carried.png")
t.check(differs(carried, whole).mean() == 0, "GPU decodes carried over frames: the same image (%.2f%% of pixels differ)"
        % (100 * differs(carried, whole).mean()))
d2.CSGVDecodeStepsPerFrame = 0
budget = int(2 * encoding_mib)  # the encoding takes more than half of it
t.check(budget >= 4, "the synthetic encoding is large enough for the test (%.1f MiB)" % encoding_mib)
d2.CSGVDeviceMemoryMiB = budget
split = t.screenshot(v2, 160, 120, "separated.png")
separated, device, budget_mib, streamed = memory()
t.check(separated == 1 and device <= budget_mib == budget and streamed > 0,
        "a %d MiB budget keeps the finest level in host memory, %.2f MiB streamed (%.1f MiB on the device)"
        % (budget, streamed, device))
t.check(differs(split, whole).mean() == 0, "separated: the same image (%.2f%% of pixels differ)"
        % (100 * differs(split, whole).mean()))
d2.CSGVDeviceMemoryMiB = 0
again = t.screenshot(v2, 160, 120, "whole_again.png")
separated, _, _, _ = memory()
t.check(separated == 0 and differs(again, whole).mean() == 0, "the automatic budget uploads it whole again")
# Host decoding needs no encoding on the device: the same budget holds it with room to spare.
d2.CSGVDecoding = 2
d2.CSGVDeviceMemoryMiB = budget
host = t.screenshot(v2, 160, 120, "host.png")
separated, device_host, _, _ = memory()
t.check(separated == 0 and device_host <= budget and differs(host, whole).mean() == 0,
        "host decoding under %d MiB: nothing separated, %.1f MiB on the device, the same image" % (budget, device_host))

# A budget whose cache cannot hold what the view touches (640x480 of the 384^3 volume at the
# finest level: about 196 bricks, 24.5 MiB of 32-bit labels; 32 MiB leave the cache about 7 MiB):
# the image still converges, and a warning says so once, with what to raise; a budget that holds
# the view clears it, and the tight one says it again.
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow  # noqa: E402

# One view of the volume: views of one volume split the budget.
Delete(d2)
del d2
Delete(v2)
del v2
v3 = t.render_view(640, 480)
d3 = Show(s, v3)
d3.CSGVCachePaletting = 0
d3.CSGVStillRenderTimeBudget = 60
v3.ResetCamera()
previous = vtkOutputWindow.GetInstance()
messages = vtkStringOutputWindow()
vtkOutputWindow.SetInstance(messages)
try:
    d3.CSGVDeviceMemoryMiB = 32
    Render(v3)
    first = messages.GetOutput().count("this view touches")
    GetActiveCamera().Azimuth(1)
    Render(v3)
    repeated = messages.GetOutput().count("this view touches")
    d3.CSGVDeviceMemoryMiB = 0
    Render(v3)
    held = messages.GetOutput().count("this view touches")
    d3.CSGVDeviceMemoryMiB = 32
    GetActiveCamera().Azimuth(1)
    Render(v3)
    again = messages.GetOutput().count("this view touches")
    text = messages.GetOutput()
finally:
    vtkOutputWindow.SetInstance(previous)
t.check(first == 1 and "Device Memory Budget (MiB) by at least" in text,
        "a cache too small for the view: one warning naming the budget (%d): %s" % (first, text[-400:]))
t.check(repeated == 1 and held == 1 and again == 2,
        "said once while it lasts, again after a budget held the view (%d, %d, %d)" % (repeated, held, again))
t.finish()
