# SPDX-License-Identifier: MIT
"""Malformed inputs give an error in ParaView's output (Core's message) and an empty output, and
the session goes on: a valid file opened afterwards reads correctly."""
import gzip
import os
import shutil

import numpy as np

import csgv_pvtest as t
from paraview.simple import *

t.load_plugin(globals())
tmp = t.temp_dir()
good = os.path.join(t.FIXTURES, "synthA_b32_rans2.csgv")
data = open(good, "rb").read()


def write(name, payload):
    path = os.path.join(tmp, name)
    with open(path, "wb") as f:
        f.write(payload)
    return path


def expect_error(tag, proxy_factory, needle):
    with t.ErrorLog() as errors:
        r = proxy_factory()
        img = t.fetch(r)
    t.check(img.GetNumberOfCells() == 0 and img.GetNumberOfPoints() == 0, tag + ": empty output")
    t.check(needle in errors.text, tag + ": error says %r" % needle)
    if needle not in errors.text:
        t.log("   got: " + errors.text.strip()[:400])
    # The empty output says why (FieldData CSGVReadError): a Segmentation Volume's summary gives
    # the reason, under MPI naming the rank (the input and NIfTI readers left it unmarked).
    mark = img.GetFieldData().GetAbstractArray("CSGVReadError")
    why = mark.GetValue(0) if mark is not None and mark.GetNumberOfValues() else ""
    t.check(why != "", tag + ": the empty output is marked with the reason (%r)" % why[:160])
    Delete(r)


