# SPDX-License-Identifier: MIT
"""Client/server where the server cannot render (Debian's pvserver without a display: "Server
DISPLAY not accessible! Remote rendering will be disabled"). ParaView then renders on the client
and moves every representation's piece there; the client's copy of a Segmentation Volume had no
piece to hand over, and the client aborted at the first render ("Wrong tag", GUI re-check 12).
Now the volume travels and the client draws it. Run by clientserver_driver.py with
CSGV_SERVER_NO_DISPLAY=1."""
import os

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
t.finish()
