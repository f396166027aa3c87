# SPDX-License-Identifier: MIT
"""Runs a pvpython client script against a fresh pvserver on a free local port, up to three
times: Xvfb drops some simultaneous connections ("bad X server connection"), which is no fault
of the code under test; retries run under a private Xvfb on a random display.
With CSGV_SERVER_RANKS=N (N > 1) the server runs as `mpiexec -np N pvserver`; with
CSGV_SERVER_NO_DISPLAY=1 it runs without DISPLAY (Debian's pvserver then cannot render, and
ParaView renders on the client).
Usage: clientserver_driver.py [--once] PVSERVER PVPYTHON SCRIPT."""
import os
import random
import shutil
import socket
import subprocess
import sys
import time


def free_port():
    s = socket.socket()
    s.bind(("localhost", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def attempt(pvserver, pvpython, script):
    port = free_port()
    command = [pvserver, "--force-offscreen-rendering", "--server-port=%d" % port]
    ranks = int(os.environ.get("CSGV_SERVER_RANKS", "1"))
    if ranks > 1:
        command = [shutil.which("mpiexec"), "-np", str(ranks)] + command
    env = dict(os.environ)
    if os.environ.get("CSGV_SERVER_NO_DISPLAY"):
        env.pop("DISPLAY", None)
    server = subprocess.Popen(command, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = []
    deadline = time.time() + 60
    while time.time() < deadline:
        line = server.stdout.readline()
        if not line:
            break
        lines.append(line)
        if "Accepting connection" in line:
            break
    else:
        server.kill()
    if server.poll() is not None or not any("Accepting connection" in l for l in lines):
        server.kill()
        print("pvserver did not start:\n" + "".join(lines))
        return 1
    # Drain the server's output while the client runs (a full pipe would block pvserver).
    import threading
    rest_lines = []
    drain = threading.Thread(target=lambda: rest_lines.extend(server.stdout), daemon=True)
    drain.start()
    env = dict(os.environ, CSGV_SERVER_PORT=str(port))
    client = subprocess.run([pvpython, "--force-offscreen-rendering", script], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=240)
    print(client.stdout)
    try:
        server.wait(timeout=30)
    except subprocess.TimeoutExpired:
        server.kill()
        server.wait()
    drain.join(timeout=5)
    print("--- pvserver ---\n" + "".join(lines) + "".join(rest_lines))
    return client.returncode


def main():
    if sys.argv[1] == "--once":
        return attempt(*sys.argv[2:5])
    pvserver, pvpython, script = sys.argv[1:4]
    for i in range(3):
        if i == 0 or not shutil.which("xvfb-run"):
            rc = attempt(pvserver, pvpython, script)
        else:
            sys.stdout.flush()
            rc = subprocess.run(["xvfb-run", "-n", str(random.randint(200, 899)), "-s", "-screen 0 1280x1024x24 -noreset",
                                 sys.executable, os.path.abspath(__file__), "--once", pvserver, pvpython,
                                 script]).returncode
        sys.stdout.flush()
        if rc == 0:
            return 0
        print("attempt %d failed (rc %d)%s" % (i + 1, rc, ", retrying" if i < 2 else ""))
    return 1


if __name__ == "__main__":
    sys.exit(main())
