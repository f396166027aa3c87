# SPDX-License-Identifier: MIT
"""What a user saves is what they asked for (issue 38, item 2): SaveScreenshot and SaveAnimation,
at a resolution other than the view's, hold every pixel at CSGVFramesPerStillRender samples,
denoised, whatever the still-render time budget (which limits interactive refinement only).
Rendering is deterministic (seeds from pixel and sample count), so a saved image under a budget
far too small to converge equals the one saved under a large budget, pixel for pixel."""
import glob
import os

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
tmp = t.temp_dir()
src = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(160, 120)
d = Show(src, v)
d.CSGVShading = "pt"
d.CSGVFramesPerStillRender = 12
v.ResetCamera()
v.CameraPosition = [a + b for a, b in zip(v.CameraPosition, [40, 25, 10])]

# The view itself stops early under a tiny budget: the case a saved image must not inherit.
d.CSGVStillRenderTimeBudget = 0.0
Render(v)
frames, fewest = t.repr_info(d)
t.check(fewest < 12, "a view's still render under a zero budget stops early (%d of 12 samples)" % fewest)


def differing(a, b):
    return int((np.abs(a.astype(int) - b).max(axis=2) > 0).sum())


def animation(tag):
    """A 3-frame camera animation larger than the view, under the current budget."""
    for old in glob.glob(os.path.join(tmp, "anim_%s.*.png" % tag)):
        os.remove(old)
    scene.AnimationTime = 0.0
    SaveAnimation(os.path.join(tmp, "anim_%s.png" % tag), v, ImageResolution=[180, 130], FrameWindow=[0, 2])
    return [t.read_png(p) for p in sorted(glob.glob(os.path.join(tmp, "anim_%s.*.png" % tag)))]


# Path-traced secondary rays read bricks at the level the cache holds, so the cache is warmed
# first (a converged screenshot and animation): what is compared below is the budget's effect.
d.CSGVStillRenderTimeBudget = 600
t.screenshot(v, 200, 150, "warm.png")
d.CSGVStillRenderTimeBudget = 0.0

# A screenshot larger than the view: the same camera, a zero and a large budget.
tiny_shot = t.screenshot(v, 200, 150, "shot_tiny.png")
_, tiny_fewest = t.repr_info(d)
t.check(tiny_fewest >= 12, "the screenshot's render holds every sample under a zero budget (%d of 12)" % tiny_fewest)
d.CSGVStillRenderTimeBudget = 600
big_shot = t.screenshot(v, 200, 150, "shot_big.png")
t.check(t.content_mask(big_shot).mean() > 0.05, "the screenshot shows the volume")
t.check(np.array_equal(tiny_shot, big_shot),
        "screenshot under a zero budget equals the converged one (%d pixels differ)" % differing(tiny_shot, big_shot))

# SaveAnimation: every frame converged, whatever the budget.
cue = GetCameraTrack(view=v)
cue.Mode = "Interpolate Camera"
start = CameraKeyFrame(KeyTime=0.0, Position=v.CameraPosition, FocalPoint=v.CameraFocalPoint,
                       ViewUp=v.CameraViewUp, ViewAngle=v.CameraViewAngle)
end_position = [p + q for p, q in zip(v.CameraPosition, [-60, 30, 20])]
end = CameraKeyFrame(KeyTime=1.0, Position=end_position, FocalPoint=v.CameraFocalPoint,
                     ViewUp=v.CameraViewUp, ViewAngle=v.CameraViewAngle)
cue.KeyFrames = [start, end]
scene = GetAnimationScene()
scene.PlayMode = "Sequence"
scene.NumberOfFrames = 3
scene.StartTime = 0.0
scene.EndTime = 1.0
d.CSGVStillRenderTimeBudget = 600
animation("warm")
d.CSGVStillRenderTimeBudget = 0.0
tiny_frames = animation("tiny")
d.CSGVStillRenderTimeBudget = 600
big_frames = animation("big")
t.check(len(tiny_frames) == 3 and len(big_frames) == 3, "3 animation frames each (%d, %d)" % (len(tiny_frames), len(big_frames)))
for k, (a, b) in enumerate(zip(tiny_frames, big_frames)):
    t.check(np.array_equal(a, b), "animation frame %d under a zero budget equals the converged one (%d pixels differ)"
            % (k, differing(a, b)))
t.check(len(big_frames) == 3 and not np.array_equal(big_frames[0], big_frames[2]), "the camera moved between frames")
t.finish()
