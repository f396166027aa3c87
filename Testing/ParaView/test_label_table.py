# SPDX-License-Identifier: MIT
"""CSGV Label Table (issue 41, item 3): one row per label of a CSGV volume as a vtkTable. Without
attributes the rows are the palettes' labels (the source volume's distinct labels); with
ComputedAttributes the voxel counts and bounding boxes equal numpy's over the source volume; a
relabelled file's rows are its database's (label, csgv_id and the CSV's columns, values equal);
Save Data writes the table as CSV; MaxRows and an input without an encoding fail clearly."""
import csv
import os

import numpy as np

import csgv_pvtest as t
from paraview import servermanager as sm
from paraview.simple import *

t.load_plugin(globals())


def column(table, name):
    a = table.GetColumnByName(name)
    if a is None:
        return None
    if a.IsA("vtkStringArray"):
        return [a.GetValue(i) for i in range(a.GetNumberOfValues())]
    return np.array([a.GetValue(i) for i in range(a.GetNumberOfValues())])


# A volume whose palettes hold its labels.
name = "synthA_b32_rans2.csgv"
src = t.source_volume(name)
r = OpenDataFile(os.path.join(t.FIXTURES, name))
lt = CSGVLabelTable(Input=r)
table = sm.Fetch(lt)
labels = column(table, "label")
want = np.unique(src)
t.check(labels is not None and np.array_equal(labels, want),
        "one row per label of the volume (%d rows, %d labels)" % (0 if labels is None else len(labels), len(want)))
t.check(table.GetColumnByName("csgv_id") is None, "no csgv_id without a database")
lt.ComputedAttributes = 1
table = sm.Fetch(lt)
counts = column(table, "voxel_count")
wanted = np.array([np.count_nonzero(src == l) for l in want])
t.check(counts is not None and np.array_equal(counts, wanted), "computed voxel counts equal numpy's")
z, y, x = np.nonzero(src == want[1])
box = [column(table, n)[1] for n in ("bbox_min_x", "bbox_min_y", "bbox_min_z", "bbox_max_x", "bbox_max_y", "bbox_max_z")]
t.check(box == [x.min(), y.min(), z.min(), x.max(), y.max(), z.max()],
        "label %d's bounding box equals numpy's (%r)" % (want[1], box))

# Save Data writes it as CSV.
out = os.path.join(t.temp_dir(), "labels.csv")
SaveData(out, proxy=lt)
with open(out, newline="") as f:
    rows = list(csv.reader(f))
t.check(len(rows) == len(want) + 1 and "label" in rows[0] and "voxel_count" in rows[0],
        "Save Data: a CSV with a header and one row per label (%d rows)" % len(rows))
Delete(lt)
Delete(r)

# A relabelled file: its database's rows and columns.
name = "synthA_b32_rans2_attr.csgv"
r = OpenDataFile(os.path.join(t.FIXTURES, name))
lt = CSGVLabelTable(Input=r)
table = sm.Fetch(lt)
with open(os.path.join(t.FIXTURES, "synthA_attributes.csv"), newline="") as f:
    ref = {int(row["label"]): row for row in csv.DictReader(f)}
labels = column(table, "label")
ids = column(table, "csgv_id")
voxels = column(table, "voxels")
score = column(table, "score")
t.check(labels is not None and set(labels.tolist()) <= set(ref) and len(labels) == len(np.unique(t.source_volume(name))),
        "relabelled: one row per label of its database (%d)" % (0 if labels is None else len(labels)))
t.check(ids is not None and sorted(ids.tolist()) == list(range(len(labels))), "relabelled: csgv_id 0..n-1")
t.check(all(int(voxels[i]) == int(ref[int(l)]["voxels"]) and abs(score[i] - float(ref[int(l)]["score"])) < 1e-6
            for i, l in enumerate(labels)), "relabelled: the database's values, row by row (its scores are float32)")
# Whole-number columns are integers, so a CSV export writes them whole (docs pass 11: ParaView's
# CSV writer wrote a double 928090 as 9.2809e+05).
t.check(table.GetColumnByName("voxels").GetDataTypeAsString() in ("long long", "long", "vtkTypeInt64"),
        "relabelled: the database's whole-number column is an integer column (%s)"
        % table.GetColumnByName("voxels").GetDataTypeAsString())
out = os.path.join(t.temp_dir(), "relabelled.csv")
SaveData(out, proxy=lt, FieldAssociation="Row Data")
with open(out, newline="") as f:
    written = {int(row["label"]): row for row in csv.DictReader(f)}
t.check(written and all(written[int(l)]["voxels"] == str(int(voxels[i])) for i, l in enumerate(labels)),
        "relabelled: Save Data writes the voxel counts as integers")

# Limits and bad input.
lt.MaxRows = 1
with t.ErrorLog() as log:
    table = sm.Fetch(lt)
t.check(table.GetNumberOfRows() == 0 and "more than MaxRows" in log.text,
        "MaxRows refuses larger volumes with a message: %r" % log.text[-200:])
Delete(lt)
w = Wavelet()
with t.ErrorLog() as log:
    bad = sm.Fetch(CSGVLabelTable(Input=w))
t.check(bad.GetNumberOfRows() == 0 and "CSGV Label Table" in log.text,
        "an input without an encoding: an empty table and a message: %r" % log.text[-200:])
t.finish()
