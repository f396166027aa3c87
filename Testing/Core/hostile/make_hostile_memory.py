# SPDX-License-Identifier: MIT
"""Writes the fixtures of test_hostile_memory.sh (numpy, h5py, zlib; Debian's python3).

Usage: make_hostile_memory.py OUTDIR

Each file is small on disk and states a volume whose careless reading needs far more memory or
time than its size suggests:
- wide.vraw.gz, wide.nii.gz, wide_gz.nrrd: 4000 x 4000 x 1 uint32 labels, gzip (a brick-deep slab
  of uint32 labels is 2 GB, a band of rows 64 MiB)
- deep.vraw.gz: 2000 x 2000 x 33 uint8, gzip (its 32-slice slabs go to a scratch file)
- slice20k.vraw.gz: 20000 x 20000 x 1 uint8 (a slice at 8 bytes a voxel is 3.2 GB)
- slices.tif: 2048 x 1100 x 20 uint16, a format read in whole slices only (150 labels)
- bomb.h5: a 64^3 uint8 dataset in one chunk whose gzip stream inflates to 1 GiB
- fill_only.h5, fill_16384.h5: 65536^3 and 16384^3 uint8 chunked, no chunk written (fill value 7)
- fill_4096.h5: 4096^3 uint32 in chunks of 64^3, no chunk written (fill value 7): 2^36 voxels in
  1.4 KB, compressed in time per brick (2^21 bricks of 32^3)
- inside/external.h5: a dataset whose raw data is an external file outside the HDF5 file's
  folder (named absolutely, so that libhdf5 finds it from any working directory)
- inside/external_inside.h5: the same with its external file beside it, named relatively
"""
import gzip
import os
import struct
import sys
import zlib

import h5py
import numpy as np


def wide_labels(w, h, dtype):
    """Blocks of 16 x 16 voxels, 250 labels: compressible, and a real segmentation's texture."""
    y, x = np.indices((h, w))
    return ((y // 16) * 7 + (x // 16) * 13) % 250 + 1


def nifti_header(w, h, d, datatype, bitpix):
    hdr = bytearray(352)
    struct.pack_into("<i", hdr, 0, 348)
    struct.pack_into("<8h", hdr, 40, 3, w, h, d, 1, 1, 1, 1)
    struct.pack_into("<hh", hdr, 70, datatype, bitpix)
    struct.pack_into("<8f", hdr, 76, 1, 1, 1, 1, 1, 1, 1, 1)
    struct.pack_into("<f", hdr, 108, 352.0)  # vox_offset
    struct.pack_into("<f", hdr, 112, 1.0)    # scl_slope
    hdr[344:348] = b"n+1\0"
    return bytes(hdr)


def crafted_gzip_chunk(total):
    """A zlib stream of `total` zero bytes, written piece by piece (never held inflated)."""
    c = zlib.compressobj(9)
    piece = bytes(1 << 20)
    out = [c.compress(piece) for _ in range(total >> 20)]
    out.append(c.flush())
    return b"".join(out)


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    p = lambda name: os.path.join(out, name)

    labels = wide_labels(4000, 4000, np.uint32).astype("<u4")
    raw = labels.tobytes()
    with gzip.open(p("wide.vraw.gz"), "wb", compresslevel=1) as f:
        f.write(b"4000 4000 1\nuint32\n")
        f.write(raw)
    with gzip.open(p("wide.nii.gz"), "wb", compresslevel=1) as f:
        f.write(nifti_header(4000, 4000, 1, 768, 32))  # NIFTI_TYPE_UINT32
        f.write(raw)
    with open(p("wide_gz.nrrd"), "wb") as f:
        f.write(b"NRRD0004\ntype: uint32\ndimension: 3\nsizes: 4000 4000 1\nencoding: gzip\nendian: little\n\n")
        f.write(gzip.compress(raw, compresslevel=1))
    del raw, labels

    # 2000 x 2000 x 33 uint8: a brick-deep slab is 128 MB at the file's width (a scratch file),
    # 512 MB as uint32 labels.
    with gzip.open(p("deep.vraw.gz"), "wb", compresslevel=1) as f:
        f.write(b"2000 2000 33\nuint8\n")
        layer = wide_labels(2000, 2000, np.uint8).astype(np.uint8)
        for z in range(33):
            f.write(((layer + z) % 250 + 1).astype(np.uint8).tobytes())

    # 400 MB of uint8 zeros with a few labels, gzipped piece by piece.
    with gzip.open(p("slice20k.vraw.gz"), "wb", compresslevel=6) as f:
        f.write(b"20000 20000 1\nuint8\n")
        row = np.zeros(20000, np.uint8)
        row[::1000] = np.arange(1, 21, dtype=np.uint8)
        block = np.tile(row, 1000).tobytes()
        for _ in range(20):
            f.write(block)

    # A TIFF (read whole slices only) whose slices `info` reads in more than one piece elsewhere.
    import tifffile
    t = (np.arange(20 * 1100 * 2048, dtype=np.uint32).reshape(20, 1100, 2048) // 300000).astype(np.uint16)
    tifffile.imwrite(p("slices.tif"), t)

    # One chunk of 64^3 bytes whose stored gzip stream inflates to 1 GiB of zeros: written raw
    # (write_direct_chunk), as a crafted file would hold it.
    with h5py.File(p("bomb.h5"), "w") as f:
        d = f.create_dataset("labels", shape=(64, 64, 64), dtype=np.uint8, chunks=(64, 64, 64), compression="gzip")
        d.id.write_direct_chunk((0, 0, 0), crafted_gzip_chunk(1 << 30))

    for n, name in ((65536, "fill_only.h5"), (16384, "fill_16384.h5")):
        with h5py.File(p(name), "w") as f:
            f.create_dataset("labels", shape=(n, n, n), dtype=np.uint8, chunks=(64, 64, 64), compression="gzip",
                             fillvalue=7)
    with h5py.File(p("fill_4096.h5"), "w") as f:
        f.create_dataset("labels", shape=(4096, 4096, 4096), dtype=np.uint32, chunks=(64, 64, 64), fillvalue=7)

    outside = os.path.join(out, "elsewhere")
    os.makedirs(os.path.join(out, "inside"), exist_ok=True)
    os.makedirs(outside, exist_ok=True)
    data = (np.arange(8 * 8 * 8) % 5).astype(np.uint8)
    data.tofile(os.path.join(outside, "secret.raw"))
    data.tofile(os.path.join(out, "inside", "beside.raw"))
    with h5py.File(os.path.join(out, "inside", "external.h5"), "w") as f:
        f.create_dataset("labels", shape=(8, 8, 8), dtype=np.uint8,
                         external=[(os.path.abspath(os.path.join(outside, "secret.raw")), 0, 512)])
    with h5py.File(os.path.join(out, "inside", "external_inside.h5"), "w") as f:
        f.create_dataset("labels", shape=(8, 8, 8), dtype=np.uint8, external=[("beside.raw", 0, 512)])


if __name__ == "__main__":
    main()
