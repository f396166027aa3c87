# SPDX-License-Identifier: MIT
"""The Segmentation Volume representation: offered for image data, the default for .csgv and
.vraw, draws the CSGV encoding and plain label arrays (compressed on the fly), in several views,
in screenshots larger than the view, in parallel projection; still renders accumulate
FramesPerStillRender samples, interactive renders one frame; a property change leaves no stale
image; hiding it draws nothing."""
import os

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
fixture = os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv")

# Availability and defaults.
csgv = OpenDataFile(fixture)
v = t.render_view(160, 120)
d = Show(csgv, v)
t.check(d.Representation == "Segmentation Volume", "default representation of .csgv is Segmentation Volume (got %r)" % d.Representation)
vraw = OpenDataFile(os.path.join(t.FIXTURES, "synthA.vraw.gz"))
dv = Show(vraw, v)
t.check(dv.Representation == "Segmentation Volume", "default representation of .vraw.gz is Segmentation Volume")
Hide(vraw, v)
nii = OpenDataFile(t.AAL)
v2 = t.render_view(160, 120)
dn = Show(nii, v2)
t.check(dn.Representation == "Segmentation Volume",
        "default representation of a NIfTI label volume is Segmentation Volume (got %r)" % dn.Representation)
T1 = "/usr/share/mricron/templates/inia19-t1-brain.nii.gz"
if os.path.exists(T1):
    # A float intensity image is not drawn as labels by default.
    t1 = OpenDataFile(T1)
    dt1 = Show(t1, v2)
    t.check(dt1.Representation != "Segmentation Volume",
            "default representation of a NIfTI image is not Segmentation Volume (got %r)" % dt1.Representation)
    Hide(t1, v2)
    Delete(t1)
wavelet = Wavelet()
dw = Show(wavelet, v2)
t.check("Segmentation Volume" in dw.Representation.Available, "offered for any image data (Wavelet)")
Hide(wavelet, v2)

# The encoding: still render, then an interactive render after a camera move.
d.CSGVFramesPerStillRender = 3
d.CSGVStillRenderTimeBudget = 60
v.ResetCamera()
img = t.screenshot(v, 160, 120)
mask = t.content_mask(img)
t.check(mask.mean() > 0.1, "the .csgv draws (%.1f%% of pixels)" % (100 * mask.mean()))
frames, samples = t.repr_info(d)
t.check(samples == 3, "a still render accumulates FramesPerStillRender samples (min samples %d)" % samples)
v.CameraPosition = [p + 3 for p in v.CameraPosition]
v.SMProxy.InteractiveRender()
frames, samples = t.repr_info(d)
t.check(frames == 1, "an interactive render renders one frame (%d)" % frames)

# No stale image: a new material colours everything red at once.
d.CSGVMaterials = t.constant_materials([1, 0, 0])
red = t.screenshot(v, 160, 120)
m = t.content_mask(red)
t.check(m.mean() > 0.1 and (red[m][:, 0].astype(int) > red[m][:, 2].astype(int) + 40).mean() > 0.95,
        "a material change shows at the next render (red)")
d.CSGVMaterials = ""

# Screenshot larger than the view: the same picture, four times the size.
big = t.screenshot(v, 640, 480, "big.png")
small = t.screenshot(v, 160, 120, "small.png")
mb, ms = t.content_mask(big), t.content_mask(small)
t.check(abs(mb.mean() - ms.mean()) < 0.02, "640x480 screenshot covers the same fraction (%.3f vs %.3f)" % (mb.mean(), ms.mean()))
down = big.reshape(120, 4, 160, 4, 3).mean(axis=(1, 3))
t.check(np.abs(down - small.astype(float)).mean() < 12, "640x480 screenshot downsampled matches 160x120 (mean diff %.1f)"
        % np.abs(down - small.astype(float)).mean())

# Parallel projection.
v.CameraParallelProjection = 1
v.ResetCamera()
par = t.screenshot(v, 160, 120, "parallel.png")
t.check(t.content_mask(par).mean() > 0.1, "parallel projection draws")
v.CameraParallelProjection = 0
before = t.screenshot(v, 160, 120, "before.png")

