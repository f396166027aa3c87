#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes Neuroglancer precomputed fixtures for test_input_precomputed.cpp into OUTDIR.

No Debian package writes precomputed volumes, so this script does, with numpy only: the info
file, raw chunks and its own compressed_segmentation encoder written from neuroglancer's
specification (sliceview/compressed_segmentation/README.md), independent of Core's decoder.
Each good case folder also holds `expected.u64`: the whole volume, little-endian uint64, x fastest.

Usage: make_precomputed.py OUTDIR
"""
import gzip
import json
import os
import shutil
import sys

import numpy as np

CS_BITS = (0, 1, 2, 4, 8, 16, 32)


def labels(shape_xyz, seed, base, distinct_per_block=None, block=None, chunk=None):
    """A deterministic label volume (array indexed [z, y, x]). With distinct_per_block, every
    compressed_segmentation block (the grid of `block` inside each chunk of `chunk`) gets that
    many distinct values (cycled), so that the encoder uses every bit width."""
    sx, sy, sz = shape_xyz
    rng = np.random.default_rng(seed)
    if distinct_per_block is None:
        # Blobs: coarse random labels upsampled, then some noise.
        coarse = rng.integers(0, 12, size=(sz // 4 + 1, sy // 4 + 1, sx // 4 + 1), dtype=np.uint64)
        v = coarse.repeat(4, 0).repeat(4, 1).repeat(4, 2)[:sz, :sy, :sx]
        v = v * np.uint64(1000003) + np.uint64(base)
        v[rng.random(v.shape) < 0.05] = 0
        return v
    v = np.zeros((sz, sy, sx), dtype=np.uint64)
    bx, by, bz = block
    cx, cy, cz = chunk or shape_xyz
    starts = [(z, y, x) for cz0 in range(0, sz, cz) for cy0 in range(0, sy, cy) for cx0 in range(0, sx, cx)
              for z in range(cz0, min(cz0 + cz, sz), bz) for y in range(cy0, min(cy0 + cy, sy), by)
              for x in range(cx0, min(cx0 + cx, sx), bx)]
    for n, (z0, y0, x0) in enumerate(starts):
        k = distinct_per_block[n % len(distinct_per_block)]
        z1 = min(z0 + bz, (z0 // cz + 1) * cz, sz)
        y1 = min(y0 + by, (y0 // cy + 1) * cy, sy)
        x1 = min(x0 + bx, (x0 // cx + 1) * cx, sx)
        sub = v[z0:z1, y0:y1, x0:x1]
        vals = rng.integers(0, k, size=sub.shape, dtype=np.uint64)
        m = min(k, vals.size)
        vals.flat[:m] = np.arange(m, dtype=np.uint64)  # every value present
        sub[...] = np.uint64(base) + np.uint64(n * 977) + vals * np.uint64(7919)
    return v


def cs_encode_block(padded, dtype, force_bits=None):
    """Lookup table and packed indices of one block (padded [z, y, x], x fastest when flattened)."""
    table, index = np.unique(padded.ravel(), return_inverse=True)
    bits = next(b for b in CS_BITS if (1 << b) >= len(table))
    if force_bits is not None:
        bits = force_bits
    packed = np.zeros(0, dtype=np.uint32)
    if bits:
        per_word = 32 // bits
        idx = index.astype(np.uint64)
        idx = np.concatenate([idx, np.zeros((-len(idx)) % per_word, dtype=np.uint64)]).reshape(-1, per_word)
        shifts = np.arange(per_word, dtype=np.uint64) * np.uint64(bits)
        packed = (idx << shifts).sum(axis=1).astype(np.uint32)
    if dtype == np.uint64:
        t = table.astype(np.uint64)
        table_words = np.stack([(t & np.uint64(0xFFFFFFFF)), t >> np.uint64(32)], axis=1).ravel().astype(np.uint32)
    else:
        table_words = table.astype(np.uint32)
    return bits, packed, table_words


def cs_encode(chunk, block, dtype, force_bits=None):
    """One-channel compressed_segmentation of chunk ([z, y, x]): word 0 = offset of the channel
    (1), then the channel: block headers, then per block its packed values and lookup table.
    Offsets inside the channel count 32-bit words from the channel's start."""
    ez, ey, ex = chunk.shape
    bx, by, bz = block
    gx, gy, gz = -(-ex // bx), -(-ey // by), -(-ez // bz)
    header = np.zeros(2 * gx * gy * gz, dtype=np.uint32)
    body = []
    at = len(header)
    used_bits = set()
    for z in range(gz):
        for y in range(gy):
            for x in range(gx):
                sub = chunk[z * bz:(z + 1) * bz, y * by:(y + 1) * by, x * bx:(x + 1) * bx]
                padded = np.full((bz, by, bx), sub.flat[0], dtype=chunk.dtype)  # any value of the block pads
                padded[:sub.shape[0], :sub.shape[1], :sub.shape[2]] = sub
                b = x + gx * (y + gy * z)
                fb = force_bits.get(b) if force_bits else None
                bits, packed, table = cs_encode_block(padded, dtype, fb)
                used_bits.add(bits)
                header[2 * b + 1] = at
                body.append(packed)
                at += len(packed)
                header[2 * b] = at | (bits << 24)
                body.append(table)
                at += len(table)
    words = np.concatenate([np.array([1], dtype=np.uint32), header] + body).astype('<u4')
    return words.tobytes(), used_bits


def write_scale(root, scale, volume, dtype, nested=False, force_bits=None):
    """Writes the chunks of one scale; returns {chunk file name: bytes written} and bit widths used."""
    key = scale["key"]
    sx, sy, sz = scale["size"]
    cx, cy, cz = scale["chunk_sizes"][0]
    ox, oy, oz = scale.get("voxel_offset", [0, 0, 0])
    os.makedirs(os.path.join(root, key), exist_ok=True)
    names = []
    used = set()
    for z0 in range(0, sz, cz):
        for y0 in range(0, sy, cy):
            for x0 in range(0, sx, cx):
                x1, y1, z1 = min(x0 + cx, sx), min(y0 + cy, sy), min(z0 + cz, sz)
                chunk = volume[z0:z1, y0:y1, x0:x1].astype(dtype)
                if scale["encoding"] == "raw":
                    data = chunk.astype(np.dtype(dtype).newbyteorder('<')).tobytes()
                else:
                    data, bits = cs_encode(chunk, scale["compressed_segmentation_block_size"], dtype, force_bits)
                    used |= bits
                r = ["%d-%d" % (o + a, o + b) for o, a, b in ((ox, x0, x1), (oy, y0, y1), (oz, z0, z1))]
                name = os.path.join(*r) if nested else "_".join(r)
                path = os.path.join(root, key, name)
                os.makedirs(os.path.dirname(path), exist_ok=True)
                with open(path, "wb") as f:
                    f.write(data)
                names.append(name)
    return names, used


def write_info(root, info):
    os.makedirs(root, exist_ok=True)
    with open(os.path.join(root, "info"), "w") as f:
        json.dump(info, f)


def write_expected(root, volume):
    volume.astype('<u8').tofile(os.path.join(root, "expected.u64"))


def info_of(data_type, scales, **extra):
    info = {"@type": "neuroglancer_multiscale_volume", "type": "segmentation", "data_type": data_type,
            "num_channels": 1, "scales": scales}
    info.update(extra)
    return info


def raw_u32(out):
    """Raw uint32, size not divisible by the chunk size, nonzero (partly negative) voxel_offset."""
    root = os.path.join(out, "raw_u32")
    scale = {"key": "4_6_40", "size": [37, 29, 21], "resolution": [4, 6, 40], "voxel_offset": [5, -3, 10],
             "chunk_sizes": [[16, 16, 8]], "encoding": "raw"}
    vol = labels(scale["size"], 1, 1)
    write_info(root, info_of("uint32", [scale]))
    write_scale(root, scale, vol, np.uint32)
    write_expected(root, vol)
    return root, scale


def cs_case(out, name, dtype, base, seed):
    """compressed_segmentation with blocks that do not divide the chunk, every bit width 0..16
    (one block forced to 32), one missing chunk (background) and one gzipped chunk."""
    root = os.path.join(out, name)
    scale = {"key": "8_8_8", "size": [45, 38, 27], "resolution": [8, 8, 8], "voxel_offset": [64, 0, 128],
             "chunk_sizes": [[20, 20, 12]], "encoding": "compressed_segmentation",
             "compressed_segmentation_block_size": [8, 6, 6]}
    # Per-block distinct counts: 1 -> 0 bits, 2 -> 1, 3 -> 2, 9 -> 4, 100 -> 8, 270 -> 16.
    vol = labels(scale["size"], seed, base, distinct_per_block=[1, 2, 3, 9, 100, 270],
                 block=scale["compressed_segmentation_block_size"], chunk=scale["chunk_sizes"][0])
    write_info(root, info_of("uint64" if dtype == np.uint64 else "uint32", [scale]))
    names, used = write_scale(root, scale, vol, dtype, force_bits={1: 32})
    assert used >= {0, 1, 2, 4, 8, 16, 32}, used
    # Chunk (1, 0, 0) is missing: background. Chunk (0, 1, 1) is gzipped.
    os.remove(os.path.join(root, "8_8_8", "84-104_0-20_128-140"))
    vol[0:12, 0:20, 20:40] = 0
    plain = os.path.join(root, "8_8_8", "64-84_20-38_140-152")
    with open(plain, "rb") as f, gzip.open(plain + ".gz", "wb") as g:
        g.write(f.read())
    os.remove(plain)
    write_expected(root, vol)
    return root


def two_scales(out):
    """Scale 0 raw (flat names), scale 1 compressed_segmentation in the nested layout."""
    root = os.path.join(out, "two_scales")
    s0 = {"key": "full", "size": [24, 20, 16], "resolution": [2, 2, 3], "voxel_offset": [0, 0, 0],
          "chunk_sizes": [[16, 16, 16]], "encoding": "raw"}
    s1 = {"key": "half", "size": [12, 10, 8], "resolution": [4, 4, 6], "voxel_offset": [1, 2, 3],
          "chunk_sizes": [[8, 8, 8]], "encoding": "compressed_segmentation",
          "compressed_segmentation_block_size": [4, 4, 4]}
    v0 = labels(s0["size"], 3, 5)
    v1 = labels(s1["size"], 4, 9)
    write_info(root, info_of("uint32", [s0, s1]))
    write_scale(root, s0, v0, np.uint32)
    write_scale(root, s1, v1, np.uint32, nested=True)
    write_expected(root, v0)
    v1.astype('<u8').tofile(os.path.join(root, "expected1.u64"))


def bad_cases(out):
    """Folders whose reading must fail with a clear message (one per kind of bad input)."""
    ok_scale = {"key": "s", "size": [8, 8, 8], "resolution": [1, 1, 1], "chunk_sizes": [[8, 8, 8]],
                "encoding": "raw"}

    def case(name, info, text=None):
        root = os.path.join(out, name)
        os.makedirs(os.path.join(root, "s"), exist_ok=True)
        with open(os.path.join(root, "info"), "w") as f:
            f.write(text if text is not None else json.dumps(info))
        return root

    case("bad_sharded", info_of("uint64", [dict(ok_scale, sharding={"@type": "neuroglancer_uint64_sharded_v1",
                                                                   "preshift_bits": 0, "hash": "identity",
                                                                   "minishard_bits": 0, "shard_bits": 0,
                                                                   "minishard_index_encoding": "gzip",
                                                                   "data_encoding": "gzip"})]))
    case("bad_jpeg", dict(info_of("uint8", [dict(ok_scale, encoding="jpeg")]), type="image"))
    case("bad_channels", dict(info_of("uint32", [ok_scale]), num_channels=2))
    case("bad_no_scales", {"type": "segmentation", "data_type": "uint32", "num_channels": 1})
    case("bad_no_size", info_of("uint32", [{k: v for k, v in ok_scale.items() if k != "size"}]))
    case("bad_not_json", None, text="{\"type\": \"segmentation\", data_type")
    case("bad_dtype", info_of("float32", [ok_scale]))

    # A raw chunk three bytes short.
    root = case("bad_truncated", info_of("uint32", [ok_scale]))
    with open(os.path.join(root, "s", "0-8_0-8_0-8"), "wb") as f:
        f.write(np.arange(8 * 8 * 8, dtype='<u4').tobytes()[:-3])

    # compressed_segmentation chunks whose offsets point outside the data.
    cs_scale = dict(ok_scale, encoding="compressed_segmentation", compressed_segmentation_block_size=[4, 4, 4])
    good, _ = cs_encode(labels([8, 8, 8], 7, 1, distinct_per_block=[3], block=[4, 4, 4],
                         chunk=[8, 8, 8]), [4, 4, 4], np.uint32)
    words = np.frombuffer(good, dtype='<u4').copy()

    def cs_bad(name, edit):
        w = words.copy()
        edit(w)
        root = case(name, info_of("uint32", [cs_scale]))
        with open(os.path.join(root, "s", "0-8_0-8_0-8"), "wb") as f:
            f.write(w.astype('<u4').tobytes())

    def bad_table(w):
        w[1 + 2 * 3] = (w[1 + 2 * 3] & 0xFF000000) | 0xFFFFFF

    def bad_values(w):
        w[1 + 2 * 5 + 1] = 0x7FFFFFFF

    def bad_channel(w):
        w[0] = len(w) + 4

    cs_bad("bad_cs_table", bad_table)
    cs_bad("bad_cs_values", bad_values)
    cs_bad("bad_cs_channel", bad_channel)

    # A gzipped raw chunk that inflates far beyond its 2048 bytes (a small "zip bomb").
    root = case("bad_gz_bomb", info_of("uint32", [ok_scale]))
    with gzip.open(os.path.join(root, "s", "0-8_0-8_0-8.gz"), "wb") as g:
        g.write(bytes(4 << 20))
    # A compressed_segmentation block larger than the chunk.
    case("bad_cs_block", info_of("uint32", [dict(cs_scale, compressed_segmentation_block_size=[16, 8, 8])]))
    # JSON nested 100000 deep (would overflow the stack of any recursive walk).
    case("bad_deep", None, text='{"type": "segmentation", "scales": ' + "[" * 100000 + "]" * 100000 + "}")
    # A chunk whose decoded size is 2^64 bytes (a product that would wrap to 0).
    huge = [65536, 32768, 1 << 30]
    case("bad_huge_chunk", info_of("uint64", [dict(ok_scale, size=huge, chunk_sizes=[huge])]))


def main():
    out = sys.argv[1]
    if os.path.exists(out):
        shutil.rmtree(out)
    os.makedirs(out)
    raw_u32(out)
    cs_case(out, "cs_u32", np.uint32, 3, 11)
    cs_case(out, "cs_u64", np.uint64, (1 << 40) + 17, 12)
    two_scales(out)
    bad_cases(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
