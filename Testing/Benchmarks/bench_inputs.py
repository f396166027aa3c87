#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""Issue 12's input benchmark: the same N^3 content in every input format, compressed by
`csgv compress`, with peak RSS, wall time, throughput and bits per voxel per format, and zstd on
the raw bytes for comparison. Prints a Markdown table. A benchmark, never a test.

    /usr/bin/python3 Testing/Benchmarks/bench_inputs.py build/bin/csgv WORKDIR [--size 1024]
        [--formats vraw,nrrd,nii,h5,tif,zarr,precomputed] [--keep]

The content is `synth:NxNxN` (the procedural volume every benchmark here uses), decompressed once
to `.vraw` by csgv and re-written slab by slab into each format with Debian's h5py, tifffile and
zarr (precomputed: raw chunks written here), so no writer holds the whole volume. Needs Debian's
python3 (numpy, h5py, tifffile, zarr). Disk: about 4 bytes a voxel per format (N=1024: 4 GiB
each, deleted after its run unless --keep).
"""
import argparse
import gzip
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import time

import numpy as np

SLAB = 64  # slices per write; all writers stream slab by slab


def run_timed(cmd):
    """Runs cmd under /usr/bin/time -v; returns (seconds, peak RSS MiB, stdout)."""
    t0 = time.time()
    p = subprocess.run(["/usr/bin/time", "-v"] + cmd, capture_output=True, text=True)
    secs = time.time() - t0
    if p.returncode != 0:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), p.stdout, p.stderr))
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr).group(1)) / 1024.0
    return secs, rss, p.stdout


def vraw_slabs(vraw, n):
    """Yields (z0, uint32 array [depth, n, n]) from the .vraw content (memory-mapped)."""
    # csgv writes a short text header; the uint32 labels fill the rest of the file.
    vol = np.memmap(vraw, dtype="<u4", mode="r", offset=os.path.getsize(vraw) - 4 * n ** 3, shape=(n, n, n))
    for z0 in range(0, n, SLAB):
        yield z0, np.asarray(vol[z0:z0 + SLAB])


def write_nrrd(src, n, out):
    with open(out, "wb") as f:
        f.write(("NRRD0004\ntype: uint32\ndimension: 3\nsizes: %d %d %d\nencoding: gzip\nendian: little\n\n" % (n, n, n)).encode())
        with gzip.GzipFile(fileobj=f, mode="wb", compresslevel=1) as g:
            for _, s in vraw_slabs(src, n):
                g.write(s.tobytes())


def write_nii(src, n, out):
    h = bytearray(352)
    struct.pack_into("<i", h, 0, 348)
    struct.pack_into("<8h", h, 40, 3, n, n, n, 1, 1, 1, 1)
    struct.pack_into("<h", h, 70, 768)  # uint32
    struct.pack_into("<h", h, 72, 32)
    struct.pack_into("<8f", h, 76, 1, 1, 1, 1, 1, 1, 1, 1)
    struct.pack_into("<f", h, 108, 352)
    struct.pack_into("<f", h, 112, 1)  # scl_slope
    h[344:348] = b"n+1\0"
    with gzip.open(out, "wb", compresslevel=1) as g:
        g.write(bytes(h))
        for _, s in vraw_slabs(src, n):
            g.write(s.tobytes())


def write_h5(src, n, out):
    import h5py
    with h5py.File(out, "w") as f:
        d = f.create_dataset("labels", (n, n, n), dtype="<u4", chunks=(64, 64, 64), compression="gzip", compression_opts=1)
        for z0, s in vraw_slabs(src, n):
            d[z0:z0 + s.shape[0]] = s


def write_tif(src, n, out):
    import tifffile
    with tifffile.TiffWriter(out, bigtiff=True) as t:
        for _, s in vraw_slabs(src, n):
            for page in s:
                t.write(page, compression="zlib", contiguous=False)


def write_zarr(src, n, out):
    import zarr
    from numcodecs import Blosc
    a = zarr.open(out, mode="w", shape=(n, n, n), chunks=(64, 64, 64), dtype="<u4",
                  compressor=Blosc(cname="lz4", clevel=5, shuffle=Blosc.SHUFFLE))
    for z0, s in vraw_slabs(src, n):
        a[z0:z0 + s.shape[0]] = s


def write_precomputed(src, n, out):
    c = 64
    key = "1_1_1"
    os.makedirs(os.path.join(out, key), exist_ok=True)
    info = {"type": "segmentation", "data_type": "uint32", "num_channels": 1,
            "scales": [{"key": key, "size": [n, n, n], "resolution": [1, 1, 1], "voxel_offset": [0, 0, 0],
                        "chunk_sizes": [[c, c, c]], "encoding": "raw"}]}
    with open(os.path.join(out, "info"), "w") as f:
        json.dump(info, f)
    for z0, s in vraw_slabs(src, n):
        for y0 in range(0, n, c):
            for x0 in range(0, n, c):
                block = s[:, y0:y0 + c, x0:x0 + c]  # z, y, x -> file order x fastest = C order of (z, y, x)
                name = "%d-%d_%d-%d_%d-%d" % (x0, x0 + block.shape[2], y0, y0 + block.shape[1], z0, z0 + block.shape[0])
                with open(os.path.join(out, key, name), "wb") as f:
                    f.write(np.ascontiguousarray(block).tobytes())


WRITERS = {
    "vraw": (None, None),
    "nrrd": (write_nrrd, "in.nrrd"),
    "nii": (write_nii, "in.nii.gz"),
    "h5": (write_h5, "in.h5"),
    "tif": (write_tif, "in.tif"),
    "zarr": (write_zarr, "in.zarr"),
    "precomputed": (write_precomputed, "in_precomputed"),
}


def du(path):
    if os.path.isfile(path):
        return os.path.getsize(path)
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(path) for f in fs)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csgv")
    ap.add_argument("workdir")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--formats", default=",".join(WRITERS))
    ap.add_argument("--keep", action="store_true")
    a = ap.parse_args()
    n = a.size
    os.makedirs(a.workdir, exist_ok=True)
    vox = n ** 3
    ref = os.path.join(a.workdir, "synth.csgv")
    vraw = os.path.join(a.workdir, "in.vraw")
    rows = []
    secs, rss, _ = run_timed([a.csgv, "compress", "synth:%dx%dx%d" % (n, n, n), ref, "--quiet"])
    rows.append(("synth (procedural)", 0, secs, rss, os.path.getsize(ref)))
    if not os.path.exists(vraw):
        subprocess.run([a.csgv, "decompress", ref, vraw], check=True, capture_output=True)
    t0 = time.time()
    subprocess.run(["zstd", "-3", "-T1", "-f", "-q", vraw, "-o", vraw + ".zst"], check=True)
    zsecs = time.time() - t0
    zbytes = os.path.getsize(vraw + ".zst")
    os.remove(vraw + ".zst")
    for fmt in a.formats.split(","):
        writer, name = WRITERS[fmt]
        path = vraw if writer is None else os.path.join(a.workdir, name)
        if writer is not None and not os.path.exists(path):
            t0 = time.time()
            writer(vraw, n, path)
            print("wrote %s in %.0f s" % (path, time.time() - t0), file=sys.stderr)
        out = os.path.join(a.workdir, "out_%s.csgv" % fmt)
        secs, rss, _ = run_timed([a.csgv, "compress", path, out, "--quiet"])
        v = subprocess.run([a.csgv, "verify", out, vraw], capture_output=True, text=True)
        rows.append((fmt + ("" if v.returncode == 0 else " (VERIFY FAILED)"), du(path), secs, rss, os.path.getsize(out)))
        if writer is not None and not a.keep:
            shutil.rmtree(path) if os.path.isdir(path) else os.remove(path)
    print("\n%d^3 uint32 labels (%.1f GiB raw), `csgv compress` (default options):\n" % (n, 4 * vox / 2 ** 30))
    print("| input | input size (MiB) | wall (s) | Mvoxels/s | peak RSS (MiB) | bits/voxel |")
    print("|---|---|---|---|---|---|")
    for fmt, size, secs, rss, outb in rows:
        print("| %s | %.0f | %.1f | %.1f | %.0f | %.4f |" % (fmt, size / 2 ** 20, secs, vox / secs / 1e6, rss, 8.0 * outb / vox))
    print("| zstd -3 -T1 of the raw bytes | %.0f | %.1f | %.1f | - | %.4f |" % (4 * vox / 2 ** 20, zsecs, vox / zsecs / 1e6, 8.0 * zbytes / vox))
    if not a.keep:
        os.remove(vraw)


if __name__ == "__main__":
    main()
