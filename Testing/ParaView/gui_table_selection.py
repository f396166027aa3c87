# SPDX-License-Identifier: MIT
"""GUI check that rows of a CSGV Label Table select their labels in 3D when the plugin is loaded
from PV_PLUGIN_PATH (run inside the ParaView client by gui_script_driver.py with
CSGV_GUI_PLUGIN_PATH set). A plugin on that path starts while ParaView's application core is
being made, before its selection manager exists; the label selection connected to none, and a
click on a row selected nothing in 3D (GUI pass 11, HIGH). A row selection made the way
paraview.simple makes it reaches ParaView's selection manager as a Spreadsheet click does."""
import os
import sys

sys.path.insert(0, os.environ["CSGV_TEST_DIR"])
sys.path.insert(0, os.path.join(os.environ["CSGV_TEST_DIR"], "..", "..", "Examples"))
from paraview.simple import *  # noqa: E402,F401
from paraview import servermanager as sm  # noqa: E402

import csgv_tools as ct  # noqa: E402

results = []


def check(cond, what):
    results.append(("ok   " if cond else "FAIL ") + what)


try:
    check("CSGVLabelTable" in dir(sys.modules["paraview.simple"]) or "CSGVLabelTable" in globals(),
          "the plugin was loaded from PV_PLUGIN_PATH")
    r = OpenDataFile(os.path.join(os.environ["CSGV_FIXTURES"], "synthA_b32_rans2_attr.csgv"))
    v = GetActiveViewOrCreate("RenderView")
    d = Show(r, v)
    d.SetRepresentationType("Segmentation Volume")
    d.CSGVFramesPerStillRender = 1
    Render(v)
    table = CSGVLabelTable(Input=r)
    table.UpdatePipeline()
    labels = sm.Fetch(table).GetColumnByName("label")
    rows = [labels.GetValue(i) for i in range(labels.GetNumberOfTuples())]
    check(len(rows) > 4, "the label table has rows (%d)" % len(rows))
    sheet = CreateView("SpreadSheetView")
    Show(table, sheet)
    SetActiveView(sheet)
    SelectIDs(IDs=[0, 3], FieldType="ROW", Source=table)
    selected = ct.selected_labels(d.CSGVMaterials)
    check(selected == [rows[3]], "the table's row 3 selects its label %r in 3D (selected: %r)" % (rows[3], selected))
    SelectIDs(IDs=[0, 1, 0, 4], FieldType="ROW", Source=table)
    selected = ct.selected_labels(d.CSGVMaterials)
    check(selected == sorted([rows[1], rows[4]]), "rows 1 and 4 select their labels (selected: %r)" % selected)
except Exception as e:  # a failure must reach the driver, not a dialog
    import traceback
    check(False, "the script ran: %s\n%s" % (e, traceback.format_exc()))
with open(os.environ["CSGV_RESULTS"], "w") as f:
    f.write("\n".join(results) + "\n")
    f.write("all checks passed\n" if all(r.startswith("ok") for r in results) else "some checks failed\n")