for cut in (10, 40, 41 + 64, len(data) // 2, len(data) - 1):
    path = write("trunc_%d.csgv" % cut, data[:cut])
    expect_error("truncated at %d bytes" % cut, lambda: CSGVReader(FileName=path), "trunc_%d.csgv" % cut)

# OpenDataFile on a truncated file: the factory still picks the reader (the magic is intact).
path = write("trunc_open.csgv", data[: len(data) // 3])
with t.ErrorLog() as errors:
    r = OpenDataFile(path)
    img = t.fetch(r) if r is not None else None
t.check(r is not None and img.GetNumberOfCells() == 0 and "trunc_open.csgv" in errors.text,
        "OpenDataFile of a truncated file: error and empty output")
# Said once, however often the pipeline executes it again (open, show, render: it was five times).
with t.ErrorLog() as errors:
    r2 = OpenDataFile(path)
    v = t.render_view(64, 48)
    Show(r2, v)
    Render(v)
    Render(v)
t.check(errors.text.count("trunc_open.csgv: file truncated") == 1,
        "a truncated file's error is said once (%d times)" % errors.text.count("trunc_open.csgv: file truncated"))
Delete(r2)

expect_error("not a csgv", lambda: CSGVReader(FileName=write("garbage.csgv", b"hello world" * 100)), "garbage.csgv")
expect_error("missing file", lambda: CSGVReader(FileName=os.path.join(tmp, "none.csgv")), "none.csgv")

# Bit flips inside the encoding arrays: decoding must either fail cleanly or give a full image.
for k, offset in enumerate((2000, 30000, 60000, 90000)):
    mutated = bytearray(data)
    for i in range(offset, offset + 16):
        mutated[i] ^= 0x5A
    path = write("flip_%d.csgv" % k, bytes(mutated))
    with t.ErrorLog() as errors:
        r = CSGVReader(FileName=path)
        img = t.fetch(r)
    ok = (img.GetNumberOfCells() == 0 and "flip_%d.csgv" % k in errors.text) or img.GetNumberOfCells() == 133 * 70 * 194
    t.check(ok, "flipped bytes at %d: clean error or complete image" % offset)
    Delete(r)

# Sidecars: broken metadata, a database for another volume.
path = write("badjson.csgv", data)
write("badjson.csgv.json", b"{ not json")
expect_error("broken .csgv.json", lambda: CSGVReader(FileName=path), "badjson.csgv.json")
dense = open(os.path.join(t.FIXTURES, "denseB_b32_rans1.csgv"), "rb").read()
path = write("wrongdb.csgv", dense)
shutil.copy(os.path.join(t.FIXTURES, "synthA_b32_rans2_attr_csgv.db3"), os.path.join(tmp, "wrongdb_csgv.db3"))
expect_error("database of another volume", lambda: CSGVReader(FileName=path), "wrongdb_csgv.db3")

# Other formats.
raw = gzip.open(os.path.join(t.FIXTURES, "synthA.vraw.gz")).read()
path = write("short.vraw", raw[:100000])
expect_error("truncated .vraw", lambda: VolcaniteRawReader(FileName=path), "short.vraw")
path = write("short.nii.gz", open(t.AAL, "rb").read()[:50000])
expect_error("truncated .nii.gz", lambda: NIfTILabelReader(FileName=path), "short.nii.gz")

# A 56-byte .nii.gz whose header claims 32767 x 32767 x 2 voxels: the reader streams through
# Core's source and never allocates what a header merely claims (it took 17 GB and 100 s when
# the reader read the whole volume at 8 bytes a voxel first).
import resource
import struct
import time
hdr = bytearray(348)
struct.pack_into("<i", hdr, 0, 348)
struct.pack_into("<8h", hdr, 40, 3, 32767, 32767, 2, 1, 1, 1, 1)
struct.pack_into("<hh", hdr, 70, 2, 8)  # uint8
struct.pack_into("<8f", hdr, 76, 1, 1, 1, 1, 1, 1, 1, 1)
struct.pack_into("<f", hdr, 108, 352)
hdr[344:348] = b"n+1\0"
path = write("bomb.nii.gz", gzip.compress(bytes(hdr) + b"\0" * 4))
rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.time()
expect_error("a .nii.gz that claims 2 G voxels", lambda: NIfTILabelReader(FileName=path), "bomb.nii.gz")
grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024.0
t.check(grown < 512 and time.time() - t0 < 60,
        "the claim costs no memory: peak grew %.0f MiB in %.1f s" % (grown, time.time() - t0))

# An HDF5 file that crashes libhdf5 1.10.8 inside itself: its metadata is walked in a child
# process first, so the reader reports it and the session goes on.
crash = open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "Fuzz", "crashers", "hdf5",
                          "h5oopen_local_heap_null_memcpy"), "rb").read()[1:]
path = write("crash.h5", crash)
expect_error("an HDF5 file that crashes libhdf5", lambda: SegmentationCSGV(FileName=path), "libhdf5 crashed")

# Extract on something without an encoding.
with t.ErrorLog() as errors:
    x = CSGVExtract(Input=Wavelet())
    x.UpdatePipeline()
t.check("carries no CSGV volume" in errors.text, "Extract on a Wavelet: clear error")

# A read the user cancels (AbortExecute during the sweep of the palettes at open, shown with its
# progress text): one clear "cancelled" error and an empty output from that update; the next
# update reads the file (VTK takes an aborted output for one to make again).
cancel_path = write("cancel.csgv", data)
rc = OpenDataFile(cancel_path)
alg = rc.GetClientSideObject()
seen = []


def abort_once(obj, event):
    if not seen and obj.GetProgressText() == "Reading the palettes":
        seen.append(obj.GetProgress())
        obj.SetAbortExecute(1)


tag = alg.AddObserver("ProgressEvent", abort_once)
with t.ErrorLog() as errors:
    rc.UpdatePipeline()
img = alg.GetOutputDataObject(0)
t.check(len(seen) == 1 and errors.text.count("cancelled") == 1 and img.GetNumberOfCells() == 0,
        "a read cancelled at open: one clear error, empty output (%d aborts, %d cells: %r)" % (len(seen), img.GetNumberOfCells(), errors.text[-300:]))
alg.RemoveObserver(tag)
alg.Modified()
img = t.fetch(rc)
t.check(np.array_equal(t.cell_labels(img), t.source_volume("synthA_").ravel()), "the next update reads the cancelled file")
Delete(rc)

# A FIFO named like a volume: File > Open asked the readers, whose check opened it and waited for a
# writer for good (ParaView frozen); a regular file only is theirs, so ParaView says no reader
# takes it. A writer here after 5 s unblocks a reader that opened it (and says so).
import threading
for name in ("fifo.csgv", "fifo.nii"):
    fifo = os.path.join(tmp, name)
    os.mkfifo(fifo)
    blocked = []

    def unblock(path=fifo, seen=blocked):
        try:
            fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
            seen.append(True)  # a reader had it open
            os.close(fd)
        except OSError:
            pass  # no reader: nobody opened it

    timer = threading.Timer(5.0, unblock)
    timer.start()
    try:
        OpenDataFile(fifo)
    except Exception:
        pass  # "No reader found"
    timer.join()
    t.check(not blocked, "a FIFO named %s is no reader's: nothing opened it" % name)

# The session goes on: a valid file reads correctly afterwards.
r = OpenDataFile(good)
img = t.fetch(r)
t.check(np.array_equal(t.cell_labels(img), t.source_volume("synthA_").ravel()), "a valid file still opens afterwards")
t.finish()
