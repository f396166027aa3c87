#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the seeds of the `precomputed` fuzz target (Testing/Fuzz/FuzzPrecomputed.cpp states the
input layout) into OUTDIR: info documents (good and refused ones) and small compressed_segmentation
and raw chunks, the chunks encoded by make_precomputed.py's encoder. Each seed is under 4 KiB.

Usage: make_precomputed_seeds.py OUTDIR   (OUTDIR is normally Testing/Fuzz/corpus/precomputed)
"""
import json
import os
import sys

import numpy as np

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_precomputed as mp  # noqa: E402


def info_seed(info):
    return b"\x00" + json.dumps(info).encode()


def chunk_seed(mode, type_byte, extent, block, payload):
    head = bytes([mode, type_byte] + [e - 1 for e in extent] + [b - 1 for b in block])
    return head + payload


def cs_seed(dtype, extent, block, distinct, seed, force_bits=None):
    vol = mp.labels(extent, seed, (1 << 33) + 5 if dtype == np.uint64 else 3, distinct_per_block=distinct,
                    block=block, chunk=extent)
    data, _ = mp.cs_encode(vol.astype(dtype), block, dtype, force_bits)
    return chunk_seed(1, 1 if dtype == np.uint64 else 0, extent, block, data)


def raw_seed(type_byte, dtype, extent, seed):
    vol = mp.labels(extent, seed, 1).astype(dtype)
    return chunk_seed(2, type_byte, extent, [1, 1, 1], vol.astype(np.dtype(dtype).newbyteorder('<')).tobytes())


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    raw = {"key": "4_4_40", "size": [37, 29, 21], "resolution": [4, 4, 40], "voxel_offset": [5, -3, 10],
           "chunk_sizes": [[16, 16, 8]], "encoding": "raw"}
    cs = {"key": "8_8_8", "size": [45, 38, 27], "resolution": [8, 8, 8], "chunk_sizes": [[20, 20, 12], [64, 64, 64]],
          "encoding": "compressed_segmentation", "compressed_segmentation_block_size": [8, 6, 6]}
    seeds = {
        "info_raw_u32": info_seed(mp.info_of("uint32", [raw])),
        "info_cs_u64_two_scales": info_seed(mp.info_of("uint64", [cs, dict(raw, key="16_16_80")], mesh="mesh")),
        "info_image_u8": info_seed(dict(mp.info_of("uint8", [raw]), type="image")),
        "info_sharded": info_seed(mp.info_of("uint64", [dict(cs, sharding={"@type": "neuroglancer_uint64_sharded_v1",
                                                                          "shard_bits": 2})])),
        "info_jpeg": info_seed(mp.info_of("uint8", [dict(raw, encoding="jpeg")])),
        "info_two_channels": info_seed(dict(mp.info_of("uint32", [raw]), num_channels=2)),
        "cs_u32_8x8x8_b4": cs_seed(np.uint32, [8, 8, 8], [4, 4, 4], [1, 2, 3, 9], 1),
        "cs_u64_10x7x5_b4x3x2": cs_seed(np.uint64, [10, 7, 5], [4, 3, 2], [1, 2, 5, 17, 3], 2),
        "cs_u32_6x6x6_b8": cs_seed(np.uint32, [6, 6, 6], [8, 8, 8], [1], 3),
        "cs_u32_5x5x5_b5_32bits": cs_seed(np.uint32, [5, 5, 5], [5, 5, 5], [40], 4, force_bits={0: 32}),
        "cs_u64_16x4x2_b8x4x1_16bits": cs_seed(np.uint64, [16, 4, 2], [8, 4, 1], [20, 2], 5, force_bits={1: 16}),
        "raw_u16_8x8x4": raw_seed(1, np.uint16, [8, 8, 4], 6),
        "raw_u64_4x4x4": raw_seed(3, np.uint64, [4, 4, 4], 7),
        # Nesting one level past the limit: refused before parsing.
        "info_nested_65_deep": b'\x00{"type": "segmentation", "scales": ' + b"[" * 65 + b"]" * 65 + b"}",
    }
    for name, data in seeds.items():
        assert len(data) < 4096, (name, len(data))
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
