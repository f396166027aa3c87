# SPDX-License-Identifier: MIT
"""Examples/compare_vtk.py end to end on a tiny procedural volume (the benchmark script must keep
working; its figures are not checked): the summary's JSON rows, the synth volume it compressed, the
side-by-side images, --drawn (half of the labels drawn: the last one passed from VTK's side to ours),
--repeat, and an input that does not exist, which gives empty cells and exit status 1.
Run with Debian's python3; CSGV_PVBATCH, CSGV_PLUGIN and CSGV_TOOL name the programs."""
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(os.path.dirname(os.path.dirname(HERE)), "Examples", "compare_vtk.py")
TIMED = ("vtk_median_frame_ms", "ours_median_frame_ms", "frame_ratio_vtk_over_ours", "view_frame_ms",
         "vtk_first_frame_s", "ours_first_frame_s", "first_frame_ratio_vtk_over_ours")


def compare(out, inputs, shadings, json_path, extra=()):
    pvbatch = os.environ["CSGV_PVBATCH"]
    command = [pvbatch, "--force-offscreen-rendering", SCRIPT, "--pvbatch", pvbatch,
               "--plugin", os.environ["CSGV_PLUGIN"], "--csgv-tool", os.environ["CSGV_TOOL"],
               "--input", inputs, "--size", "64x48", "--shadings", shadings, "--frames", "2",
               "--output", out, "--json", json_path, "--timeout", "300"] + list(extra)
    run = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=900)
    sys.stdout.write(run.stdout)
    compare.stdout = run.stdout
    return run.returncode, json.load(open(json_path))


def main():
    out = tempfile.mkdtemp(prefix="csgv-compare-test-")
    code, rows = compare(out, "synth:24x20x16", "local,pt", os.path.join(out, "ok.json"), ["--drawn", "1,0.5"])
    assert code == 0, "exit status %d" % code
    assert [(r["input"], r["size"], r["shading"], r["drawn"]) for r in rows] == [
        ("synth:24x20x16", "64x48", "local", "100%"), ("synth:24x20x16", "64x48", "pt", "100%"),
        ("synth:24x20x16", "64x48", "local", "50%"), ("synth:24x20x16", "64x48", "pt", "50%")], rows
    assert rows[0]["label_max"] is None and rows[1]["label_max"] is None, rows
    assert isinstance(rows[2]["label_max"], int) and rows[2]["label_max"] == rows[3]["label_max"] > 0, rows
    assert rows[2]["side_by_side"] != rows[0]["side_by_side"], rows
    for r in rows:
        for key in TIMED:
            assert isinstance(r[key], (int, float)) and r[key] > 0, (key, r)
        assert r["errors"] is None, r
        assert os.path.isfile(r["side_by_side"]), r
    synth = os.path.join(out, "synth_24x20x16.csgv")
    assert os.path.isfile(synth), os.listdir(out)
    made = os.path.getmtime(synth)

    missing = os.path.join(out, "no-such-volume.csgv")
    code, rows = compare(out, "synth:24x20x16," + missing, "local", os.path.join(out, "bad.json"), ["--repeat", "2"])
    assert code == 1, "a missing input must make the exit status 1, not %d" % code
    assert [r["input"] for r in rows] == ["synth:24x20x16", missing], rows
    assert all(isinstance(rows[0][k], (int, float)) for k in TIMED), rows[0]
    assert all(rows[1][k] is None for k in TIMED), rows[1]
    assert rows[1]["errors"] and any("no-such-volume" in e for e in rows[1]["errors"]), rows[1]
    assert os.path.getmtime(synth) == made, "the synth volume of the first run is reused"
    # --repeat 2: each side measured twice, in turn; the row holds the median of both runs.
    assert rows[0]["repeats"] == 2, rows[0]
    assert compare.stdout.count("Segmentation Volume, local") >= 4, compare.stdout
    assert "median of the 2 runs" in compare.stdout, compare.stdout
    print("compare_vtk.py: table, JSON, images, reuse, --repeat and a missing input all as documented")
    return 0


if __name__ == "__main__":
    sys.exit(main())
