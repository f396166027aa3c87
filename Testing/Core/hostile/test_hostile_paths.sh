#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Hostile inputs (issue 37, items 6-8) for the NRRD, TIFF, Zarr and precomputed readers, through
# the `csgv` tool under memory and time ceilings (expect_bounded): files a dataset names outside
# its own folder (NRRD data files, precomputed scale keys, OME-Zarr dataset paths, chunks that are
# links out) are refused unless --allow-outside-paths; a dangling link or a FIFO among TIFF
# slices or as a Zarr chunk is named, never skipped, and no FIFO is opened (it would block); a
# gzip NRRD with
# gigabytes of surplus is refused after a small probe, not inflated to its end; a cut or corrupt
# precomputed gzip chunk and a looping TIFF page chain get messages that say so. Fixtures are
# written here, small (the largest is a 32 MiB gzip stream of zeros); compress runs one thread,
# so that the address-space ceiling does not depend on the machine's core count.
set -u
CSGV=$1
PYTHON=${3:-/usr/bin/python3} # the system one, which has numpy and tifffile ($2: fixtures, unused)
source "$(dirname "$0")/../../tool_test_lib.sh"
H=$TMP/h
mkdir -p "$H"

"$PYTHON" - "$H" <<'EOF'
import gzip, json, os, struct, sys, zlib
import numpy as np
import tifffile

h = sys.argv[1]
os.makedirs(h, exist_ok=True)

def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data)

# -- precomputed: a scale whose key climbs out of the dataset, one with an absolute key, and
# one raw scale with gzip chunks that are cut, empty or not gzip at all.
def precomputed(root, key, chunk_files=None):
    info = {"type": "segmentation", "data_type": "uint8", "num_channels": 1,
            "scales": [{"key": key, "size": [8, 8, 8], "resolution": [1, 1, 1], "voxel_offset": [0, 0, 0],
                        "chunk_sizes": [[8, 8, 8]], "encoding": "raw"}]}
    write(os.path.join(root, "info"), json.dumps(info).encode())
    for name, data in (chunk_files or {}).items():
        write(os.path.join(root, name), data)
write(os.path.join(h, "outside", "0-8_0-8_0-8"), bytes(range(8)) * 64)  # what the keys point at
precomputed(os.path.join(h, "pc_up"), "../outside")
precomputed(os.path.join(h, "pc_abs"), os.path.join(h, "outside"))
precomputed(os.path.join(h, "pc_cut"), "s", {"s/0-8_0-8_0-8.gz": gzip.compress(bytes(512))[:12]})
precomputed(os.path.join(h, "pc_empty"), "s", {"s/0-8_0-8_0-8.gz": b""})
precomputed(os.path.join(h, "pc_notgz"), "s", {"s/0-8_0-8_0-8.gz": b"this is not gzip data at all"})

# -- OME-Zarr: a multiscale group whose dataset path climbs out of the group.
def zarr_array(d, chunk_bytes=None):
    write(os.path.join(d, ".zarray"), json.dumps({
        "zarr_format": 2, "shape": [4, 4, 4], "chunks": [4, 4, 4], "dtype": "|u1", "compressor": None,
        "fill_value": 0, "order": "C", "filters": None}).encode())
    if chunk_bytes is not None:
        write(os.path.join(d, "0.0.0"), chunk_bytes)
zarr_array(os.path.join(h, "elsewhere", "0"), bytes(64))
g = os.path.join(h, "up.zarr")
write(os.path.join(g, ".zgroup"), b'{"zarr_format": 2}')
write(os.path.join(g, ".zattrs"), json.dumps({"multiscales": [{"version": "0.4", "axes": [
    {"name": "z", "type": "space"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}],
    "datasets": [{"path": "../elsewhere/0", "coordinateTransformations": [{"type": "scale", "scale": [1, 1, 1]}]}]}]}).encode())
zarr_array(os.path.join(h, "fifo.zarr"))  # its chunk 0.0.0 becomes a FIFO below
# Chunks that are symbolic links out of their dataset, of just the size a raw chunk has.
zarr_array(os.path.join(h, "link.zarr"))
os.symlink(os.path.join(h, "elsewhere", "0", "0.0.0"), os.path.join(h, "link.zarr", "0.0.0"))
precomputed(os.path.join(h, "pc_link"), "s")
os.makedirs(os.path.join(h, "pc_link", "s"))
os.symlink(os.path.join(h, "outside", "0-8_0-8_0-8"), os.path.join(h, "pc_link", "s", "0-8_0-8_0-8"))

