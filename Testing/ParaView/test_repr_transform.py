# SPDX-License-Identifier: MIT
"""The display's Transforming properties (Position, Scale, Orientation, Origin) place a
Segmentation Volume as they place ParaView's own representations (they were accepted and
ignored: the volume stayed while an Outline of the same display moved).

- Moved by Position and seen from a camera moved by the same vector, the label image is the
  unmoved one's (perspective: moving both changes no ray), and a pick there reports the same
  voxel at a world point moved by the vector.
- The same display shown as Outline and as Segmentation Volume, with Position, Scale and
  Orientation set: the volume's silhouette lies within the outline's box on the screen, and the
  outline's corners lie within a pixel of the volume's (their extents on the screen agree).
- Bounds: ResetCamera frames the moved volume (ParaView takes the bounds with the matrix).
- A zero scale, or a Position that is not finite or beyond float's range, is not drawn, with an
  error, and nothing breaks; a negative Scale mirrors.
- A state file keeps the placement."""
import os
import sys

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools as ct  # noqa: E402

t.load_plugin(globals())
W, H = 160, 120
INVALID = 0xFFFFFFFF
r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(W, H)
d = Show(r, v)
d.SetRepresentationType("Segmentation Volume")
d.CSGVFramesPerStillRender = 1
d.CSGVStillRenderTimeBudget = 60


def look(offset):
    v.CameraPosition = [66 + offset[0] + 60, -260 + offset[1], 140 + offset[2]]
    v.CameraFocalPoint = [66 + offset[0], 35 + offset[1], 97 + offset[2]]
    v.CameraViewUp = [0, 0, 1]
    v.CameraViewAngle = 30


def along_y(centre, scale):
    """An orthographic camera looking along +y at `centre`, z up."""
    v.CameraParallelProjection = 1
    v.CameraFocalPoint = list(centre)
    v.CameraPosition = [centre[0], centre[1] - 500, centre[2]]
    v.CameraViewUp = [0, 0, 1]
    v.CameraParallelScale = scale


# 1. Position, with the camera moved alike: the same label image, the same voxels.
Render(v)  # paraview.simple resets the camera at a view's first render: before the camera is set
look((0, 0, 0))
Render(v)
before = ct.label_image(d)
ys, xs = np.nonzero(before != INVALID)
px = [(int(xs[i]), int(ys[i])) for i in np.linspace(0, len(xs) - 1, 12).astype(int)]
picks = [ct.pick(d, x, y) for x, y in px]
shift = (20.0, -7.0, 11.5)
d.Position = list(shift)
look(shift)
Render(v)
after = ct.label_image(d)
same = float(np.mean(before == after))
t.check(before.shape == after.shape and (before != INVALID).sum() > 2000 and same > 0.995,
        "moved by Position and seen from a camera moved alike: the label image is the unmoved one's "
        "(%.2f %% of pixels equal)" % (100 * same))
moved = [ct.pick(d, x, y) for x, y in px]
voxels = sum(1 for a, b in zip(picks, moved) if a.get("voxel") == b.get("voxel") and a.get("hit"))
near = all(np.allclose(np.array(b["world"]) - np.array(a["world"]), shift, atol=0.05)
           for a, b in zip(picks, moved) if a.get("voxel") == b.get("voxel") and a.get("hit"))
t.check(voxels >= 10 and near, "picks: %d of %d the same voxel, at world points moved by Position" % (voxels, len(px)))
# Without the camera moved, the image does change (the check above can fail).
look((0, 0, 0))
Render(v)
t.check(float(np.mean(ct.label_image(d) == before)) < 0.9, "moved by Position, the volume is elsewhere on the screen")

# 2. Scale and Orientation: a solid block's extent on the screen is its outline's (the synthetic
# volume's edges have empty voxels).
Hide(r, v)
N = 32
block = OpenDataFile(t.block_vti(N))
b = Show(block, v)
b.SetRepresentationType("Segmentation Volume")
b.CSGVFramesPerStillRender = 1
b.Position = [5, 0, -10]
b.Scale = [1.5, 0.5, 1.0]
b.Orientation = [10, 0, 35]
b.Origin = [16, 16, 16]
along_y((16, 16, 16), 40)
v.Background = [0, 0, 0]
Render(v)
vol = ct.label_image(b) != INVALID
b.SetRepresentationType("Outline")
b.AmbientColor = b.DiffuseColor = [1, 1, 1]
b.LineWidth = 1
outline = t.screenshot(v, W, H, "outline.png")
b.SetRepresentationType("Segmentation Volume")
Hide(block, v)
Show(r, v)
lines = outline.max(axis=2) > 64
lines = lines[::-1]  # PNG rows top first; the label image's row 0 is the bottom


