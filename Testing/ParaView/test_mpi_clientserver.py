# SPDX-License-Identifier: MIT
"""Client/server with a multi-rank server (issue 14): mpi_clientserver.py runs as a client of a
pvserver of 1 rank and of 2 ranks (`mpiexec -np 2 pvserver`, clientserver_driver.py). With 2 ranks
the server renders each rank's bricks and IceT composites them: the image the client receives
equals one rank's exactly (opaque, one sample a pixel), picks and the label image are answered
by both ranks together and equal one rank's, and SaveData from the client writes, from both
server ranks, the bytes one rank writes. Exit 77 (skipped) without mpiexec."""
import filecmp
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader

HERE = os.path.dirname(os.path.abspath(__file__))
failures = []


def check(cond, what):
    print(("ok: " if cond else "FAIL: ") + what, flush=True)
    if not cond:
        failures.append(what)


def load(path):
    r = vtkPNGReader()
    r.SetFileName(path)
    r.Update()
    return vtk_to_numpy(r.GetOutput().GetPointData().GetScalars()).astype(int)


def main():
    pvserver, pvpython = sys.argv[1:3]
    if not shutil.which("mpiexec"):
        print("mpiexec missing: skipped")
        return 77
    for key in list(os.environ):
        if key.startswith(("OMPI_", "PMIX_", "OPAL_", "ORTE_")):
            del os.environ[key]
    os.environ.update({"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
                       "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMP_NUM_THREADS": "1"})
    top = tempfile.mkdtemp(prefix="csgv-mpi-cs-")
    outs = {}
    for ranks in (1, 2):
        out = os.path.join(top, "np%d" % ranks)
        os.makedirs(out)
        env = dict(os.environ, CSGV_OUT=out, CSGV_SERVER_RANKS=str(ranks))
        p = subprocess.run([sys.executable, os.path.join(HERE, "clientserver_driver.py"), pvserver, pvpython,
                            os.path.join(HERE, "mpi_clientserver.py")], env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True, timeout=500)
        check(p.returncode == 0, "client of a %d-rank server ran" % ranks)
        if p.returncode != 0:
            print(p.stdout[-6000:])
            return 1
        outs[ranks] = out
    one = json.load(open(os.path.join(outs[1], "facts.json")))
    two = json.load(open(os.path.join(outs[2], "facts.json")))
    check(one["ranks"] == 1 and two["ranks"] == 2, "the servers have %d and %d ranks" % (one["ranks"], two["ranks"]))
    a, b = load(os.path.join(outs[1], "opaque.png")), load(os.path.join(outs[2], "opaque.png"))
    drawn = (a.max(axis=1) > 8).mean()
    differ = int((np.abs(a - b).max(axis=1) > 0).sum())
    check(drawn > 0.1 and differ == 0, "the client's image from 2 ranks equals 1 rank's (%d pixels differ, %.0f%% drawn)"
          % (differ, 100 * drawn))
    same = [k for k in one["picks"] if two["picks"].get(k) == one["picks"][k]]
    hits = sum(1 for k in one["picks"] if one["picks"][k][0])
    check(len(same) == len(one["picks"]) and hits > len(same) // 4,
          "%d of %d picks (%d hits) equal one rank's" % (len(same), len(one["picks"]), hits))
    check(two["labels"] == one["labels"], "the label image equals one rank's")
    check(not two["summary_error"], "the attribute summary answers (%r)" % two["summary_error"])
    check(len(one["match"]) > 0 and two["match"] == one["match"],
          "a label query (match) answers the same labels from 2 ranks as from 1 (%d)" % len(one["match"]))
    w1, w2 = os.path.join(outs[1], "written.csgv"), os.path.join(outs[2], "written.csgv")
    check(os.path.isfile(w2) and filecmp.cmp(w1, w2, shallow=False),
          "SaveData from the client writes, from 2 server ranks, the bytes of one")
    shutil.rmtree(top, ignore_errors=True)
    print("%d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
