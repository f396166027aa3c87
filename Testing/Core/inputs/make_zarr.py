#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the Zarr v2 / OME-Zarr fixtures of test_input_zarr.cpp into OUTDIR.

Usage: make_zarr.py OUTDIR

Each good fixture NAME (a .zarr folder, or a path inside one) comes with NAME.expected: the
volume the reader must return, as little-endian 64-bit values (signed ones as two's complement),
z slowest, x fastest. Bad fixtures (bad_*.zarr) are written with zarr and then damaged.
Written with Debian's python3-zarr 2.13 and numcodecs; everything is small (<= 32^3).
"""
import json
import os
import sys

import numpy as np
import zarr
from numcodecs import GZip, Blosc, Delta, Zlib, Zstd

OUT = sys.argv[1]
RNG = np.random.default_rng(12)


def expect(name, values):
    """The reader's answer for NAME: the array without its size-1 axes, at full width."""
    v = np.asarray(values)
    while v.ndim > 3:
        v = v[0]
    v = v.astype(np.int64) if v.dtype.kind == 'i' else v.astype(np.uint64)
    with open(os.path.join(OUT, name + '.expected'), 'wb') as f:
        f.write(np.ascontiguousarray(v).astype('<u8' if v.dtype.kind == 'u' else '<i8').tobytes())


def labels(shape, dtype, low, high):
    """Blocky labels (runs, like a segmentation) plus some noise."""
    base = RNG.integers(low, high, size=shape, dtype=np.int64)
    base[..., 1::2] = base[..., ::2][..., : base[..., 1::2].shape[-1]]
    return base.astype(dtype)


def array(name, data, chunks, **kw):
    path = os.path.join(OUT, name)
    z = zarr.open_array(path, mode='w', shape=data.shape, chunks=chunks, dtype=data.dtype, **kw)
    z[...] = data
    return z


def write_json(path, obj):
    with open(path, 'w') as f:
        json.dump(obj, f, indent=2)


def good_arrays():
    d = labels((20, 17, 13), np.uint32, 0, 1 << 31)
    array('u32_blosc_lz4.zarr', d, (8, 8, 5), compressor=Blosc(cname='lz4', clevel=5, shuffle=Blosc.SHUFFLE))
    expect('u32_blosc_lz4.zarr', d)

    d = labels((9, 10, 11), np.uint8, 0, 256)
    array('u8_zlib.zarr', d, (4, 4, 4), compressor=Zlib(level=3))
    expect('u8_zlib.zarr', d)

    d = labels((10, 12, 7), np.uint16, 0, 65536)
    array('u16_gzip.zarr', d, (3, 5, 7), compressor=GZip(level=5))
    expect('u16_gzip.zarr', d)

    d = labels((7, 9, 11), np.int64, -(1 << 40), 1 << 40)
    d[0, 0, 0] = -1
    d[1, 2, 3] = np.iinfo(np.int64).min
    array('i64_zstd.zarr', d, (4, 4, 4), compressor=Zstd(level=3))
    expect('i64_zstd.zarr', d)

    d = labels((8, 6, 10), np.uint64, 1 << 32, 1 << 62)
    d[0, 0, 0] = np.uint64(0xFFFFFFFFFFFFFFFF)
    array('u64_blosc_zstd.zarr', d, (5, 6, 4), compressor=Blosc(cname='zstd', clevel=3, shuffle=Blosc.BITSHUFFLE))
    expect('u64_blosc_zstd.zarr', d)

    d = labels((6, 11, 9), np.uint32, 0, 100000)
    array('u32_forder.zarr', d, (4, 4, 4), order='F', compressor=None)
    expect('u32_forder.zarr', d)

    d = labels((9, 8, 7), np.uint16, 0, 60000)
    array('u16_slash.zarr', d, (4, 3, 5), dimension_separator='/', compressor=Blosc(cname='lz4', shuffle=Blosc.NOSHUFFLE))
    expect('u16_slash.zarr', d)

    d = labels((5, 7, 6), np.int32, -1000, 1000)
    array('i32_bigendian.zarr', d.astype('>i4'), (3, 3, 3), compressor=Zlib())
    expect('i32_bigendian.zarr', d)

    d = labels((6, 5, 4), np.float32, -500, 500)
    array('f32_integers.zarr', d, (3, 5, 4), compressor=None)
    expect('f32_integers.zarr', d.astype(np.int64))

    d = labels((4, 4, 8), np.float64, -(1 << 50), 1 << 50)
    array('f64_nanfill.zarr', d, (4, 4, 4), fill_value=float('nan'), compressor=Zstd())
    expect('f64_nanfill.zarr', d.astype(np.int64))


def missing_chunks():
    for fill in (0, 7):
        name = 'missing_fill%d.zarr' % fill
        d = labels((8, 8, 8), np.uint32, 100, 200)
        array(name, d, (4, 4, 4), fill_value=fill, compressor=Zlib())
        for key in ('0.0.0', '1.1.0', '1.1.1'):
            os.remove(os.path.join(OUT, name, key))
        d[0:4, 0:4, 0:4] = fill
        d[4:8, 4:8, 0:8] = fill
        expect(name, d)


def ome_image():
    """A 2-level multiscale image with per-level and global transforms, and a label group."""
    root = os.path.join(OUT, 'ome.zarr')
    g = zarr.open_group(root, mode='w')
    full = labels((16, 10, 12), np.uint16, 1, 40)
    half = full[::2, ::2, ::2].copy()
    g.create_dataset('0', data=full, chunks=(8, 5, 6), compressor=Blosc(cname='lz4'))
    g.create_dataset('1', data=half, chunks=(4, 5, 6), compressor=Zstd())
    axes = [{'name': a, 'type': 'space', 'unit': 'micrometer'} for a in 'zyx']
    g.attrs['multiscales'] = [{
        'version': '0.4', 'name': 'ome', 'axes': axes,
        'datasets': [
            {'path': '0', 'coordinateTransformations': [{'type': 'scale', 'scale': [2.0, 0.5, 0.25]},
                                                        {'type': 'translation', 'translation': [1.0, 2.0, 3.0]}]},
            {'path': '1', 'coordinateTransformations': [{'type': 'scale', 'scale': [4.0, 1.0, 0.5]},
                                                        {'type': 'translation', 'translation': [2.0, 2.25, 3.125]}]},
        ],
        'coordinateTransformations': [{'type': 'scale', 'scale': [1.0, 1.0, 2.0]}],
    }]
    expect('ome.zarr', full)
    expect('ome.zarr/1', half)

    lab = g.create_group('labels')
    lab.attrs['labels'] = ['cells', 'nuclei']
    for i, name in enumerate(('cells', 'nuclei')):
        img = lab.create_group(name)
        d = labels((16, 10, 12), np.uint32, 0, 5 + i * 1000)
        img.create_dataset('0', data=d, chunks=(16, 5, 12), compressor=GZip())
        img.attrs['multiscales'] = [{'version': '0.4', 'axes': axes,
                                     'datasets': [{'path': '0', 'coordinateTransformations': [{'type': 'scale', 'scale': [2.0, 0.5, 0.25]}]}]}]
        img.attrs['image-label'] = {'version': '0.4'}
        expect('ome.zarr/labels/' + name, d)


def tczyx():
    root = os.path.join(OUT, 'tczyx.zarr')
    g = zarr.open_group(root, mode='w')
    d = labels((1, 1, 6, 7, 8), np.uint32, 0, 1 << 20)
    g.create_dataset('0', data=d, chunks=(1, 1, 4, 4, 4), compressor=Zlib())
    axes = [{'name': 't', 'type': 'time'}, {'name': 'c', 'type': 'channel'}] + [{'name': a, 'type': 'space'} for a in 'zyx']
    g.attrs['multiscales'] = [{'version': '0.4', 'axes': axes, 'datasets': [
        {'path': '0', 'coordinateTransformations': [{'type': 'scale', 'scale': [1.0, 1.0, 3.0, 2.0, 1.5]}]}]}]
    expect('tczyx.zarr', d)

    root = os.path.join(OUT, 'bad_channels.zarr')
    g = zarr.open_group(root, mode='w')
    g.create_dataset('0', data=np.zeros((1, 2, 4, 4, 4), np.uint8), chunks=(1, 1, 4, 4, 4))
    g.attrs['multiscales'] = [{'version': '0.4', 'axes': axes, 'datasets': [{'path': '0'}]}]


def bad_arrays():
    zarr.open_group(os.path.join(OUT, 'bad_group.zarr'), mode='w')  # a plain group, no array

    d = labels((4, 4, 4), np.uint32, 0, 100)
    array('bad_filter.zarr', d, (4, 4, 4), filters=[Delta(dtype='<u4')], compressor=None)

    array('bad_dtype.zarr', d, (4, 4, 4), compressor=None)
    meta = os.path.join(OUT, 'bad_dtype.zarr', '.zarray')
    with open(meta) as f:
        m = json.load(f)
    m['dtype'] = '<c8'
    write_json(meta, m)

    array('bad_truncated.zarr', labels((8, 8, 8), np.uint32, 0, 1 << 30), (4, 4, 4), compressor=Zlib())
    chunk = os.path.join(OUT, 'bad_truncated.zarr', '1.0.1')
    with open(chunk, 'rb') as f:
        b = f.read()
    with open(chunk, 'wb') as f:
        f.write(b[: len(b) // 2])

    array('bad_nanfill_missing.zarr', labels((4, 4, 8), np.float64, 0, 9), (4, 4, 4), fill_value=float('nan'), compressor=None)
    os.remove(os.path.join(OUT, 'bad_nanfill_missing.zarr', '0.0.1'))

    f = labels((4, 4, 4), np.float32, 0, 9)
    f[3, 2, 1] = 2.5
    array('bad_fraction.zarr', f, (4, 4, 4), compressor=None)

    # Whole, valid streams of the wrong length (256 bytes expected).
    import zlib as pyzlib
    for name, comp, payload in (('bad_zlib_long.zarr', Zlib(), pyzlib.compress(bytes(300))),
                                ('bad_zlib_short.zarr', Zlib(), pyzlib.compress(bytes(200))),
                                ('bad_zstd_long.zarr', Zstd(), Zstd().encode(bytes(1000)))):
        array(name, d, (4, 4, 4), compressor=comp)
        with open(os.path.join(OUT, name, '0.0.0'), 'wb') as f:
            f.write(payload)

    array('bad_raw_short.zarr', d, (4, 4, 4), compressor=None)
    chunk = os.path.join(OUT, 'bad_raw_short.zarr', '0.0.0')
    with open(chunk, 'rb') as f:
        b = f.read()
    with open(chunk, 'wb') as f:
        f.write(b[:-3])

    array('bad_blosc.zarr', labels((8, 8, 8), np.uint32, 0, 1 << 30), (4, 4, 4), compressor=Blosc(cname='lz4'))
    chunk = os.path.join(OUT, 'bad_blosc.zarr', '0.1.0')
    with open(chunk, 'rb') as f:
        b = bytearray(f.read())
    b[4:8] = (12345).to_bytes(4, 'little')  # nbytes no longer what the metadata says
    with open(chunk, 'wb') as f:
        f.write(bytes(b))

    array('bad_blosc_data.zarr', labels((8, 8, 8), np.uint32, 0, 4), (4, 4, 4), compressor=Blosc(cname='lz4', shuffle=Blosc.NOSHUFFLE))
    chunk = os.path.join(OUT, 'bad_blosc_data.zarr', '0.0.0')
    with open(chunk, 'rb') as f:
        b = bytearray(f.read())
    b[16:] = b'\xff' * (len(b) - 16)  # block offsets and lz4 data destroyed
    with open(chunk, 'wb') as f:
        f.write(bytes(b))


def main():
    os.makedirs(OUT, exist_ok=True)
    good_arrays()
    missing_chunks()
    ome_image()
    tczyx()
    bad_arrays()


if __name__ == '__main__':
    main()
