# SPDX-License-Identifier: MIT
"""A Segmentation Volume screenshot (200x150, local shading, 1 sample a pixel, fixed camera)
equals the committed baseline within a stated tolerance.

Tolerance: per-channel absolute difference; the mean over all pixels must stay below 1.0 (of
255) and at most 0.5% of pixels may differ by more than 32. One sample a pixel has no sub-pixel
jitter, so the image is the renderer's exact G-buffer shaded (the backend's own tests compare it
with a CPU reference): differences come from the GL rasteriser, another Vulkan device or a
change of the local shading model; the tolerance allows a few edge pixels, not a shifted or
recoloured image.
Set CSGV_UPDATE_BASELINES=1 to rewrite the baseline (then look at it before committing)."""
import os
import shutil

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
HERE = os.path.dirname(os.path.abspath(__file__))
BASELINE = os.path.join(HERE, "baselines", "repr_synthA_local.png")
W, H = 200, 150

r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(W, H, background=(1.0, 1.0, 1.0))
d = Show(r, v)
d.CSGVShading = "local"
d.CSGVFramesPerStillRender = 1  # the first sample has no jitter: independent of the jitter sequence
d.CSGVStillRenderTimeBudget = 120
b = r.GetDataInformation().GetBounds()
c = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
diag = np.linalg.norm([b[1] - b[0], b[3] - b[2], b[5] - b[4]])
v.CameraFocalPoint = c
v.CameraPosition = [c[0] + 1.0 * diag, c[1] - 1.5 * diag, c[2] + 0.8 * diag]
v.CameraViewUp = [0, 0, 1]
v.CameraViewAngle = 30

path = os.path.join(t.temp_dir(), "repr.png")
SaveScreenshot(path, v, ImageResolution=[W, H], TransparentBackground=0)
img = t.read_png(path)
frames, samples = t.repr_info(d)
t.check(samples == 1, "1 sample in every pixel (%d)" % samples)

if os.environ.get("CSGV_UPDATE_BASELINES"):
    os.makedirs(os.path.dirname(BASELINE), exist_ok=True)
    shutil.copyfile(path, BASELINE)
    t.log("baseline written: " + BASELINE)

ref = t.read_png(BASELINE)
t.check(ref.shape == img.shape, "image size %s equals the baseline's %s" % (img.shape, ref.shape))
if ref.shape == img.shape:
    diff = np.abs(ref.astype(int) - img.astype(int))
    mean = diff.mean()
    large = (diff.max(axis=2) > 32).mean()
    t.check(mean < 1.0, "mean difference %.3f < 1.0" % mean)
    t.check(large <= 0.005, "pixels differing by more than 32: %.3f%% <= 0.5%%" % (100 * large))
    if mean >= 1.0 or large > 0.005:
        keep = os.path.join(os.environ.get("CSGV_TEST_OUTPUT", "/tmp"), "repr_synthA_local_actual.png")
        shutil.copyfile(path, keep)
        t.log("actual image kept at " + keep)
t.check(t.content_mask(img, (255, 255, 255)).mean() > 0.1, "the volume covers part of the image")
t.finish()
