# SPDX-License-Identifier: MIT
"""GUI check of a Segmentation Volume with translucent materials beside a 3D widget (run inside
the ParaView client by gui_script_driver.py, which passes when this script's results file ends
with "all checks passed"). A user applies Filters > Clip to the volume: the Clip's plane widget
(a translucent plane, its outline, normal arrow and handle) shows in the view and ParaView depth-
peels. The plane is edge-on (normal +x, seen down -z): away from its line, the arrow's row and the
outline at the block's edges, the image with the widget must equal the image without it, and
nothing may be logged (before: stripes and pink/cyan rectangles under the plane, and "Error in
cache state for GL_READ_FRAMEBUFFER_BINDING" on every render)."""
import os
import sys

sys.path.insert(0, os.environ["CSGV_TEST_DIR"])
import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401

import csgv_pvtest as t  # noqa: E402

results = []


def check(cond, what):
    results.append(("ok   " if cond else "FAIL ") + what)


try:
    N = 32
    W = H = 200
    SCALE = 20.0
    v = GetActiveViewOrCreate("RenderView")
    v.OrientationAxesVisibility = 0
    if "UseColorPaletteForBackground" in v.ListProperties():
        v.UseColorPaletteForBackground = 0
    v.Background = [0.0, 0.0, 0.0]
    block = OpenDataFile(t.block_vti(N))
    d = Show(block, v)
    d.SetRepresentationType("Segmentation Volume")
    d.CSGVFramesPerStillRender = 2
    d.CSGVStillRenderTimeBudget = 60
    d.CSGVMaterials = t.constant_materials([0.0, 0.0, 1.0], 0.6)
    v.CameraParallelProjection = 1
    v.CameraFocalPoint = [16, 16, 16]
    v.CameraPosition = [16, 16, 100]
    v.CameraViewUp = [0, 1, 0]
    v.CameraParallelScale = SCALE
    clip = Clip(Input=block)
    clip.ClipType = "Plane"
    clip.ClipType.Origin = [16, 16, 16]
    clip.ClipType.Normal = [1, 0, 0]
    SetActiveSource(clip)
    with t.ErrorLog() as errors:
        Hide3DWidgets(proxy=clip.ClipType)
        without = t.screenshot(v, W, H, "without.png").astype(int)
        Show3DWidgets(proxy=clip.ClipType)
        shown = t.screenshot(v, W, H, "with.png").astype(int)
    check(errors.text == "", "no errors or warnings while the widget shows (%s)" % errors.text.strip()[:400])
    px = (np.arange(W) + 0.5) / W * 2 - 1
    X, Y = np.meshgrid(16 + px * SCALE, 16 - px * SCALE)
    pixel = 2 * SCALE / W
    # The plane edge-on with its handle (a column 12 pixels either side), the normal arrow (a row
    # 12 pixels either side), the outline (padded around the block) and the block's own edges.
    away = ((np.abs(X - 16) > 12 * pixel) & (np.abs(Y - 16) > 12 * pixel) &
            (X > 4 * pixel) & (X < N - 4 * pixel) & (Y > 4 * pixel) & (Y < N - 4 * pixel))
    diff = np.abs(shown - without).max(axis=2)
    check(diff.max() > 40, "the widget is drawn (largest change %d)" % diff.max())
    changed = (diff[away] > 3).mean()
    check(changed == 0, "away from the widget the volume is unchanged (%.2f%% of %d pixels differ)"
          % (100 * changed, away.sum()))
    check(t.content_mask(without.astype(np.uint8))[away].mean() > 0.99, "the volume is drawn without the widget")
except Exception as e:  # a failure must reach the driver, not a dialog
    import traceback
    check(False, "the script ran: %s\n%s" % (e, traceback.format_exc()))
with open(os.environ["CSGV_RESULTS"], "w") as f:
    f.write("\n".join(results) + "\n")
    f.write("all checks passed\n" if all(r.startswith("ok") for r in results) else "some checks failed\n")