# Cell data from another reader, compressed on the fly, in a second view at the same time.
v2.ResetCamera()
aal = t.screenshot(v2, 160, 120, "aal.png")
t.check(t.content_mask(aal).mean() > 0.1, "NIfTI labels draw (compressed on the fly)")
again = t.screenshot(v, 160, 120, "again.png")
t.check(np.abs(again.astype(int) - before.astype(int)).mean() < 1,
        "the first view still draws its volume after the second view rendered")

# The same source in a second view shares the upload and the cache budget, and still draws.
d.CSGVCacheSizeMiB = 64
t.screenshot(v, 160, 120, "v_64.png")
cache1, _, _ = t.repr_memory(d)
v3 = t.render_view(160, 120)
d3 = Show(csgv, v3)
d3.CSGVCacheSizeMiB = 64
v3.ResetCamera()
t.check(t.content_mask(t.screenshot(v3, 160, 120, "v3.png")).mean() > 0.1, "a second view of the same .csgv draws")
t.screenshot(v, 160, 120, "v_again.png")
cache_a, _, _ = t.repr_memory(d)
cache_b, _, _ = t.repr_memory(d3)
t.check(abs(cache1 - 64) < 1 and abs(cache_a - 32) < 1 and abs(cache_b - 32) < 1,
        "two views of one volume split its 64 MiB cache budget (%.0f -> %.0f + %.0f MiB)" % (cache1, cache_a, cache_b))

# A device-memory budget bounds each view's renderer (the views split it, each counting the
# shared encoding); the cache takes what the rest leaves. Too small a budget is an error that
# names it, nothing is drawn, and a larger one draws again.
_, _, automatic = t.repr_memory(d)
t.check(automatic > 64, "the automatic device-memory budget is what the device reports (%.0f MiB)" % automatic)
for display in (d, d3):
    display.CSGVDeviceMemoryMiB = 12
bounded = t.screenshot(v, 160, 120, "v_budget.png")
t.screenshot(v3, 160, 120, "v3_budget.png")
for name, display in (("first", d), ("second", d3)):
    cache, device, budget = t.repr_memory(display)
    t.check(5 < budget < 7 and device <= budget and cache < budget,
            "the %s view keeps within its share of a 12 MiB budget (cache %.1f, device %.1f, budget %.1f MiB)"
            % (name, cache, device, budget))
t.check(np.abs(bounded.astype(int) - again.astype(int)).mean() < 1, "the budget leaves the image as it was")
with t.ErrorLog() as errors:
    d.CSGVDeviceMemoryMiB = 1
    tiny = t.screenshot(v, 160, 120, "v_tiny_budget.png")
t.check("budget" in errors.text and t.content_mask(tiny).mean() == 0,
        "a budget too small for the view is refused with a message naming it")
d.CSGVDeviceMemoryMiB = 0
d3.CSGVDeviceMemoryMiB = 0
t.check(t.content_mask(t.screenshot(v, 160, 120, "v_unbounded.png")).mean() > 0.1, "the automatic budget draws again")