def extent(mask):
    ys, xs = np.nonzero(mask)
    return np.array([xs.min(), xs.max(), ys.min(), ys.max()]) if len(xs) else None


ev, eo = extent(vol), extent(lines)
t.check(ev is not None and eo is not None and np.all(np.abs(ev - eo) <= 2),
        "scaled, rotated and moved: the volume's extent on the screen %s is its outline's %s" % (ev, eo))

# 3. ResetCamera frames the moved volume.
d.Scale = [1, 1, 1]
d.Orientation = [0, 0, 0]
d.Origin = [0, 0, 0]
d.Position = [1000, 0, 0]
v.CameraParallelProjection = 0
v.ResetCamera()
Render(v)
framed = ct.label_image(d) != INVALID
t.check(framed.mean() > 0.15, "ResetCamera frames the volume moved by 1000 (%.1f %% of pixels)" % (100 * framed.mean()))

# 4. A zero scale: an error, nothing drawn, and the next scale draws again.
with t.ErrorLog() as errors:
    d.Scale = [1, 0, 1]
    Render(v)
t.check("singular" in errors.text, "a zero scale is said (%s)" % errors.text.strip()[:200])
d.Scale = [1, 1, 1]
Render(v)
t.check((ct.label_image(d) != INVALID).mean() > 0.15, "a scale of one draws again")
# A Position that is not finite: said, nothing drawn (it drew nothing without a word), no bounds
# for the view (its camera stays finite); a finite one draws again.
with t.ErrorLog() as errors:
    d.Position = [float("nan"), 0, 0]
    Render(v)
t.check("not finite" in errors.text, "a NaN Position is said (%s)" % errors.text.strip()[:200])
d.Position = [1000, 0, 0]
Render(v)
t.check((ct.label_image(d) != INVALID).mean() > 0.15, "a finite Position draws again")
# A Position beyond float's range (after a drawn frame: a message is said once until then): said
# as such (it was "the camera matrix holds a non-finite value" after ResetCamera, nothing before),
# and no bounds for the view.
with t.ErrorLog() as errors:
    d.Position = [1e308, 0, 0]
    Render(v)
    v.ResetCamera()
    Render(v)
t.check("beyond" in errors.text and "non-finite" not in errors.text,
        "a Position of 1e308 is said (%s)" % errors.text.strip()[:300])
# A negative Scale mirrors, as for ParaView's own representations: seen along y, the label image
# of Scale (-1, 1, 1) about the volume's centre is the unmirrored one flipped left to right.
d.Position = [0, 0, 0]
along_y((66.5, 35, 97), 110)
Render(v)
plain = ct.label_image(d)
d.Origin = [66.5, 35, 97]
d.Scale = [-1, 1, 1]
Render(v)
mirrored = ct.label_image(d)
t.check((plain != INVALID).mean() > 0.1 and np.array_equal(plain[:, ::-1], mirrored),
        "Scale (-1, 1, 1) draws the mirror image (%.4f of pixels equal)" % np.mean(plain[:, ::-1] == mirrored))
d.Scale = [1, 1, 1]
d.Origin = [0, 0, 0]
v.CameraParallelProjection = 0

# 5. A state file keeps the placement: loaded, the same label image.
RenameSource("volume", r)
d.Position = list(shift)
look(shift)
Render(v)
placed = ct.label_image(d)
state = os.path.join(t.temp_dir(), "placed.pvsm")
SaveState(state)
ResetSession()
LoadState(state)
views = GetRenderViews()
d2 = GetDisplayProperties(FindSource("volume"), views[0])
Render(views[0])
t.check(list(d2.Position) == list(shift) and np.array_equal(ct.label_image(d2), placed),
        "a state file keeps the placement (Position %s, the same label image)" % list(d2.Position))
t.finish()
