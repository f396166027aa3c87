# SPDX-License-Identifier: MIT
"""Writes the small HDF5 fixtures of test_input_hdf5.cpp (h5py, Debian's python3).

Usage: make_hdf5.py OUTDIR

Every dataset the tests read has its expected values beside it in OUTDIR/NAME.expected: the
voxels in C order of the (z, y, x) array (x fastest), as little-endian 64-bit words at full
width (signed types sign-extended, as the InputSource contract gives them). NAME is the file
name with the dataset path's slashes turned into underscores, e.g. `nested.h5:/a/b/labels`
-> `nested_a_b_labels.expected`. Values are deterministic (fixed seeds).
"""
import os
import shutil
import sys
import zlib

import h5py
import numpy as np


def blocky(shape, block, seed, lo, hi, dtype):
    """Labels constant over blocks of `block` voxels, drawn from [lo, hi) by a fixed seed."""
    rng = np.random.default_rng(seed)
    grid = [(n + block - 1) // block for n in shape]
    cells = rng.integers(lo, hi, size=grid, dtype=np.int64 if lo < 0 else np.uint64, endpoint=False)
    z, y, x = np.indices(shape)
    out = cells[z // block, y // block, x // block].astype(dtype)
    out[rng.random(shape) < 0.05] = 0  # some background
    return out


def expect(outdir, name, array):
    wide = array.astype(np.int64) if array.dtype.kind == "i" else array.astype(np.uint64)
    wide.astype("<u8" if wide.dtype.kind == "u" else "<i8").tofile(os.path.join(outdir, name + ".expected"))


def main():
    outdir = sys.argv[1]
    os.makedirs(outdir, exist_ok=True)
    p = lambda name: os.path.join(outdir, name)

    # Chunked + shuffle + gzip, chunks that do not divide the shape, Fiji's spacing attribute.
    a = blocky((19, 23, 29), 4, 1, 1, 4_000_000_000, np.uint32)
    with h5py.File(p("chunked_gzip.h5"), "w") as f:
        d = f.create_dataset("labels", data=a, chunks=(8, 10, 7), compression="gzip", compression_opts=4, shuffle=True)
        d.attrs["element_size_um"] = np.array([2.5, 0.5, 0.25])  # z, y, x
    expect(outdir, "chunked_gzip_labels", a)

    # Contiguous uint16, no attributes.
    a = blocky((12, 17, 9), 3, 2, 0, 65535, np.uint16)
    with h5py.File(p("contiguous_u16.h5"), "w") as f:
        f.create_dataset("data", data=a)
    expect(outdir, "contiguous_u16_data", a)

    # uint8 chunked without filters, file extension .hdf5.
    a = blocky((7, 6, 5), 2, 3, 0, 256, np.uint8)
    with h5py.File(p("small_u8.hdf5"), "w") as f:
        f.create_dataset("seg", data=a, chunks=(3, 3, 3))
    expect(outdir, "small_u8_seg", a)

    # Signed types with negatives: int32 native, int16 big-endian (HDF5 converts), int64 beyond 2^40.
    a = blocky((10, 11, 12), 3, 4, -50_000, 50_000, np.int32)
    with h5py.File(p("i32.h5"), "w") as f:
        f.create_dataset("labels", data=a, chunks=(4, 4, 4), compression="gzip")
    expect(outdir, "i32_labels", a)
    a = blocky((5, 6, 7), 2, 5, -30_000, 30_000, np.int16)
    with h5py.File(p("i16be.h5"), "w") as f:
        f.create_dataset("labels", data=a.astype(">i2"))
    expect(outdir, "i16be_labels", a)
    a = blocky((9, 8, 13), 3, 6, -(1 << 45), 1 << 45, np.int64)
    with h5py.File(p("i64.h5"), "w") as f:
        f.create_dataset("labels", data=a, chunks=(4, 8, 8), compression="gzip")
    expect(outdir, "i64_labels", a)

    # int8 with fletcher32 checksums; the same under szip when this HDF5 can write it (the test
    # skips that part when the file is absent).
    a = blocky((6, 7, 9), 2, 13, -128, 128, np.int8)
    with h5py.File(p("i8.h5"), "w") as f:
        f.create_dataset("labels", data=a, chunks=(4, 4, 4), fletcher32=True)
    expect(outdir, "i8_labels", a)
    if h5py.h5z.filter_avail(h5py.h5z.FILTER_SZIP):
        with h5py.File(p("i8_szip.h5"), "w") as f:
            f.create_dataset("labels", data=a, chunks=(4, 4, 4), compression="szip")

    # uint64 above 2^32 (and above 2^63).
    a = blocky((8, 9, 10), 3, 7, 0, 1 << 63, np.uint64)
    a[a % 3 == 1] += np.uint64(1 << 63)
    with h5py.File(p("u64.h5"), "w") as f:
        f.create_dataset("labels", data=a, chunks=(8, 9, 10), compression="gzip")
    expect(outdir, "u64_labels", a)

    # Nested groups, named explicitly; floats holding integers and floats that do not.
    a = blocky((6, 7, 8), 2, 8, 0, 1000, np.uint32)
    with h5py.File(p("nested.h5"), "w") as f:
        f.create_dataset("a/b/labels", data=a)
        f.create_dataset("a/b/other", data=a + 1)
        f.create_dataset("a/flat", data=a[0])
        f.create_dataset("a/b/float_ints", data=(a.astype(np.float32) - 500))
        frac = a.astype(np.float64)
        frac[3, 4, 5] = 2.5
        f.create_dataset("a/b/float_frac", data=frac)
        f.create_dataset("a/b/vol4d", data=a[np.newaxis])
        f.create_dataset("a/b/vol4d_bad", data=np.stack([a, a]))
        f.create_dataset("a/b/vol5d_channel", data=a[np.newaxis, :, :, :, np.newaxis])
        f.create_dataset("a/b/empty", shape=(0, 4, 4), dtype=np.uint8)
        f.create_dataset("a/b/names", data=np.array([[[b"x"]]], dtype="S4"))
        f.create_dataset("a/b/pairs", data=np.zeros((2, 2, 2), dtype=[("id", "<u4"), ("w", "<f4")]))
        f.create_dataset("a/b/half", data=np.zeros((2, 2, 2), dtype=np.float16))
        f.create_dataset("a/b/lzf", data=a, chunks=(3, 7, 8), compression="lzf")
    expect(outdir, "nested_a_b_labels", a)
    expect(outdir, "nested_a_b_float_ints", a.astype(np.int64) - 500)

    # The only 3D integer dataset among 2D, 1D and float ones, found without a path.
    a = blocky((9, 10, 11), 3, 9, 1, 100_000, np.uint32)
    with h5py.File(p("autopick.h5"), "w") as f:
        f.create_dataset("raw", data=np.zeros((9, 10, 11), dtype=np.float32))
        f.create_dataset("mask", data=np.ones((10, 11), dtype=np.uint8))
        f.create_dataset("meta/ids", data=np.arange(5, dtype=np.int64))
        f.create_dataset("volume/seg", data=a, chunks=(5, 5, 5), compression="gzip")
        f.create_dataset("volume/prob", data=np.zeros((9, 10, 11), dtype=np.float64))
    expect(outdir, "autopick", a)

    # Two 3D integer datasets: ambiguous. Only floats and 2D: none.
    with h5py.File(p("ambiguous.h5"), "w") as f:
        f.create_dataset("seg1", data=np.zeros((2, 3, 4), dtype=np.uint16))
        f.create_dataset("group/seg2", data=np.zeros((2, 3, 4), dtype=np.int64))
    with h5py.File(p("none.h5"), "w") as f:
        f.create_dataset("raw", data=np.zeros((2, 3, 4), dtype=np.float32))
        f.create_dataset("flat", data=np.zeros((3, 4), dtype=np.uint32))
        f.create_group("empty_group")

    # CREMI-style attributes: resolution and offset (z, y, x); and an unusable spacing attribute.
    a = blocky((4, 5, 6), 2, 10, 0, 50, np.uint8)
    with h5py.File(p("cremi.h5"), "w") as f:
        d = f.create_dataset("volumes/labels/neuron_ids", data=a.astype(np.uint64))
        d.attrs["resolution"] = np.array([40.0, 4.0, 4.0])
        d.attrs["offset"] = np.array([80, 12, 8], dtype=np.int32)
        d = f.create_dataset("volumes/bad_spacing", data=a)
        d.attrs["resolution"] = np.array([4.0, -1.0, 4.0])
    expect(outdir, "cremi_volumes_labels_neuron_ids", a)

    # Truncated: a valid file cut in half. Text named .h5.
    with h5py.File(p("truncated.h5"), "w") as f:
        f.create_dataset("labels", data=blocky((16, 16, 16), 4, 11, 0, 1 << 30, np.uint32), chunks=(8, 8, 8),
                         compression="gzip")
    size = os.path.getsize(p("truncated.h5"))
    with open(p("truncated.h5"), "r+b") as fh:
        fh.truncate(size // 2)
    # A chunk whose deflate stream is damaged (found through HDF5's chunk index); the file's
    # structure is intact, so only reading that chunk fails.
    a = blocky((16, 16, 16), 4, 12, 0, 1 << 30, np.uint32)
    with h5py.File(p("corrupt.h5"), "w") as f:
        f.create_dataset("labels", data=a, chunks=(8, 16, 16), compression="gzip")
    with h5py.File(p("corrupt.h5"), "r") as f:
        info = f["labels"].id.get_chunk_info_by_coord((8, 0, 0))
    with open(p("corrupt.h5"), "r+b") as fh:
        fh.seek(info.byte_offset + 2)
        fh.write(bytes(range(0xF0, 0x100)) * 2)
    expect(outdir, "corrupt_labels", a)

    # The dataset's object header overwritten (its messages): the link exists, the object does not open.
    shutil.copy(p("chunked_gzip.h5"), p("damaged_header.h5"))
    with h5py.File(p("damaged_header.h5"), "r") as f:
        header = h5py.h5o.get_info(f["labels"].id).addr
    with open(p("damaged_header.h5"), "r+b") as fh:
        fh.seek(header + 16)
        fh.write(b"\xff" * 32)

    with open(p("text.h5"), "w") as fh:
        fh.write("labels,1,2,3\nthis is not an HDF5 file\n")

    # Hostile chunks, written raw (write_direct_chunk) as a crafted file holds them. 16^3 uint16
    # chunks of 8 KiB: one whose gzip stream (within what deflate can need for 8 KiB) inflates
    # to 4 MiB, one storing far more bytes than any gzip of 8 KiB, one that inflates short.
    def zeros_stream(n):
        c = zlib.compressobj(9)
        return c.compress(bytes(n)) + c.flush()
    with h5py.File(p("hostile_chunks.h5"), "w") as f:
        for name, stream in (("bomb", zeros_stream(4 << 20)), ("oversized", zeros_stream(8192) + bytes(20000)),
                             ("short", zeros_stream(4096))):
            d = f.create_dataset(name, shape=(16, 16, 16), dtype=np.uint16, chunks=(16, 16, 16), compression="gzip")
            d.id.write_direct_chunk((0, 0, 0), stream)
        # scaleoffset then gzip: a pipeline libhdf5 decodes, whose gzip stream is checked first.
        d = f.create_dataset("bomb_scaleoffset", shape=(16, 16, 16), dtype=np.uint16, chunks=(16, 16, 16),
                             scaleoffset=0, compression="gzip")
        d.id.write_direct_chunk((0, 0, 0), zeros_stream(4 << 20))
        d = f.create_dataset("scaleoffset", data=np.arange(16 ** 3, dtype=np.uint16).reshape(16, 16, 16) % 1000,
                             chunks=(8, 16, 16), scaleoffset=0, compression="gzip")
        expect(outdir, "hostile_chunks_scaleoffset", d[...])
        if h5py.h5z.filter_avail(h5py.h5z.FILTER_SZIP):
            # libhdf5's szip decoder allocates what a chunk's first four bytes state: 1 GiB here.
            d = f.create_dataset("szip_claims", shape=(16, 16, 16), dtype=np.uint16, chunks=(16, 16, 16),
                                 compression="szip")
            d.id.write_direct_chunk((0, 0, 0), (1 << 30).to_bytes(4, "little") + bytes(60))

    # gzip + shuffle + fletcher32 (decoded by us too: a checksum must not hand a crafted chunk back
    # to libhdf5), and the same with one stored byte of a chunk changed: its checksum fails.
    a = blocky((10, 11, 12), 3, 14, 1, 1 << 40, np.uint64)
    with h5py.File(p("checksummed.h5"), "w") as f:
        f.create_dataset("labels", data=a, chunks=(5, 6, 7), compression="gzip", shuffle=True, fletcher32=True)
    expect(outdir, "checksummed_labels", a)
    shutil.copy(p("checksummed.h5"), p("checksum_bad.h5"))
    with h5py.File(p("checksum_bad.h5"), "r") as f:
        info = f["labels"].id.get_chunk_info_by_coord((5, 6, 7))
    with open(p("checksum_bad.h5"), "r+b") as fh:
        fh.seek(info.byte_offset + info.size - 1)
        last = fh.read(1)
        fh.seek(info.byte_offset + info.size - 1)
        fh.write(bytes([last[0] ^ 0x55]))

    # Fill values: no chunk written at all (a large volume in a tiny file), and some chunks written
    # among unwritten ones (shuffle + gzip, fill value 5, signed with a negative fill too).
    with h5py.File(p("fill.h5"), "w") as f:
        f.create_dataset("none", shape=(4096, 4096, 4096), dtype=np.uint8, chunks=(64, 64, 64), compression="gzip",
                         fillvalue=7)
        d = f.create_dataset("some", shape=(20, 21, 22), dtype=np.uint32, chunks=(8, 8, 8), compression="gzip",
                             shuffle=True, fillvalue=5)
        a = np.full((20, 21, 22), 5, np.uint32)
        a[8:16, 0:8, 8:16] = blocky((8, 8, 8), 2, 13, 1, 1 << 31, np.uint32)
        a[16:20, 16:21, 16:22] = 9
        d[8:16, 0:8, 8:16] = a[8:16, 0:8, 8:16]
        d[16:20, 16:21, 16:22] = 9
        expect(outdir, "fill_some", a)
        d = f.create_dataset("negative", shape=(9, 9, 9), dtype=">i2", chunks=(4, 4, 4), compression="gzip",
                             fillvalue=-3)
        b = np.full((9, 9, 9), -3, np.int16)
        b[0:4, 0:4, 0:4] = np.arange(64, dtype=np.int16).reshape(4, 4, 4) - 30
        d[0:4, 0:4, 0:4] = b[0:4, 0:4, 0:4]
        expect(outdir, "fill_negative", b)

    # A few chunks written among many never written (the encoder's constant-region path,
    # Hdf5Uniform): chunks that divide bricks of 8 and 16 and chunks that divide no brick; fill
    # values 0, 7, negative and float; pipelines we decode (none, gzip, shuffle) and one libhdf5
    # decodes (scaleoffset); fill time "never" on both (libhdf5 leaves those voxels alone: they are
    # the fill value all the same); contiguous storage never written. 45 x 50 x 70 voxels cut
    # bricks of 8, 16 and 32 at every far end.
    shape = (45, 50, 70)
    with h5py.File(p("uniform.h5"), "w") as f:
        def partly(name, dtype, chunks, fill, never=False, **kw):
            if never:  # h5py 3.7 has no fill_time: the low-level API
                dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
                dcpl.set_chunk(chunks)
                dcpl.set_fill_time(h5py.h5d.FILL_TIME_NEVER)
                dcpl.set_fill_value(np.array(fill, dtype))
                if kw.get("scaleoffset") is not None:
                    dcpl.set_scaleoffset(h5py.h5z.SO_INT, h5py.h5z.SO_INT_MINBITS_DEFAULT)
                else:
                    dcpl.set_deflate(4)
                h5py.h5d.create(f.id, name.encode(), h5py.h5t.py_create(np.dtype(dtype)),
                                h5py.h5s.create_simple(shape), dcpl=dcpl)
                d = f[name]
            else:
                d = f.create_dataset(name, shape=shape, dtype=dtype, chunks=chunks, fillvalue=fill, **kw)
            a = np.full(shape, fill, dtype)
            cz, cy, cx = chunks
            regions = [
                (slice(0, 10), slice(0, 12), slice(0, 20)),                       # varied labels
                (slice(cz, 2 * cz), slice(cy, 2 * cy), slice(2 * cx, 3 * cx)),   # a chunk of the fill value, written
                (slice(30, 45), slice(34, 50), slice(40, 70)),                     # another label, constant
            ]
            a[regions[0]] = blocky((10, 12, 20), 3, 41, 1, 120, dtype)
            a[regions[2]] = 9
            for r in regions:
                if never:  # whole chunks: the rest of a chunk written in part is not the fill value
                    r = tuple(slice(q.start // c * c, min(n, -(-q.stop // c) * c)) for q, c, n in zip(r, chunks, shape))
                d[r] = a[r]
            expect(outdir, "uniform_" + name, a)
        partly("aligned0", np.uint32, (16, 16, 16), 0, compression="gzip")
        partly("odd7", np.uint32, (12, 20, 24), 7, compression="gzip", shuffle=True)
        partly("big7", np.uint16, (40, 40, 40), 7)
        partly("negative", np.int16, (16, 16, 16), -3, compression="gzip")
        partly("float4", np.float32, (10, 10, 10), 4.0, compression="gzip")
        partly("scaleoffset5", np.uint16, (16, 16, 16), 5, scaleoffset=0)
        partly("never7", np.uint32, (16, 16, 16), 7, never=True)
        partly("never_scaleoffset7", np.uint16, (16, 16, 16), 7, never=True, scaleoffset=0)
        f.create_dataset("contiguous11", shape=shape, dtype=np.uint8, fillvalue=11)
        expect(outdir, "uniform_contiguous11", np.full(shape, 11, np.uint8))
        # A fill value that is no label: nothing is uniform, reading a chunk never written fails.
        d = f.create_dataset("fill_fraction", shape=shape, dtype=np.float32, chunks=(16, 16, 16), fillvalue=2.5)
        d[0:16, 0:16, 0:16] = 1

    # External storage: raw data in a file beside the HDF5 file (named relatively: allowed), and
    # in a folder beside the fixtures' (named absolutely: outside, refused unless allowed).
    ext = os.path.join(outdir, "external")
    os.makedirs(ext, exist_ok=True)
    raw = (np.arange(6 * 5 * 4) % 7).astype(np.uint8)
    raw.tofile(os.path.join(ext, "beside.raw"))
    outside = os.path.abspath(os.path.join(outdir, "outside.raw"))
    raw.tofile(outside)
    with h5py.File(os.path.join(ext, "beside.h5"), "w") as f:
        f.create_dataset("labels", shape=(6, 5, 4), dtype=np.uint8, external=[("beside.raw", 0, raw.size)])
    with h5py.File(os.path.join(ext, "outside.h5"), "w") as f:
        f.create_dataset("labels", shape=(6, 5, 4), dtype=np.uint8, external=[(outside, 0, raw.size)])
    expect(outdir, "external_labels", raw.reshape(6, 5, 4))
    with h5py.File(os.path.join(ext, "device.h5"), "w") as f:
        f.create_dataset("labels", shape=(6, 5, 4), dtype=np.uint8, external=[("/dev/zero", 0, raw.size)])

    # External links and virtual datasets name other files, which libhdf5 opens when a name is
    # followed or voxels are read. links/ holds names of files beside them (read), of a file in
    # the folder above (refused unless allowed: absolutely, relatively, through a group, behind a
    # soft link, from a virtual dataset beside that takes its voxels from outside, from a source in
    # its own file that is an external link), a virtual dataset that is its own source, and names
    # of "pipe.h5", which the tests make a FIFO in a copy of the folder.
    links = os.path.join(outdir, "links")
    os.makedirs(links, exist_ok=True)
    a = blocky((6, 5, 4), 2, 40, 1, 60000, np.uint16)
    expect(outdir, "link_labels", a)
    outside = os.path.abspath(os.path.join(outdir, "outside_target.h5"))
    for target in (os.path.join(links, "target.h5"), outside):
        with h5py.File(target, "w") as f:
            f.create_dataset("labels", data=a)
            f.create_group("g").create_dataset("labels", data=a)

    def virtual(name, source_file, source="labels", extra=None):
        layout = h5py.VirtualLayout(shape=a.shape, dtype=a.dtype)
        layout[:] = h5py.VirtualSource(source_file, source, shape=a.shape, dtype=a.dtype)
        with h5py.File(os.path.join(links, name), "w", libver="latest") as f:
            if extra:
                extra(f)
            f.create_virtual_dataset("labels", layout, fillvalue=0)

    def links_file(name, **entries):
        with h5py.File(os.path.join(links, name), "w") as f:
            for key, link in entries.items():
                f[key] = link

    # A chain of 1500 nested groups with one dataset at its end (the walk looked every object up
    # by its whole path: 30 s).
    with h5py.File(p("deep_groups.h5"), "w") as f:
        g = f
        for _ in range(1500):
            g = g.create_group("g")
        g.create_dataset("labels", data=a)

    links_file("elink_beside.h5", d=h5py.ExternalLink("target.h5", "/labels"))
    links_file("elink_outside.h5", d=h5py.ExternalLink(outside, "/labels"), g=h5py.ExternalLink(outside, "/g"),
               s=h5py.SoftLink("/d"))
    links_file("elink_relative_outside.h5", d=h5py.ExternalLink("../outside_target.h5", "/labels"))
    links_file("elink_pipe.h5", d=h5py.ExternalLink("pipe.h5", "/labels"))
    virtual("vds_beside.h5", "target.h5")
    virtual("vds_outside.h5", outside)
    virtual("vds_relative_outside.h5", "../outside_target.h5")
    virtual("vds_nested.h5", "vds_outside.h5")
    virtual("vds_self.h5", ".", "labels")
    virtual("vds_through_link.h5", ".", "/e", lambda f: f.__setitem__("e", h5py.ExternalLink(outside, "/labels")))
    virtual("vds_pipe.h5", "pipe.h5")

    # Sources named by a pattern (printf form, over an unlimited axis): libhdf5 opens them itself
    # when the dataset is opened. "pipe%b.h5" is made a FIFO (pipe0.h5) by the tests; the other
    # takes "src%b" from its own file, where src0 is an external link to the folder above.
    def pattern(name, source_file, source):
        vspace = h5py.h5s.create_simple((4, 5, 6), (h5py.h5s.UNLIMITED, 5, 6))
        vspace.select_hyperslab((0, 0, 0), (h5py.h5s.UNLIMITED, 1, 1), stride=(1, 1, 1), block=(1, 5, 6))
        sspace = h5py.h5s.create_simple((1, 5, 6), (1, 5, 6))
        dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
        dcpl.set_virtual(vspace, source_file.encode(), source.encode(), sspace)
        with h5py.File(os.path.join(links, name), "w") as f:
            h5py.h5d.create(f.id, b"labels", h5py.h5t.NATIVE_UINT16,
                            h5py.h5s.create_simple((4, 5, 6), (h5py.h5s.UNLIMITED, 5, 6)), dcpl=dcpl)
            return f.filename

    pattern("vds_pattern_pipe.h5", "pipe%b.h5", "labels")
    pattern("vds_pattern_self.h5", ".", "src%b")
    with h5py.File(os.path.join(links, "vds_pattern_self.h5"), "a") as f:
        f["src0"] = h5py.ExternalLink(outside, "/g/labels")


if __name__ == "__main__":
    main()