# Which array: an image with a float intensity and integer labels (point data) picks the labels;
# naming the intensity is an error naming it (it holds non-integers); naming the labels draws.
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonDataModel import vtkImageData
from vtkmodules.vtkIOXML import vtkXMLImageDataWriter
n = 24
img = vtkImageData()
img.SetDimensions(n, n, n)
k, j, i = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
intensity = numpy_to_vtk((np.sin(i * 0.3) * 100.5).ravel().astype(np.float32), deep=1)
intensity.SetName("intensity")
labels = numpy_to_vtk((1 + (i // 6) + 4 * (j // 6) + 16 * (k // 6)).ravel().astype(np.uint16), deep=1)
labels.SetName("labels")
img.GetPointData().AddArray(intensity)
img.GetPointData().AddArray(labels)
vti = os.path.join(t.temp_dir(), "two_arrays.vti")
w = vtkXMLImageDataWriter()
w.SetFileName(vti)
w.SetInputData(img)
w.Write()
two = OpenDataFile(vti)
v4 = t.render_view(120, 90)
d4 = Show(two, v4)
d4.SetRepresentationType("Segmentation Volume")
v4.ResetCamera()
t.check(t.content_mask(t.screenshot(v4, 120, 90, "auto.png")).mean() > 0.1, "automatic array choice: the integer labels")
with t.ErrorLog() as errors:
    d4.CSGVLabelArray = "intensity"
    img4 = t.screenshot(v4, 120, 90, "intensity.png")
t.check("intensity" in errors.text and t.content_mask(img4).mean() == 0,
        "a non-integer array is refused with a message naming it")
d4.CSGVLabelArray = "labels"
t.check(t.content_mask(t.screenshot(v4, 120, 90, "named.png")).mean() > 0.1, "the array chosen by name draws")

# Values no domain checks (Python, state files) are held to their ranges, each named in one
# warning: a NaN light direction or blend draws as the defaults do (not black), a huge
# FramesPerStillRender renders as 4096 would (it made saving a screenshot run without end).
v4.ViewSize = [64, 48]
d4.CSGVShading = "shadow"
d4.CSGVFramesPerStillRender = 1
reference = t.screenshot(v4, 64, 48, "held_reference.png")
with t.ErrorLog() as errors:
    d4.CSGVLightDirection = [float("nan")] * 3
    d4.CSGVShadingBlend = float("nan")
    held = t.screenshot(v4, 64, 48, "held.png")
t.check(np.array_equal(held, reference), "NaN light direction and blend draw as the defaults do")
d4.CSGVLightDirection = [0.35e308, 0.6e308, 0.72e308]  # finite, beyond float: the same direction
t.check(np.abs(t.screenshot(v4, 64, 48, "held_huge.png").astype(int) - reference.astype(int)).max() <= 1,
        "a light direction of huge components draws as the same direction does")
d4.CSGVLightDirection = [0.35e-300, 0.6e-300, 0.72e-300]  # and of tiny ones
t.check(np.abs(t.screenshot(v4, 64, 48, "held_tiny.png").astype(int) - reference.astype(int)).max() <= 1,
        "a light direction of tiny components draws as the same direction does")
for name in ("CSGVLightDirection (nan, nan, nan) is not finite", "CSGVShadingBlend nan is not a number: 1 is used"):
    t.check(name in errors.text, "the warning names it: %s (%s)" % (name, errors.text.strip()[:300]))
with t.ErrorLog() as errors:
    Render(v4)
t.check(errors.text.strip() == "", "said once, not at every render (%s)" % errors.text.strip()[:200])
d4.CSGVShading = "local"
d4.CSGVLightDirection = [0, 0, 0]
with t.ErrorLog() as errors:
    d4.CSGVFramesPerStillRender = 2147483647
    d4.CSGVShading = 7
    d4.GetProperty("CSGVSubsampling").SetData(3)  # not an entry: as a state file could set it
    d4.GetProperty("CSGVDecoding").SetData(7)
    d4.GetProperty("CSGVCacheSizeMiB").SetData(-5)
    Render(v4)
t.check("CSGVFramesPerStillRender 2147483647 is outside [1, 4096]: 4096 is used" in errors.text
        and "CSGVLightDirection (0, 0, 0) is zero" in errors.text and "CSGVShading 7 is not one of 0, 1, 2, 3: 0 is used"
        in errors.text and "CSGVSubsampling 3 is not one of 1, 2, 4, 8: 1 is used" in errors.text
        and "CSGVDecoding 7 is not one of 0, 1, 2: 0 is used" in errors.text
        and "CSGVCacheSizeMiB -5 is outside [0, 65536]: 0 is used" in errors.text,
        "a huge frame count, a zero light and unknown enumeration values are named (%s)" % errors.text.strip()[:400])
d4.CSGVSubsampling = "1"
d4.CSGVDecoding = "Automatic"
d4.CSGVCacheSizeMiB = 0
d4.CSGVFramesPerStillRender = 1
d4.CSGVShading = "local"
d4.CSGVLightDirection = [0.35, 0.6, 0.72]
d4.CSGVShadingBlend = 1

# Hidden: nothing drawn.
Hide(csgv, v)
t.check(t.content_mask(t.screenshot(v, 160, 120, "hidden.png")).mean() == 0, "hidden: nothing drawn")
t.finish()
