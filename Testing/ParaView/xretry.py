# SPDX-License-Identifier: MIT
"""Runs a command and, only when it failed because the X server refused the connection ("bad X
server connection", or a GLX context it lost: an Xvfb started without -noreset resets when its
last client leaves and refuses connections meanwhile, and concurrent `xvfb-run -a` sessions on
one machine can pick the same display and clobber each other's authority; PARAVIEW-NOTES.md), runs
it again under a fresh private Xvfb on a random display, up to three attempts in all. Any other
failure is reported at once. Usage: xretry.py COMMAND ARGS..."""
import random
import shutil
import subprocess
import sys

SIGNATURES = ("bad X server connection", "X Error of failed request:  GLXBadContext")


def main():
    command = sys.argv[1:]
    for attempt in range(3):
        run = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        sys.stdout.write(run.stdout)
        sys.stdout.flush()
        if run.returncode == 0 or not any(sig in run.stdout for sig in SIGNATURES):
            return run.returncode
        if attempt == 2 or not shutil.which("xvfb-run"):
            break
        display = random.randint(200, 899)
        print("xretry: attempt %d lost its X connection, retrying on a private Xvfb :%d" % (attempt + 1, display))
        command = ["xvfb-run", "-n", str(display), "-s", "-screen 0 1280x1024x24 -noreset"] + sys.argv[1:]
    print("xretry: giving up")
    return run.returncode


if __name__ == "__main__":
    sys.exit(main())
