#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""Writes a large chunked HDF5 label volume for the out-of-core benchmarks (issue 12).

Usage: make_big_hdf5.py OUT.h5 N [--workers K] [--check]

The file holds one dataset, /labels: uint32, shape (N, N, N) as (z, y, x), chunks 64^3,
gzip level 1 (HDF5's deflate filter, no shuffle). Its content is procedural and deterministic:

- blocky cells: label = a 31-bit hash of (x // 24, y // 24, z // 24), plus one; about one
  cell in 16 is background (0);
- a few hundred large objects drawn over them (label 2^31 + i): spheres of radius N/40..N/12
  and tubes of radius N/100..N/40 running through the whole volume along x, y or z.

The volume is never in memory: worker processes each generate one row of chunks (64 slices of z,
64 rows of y, all of x), deflate its chunks (zlib, what HDF5's deflate filter stores) and hand
them back; the main process writes them with H5Dwrite_chunk (h5py's write_direct_chunk), so that
compression runs on every core. Memory is about 40 MiB per worker at N = 2048. Progress goes to
stderr. `--check` rereads some chunks through HDF5 and compares them with the generator.

Run it with Debian's python3 (numpy, h5py); 2048^3 gives 32 GiB of decoded labels.
"""
import argparse
import multiprocessing as mp
import os
import sys
import time
import zlib

import h5py
import numpy as np

CHUNK = 64
CELL = 24
SEED = 20240612


def objects(n):
    """The large objects, deterministic for a given N: (kind, centre zyx, radius, axis)."""
    rng = np.random.default_rng(SEED)
    spheres = [("sphere", rng.uniform(0, n, 3), rng.uniform(n / 40, n / 12), -1) for _ in range(240)]
    tubes = [("tube", rng.uniform(0, n, 3), rng.uniform(n / 100, n / 40), int(rng.integers(0, 3))) for _ in range(60)]
    return spheres + tubes


def cell_labels(z0, y0, shape):
    """Labels of the blocky cells over the box starting at (z0, y0, 0) of `shape` (z, y, x)."""
    dz, dy, dx = shape
    zc = (np.arange(z0, z0 + dz, dtype=np.uint64) // CELL)
    yc = (np.arange(y0, y0 + dy, dtype=np.uint64) // CELL)
    xc = (np.arange(0, dx, dtype=np.uint64) // CELL)
    uz, nz = np.unique(zc, return_counts=True)
    uy, ny = np.unique(yc, return_counts=True)
    ux, nx = np.unique(xc, return_counts=True)
    # Hash of every cell in the box (a few hundred), then repeated out to the voxels.
    h = (uz[:, None, None] * np.uint64(0x9E3779B97F4A7C15)) ^ (uy[None, :, None] * np.uint64(0xC2B2AE3D27D4EB4F)) ^ (
        ux[None, None, :] * np.uint64(0x165667B19E3779F9))
    h ^= h >> np.uint64(29)
    h *= np.uint64(0xBF58476D1CE4E5B9)
    h ^= h >> np.uint64(32)
    labels = ((h & np.uint64(0x7FFFFFFF)) + np.uint64(1)).astype(np.uint32)
    labels[(h >> np.uint64(40)) % np.uint64(16) == 0] = 0
    return np.repeat(np.repeat(np.repeat(labels, nz, axis=0), ny, axis=1), nx, axis=2)


def draw_objects(block, z0, y0, n, objs):
    """Draws the objects that meet the block (z0.., y0.., all x) into it, in order."""
    dz, dy, dx = block.shape
    for i, (kind, c, r, axis) in enumerate(objs):
        lo = [c[k] - r for k in range(3)]
        hi = [c[k] + r for k in range(3)]
        if kind == "tube":
            lo[axis], hi[axis] = 0, n
        box_lo = [max(int(np.floor(lo[0])), z0), max(int(np.floor(lo[1])), y0), max(int(np.floor(lo[2])), 0)]
        box_hi = [min(int(np.ceil(hi[0])) + 1, z0 + dz), min(int(np.ceil(hi[1])) + 1, y0 + dy),
                  min(int(np.ceil(hi[2])) + 1, dx)]
        if any(box_lo[k] >= box_hi[k] for k in range(3)):
            continue
        z = np.arange(box_lo[0], box_hi[0], dtype=np.float64)[:, None, None] - c[0]
        y = np.arange(box_lo[1], box_hi[1], dtype=np.float64)[None, :, None] - c[1]
        x = np.arange(box_lo[2], box_hi[2], dtype=np.float64)[None, None, :] - c[2]
        d2 = [z * z, y * y, x * x]
        if kind == "tube":
            d2[axis] = np.zeros_like(d2[axis])  # keeps the axis for broadcasting
        inside = (d2[0] + d2[1] + d2[2]) < r * r
        view = block[box_lo[0] - z0:box_hi[0] - z0, box_lo[1] - y0:box_hi[1] - y0, box_lo[2]:box_hi[2]]
        view[inside] = np.uint32((1 << 31) + i)


def chunk_row(z0, y0, n, objs):
    """One row of chunks (64 z, 64 y, all x), padded to whole chunks, as uint32 (z, y, x)."""
    shape = (min(CHUNK, n - z0), min(CHUNK, n - y0), n)
    block = cell_labels(z0, y0, shape)
    draw_objects(block, z0, y0, n, objs)
    if shape != (CHUNK, CHUNK, shape[2]) or n % CHUNK:
        padded = np.zeros((CHUNK, CHUNK, -(-n // CHUNK) * CHUNK), dtype=np.uint32)
        padded[:shape[0], :shape[1], :shape[2]] = block
        block = padded
    return block


_OBJS = None
_N = 0


def _init(n):
    global _OBJS, _N
    _N = n
    _OBJS = objects(n)


def _work(task):
    z0, y0 = task
    block = chunk_row(z0, y0, _N, _OBJS)
    out = []
    for x0 in range(0, _N, CHUNK):
        chunk = np.ascontiguousarray(block[:, :, x0:x0 + CHUNK])
        out.append((x0, zlib.compress(chunk.astype("<u4").tobytes(), 1)))
    return z0, y0, out


def check(path, n, samples=6):
    objs = objects(n)
    rng = np.random.default_rng(1)
    with h5py.File(path, "r") as f:
        d = f["labels"]
        for _ in range(samples):
            z0 = int(rng.integers(0, -(-n // CHUNK))) * CHUNK
            y0 = int(rng.integers(0, -(-n // CHUNK))) * CHUNK
            want = chunk_row(z0, y0, n, objs)[:min(CHUNK, n - z0), :min(CHUNK, n - y0), :n]
            got = d[z0:z0 + CHUNK, y0:y0 + CHUNK, :]
            if not np.array_equal(want, got):
                sys.exit(f"check failed at chunk row z {z0}, y {y0}")
    print(f"check: {samples} chunk rows equal the generator", file=sys.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("n", type=int)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args()
    n = args.n
    if n < 1:
        sys.exit("N must be positive")
    tasks = [(z0, y0) for z0 in range(0, n, CHUNK) for y0 in range(0, n, CHUNK)]
    rows_per_slab = -(-n // CHUNK)
    start = time.time()
    tmp = args.out + ".part"
    with h5py.File(tmp, "w") as f:
        d = f.create_dataset("labels", shape=(n, n, n), dtype=np.uint32, chunks=(CHUNK, CHUNK, CHUNK),
                             compression="gzip", compression_opts=1)
        stored = 0
        with mp.Pool(args.workers, initializer=_init, initargs=(n,)) as pool:
            for done, (z0, y0, chunks) in enumerate(pool.imap(_work, tasks), 1):
                for x0, data in chunks:
                    d.id.write_direct_chunk((z0, y0, x0), data)
                    stored += len(data)
                if done % rows_per_slab == 0 or done == len(tasks):
                    z = min(n, (done // rows_per_slab) * CHUNK)
                    t = time.time() - start
                    decoded = z * n * n * 4
                    print(f"z {z}/{n} ({100.0 * done / len(tasks):.1f}%), {decoded / 2**20 / max(t, 1e-9):.0f} MiB/s "
                          f"decoded, {stored / 2**20:.1f} MiB stored, {t:.0f} s", file=sys.stderr, flush=True)
    os.replace(tmp, args.out)
    t = time.time() - start
    print(f"wrote {args.out}: {n}^3 uint32 ({n**3 * 4 / 2**30:.2f} GiB decoded, {os.path.getsize(args.out) / 2**20:.1f} "
          f"MiB on disk) in {t:.1f} s", file=sys.stderr)
    if args.check:
        check(args.out, n)


if __name__ == "__main__":
    main()
