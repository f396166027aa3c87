# SPDX-License-Identifier: MIT
"""Writes the TIFF input fixtures of test_input_tiff.cpp into OUTDIR (small files only).

Usage: make_tiff.py OUTDIR

Every good fixture NAME comes with NAME.u64: its voxels as little-endian uint64 (x fastest, then
y, then z; signed values sign-extended, floats holding integers as int64), which is what
InputSource::readSlab must deliver. Volumes are numpy arrays of shape (z, y, x); a multi-page
file stores page z as a y-by-x image.

Debian's tifffile has no imagecodecs, so the LZW and PackBits encoders it would take from there
are written here (TIFF 6.0 sections 9 and 13) and handed to tifffile's codec table.
"""
import os
import sys

import numpy as np
import tifffile


def lzw_encode(data, **_):
    """TIFF LZW: MSB-first codes of 9..12 bits, Clear 256, EOI 257, libtiff's early change."""
    data = data if isinstance(data, bytes) else np.ascontiguousarray(data).tobytes()
    out = bytearray()
    acc = 0
    nacc = 0

    def put(code, nbits):
        nonlocal acc, nacc
        acc = (acc << nbits) | code
        nacc += nbits
        while nacc >= 8:
            nacc -= 8
            out.append((acc >> nacc) & 0xFF)
        acc &= (1 << nacc) - 1

    def reset():
        return {bytes([i]): i for i in range(256)}, 258, 9

    table, free, nbits = reset()
    put(256, nbits)
    w = b''
    for b in data:
        wc = w + bytes([b])
        if wc in table:
            w = wc
            continue
        put(table[w], nbits)
        table[wc] = free
        free += 1
        w = bytes([b])
        if free == 4094:  # table full: clear with the current width
            put(256, nbits)
            table, free, nbits = reset()
        elif free > (1 << nbits) - 1:
            nbits += 1
    if w:
        put(table[w], nbits)
        # The decoder adds one more entry after this code: the width of EOI follows it.
        free += 1
        if free == 4094:
            put(256, nbits)
            nbits = 9
        elif free > (1 << nbits) - 1:
            nbits += 1
    put(257, nbits)
    if nacc:
        out.append((acc << (8 - nacc)) & 0xFF)
    return bytes(out)


def packbits_encode(data, axis=None, **_):
    """PackBits, each row on its own: runs of 3+ equal bytes replicated, the rest literal."""
    arr = np.ascontiguousarray(data)
    # tifffile hands a strip or tile as (..., rows, width, samples) with axis=-2: one row is the
    # last two axes.
    rows = arr.reshape(-1, arr.shape[-2] * arr.shape[-1]) if arr.ndim >= 2 else arr.reshape(1, -1)
    out = bytearray()
    for row in rows:
        b = row.tobytes()
        i = 0
        while i < len(b):
            run = 1
            while i + run < len(b) and run < 128 and b[i + run] == b[i]:
                run += 1
            if run >= 3:
                out += bytes([(257 - run) & 0xFF, b[i]])
                i += run
                continue
            j = i
            while j < len(b) and j - i < 128:
                if j + 2 < len(b) and b[j] == b[j + 1] == b[j + 2]:
                    break
                j += 1
            out.append(j - i - 1)
            out += b[i:j]
            i = j
    return bytes(out)


tifffile.TIFF.COMPRESSORS._codecs[5] = lzw_encode
tifffile.TIFF.COMPRESSORS._codecs[32773] = packbits_encode


def crafted_tiff(path, pages, tail=b''):
    """A little-endian classic TIFF written field by field, for headers no writer would make.

    Each page is a dict: w, h, data (one strip or tile of bytes), and optionally tile=(tw, th),
    comp (259), count (the byte count to claim instead of len(data)). Several pages may share
    one data block (shared=True on the later ones). `tail` is appended after everything.
    """
    import struct
    out = bytearray(b'II*\0\0\0\0\0')
    offsets = []
    for p in pages:
        if p.get('shared') and offsets:
            offsets.append(offsets[-1])
            continue
        offsets.append(len(out))
        out += p['data']
        out += b'\0' * (len(out) % 2)
    link = 4
    for p, offset in zip(pages, offsets):
        count = p.get('count', len(p['data']))
        tags = [(256, 4, p['w']), (257, 4, p['h']), (258, 3, 8), (259, 3, p.get('comp', 1)), (262, 3, 1),
                (277, 3, 1)]
        if 'tile' in p:
            tags += [(322, 4, p['tile'][0]), (323, 4, p['tile'][1]), (324, 4, offset), (325, 4, count)]
        else:
            tags += [(273, 4, offset), (278, 4, p['h']), (279, 4, count)]
        tags.sort()
        ifd = len(out)
        struct.pack_into('<I', out, link, ifd)
        out += struct.pack('<H', len(tags))
        for tag, kind, value in tags:
            out += struct.pack('<HHI', tag, kind, 1) + struct.pack('<H' if kind == 3 else '<I', value).ljust(4, b'\0')
        link = len(out)
        out += b'\0\0\0\0'
    out += tail
    with open(path, 'wb') as f:
        f.write(out)


