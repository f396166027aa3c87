# SPDX-License-Identifier: MIT
"""Runs the ParaView GUI with the CSGV plugin and a check script (`paraview --script`), waits for
the script's results file (CSGV_RESULTS), prints it, closes the GUI and passes when it ends with
"all checks passed". With CSGV_GUI_PLUGIN_PATH set the plugin is loaded from PV_PLUGIN_PATH (at
the application core's start) instead of --plugins. Usage: gui_script_driver.py PARAVIEW
PLUGIN_DIR SCRIPT [SECONDS]"""
import os
import subprocess
import sys
import tempfile
import time


def main():
    paraview, plugin_dir, script = sys.argv[1:4]
    seconds = float(sys.argv[4]) if len(sys.argv) > 4 else 120
    results = os.path.join(tempfile.mkdtemp(prefix="csgv-gui-"), "results.txt")
    env = dict(os.environ, CSGV_RESULTS=results, CSGV_TEST_DIR=os.path.dirname(os.path.abspath(__file__)))
    args = [paraview, "--plugin-search-paths=" + plugin_dir, "--plugins=CSGV", "--script=" + script]
    if os.environ.get("CSGV_GUI_PLUGIN_PATH"):
        env["PV_PLUGIN_PATH"] = plugin_dir
        args = [paraview, "--script=" + script]
    gui = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    deadline = time.time() + seconds
    try:
        while not os.path.exists(results) and time.time() < deadline and gui.poll() is None:
            time.sleep(0.2)
        time.sleep(0.5)  # the file is written in one go; let it be closed
    finally:
        gui.kill()
        output = gui.communicate()[0]
    if not os.path.exists(results):
        sys.stdout.write(output[-4000:])
        print("FAIL the GUI wrote no results within %.0f s (its output ends above)" % seconds)
        return 1
    with open(results) as f:
        text = f.read()
    sys.stdout.write(text)
    return 0 if text.rstrip().endswith("all checks passed") else 1


if __name__ == "__main__":
    sys.exit(main())
