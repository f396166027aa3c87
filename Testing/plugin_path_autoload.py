# SPDX-License-Identifier: MIT
# PV_PLUGIN_PATH alone (no LoadPlugin call) loads the CSGV plugin in pvpython: its reader exists
# and OpenDataFile picks it for a .csgv.
import os
import sys

from paraview.simple import OpenDataFile
import paraview.simple as simple

if not hasattr(simple, "CSGVReader"):
    sys.exit("PV_PLUGIN_PATH=%s did not load the CSGV plugin" % os.environ.get("PV_PLUGIN_PATH"))
reader = OpenDataFile(os.path.join(os.environ["CSGV_FIXTURES"], "synthA_b32_rans2.csgv"))
if reader is None or reader.GetXMLName() != "CSGVReader":
    sys.exit("OpenDataFile did not pick the CSGV reader")
reader.UpdatePipeline()
extent = reader.GetDataInformation().GetExtent()
if tuple(extent) != (0, 133, 0, 70, 0, 194):
    sys.exit("unexpected extent %s" % (extent,))
print("ok: PV_PLUGIN_PATH loads CSGV")
