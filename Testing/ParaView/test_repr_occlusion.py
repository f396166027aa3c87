# SPDX-License-Identifier: MIT
"""Depth compositing: an opaque red sphere half inside a solid blue label block. Looking down -z
with a parallel camera, the sphere (centre 5 below the block's front face, radius 8) pokes out
of the face where its distance d from the axis is below sqrt(8^2 - 5^2) = 6.24: there the sphere
is in front and pixels are red; for 6.24 < d < 8 the block's face is in front of the sphere, and
outside the sphere the block shows: pixels are blue. Checked analytically per pixel, away from
the edges (2 pixels), for opaque materials (drawn in the opaque pass) and for translucent ones
(volumetric pass: rays stop at the sphere's depth read from the depth buffer, and the
translucent block in front of the sphere's rim blends blue over red). The block is a plain
.vti cell array, so it is compressed on the fly."""
import os

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
N = 32
path = t.block_vti(N)

W = H = 200
SCALE = 20.0                      # parallel scale: 10 pixels a world unit... 200 / 40 = 5
CENTRE = np.array([16.0, 16.0, N - 5.0])
R = 8.0
v = t.render_view(W, H)
block = OpenDataFile(path)
d = Show(block, v)
d.SetRepresentationType("Segmentation Volume")
d.CSGVFramesPerStillRender = 2
d.CSGVStillRenderTimeBudget = 60
sphere = Sphere(Center=list(CENTRE), Radius=R, ThetaResolution=96, PhiResolution=96)
ds = Show(sphere, v)
ds.DiffuseColor = [1.0, 0.0, 0.0]
ds.AmbientColor = [1.0, 0.0, 0.0]
ds.Specular = 0.0
v.CameraParallelProjection = 1
v.CameraFocalPoint = [16, 16, 16]
v.CameraPosition = [16, 16, 100]
v.CameraViewUp = [0, 1, 0]
v.CameraParallelScale = SCALE

# World x, y of each pixel centre (row 0 at the top of the screenshot).
px = (np.arange(W) + 0.5) / W * 2 - 1
py = (np.arange(H) + 0.5) / H * 2 - 1
x = 16 + px * SCALE
y = 16 - py * SCALE
X, Y = np.meshgrid(x, y)
dist = np.hypot(X - CENTRE[0], Y - CENTRE[1])
edge = 2 * (2 * SCALE / H)        # two pixels in world units
inside_block = (X > edge) & (X < N - edge) & (Y > edge) & (Y < N - edge)
poke = np.sqrt(R * R - 5.0 * 5.0)
sphere_front = inside_block & (dist < poke - edge)
block_front = inside_block & (((dist > poke + edge) & (dist < R - edge)) | (dist > R + edge))
rim = inside_block & (dist > poke + edge) & (dist < R - edge)
t.check(sphere_front.sum() > 500 and rim.sum() > 500, "test geometry has enough pixels (%d, %d)"
        % (sphere_front.sum(), rim.sum()))


def red(p):
    return (p[..., 0].astype(int) > p[..., 2].astype(int) + 40) & (p[..., 1] < 80)


def blue(p):
    return (p[..., 2].astype(int) > p[..., 0].astype(int) + 40) & (p[..., 1] < 80)


for label, opacity in (("opaque materials", 1.0), ("translucent materials", 0.6)):
    d.CSGVMaterials = t.constant_materials([0.0, 0.0, 1.0], opacity)
    shot = t.screenshot(v, W, H, "occlusion_%s.png" % opacity)
    r = red(shot[sphere_front]).mean()
    t.check(r > 0.99, "%s: sphere in front of the block is red (%.1f%%)" % (label, 100 * r))
    if opacity == 1.0:
        b = blue(shot[block_front]).mean()
        t.check(b > 0.99, "%s: block in front of the sphere is blue (%.1f%%)" % (label, 100 * b))
    else:
        # The translucent face blends over the sphere's rim: both colours present.
        p = shot[rim].astype(int)
        mixed = ((p[:, 0] > 30) & (p[:, 2] > 30)).mean()
        t.check(mixed > 0.95, "%s: block blended over the sphere's rim (%.1f%%)" % (label, 100 * mixed))
        out = block_front & ~rim
        b = blue(shot[out]).mean()
        t.check(b > 0.99, "%s: block elsewhere is blue (%.1f%%)" % (label, 100 * b))