# -- NRRD: detached headers naming data outside their folder, and a gzip NRRD whose stream goes
# on for 32 GiB of zeros after the 64 bytes its header claims (32 MiB on disk, no trailer).
write(os.path.join(h, "secret.raw"), bytes(64))
write(os.path.join(h, "n", "up.nhdr"), b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: ../secret.raw\n")
write(os.path.join(h, "n", "abs.nhdr"), ("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: %s\n" % os.path.join(h, "secret.raw")).encode())
write(os.path.join(h, "n", "link.nhdr"), b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: link.raw\n")
os.symlink(os.path.join(h, "secret.raw"), os.path.join(h, "n", "link.raw"))
c = zlib.compressobj(9, zlib.DEFLATED, 31)
head = c.compress(bytes(range(64))) + c.flush(zlib.Z_FULL_FLUSH)
mib = bytes(1 << 20)
seg = c.compress(mib) + c.flush(zlib.Z_FULL_FLUSH)
assert c.compress(mib) + c.flush(zlib.Z_FULL_FLUSH) == seg  # a full flush makes segments repeat
with open(os.path.join(h, "surplus.nrrd"), "wb") as f:
    f.write(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: gzip\n\n" + head)
    for _ in range(32):
        f.write(seg * 1024)

# -- TIFF: four single-page slices (the fourth is replaced by a dangling link or a FIFO below),
# and a five-page file whose last IFD names the fourth page's IFD as its next.
os.makedirs(os.path.join(h, "slices"), exist_ok=True)
for i in range(3):
    tifffile.imwrite(os.path.join(h, "slices", "s%d.tif" % i), np.full((4, 5), i + 1, np.uint8))
tifffile.imwrite(os.path.join(h, "loop.tif"), np.arange(5 * 4 * 5, dtype=np.uint8).reshape(5, 4, 5))
with tifffile.TiffFile(os.path.join(h, "loop.tif")) as t:
    assert not t.is_bigtiff and t.byteorder == "<"
    offsets = [p.offset for p in t.pages]
assert len(offsets) == 5
with open(os.path.join(h, "loop.tif"), "r+b") as f:
    f.seek(offsets[4])
    entries = struct.unpack("<H", f.read(2))[0]
    f.seek(offsets[4] + 2 + 12 * entries)
    f.write(struct.pack("<I", offsets[3]))
EOF
[ $? -eq 0 ] || { bad "fixtures could not be written"; finish; exit; }

# Item 8: paths that leave the dataset's folder.
expect_bounded 1 512 10 "pc_up/info: scale key '\.\./outside' lies outside the dataset's folder '.*pc_up' \(pass --allow-outside-paths" \
  "precomputed scale key ../outside is refused" "$CSGV" info "$H/pc_up"
expect_bounded 0 512 10 "" "precomputed scale key ../outside is read with --allow-outside-paths" \
  "$CSGV" compress "$H/pc_up" "$TMP/pc_up.csgv" --quiet --threads 1 --allow-outside-paths
expect_bounded 1 512 10 "scale key '/.*/outside' lies outside the dataset's folder" \
  "precomputed absolute scale key is refused" "$CSGV" info "$H/pc_abs"
expect_bounded 1 512 10 "up.zarr: multiscale dataset path '\.\./elsewhere/0' lies outside the group's folder" \
  "OME-Zarr dataset path ../elsewhere/0 is refused" "$CSGV" info "$H/up.zarr"
expect_bounded 0 512 10 "" "OME-Zarr dataset path ../elsewhere/0 is read with --allow-outside-paths" \
  "$CSGV" compress "$H/up.zarr" "$TMP/up.csgv" --quiet --threads 1 --allow-outside-paths
expect_bounded 1 512 10 "pc_link/s/0-8_0-8_0-8: chunk 's/0-8_0-8_0-8' lies outside the dataset's folder" \
  "precomputed chunk linking out of the dataset is refused" "$CSGV" compress "$H/pc_link" "$TMP/pc_link.csgv" --quiet --threads 1
expect_bounded 0 512 10 "" "precomputed chunk linking out is read with --allow-outside-paths" \
  "$CSGV" compress "$H/pc_link" "$TMP/pc_link.csgv" --quiet --threads 1 --allow-outside-paths
expect_bounded 1 512 10 "link.zarr/0.0.0: chunk '0.0.0' lies outside the dataset's folder" \
  "Zarr chunk linking out of the dataset is refused" "$CSGV" compress "$H/link.zarr" "$TMP/link.csgv" --quiet --threads 1
expect_bounded 1 512 10 "up.nhdr: data file '\.\./secret.raw' lies outside the header's folder '.*/n' \(pass --allow-outside-paths" \
  "NRRD data file ../secret.raw is refused" "$CSGV" info "$H/n/up.nhdr"
expect_bounded 0 512 10 "" "NRRD data file ../secret.raw is read with --allow-outside-paths" \
  "$CSGV" compress "$H/n/up.nhdr" "$TMP/up_nrrd.csgv" --quiet --threads 1 --allow-outside-paths
expect_bounded 1 512 10 "abs.nhdr: data file '/.*secret.raw' lies outside the header's folder" \
  "NRRD absolute data file outside the folder is refused" "$CSGV" info "$H/n/abs.nhdr"
expect_bounded 1 512 10 "link.nhdr: data file 'link.raw' lies outside the header's folder" \
  "NRRD data file through a symbolic link out of the folder is refused" "$CSGV" info "$H/n/link.nhdr"

# Item 7: silent acceptance. A slice that is no file is named; a FIFO is never opened.
ln -s "$H/slices/gone.tif" "$H/slices/s3.tif"
expect_bounded 1 512 10 "slice 's3.tif' is a dangling symbolic link" \
  "TIFF folder with a dangling link is refused, not 3 slices deep" "$CSGV" info "$H/slices"
rm "$H/slices/s3.tif"
mkfifo "$H/slices/s3.tif"
expect_bounded 1 512 5 "slice 's3.tif' is a FIFO" "TIFF folder with a FIFO is refused" "$CSGV" info "$H/slices"
expect_bounded 1 512 5 "s3.tif.*FIFO" "a FIFO named as a TIFF file is refused, not opened" "$CSGV" info "$H/slices/s3.tif"
rm "$H/slices/s3.tif"
expect_bounded 0 512 10 "" "TIFF folder of three slices still reads" "$CSGV" info "$H/slices"
mkfifo "$H/fifo.zarr/0.0.0"
expect_bounded 1 512 5 "fifo.zarr/0.0\.0: chunk is a FIFO" "a FIFO as a Zarr chunk is refused, not opened" \
  "$CSGV" compress "$H/fifo.zarr" "$TMP/fifo.csgv" --quiet --threads 1
expect_bounded 1 512 8 "surplus.nrrd: gzip data in '.*surplus.nrrd' inflate to more than the 64 bytes .* over 65536 bytes more follow" \
  "gzip NRRD with 32 GiB of surplus is refused without inflating it" "$CSGV" compress "$H/surplus.nrrd" "$TMP/surplus.csgv" --quiet --threads 1

# Item 6: messages that say what is wrong.
expect_bounded 1 512 10 "pc_cut/s/0-8_0-8_0-8.gz: gzip data are cut: the file's 12 bytes end inside the compressed stream" \
  "cut precomputed gzip chunk" "$CSGV" compress "$H/pc_cut" "$TMP/pc_cut.csgv" --quiet --threads 1
expect_bounded 1 512 10 "pc_empty/s/0-8_0-8_0-8.gz: gzip chunk file is empty" \
  "empty precomputed gzip chunk" "$CSGV" compress "$H/pc_empty" "$TMP/pc_empty.csgv" --quiet --threads 1
expect_bounded 1 512 10 "pc_notgz/s/0-8_0-8_0-8.gz: gzip data is corrupt \(incorrect header check\)" \
  "corrupt precomputed gzip chunk" "$CSGV" compress "$H/pc_notgz" "$TMP/pc_notgz.csgv" --quiet --threads 1
expect_bounded 1 512 10 "loop.tif: its page chain loops back to page 3 after 5 pages" \
  "looping TIFF page chain" "$CSGV" info "$H/loop.tif"

finish
