# SPDX-License-Identifier: MIT
"""Client/server where the server cannot render (Debian's pvserver without a display: "Server
DISPLAY not accessible! Remote rendering will be disabled"). ParaView then renders on the client
and moves every representation's piece there; the client's copy of a Segmentation Volume had no
piece to hand over, and the client aborted at the first render ("Wrong tag", GUI re-check 12).
Now the volume travels and the client draws it, and the questions of csgv_tools (picks, the
label image, statistics) are asked of the client's copy, which drew it, not of the server, which
drew nothing. Run by clientserver_driver.py with CSGV_SERVER_NO_DISPLAY=1."""
import os
import sys

import csgv_pvtest as t
from paraview.simple import *

t.connect_to_server(globals())
r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(160, 120)
d = Show(r, v)
d.SetRepresentationType("Segmentation Volume")
d.CSGVFramesPerStillRender = 2
v.ResetCamera()
t.check_drawn_and_red(v, d, "the volume is drawn on the client", "a property change reaches the client's drawing")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools  # noqa: E402

p = csgv_tools.pick(d, 80, 60)
t.check(p.get("hit") and p.get("label", 0) > 0, "a pick is answered by the process that drew the volume (%s)" % p)
image = csgv_tools.label_image(d)
t.check(image.shape == (120, 160) and (image != 0xFFFFFFFF).mean() > 0.05,
        "the label image is the client's drawing (%s, %.1f%% labelled)"
        % (image.shape, 100 * (image != 0xFFFFFFFF).mean() if image.size else 0))
stats = csgv_tools.render_stats(d)
t.check(stats.get("CSGVMinSamples", 0) >= 2, "render_stats are the client's renderer's (%s)" % stats)
t.finish()
