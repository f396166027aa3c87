#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""Writes the seeds of the file-reading fuzz targets into Testing/Fuzz/corpus/NAME (the framing
of each target is in the header comment of its FuzzNAME.cpp): small valid TIFF files and slice
folders (tiff), HDF5 files (hdf5), `.csgv.json` sidecars (metadata), `_csgv.db3` and other SQLite
attribute databases (attributedb), material documents (materials) and attribute tables (csv).

Usage: make_seeds.py [CORPUS_DIR]   (default: the corpus folder beside this script)

Every seed is a few KiB at most. Needs numpy, h5py and tifffile (Debian's python3-* packages).
"""
import io
import json
import os
import sqlite3
import sys
import tempfile

import h5py
import numpy as np
import tifffile

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, 'corpus')
sys.path.insert(0, os.path.join(HERE, '..', 'Core', 'inputs'))
import make_tiff  # noqa: E402  (registers its LZW and PackBits encoders with tifffile)

rng = np.random.default_rng(37)


def seed(target, name, data, limit=8192):
    assert len(data) <= limit, (target, name, len(data))
    folder = os.path.join(CORPUS, target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), 'wb') as f:
        f.write(data)


def blocky(shape, dtype, lo=0, hi=6):
    return rng.integers(lo, hi, size=shape).astype(dtype)


# ---- tiff: mode byte (bits 0-1 form, bits 2-3 working budget, bit 4 a folder's slices as an
# explicit list), then the file(s) -----------------------------------------------------------------
def tiff_bytes(vol, **kw):
    kw.setdefault('photometric', 'minisblack')
    b = io.BytesIO()
    tifffile.imwrite(b, vol, **kw)
    return b.getvalue()


def tiffs():
    single = {
        'u8_pages': tiff_bytes(blocky((3, 5, 6), np.uint8)),
        'u16_strips2': tiff_bytes(blocky((2, 7, 5), np.uint16, 0, 60000), rowsperstrip=2),
        'i32_neg': tiff_bytes(blocky((2, 4, 4), np.int32, -5, 5)),
        'u64_big': tiff_bytes(np.array([[[0, 2**64 - 1], [7, 2**40]]], dtype=np.uint64)),
        'i8': tiff_bytes(blocky((1, 3, 9), np.int8, -128, 127)),
        'f32_ints': tiff_bytes(blocky((2, 3, 3), np.float32, -4, 4)),
        'f64_frac': tiff_bytes(np.array([[[0.5, 1.0]]], dtype=np.float64)),
        'tiled_u16': tiff_bytes(blocky((2, 20, 18), np.uint16), tile=(16, 16)),
        'deflate_u32': tiff_bytes(blocky((2, 6, 6), np.uint32), compression='zlib'),
        'lzw_u8': tiff_bytes(blocky((2, 8, 8), np.uint8), compression=5),
        'packbits_u8': tiff_bytes(blocky((2, 8, 8), np.uint8), compression=32773),
        'rgb': tiff_bytes(blocky((4, 4, 3), np.uint8), photometric='rgb'),
        'bigtiff_u16': tiff_bytes(blocky((2, 4, 5), np.uint16), bigtiff=True),
        'bigendian_u16': tiff_bytes(blocky((2, 4, 5), np.uint16), byteorder='>'),
    }
    for i, (name, data) in enumerate(sorted(single.items())):
        seed('tiff', name + '.bin', bytes([(i % 2) | ((i % 4) << 2)]) + data)
    # Slice folders: pieces separated by "SLICE".
    a, b, c = (tiff_bytes(blocky((5, 6), np.uint16)) for _ in range(3))
    seed('tiff', 'folder3_u16.bin', bytes([2 | (1 << 2)]) + a + b'SLICE' + b + b'SLICE' + c)
    seed('tiff', 'glob2_u16.bin', bytes([3 | (2 << 2)]) + a + b'SLICE' + b)
    odd = tiff_bytes(blocky((5, 7), np.uint16))
    seed('tiff', 'folder_mismatch.bin', bytes([2 | (2 << 2)]) + a + b'SLICE' + odd)
    two = tiff_bytes(blocky((2, 5, 6), np.uint16))
    seed('tiff', 'folder_multipage.bin', bytes([2 | (2 << 2)]) + a + b'SLICE' + two)
    # The same as explicit lists of slice files (openTiffSlices).
    seed('tiff', 'list3_u16.bin', bytes([2 | (1 << 2) | 16]) + a + b'SLICE' + b + b'SLICE' + c)
    seed('tiff', 'list_mismatch.bin', bytes([2 | (2 << 2) | 16]) + a + b'SLICE' + odd)
    seed('tiff', 'list_multipage.bin', bytes([2 | (2 << 2) | 16]) + a + b'SLICE' + two)


# ---- hdf5: mode byte (bits 0-1 dataset path, bits 2-3 budget), then the file -------------------
def h5_bytes(build, libver='latest'):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, 'x.h5')
        with h5py.File(path, 'w', libver=libver) as f:
            build(f)
        with open(path, 'rb') as f:
            return f.read()


def hdf5s():
    def plain(f):
        f.create_dataset('data', data=blocky((3, 4, 5), np.uint16))

    def chunked_gzip(f):
        d = f.create_dataset('data', data=blocky((6, 6, 6), np.uint32), chunks=(2, 3, 3), compression='gzip',
                             shuffle=True)
        d.attrs['element_size_um'] = np.array([2.0, 1.0, 0.5])
        d.attrs['offset'] = np.array([1.0, 2.0, 3.0])

    def grouped(f):
        f.create_dataset('g/labels', data=blocky((2, 3, 4), np.int64, -3, 3), chunks=(1, 3, 2))
        f.create_dataset('g/raw', data=np.zeros((2, 3, 4), np.float32))

    def five_d(f):
        f.create_dataset('data', data=blocky((1, 2, 3, 4, 1), np.uint8))

    def floats(f):
        d = f.create_dataset('data', data=blocky((2, 2, 3), np.float64, -2, 2))
        d.attrs['resolution'] = np.array([4, 4, 40], dtype=np.int32)

    def several(f):
        f.create_dataset('data', data=blocky((2, 2, 2), np.int8))
        f.create_dataset('g/labels', data=blocky((2, 2, 2), np.uint64))

    def big_endian(f):
        f.create_dataset('data', data=blocky((2, 3, 3), '>i2'), chunks=(1, 3, 3), fletcher32=True)

    def compact(f):
        space = h5py.h5s.create_simple((2, 2, 2))
        plist = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
        plist.set_layout(h5py.h5d.COMPACT)
        dset = h5py.h5d.create(f.id, b'data', h5py.h5t.STD_U8LE, space, plist)
        dset.write(h5py.h5s.ALL, h5py.h5s.ALL, np.arange(8, dtype=np.uint8).reshape(2, 2, 2))

    builds = [('plain_u16', plain, 0), ('chunked_gzip_geometry', chunked_gzip, 1), ('grouped_i64', grouped, 2),
              ('five_d_u8', five_d, 0), ('floats_resolution', floats, 1), ('several', several, 0),
              ('bigendian_fletcher', big_endian, 1), ('compact_u8', compact, 1)]
    for i, (name, build, path) in enumerate(builds):
        seed('hdf5', name + '.bin', bytes([path | ((i % 4) << 2)]) + h5_bytes(build))
    seed('hdf5', 'earliest_plain.bin', bytes([1 | (1 << 2)]) + h5_bytes(plain, libver='earliest'), limit=12288)
    seed('hdf5', 'root_group.bin', bytes([3]) + h5_bytes(grouped))
    # Chunks never written are the fill value (InputSource::uniformBoxes): none written, and some.
    seed('hdf5', 'fill_only.bin', bytes([0 | (1 << 2)]) + h5_bytes(fill_only))
    seed('hdf5', 'partly_written.bin', bytes([0 | (2 << 2)]) + h5_bytes(partly_written))


def fill_only(f):
    f.create_dataset('data', shape=(6, 8, 10), chunks=(2, 4, 4), dtype=np.uint32, fillvalue=7)


def partly_written(f):
    d = f.create_dataset('data', shape=(6, 8, 10), chunks=(2, 4, 4), dtype=np.int16, fillvalue=-3,
                         compression='gzip')
    d[0:2, 0:4, 4:8] = blocky((2, 4, 4), np.int16, 0, 9)


# ---- metadata: the .csgv.json text ----------------------------------------------------------------
def metadatas():
    full = {'format': 'csgv-metadata', 'version': 1, 'dimensions': [181, 217, 181], 'spacing': [1, 1, 1],
            'origin': [-90.5, -126.5, -72.5], 'direction': [1, 0, 0, 0, 1, 0, 0, 0, 1],
            'original_type': 'int16', 'relabelled': False, 'source': 'aal.nii.gz'}
    seed('metadata', 'full.json', json.dumps(full, indent=2).encode())
    seed('metadata', 'rotated.json', json.dumps({'dimensions': [4, 5, 6], 'spacing': [0.5, 2, 1e-3],
                                                 'direction': [0, -1, 0, 1, 0, 0, 0, 0, 1],
                                                 'relabelled': True, 'original_type': 'uint64'}).encode())
    seed('metadata', 'minimal.json', b'{}')
    seed('metadata', 'unknown_keys.json', b'{"version": 1, "future": {"a": [1, 2, {"b": null}]}, "source": 7}')
    seed('metadata', 'bad_spacing.json', b'{"spacing": [1, 0, 1]}')
    seed('metadata', 'fractional_dims.json', b'{"dimensions": [1.5, 2, 3e9]}')
    seed('metadata', 'not_object.json', b'[1, 2, 3]')
    seed('metadata', 'unicode.json', '{"source": "\u00e9t\u00e9 \\ud83d\\ude00.nii", "original_type": "int8"}'.encode())


# ---- attributedb: SQLite files ----------------------------------------------------------------------
def sqlite_bytes(statements):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, 'x.db3')
        con = sqlite3.connect(path)
        con.execute('PRAGMA page_size=512')
        con.execute('PRAGMA journal_mode=OFF')
        for s in statements:
            con.execute(s)
        con.commit()
        con.execute('VACUUM')
        con.close()
        with open(path, 'rb') as f:
            return f.read()


def attributedbs():
    info = ('CREATE TABLE csgv_info (volume_width INTEGER, volume_height INTEGER, volume_depth INTEGER, '
            'chunk_width INTEGER, chunk_height INTEGER, chunk_depth INTEGER, label_column TEXT)')
    volcanite = [info, "INSERT INTO csgv_info VALUES (8, 8, 8, 8, 8, 8, 'label')",
                 'CREATE TABLE csgv_attribute (csgv_id UNSIGNED INT PRIMARY KEY, "label" UNSIGNED INT UNIQUE, '
                 'volume REAL, name TEXT)',
                 "INSERT INTO csgv_attribute VALUES (0, 0, NULL, 'background'), (1, 17, 2.5, 'a'), "
                 "(2, -4, 1e300, 'b''q'), (3, 9007199254740993, 3, NULL)"]
    seed('attributedb', 'volcanite.db3', sqlite_bytes(volcanite))
    seed('attributedb', 'uint64_labels.db3', sqlite_bytes(volcanite + [
        'CREATE TABLE csgv_label_type (original_type TEXT)', "INSERT INTO csgv_label_type VALUES ('uint64')"]))
    seed('attributedb', 'id_column.db3', sqlite_bytes([
        info, "INSERT INTO csgv_info VALUES (1, 2, 3, 1, 2, 3, 'id')",
        'CREATE TABLE csgv_attribute (csgv_id INTEGER, id INTEGER, "Label" TEXT)',
        "INSERT INTO csgv_attribute VALUES (0, 5, 'x'), (1, 6, 'y')"]))
    seed('attributedb', 'gap_in_ids.db3', sqlite_bytes([
        info, "INSERT INTO csgv_info VALUES (2, 2, 2, 2, 2, 2, 'label')",
        'CREATE TABLE csgv_attribute (csgv_id INTEGER, label INTEGER)',
        'INSERT INTO csgv_attribute VALUES (0, 1), (2, 3)']))
    seed('attributedb', 'plain_table.db3', sqlite_bytes([
        'CREATE TABLE regions (id INTEGER, name TEXT, code REAL)',
        "INSERT INTO regions VALUES (1, 'Precentral_L', 2001), (2, 'Precentral_R', 2002), (3.0, NULL, 'NA')"]))
    seed('attributedb', 'two_tables.db3', sqlite_bytes([
        'CREATE TABLE a (label INTEGER)', 'CREATE TABLE b (label INTEGER)', 'INSERT INTO a VALUES (1)']))
    seed('attributedb', 'view.db3', sqlite_bytes([
        'CREATE TABLE t (label INTEGER, v REAL)', 'INSERT INTO t VALUES (1, 0.5), (2, 1.5)',
        'CREATE VIEW labels AS SELECT label, v * 2 AS w FROM t']))


# ---- materials: the JSON document ----------------------------------------------------------------
def materials():
    docs = {
        'default.json': {'version': 1, 'materials': [{'name': 'all'}]},
        'full.json': {'version': 1, 'materials': [
            {'name': 'small', 'filter': {'attribute': 'volume', 'min': 0, 'max': 40},
             'color': {'mode': 'colormap', 'attribute': 'volume', 'min': 0, 'max': 40, 'wrap': 'repeat',
                       'colormap': [[0, 0, 0, 1], [0.5, 1, 0, 0], [1, 1, 1, 0]]}, 'opacity': 0.35, 'emission': 2},
            {'name': 'left', 'filter': {'attribute': 'side', 'min': 0, 'max': 0},
             'color': {'mode': 'constant', 'rgb': [0.2, 0.4, 0.6]}},
            {'name': 'rest', 'color': {'mode': 'random', 'colormap': 'Turbo'}}]},
        'overlay.json': {'materials': [{'filter': {'min': 1, 'max': 100}}], 'hidden': [3, 4, 4, 50],
                         'only': [2, 3, 5, 6, 7, 99, 4294967294]},
        'named_colormaps.json': {'materials': [
            {'color': {'mode': 'colormap', 'colormap': 'Viridis (matplotlib)', 'min': 1, 'max': 1}},
            {'color': {'mode': 'colormap', 'colormap': 'Nope'}}]},
        'half_edit.json': {'materials': [{'name': 'x', 'filter': {'min': 9, 'max': 2}}]},
        'hidden_other_attribute.json': {'materials': [{'filter': {'attribute': 'volume', 'min': 0, 'max': 1e9}}],
                                        'hidden': [0, 1, 2]},
    }
    for name, doc in docs.items():
        seed('materials', name, json.dumps(doc, indent=1).encode())
    seed('materials', 'blank.json', b'  \n')
    seed('materials', 'unknown_key.json', b'{"materials": [{"colour": {}}]}')
    seed('materials', 'bad_version.json', b'{"version": 2.0}')


# ---- csv: mode byte (bits 0-2 delimiter, 3-4 header, 5 label column `id`, 6 names), then text ----
def csvs():
    texts = [
        (0, 'label,name,volume\n0,background,\n1,"left, ""upper""",12.5\n2,right,NA\n'),
        (0, '\ufeff# MRIcron\n1 Precentral_L 2001\n2 Precentral_R 2002\n\n3 Frontal_Sup_L 2101\r\n'),
        (3, 'id\tname\tvolume\n5\ta\t1e3\n6\tb\t-0\n'),
        (2 | (1 << 3), 'Label;Area\n3.0;1,5\n18446744073709551615;2\n'),
        (4 | (2 << 3), '10 x 1\n11 y 2\n'),
        (1 | 32, 'id,label\n1,2\n'),
        (1 | 64 | (2 << 3), '1,a,2\n2,b,3\n'),
        (0, '"multi\nline",v\n1,2\n'),
        (0, 'label,x\n1,2\n1,3\n'),
        (0, 'label,x\n1,"open\n'),
        (5, 'a|b\n1|2\n'),
    ]
    for i, (mode, text) in enumerate(texts):
        seed('csv', 'table%02d.bin' % i, bytes([mode]) + text.encode())


tiffs()
hdf5s()
metadatas()
attributedbs()
materials()
csvs()
