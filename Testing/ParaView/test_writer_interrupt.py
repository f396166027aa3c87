# SPDX-License-Identifier: MIT
"""Ctrl-C in pvpython while the CSGV writer saves over an existing set (found by an attack pass:
the process ended through ParaView's own signal handler and left the writer's temporaries beside
the output, one of them ending in .csgv). The process must end, leave no temporary, and leave a
whole set: the old files, or the new ones. Run by /usr/bin/python3; it starts pvpython itself."""
import os
import signal
import subprocess
import sys
import tempfile
import time

if len(sys.argv) > 1 and sys.argv[1] == "--child":
    import csgv_pvtest as t
    from paraview.simple import OpenDataFile, SaveData
    t.load_plugin(globals())
    r = OpenDataFile(sys.argv[2])
    r.UpdatePipeline()
    SaveData(sys.argv[3], proxy=r)
    if len(sys.argv) > 4:  # saved: say so, then wait for the signal
        open(sys.argv[4], "w").close()
        time.sleep(60)
    sys.exit(0)

fails = 0


def check(ok, what):
    global fails
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    fails += 0 if ok else 1


tool, pvpython = os.environ["CSGV_TOOL"], os.environ["CSGV_PVPYTHON"]
work = tempfile.mkdtemp(prefix="csgv-interrupt-")
source = os.path.join(work, "big.csgv")
subprocess.run([tool, "compress", "synth:320x320x320", source, "--quiet"], check=True)
out_dir = os.path.join(work, "out")


def interrupted_saves(sig, name):
    """Saves over an existing set, each ended by `sig` while a temporary is there."""
    rounds = 0
    for attempt in range(3):
        os.makedirs(out_dir, exist_ok=True)
        for f in os.listdir(out_dir):
            os.remove(os.path.join(out_dir, f))
        out = os.path.join(out_dir, "out.csgv")
        with open(out, "w") as f:
            f.write("OLD")
        with open(out + ".json", "w") as f:
            f.write("OLDJSON")
        child = subprocess.Popen([pvpython, "--force-offscreen-rendering", os.path.abspath(__file__), "--child", source, out],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.time() + 90
        while time.time() < deadline and child.poll() is None and not any(".tmp-" in f for f in os.listdir(out_dir)):
            time.sleep(0.002)
        if child.poll() is not None:
            continue  # the save ended before a temporary was seen: try again
        child.send_signal(sig)
        try:
            child.wait(timeout=10)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
            check(False, "pvpython still ran 10 s after %s" % name)
            continue
        rounds += 1
        left = sorted(os.listdir(out_dir))
        check(not any(".tmp-" in f for f in left), "save %d ended by %s: no temporaries left (%s)" % (rounds, name, left))
        old = open(out, "rb").read(3) == b"OLD"
        old_json = open(out + ".json", "rb").read() == b"OLDJSON"
        check(old == old_json, "save %d ended by %s: a whole set, old or new (old volume %s, old metadata %s)"
              % (rounds, name, old, old_json))
    check(rounds > 0, "the save was ended by %s while it wrote (%d rounds)" % (name, rounds))


interrupted_saves(signal.SIGINT, "SIGINT")
# A terminal closed under pvpython: SIGHUP's default action ended it and left the temporaries.
interrupted_saves(signal.SIGHUP, "SIGHUP")

# After a save, SIGINT and SIGTERM end pvpython by the signal, without ParaView's (loguru's) stack
# trace: it takes its symbols from malloc inside the handler and hung pvpython for good when the
# signal came inside malloc or free (an attack pass: 4 of 42 interrupts about a save's end).
small = os.path.join(work, "small.csgv")
subprocess.run([tool, "compress", "synth:32x32x32", small, "--quiet"], check=True)
for sig in (signal.SIGINT, signal.SIGTERM):
    ready = os.path.join(work, "ready-%d" % sig)
    child = subprocess.Popen([pvpython, "--force-offscreen-rendering", os.path.abspath(__file__), "--child", small,
                              os.path.join(out_dir, "small.csgv"), ready], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.time() + 90
    while time.time() < deadline and child.poll() is None and not os.path.exists(ready):
        time.sleep(0.02)
    child.send_signal(sig)
    try:
        _, err = child.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        child.kill()
        _, err = child.communicate()
        check(False, "pvpython still ran 10 s after signal %d" % sig)
        continue
    err = err.decode(errors="replace")
    name = "SIGINT" if sig == signal.SIGINT else "SIGTERM"
    check(child.returncode == -sig and ("CSGV: %s: ended" % name) in err and "Stack trace" not in err,
          "%s after a save ends pvpython by the signal, without a stack trace (status %s: %s)"
          % (name, child.returncode, err.strip()[-300:]))
print("%d failed" % fails)
sys.exit(1 if fails else 0)
