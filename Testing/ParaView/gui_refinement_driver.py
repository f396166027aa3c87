# SPDX-License-Identifier: MIT
"""Runs the ParaView GUI with the CSGV plugin and gui_refinement.py, with CSGV_TRACE_REFINEMENT
on, and passes when the auto-start refined a Segmentation Volume from below its sample target
to the target (the trace then reports no volume left to refine), and again after the script's
interactive renders, and the representation's CSGVRefinementSlice was set by the auto-start (the still render after them is marked "after interaction"). The GUI is closed afterwards.
With CSGV_GUI_PVSERVER set (a pvserver executable), the GUI connects to a server started with
the plugin, which renders (GUI pass 10: refinement was for builtin sessions only); with
CSGV_SERVER_NO_DISPLAY=1 too, the server has no display and cannot render, so the GUI renders
and its refinement must ask the client's copy of the representation, which drew the volume.
Usage: gui_refinement_driver.py PARAVIEW PLUGIN_DIR SCRIPT"""
import os
import shutil
import socket
import subprocess
import sys
import threading
import time


def free_port():
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def answer_warning():
    """Presses OK (Return) on ParaView's "Server DISPLAY not accessible!" warning once it shows."""
    deadline = time.time() + 60
    while time.time() < deadline:
        found = subprocess.run(["xdotool", "search", "--name", "Server DISPLAY not accessible"],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout.split()
        if found:
            subprocess.run(["xdotool", "key", "--window", found[0], "Return"], stderr=subprocess.DEVNULL)
            return
        time.sleep(0.5)


def main():
    paraview, plugin_dir, script = sys.argv[1:4]
    if os.environ.get("CSGV_SERVER_NO_DISPLAY") and not shutil.which("xdotool"):
        print("FAIL xdotool answers ParaView's warning about the server's display (scripts/setup.sh installs it)")
        return 1
    env = dict(os.environ, CSGV_TRACE_REFINEMENT="1")
    args = [paraview, "--plugin-search-paths=" + plugin_dir, "--plugins=CSGV", "--script=" + script]
    server = None
    if os.environ.get("CSGV_GUI_PVSERVER"):
        # A HOME of its own without the welcome dialog, which holds a client connecting to a
        # server before its script runs.
        home = os.path.join(os.environ.get("TMPDIR", "/tmp"), "csgv-gui-remote-%d" % os.getpid())
        os.makedirs(os.path.join(home, ".config", "ParaView"), exist_ok=True)
        with open(os.path.join(home, ".config", "ParaView", "ParaView5.11.0.ini"), "w") as f:
            f.write("[General]\nGeneralSettings.ShowWelcomeDialog=false\n")
        env["HOME"] = home
        port = free_port()
        server_env = dict(env)
        if os.environ.get("CSGV_SERVER_NO_DISPLAY"):
            server_env.pop("DISPLAY", None)
        server = subprocess.Popen([os.environ["CSGV_GUI_PVSERVER"], "--force-offscreen-rendering",
                                   "--server-port=%d" % port, "--plugin-search-paths=" + plugin_dir,
                                   "--plugins=CSGV"], env=server_env, stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL)
        time.sleep(2)
        args.append("--server-url=cs://localhost:%d" % port)
    gui = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if server and os.environ.get("CSGV_SERVER_NO_DISPLAY"):
        # ParaView's modal warning "Display is not accessible on the server side. Remote rendering
        # will be disabled." holds the GUI (and its script) until it is answered, as a user does.
        threading.Thread(target=answer_warning, daemon=True).start()
    refined, converged, released, log, slice_ = 0, False, False, [], None
    # The GUI's lines through a queue: a GUI that prints nothing more (refinement that stopped)
    # is given up at the deadline, not waited for.
    import queue
    lines = queue.Queue()
    threading.Thread(target=lambda: [lines.put(l) for l in gui.stdout], daemon=True).start()
    deadline = time.time() + 90
    try:
        while time.time() < deadline:
            try:
                line = lines.get(timeout=1)
            except queue.Empty:
                continue
            log.append(line)
            if line.startswith("csgv slice:"):
                slice_ = float(line.split(":")[1])
            if "csgv refinement:" in line:
                fewest = int(line.split("fewest samples")[1].split()[0])
                released = released or "after interaction" in line
                if fewest > 0:
                    refined += 1
                elif fewest == -1 and refined > 0 and released:
                    converged = True
                    break
    finally:
        gui.kill()
        gui.wait()
        if server:
            server.kill()
            server.wait()
    sys.stdout.write("".join(l for l in log if "csgv refinement" in l or "ERR" in l or "bad X" in l))
    if any("require remote rendering" in l for l in log):
        print("FAIL ParaView said a representation requires remote rendering, which is not available")
        return 1
    if not slice_ or slice_ <= 0:
        print("FAIL the representation's CSGVRefinementSlice is %r: the GUI's slice did not reach it" % slice_)
        return 1
    print("ok   the GUI set the representation's refinement slice (%g s)" % slice_)
    if converged and refined >= 2:
        print("ok   the GUI refined the volume over %d renders to its sample target, also after "
              "interactive renders" % refined)
        return 0
    print("FAIL refinement did not reach the target (%d refining renders seen)" % refined)
    return 1


if __name__ == "__main__":
    sys.exit(main())
