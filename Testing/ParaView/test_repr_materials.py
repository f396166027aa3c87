# SPDX-License-Identifier: MIT
"""Materials through the representation: a malformed document gives an error in ParaView's
output, nothing is drawn and the session goes on; a valid document afterwards draws again. A
material that cannot be drawn as it stands (a missing attribute, an empty interval) is left out
without an error while the rest draws, and the summary query says why. Colormaps may be ParaView preset names (resolved by the plugin, e.g.
"Jet", which Core does not know) or Core's built-in names.

With CSGV_EXPECT_NO_DEVICE=1 (run with CSGV_VULKAN_DEVICE naming no device), the representation
instead reports that no Vulkan device is usable, once, draws nothing, and the session goes on."""
import json
import os
import sys

import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
r = OpenDataFile(os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv"))
v = t.render_view(120, 90)
d = Show(r, v)
d.CSGVFramesPerStillRender = 1
v.ResetCamera()

if os.environ.get("CSGV_EXPECT_NO_DEVICE"):
    with t.ErrorLog() as errors:
        img = t.screenshot(v, 120, 90)
        img2 = t.screenshot(v, 120, 90, "again.png")
    t.check("Vulkan" in errors.text and "nothing is drawn" in errors.text, "no device: a clear error")
    t.check(errors.text.count("no usable Vulkan device") == 1, "no device: said once")
    if "Vulkan" not in errors.text:
        t.log("   got: " + errors.text.strip()[:400])
    t.check(t.content_mask(img).mean() == 0, "no device: nothing drawn")
    b = r.GetDataInformation().GetBounds()
    Show(Sphere(Center=[(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2], Radius=(b[1] - b[0]) / 3), v)
    t.check(t.content_mask(t.screenshot(v, 120, 90, "sphere.png")).mean() > 0.01, "no device: other geometry still draws")
    t.finish()

good = t.screenshot(v, 120, 90, "good.png")
t.check(t.content_mask(good).mean() > 0.05, "default materials draw")

for tag, doc, needle in (
        ("malformed JSON", '{"version": 1, "materials": [', "Materials"),
        ("unknown key", json.dumps({"version": 1, "materials": [{"colour": "red"}]}), "colour"),
        ("unknown colormap", json.dumps({"version": 1, "materials": [
            {"color": {"mode": "random", "colormap": "No Such Map"}}]}), "No Such Map")):
    with t.ErrorLog() as errors:
        d.CSGVMaterials = doc
        img = t.screenshot(v, 120, 90, "bad.png")
    t.check(needle in errors.text, "%s: the error names %r" % (tag, needle))
    if needle not in errors.text:
        t.log("   got: " + errors.text.strip()[:400])
    t.check(t.content_mask(img).mean() == 0, "%s: nothing drawn" % tag)
    d.CSGVMaterials = ""
    t.check(t.content_mask(t.screenshot(v, 120, 90, "back.png")).mean() > 0.05, "%s: session goes on, a valid document draws" % tag)

# A material that cannot be drawn as it stands (an attribute the volume lacks, a half-finished
# interval) is no error: it is left out, the rest of the volume keeps drawing, and the summary
# query says why (the editor marks it).
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Examples"))
import csgv_tools  # noqa: E402
for tag, bad in (("missing attribute", {"filter": {"attribute": "volume_um3", "min": 0, "max": 10}}),
                 ("empty filter interval", {"filter": {"attribute": "label", "min": 20, "max": 10}}),
                 ("empty colour interval", {"color": {"mode": "colormap", "attribute": "label", "min": 3,
                                                      "max": 3, "colormap": "Jet"}})):
    with t.ErrorLog() as errors:
        d.CSGVMaterials = json.dumps({"version": 1, "materials": [dict(bad, name="half done"), {"name": "rest"}]})
        img = t.screenshot(v, 120, 90, "skipped.png")
    skipped = json.loads(csgv_tools.query(d, "summary")).get("skipped", [])
    t.check("ERR|" not in errors.text, "%s: no error message" % tag)
    t.check(t.content_mask(img).mean() > 0.05, "%s: the other materials draw" % tag)
    t.check(len(skipped) == 1 and skipped[0].startswith("material 1 ('half done')"),
            "%s: the summary names the skipped material from 1 (%r)" % (tag, skipped))
    if tag == "missing attribute":
        t.check("volume_um3" in skipped[0], "missing attribute: the reason names it")
d.CSGVMaterials = json.dumps({"version": 1, "materials": [
    {"filter": {"attribute": "volume_um3", "min": 0, "max": 10}}]})
t.check(t.content_mask(t.screenshot(v, 120, 90, "none.png")).mean() == 0, "only skipped materials: nothing drawn")
d.CSGVMaterials = ""

for name in ("Jet", "Viridis (matplotlib)", "Blue Orange (divergent)"):
    with t.ErrorLog() as errors:
        d.CSGVMaterials = json.dumps({"version": 1, "materials": [
            {"color": {"mode": "colormap", "attribute": "label", "min": 0, "max": 200, "colormap": name}}]})
        img = t.screenshot(v, 120, 90, "preset.png")
    t.check("ERR|" not in errors.text and t.content_mask(img).mean() > 0.05, "preset %r resolves and draws" % name)
t.finish()