# Translucent ParaView geometry in front of a volume with opaque materials: the volume is drawn
# in the opaque pass, so the translucent plane blends over it (green over blue).
d.CSGVMaterials = t.constant_materials([0.0, 0.0, 1.0], 1.0)
ds.Visibility = 0
plane = Plane(Origin=[4, 4, N + 10], Point1=[28, 4, N + 10], Point2=[4, 28, N + 10])
dp = Show(plane, v)
dp.DiffuseColor = [0.0, 1.0, 0.0]
dp.AmbientColor = [0.0, 1.0, 0.0]
dp.Specular = 0.0
dp.Opacity = 0.5
shot = t.screenshot(v, W, H, "translucent_plane.png")
under = (X > 4 + edge) & (X < 28 - edge) & (Y > 4 + edge) & (Y < 28 - edge)
p = shot[under].astype(int)
blend = ((p[:, 1] > 60) & (p[:, 2] > 60)).mean()
t.check(blend > 0.99, "translucent plane in front of an opaque-material volume blends over it (%.1f%%)" % (100 * blend))

# Translucent materials beside translucent geometry: ParaView depth-peels (its default), and the
# frame takes part as one translucent layer at its first hit's depth. A half-transparent plane in
# front of the block's face (z = N + 10) blends over the volume: both = plane + (1 - 0.5) volume,
# from the plane and the volume rendered alone. A plane inside the block (z = 16), behind the
# face, is seen through the volume: blue is the volume's alone, and green the plane's attenuated
# by the volume's alpha, measured from the volume alone over a white background. Before, the
# frame was drawn in the volume pass of the peeling, read a depth buffer the peeling framebuffer
# does not have, and bound the read framebuffer behind vtkOpenGLState's back: stripes, wrong
# colours and "Error in cache state for GL_READ_FRAMEBUFFER_BINDING" on every render.
d.CSGVMaterials = t.constant_materials([0.0, 0.0, 1.0], 0.6)
inner = under & ~(np.abs(X - 16) < 1) & ~(np.abs(Y - 16) < 1)


def alone(display):
    other = dp if display is d else d
    other.Visibility = 0
    image = t.screenshot(v, W, H, "alone.png").astype(int)
    other.Visibility = 1
    return image


for z, where in ((N + 10.0, "in front of"), (16.0, "inside")):
    plane.Origin = [4, 4, z]
    plane.Point1 = [28, 4, z]
    plane.Point2 = [4, 28, z]
    with t.ErrorLog() as errors:
        both = t.screenshot(v, W, H, "peeled_%d.png" % z).astype(int)
        plane_alone = alone(dp)
        volume_alone = alone(d)
    t.check(errors.text == "", "translucent plane %s a translucent-material volume: no errors (%s)"
            % (where, errors.text.strip()[:300]))
    if where == "in front of":
        expected = plane_alone + volume_alone // 2
        err = np.abs(both[inner] - expected[inner]).max()
        t.check(err <= 4, "translucent plane in front of translucent materials blends over them "
                "(largest error %d of 255)" % err)
    else:
        v.Background = [1.0, 1.0, 1.0]
        dp.Visibility = 0
        over_white = t.screenshot(v, W, H, "white.png").astype(int)
        dp.Visibility = 1
        v.Background = [0.0, 0.0, 0.0]
        transmitted = (over_white[..., 0] - volume_alone[..., 0]) / 255.0  # 1 - the volume's alpha
        green = transmitted * plane_alone[..., 1]
        err_g = np.abs(both[..., 1][inner] - green[inner]).max()
        err_b = np.abs(both[..., 2][inner] - volume_alone[..., 2][inner]).max()
        t.check(transmitted[inner].min() > 0.1 and err_g <= 4 and err_b <= 4,
                "translucent plane behind the face of translucent materials shows through them "
                "(transmitted %.2f, largest error green %d, blue %d)" % (transmitted[inner].mean(), err_g, err_b))

# A second Segmentation Volume (red, half transparent, in front) and ParaView's own Volume
# representation beside the first, with FXAA: each composites by depth, nothing is logged.
dp.Visibility = 0
front = Show(OpenDataFile(t.block_vti(16, (8, 8, N + 8), "front.vti")), v)
front.SetRepresentationType("Segmentation Volume")
front.CSGVFramesPerStillRender = 2
front.CSGVMaterials = t.constant_materials([1.0, 0.0, 0.0], 0.5)
wavelet = Show(Wavelet(WholeExtent=[20, 36, 20, 36, N + 4, N + 20]), v)
wavelet.SetRepresentationType("Volume")
ColorBy(wavelet, ("POINTS", "RTData"))
v.UseFXAA = 1
with t.ErrorLog() as errors:
    shot = t.screenshot(v, W, H, "two_volumes.png").astype(int)
v.UseFXAA = 0
t.check(errors.text == "", "two Segmentation Volumes, a ParaView Volume and FXAA: no errors (%s)"
        % errors.text.strip()[:300])
centre = shot[90:110, 90:110].reshape(-1, 3)
t.check((centre[:, 0] > 60).all() and (centre[:, 2] > 30).all() and (centre[:, 1] < 20).all(),
        "the front Segmentation Volume blends over the one behind (red over blue, %s)" % centre.mean(axis=0))
t.finish()
