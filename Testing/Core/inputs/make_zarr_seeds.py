#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the fuzz seeds of Testing/Fuzz/FuzzZarr.cpp (its header comment gives the framing).

Usage: make_zarr_seeds.py OUTDIR   (the committed corpus is Testing/Fuzz/corpus/zarr)

Seeds are real: .zarray/.zattrs texts and chunks written by python3-zarr 2.13 and numcodecs,
each under 4 KiB.
"""
import json
import os
import sys
import tempfile

import numpy as np
import zarr
from numcodecs import GZip, Blosc, Zlib, Zstd

OUT = sys.argv[1]
COMPRESSORS = {'none': (0, None), 'blosc_lz4': (1, Blosc(cname='lz4', shuffle=Blosc.SHUFFLE)),
               'blosc_zstd_bit': (1, Blosc(cname='zstd', shuffle=Blosc.BITSHUFFLE)),
               'zlib': (2, Zlib()), 'gzip': (3, GZip()), 'zstd': (4, Zstd())}
DTYPES = ['|u1', '|i1', '<u2', '<i2', '<u4', '<i4', '<u8', '<i8', '<f4', '<f8']


def seed(name, data):
    assert len(data) < 4096, name
    with open(os.path.join(OUT, name), 'wb') as f:
        f.write(data)


def main():
    os.makedirs(OUT, exist_ok=True)
    work = tempfile.mkdtemp()
    d = (np.arange(4 * 4 * 4, dtype=np.uint32) // 5).reshape(4, 4, 4)
    for name, (code, comp) in COMPRESSORS.items():
        for dtype, order in (('<u4', 'C'), ('<u2', 'F')) if name in ('none', 'blosc_lz4') else (('<u4', 'C'),):
            path = os.path.join(work, name + dtype[1:] + order)
            z = zarr.open_array(path, mode='w', shape=(4, 4, 4), chunks=(4, 4, 4), dtype=dtype, order=order, compressor=comp)
            z[...] = d.astype(dtype)
            with open(os.path.join(path, '0.0.0'), 'rb') as f:
                chunk = f.read()
            with open(os.path.join(path, '.zarray'), 'rb') as f:
                meta = f.read()
            tag = '%s_%s%s' % (name, dtype[1:], order)
            # 2: fixed metadata header (compressor, dtype, order, chunk 4x4x4 as 3 = 1 + 3)
            seed('chunk_' + tag, bytes([2, code, DTYPES.index(dtype), 1 if order == 'F' else 0, 3, 3, 3]) + chunk)
            # 3: the .zarray text, NUL, the chunk
            seed('array_' + tag, bytes([3]) + meta + b'\0' + chunk)
    seed('zarray_blosc', bytes([0]) + open(os.path.join(work, 'blosc_lz4u4C', '.zarray'), 'rb').read())
    seed('zarray_slash_fill', bytes([0]) + json.dumps({
        'zarr_format': 2, 'shape': [1, 1, 6, 7, 8], 'chunks': [1, 1, 4, 4, 4], 'dtype': '>i8', 'order': 'C',
        'fill_value': -7, 'compressor': {'id': 'zstd', 'level': 1}, 'filters': None, 'dimension_separator': '/'}).encode())
    axes = [{'name': a, 'type': 'space'} for a in 'zyx']
    seed('zattrs_multiscales', bytes([1]) + json.dumps({'multiscales': [{
        'version': '0.4', 'axes': axes,
        'datasets': [{'path': '0', 'coordinateTransformations': [{'type': 'scale', 'scale': [2.0, 0.5, 0.25]},
                                                                 {'type': 'translation', 'translation': [1, 2, 3]}]},
                     {'path': '1', 'coordinateTransformations': [{'type': 'scale', 'scale': [4.0, 1.0, 0.5]}]}],
        'coordinateTransformations': [{'type': 'scale', 'scale': [1, 1, 2]}]}]}).encode())
    seed('zattrs_labels', bytes([1]) + json.dumps({'labels': ['cells', 'nuclei']}).encode())
    seed('zattrs_v03_axes', bytes([1]) + json.dumps({'multiscales': [{'version': '0.3', 'axes': ['t', 'c', 'z', 'y', 'x'],
                                                                      'datasets': [{'path': 's0'}]}]}).encode())
    # Nesting one level past the limit (refused before parsing) and containers where scalars belong
    # (described in messages, never dumped).
    seed('zarray_nested_65_deep', b'\x00{"zarr_format": 2, "shape": ' + b'[' * 65 + b']' * 65 +
         b', "chunks": [1, 1], "dtype": "|u1"}')
    seed('zattrs_nested_container_in_axes',
         b'\x01{"multiscales": [{"axes": [[["x"]], {"name": 1}], "datasets": [{"path": "0"}]}]}')


if __name__ == '__main__':
    main()