def expected(path, vol):
    vol = np.asarray(vol)
    if vol.dtype.kind in 'if':
        vol.astype('<i8').tofile(path + '.u64')
    else:
        vol.astype('<u8').tofile(path + '.u64')


def write(out, name, vol, **kw):
    path = os.path.join(out, name)
    kw.setdefault('photometric', 'minisblack')
    tifffile.imwrite(path, vol, **kw)
    expected(path, vol)
    return path


def write_slices(folder, names, vols, **kw):
    os.makedirs(folder, exist_ok=True)
    for n, v in zip(names, vols):
        tifffile.imwrite(os.path.join(folder, n), v, photometric='minisblack', **kw)


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(12)

    # ---- good files
    u16 = rng.integers(0, 65536, size=(7, 13, 11), dtype=np.uint16)
    u16[0, 0, 0] = 0
    u16[6, 12, 10] = 65535
    write(out, 'u16_pages.tif', u16)
    write(out, 'u8.tif', rng.integers(0, 256, size=(5, 9, 10), dtype=np.uint8), rowsperstrip=2)
    i32 = rng.integers(-2**31, 2**31, size=(4, 10, 12), dtype=np.int32)
    i32[0, 0, :4] = [-2**31, -1, 0, 2**31 - 1]
    write(out, 'i32_neg.tif', i32)
    u32 = rng.integers(2**31, 2**32, size=(3, 8, 9), dtype=np.uint64).astype(np.uint32)
    u32[1, 2, :3] = [0xFFFFFFFF, 0xFFFFFFFE, 0]
    write(out, 'u32_large.tif', u32)
    i8 = rng.integers(-128, 128, size=(3, 4, 5), dtype=np.int8)
    write(out, 'i8.tif', i8)
    u64 = rng.integers(0, 2**63, size=(2, 5, 6), dtype=np.uint64)
    u64[0, 0, 0] = 2**64 - 1
    write(out, 'u64.tif', u64)
    i64 = rng.integers(-2**62, 2**62, size=(2, 5, 6), dtype=np.int64)
    i64[1, 4, 5] = -2**63
    write(out, 'i64.tif', i64)
    # int16 in runs (so PackBits has runs and literals to write), one strip of 3 rows each.
    i16 = np.repeat(rng.integers(-300, 300, size=(4, 9, 7), dtype=np.int16), 3, axis=2)
    write(out, 'i16_packbits.tif', i16, compression='packbits', rowsperstrip=3)
    # Tiles of 16x16 over 40x37 (partial tiles at the right and bottom), deflate.
    tiled = (rng.integers(0, 40, size=(6, 40, 37)) * 1000 + 7).astype(np.uint16)
    write(out, 'tiled_deflate.tif', tiled, tile=(16, 16), compression='zlib')
    # LZW strips of 5 rows over 23 rows: the last strip has 3. Repetitive content so the codes
    # grow past 9 bits.
    lzw = (np.arange(5 * 23 * 19, dtype=np.uint32).reshape(5, 23, 19) // 7 * 100003) % 4000000000
    lzw = lzw.astype(np.uint32)
    write(out, 'lzw_strips.tif', lzw, compression='lzw', rowsperstrip=5)
    lzw_big = np.tile(rng.integers(0, 5, size=(1, 64, 64), dtype=np.uint8), (3, 1, 1))
    write(out, 'lzw_long.tif', lzw_big, compression='lzw', rowsperstrip=64)
    write(out, 'big_endian.tif', u16[:3], byteorder='>')
    f32 = rng.integers(-5000, 5000, size=(3, 6, 7)).astype(np.float32)
    write(out, 'f32_int.tif', f32)
    write(out, 'single.tif', rng.integers(0, 1000, size=(9, 8), dtype=np.uint16)[np.newaxis])

    # Memory: a shallow wide volume (the encoder's band must hold its 3 slices, not a brick's
    # 32), and a file whose strips grow from page to page (its working memory is that of its
    # largest strip, known when it is opened).
    shallow = (rng.integers(0, 50, size=(3, 24, 32)) * 7 + 1).astype(np.uint16)
    write(out, 'shallow.tif', np.repeat(np.repeat(shallow, 16, axis=1), 16, axis=2), compression='zlib',
          rowsperstrip=16)
    with tifffile.TiffWriter(os.path.join(out, 'growing_strips.tif')) as w:
        grow = rng.integers(0, 256, size=(3, 32, 64), dtype=np.uint8)
        for page, rps in zip(grow, [4, 4, 32]):
            w.write(page, photometric='minisblack', rowsperstrip=rps, contiguous=False)
    expected(os.path.join(out, 'growing_strips.tif'), grow)

    slices = [np.full((10, 14), 0, np.uint16) + np.arange(14, dtype=np.uint16) + 100 * (i + 1) for i in range(12)]
    names = ['slice_%d.tif' % (i + 1) for i in range(12)]
    write_slices(os.path.join(out, 'slices'), names, slices)
    with open(os.path.join(out, 'slices', 'notes.txt'), 'w') as f:
        f.write('not a slice\n')
    expected(os.path.join(out, 'slices'), np.stack(slices))
    # A glob picks slice_*.tif out of a folder that also holds a TIFF of another size.
    write_slices(os.path.join(out, 'mixed'), names, slices, compression='zlib', rowsperstrip=3)
    write_slices(os.path.join(out, 'mixed'), ['other.tif'], [np.zeros((3, 3), np.uint8)])

    # ---- bad files
    with tifffile.TiffWriter(os.path.join(out, 'bad_page_size.tif')) as w:
        for shape in [(13, 11), (13, 11), (12, 11), (13, 11)]:
            w.write(np.zeros(shape, np.uint16), photometric='minisblack', contiguous=False)
    with tifffile.TiffWriter(os.path.join(out, 'bad_page_type.tif')) as w:
        for dtype in [np.uint16, np.int16]:
            w.write(np.zeros((4, 4), dtype), photometric='minisblack', contiguous=False)
    write_slices(os.path.join(out, 'bad_slice_size'), ['s1.tif', 's2.tif', 's3.tif'],
                 [np.zeros((5, 6), np.uint16), np.zeros((5, 7), np.uint16), np.zeros((5, 6), np.uint16)])
    write_slices(os.path.join(out, 'bad_slice_type'), ['s1.tif', 's2.tif'],
                 [np.zeros((5, 6), np.uint16), np.zeros((5, 6), np.uint8)])
    write_slices(os.path.join(out, 'multipage_slices'), ['a.tif', 'b.tif'],
                 [np.zeros((2, 5, 6), np.uint16), np.zeros((2, 5, 6), np.uint16)])
    tifffile.imwrite(os.path.join(out, 'rgb.tif'), rng.integers(0, 256, size=(8, 9, 3), dtype=np.uint8),
                     photometric='rgb')
    tifffile.imwrite(os.path.join(out, 'bilevel.tif'), rng.integers(0, 2, size=(8, 16)).astype(bool))
    frac = f32.copy()
    frac[1, 2, 3] = 2.5
    tifffile.imwrite(os.path.join(out, 'f32_fraction.tif'), frac, photometric='minisblack')
    with open(os.path.join(out, 'u16_pages.tif'), 'rb') as f:
        whole = f.read()
    with open(os.path.join(out, 'truncated.tif'), 'wb') as f:
        f.write(whole[:len(whole) * 6 // 10])
    # Directories intact, pixel data cut short: a strip and a tile beyond the end of the file.
    for name, vol, kw in [('truncated_strips.tif', u16[0], {}),
                          ('truncated_tiles.tif', tiled[0], {'tile': (16, 16), 'compression': 'zlib'})]:
        path = os.path.join(out, name)
        tifffile.imwrite(path, vol, photometric='minisblack', **kw)
        with open(path, 'rb') as f:
            whole = f.read()
        with open(path, 'wb') as f:
            f.write(whole[:-30])
    # Crafted headers: a 64 x 64 page in one tile of 2^30 x 2^30; a 4 x 4 page whose one strip
    # claims 70000 bytes (present in the file, far more than 16 pixels can need); 33 pages of
    # 4096 x 4096 zeros sharing one deflate strip (a 4096^2 x 32 band of uint32 labels is 2 GiB).
    import zlib
    crafted_tiff(os.path.join(out, 'huge_tile.tif'), [dict(w=64, h=64, tile=(2**30, 2**30), data=b'\0' * 16)])
    crafted_tiff(os.path.join(out, 'strip_claims.tif'), [dict(w=4, h=4, data=b'\1' * 16, count=70000)],
                 tail=b'\0' * 70000)
    zeros = zlib.compress(b'\0' * (4096 * 4096), 9)
    crafted_tiff(os.path.join(out, 'deep_wide.tif'),
                 [dict(w=4096, h=4096, comp=8, data=zeros, shared=z > 0) for z in range(33)])

    os.makedirs(os.path.join(out, 'empty'), exist_ok=True)
    with open(os.path.join(out, 'text.tif'), 'w') as f:
        f.write('this is a text file, not a TIFF\n')
    open(os.path.join(out, 'zero.tif'), 'wb').close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
