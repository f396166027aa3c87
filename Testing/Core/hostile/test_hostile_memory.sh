#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Hostile inputs against memory and time (issue 37, item 3, with HDF5's share of items 4 and 8):
# small files that state volumes whose careless reading needs gigabytes or hours. Each case runs
# `csgv` under an address-space ceiling and a time ceiling (expect_bounded), or is interrupted
# and must end at once. Fixtures are written here by make_hostile_memory.py (about 10 MB).
# Before the fixes: gzip compress 2.1 GB (out of memory at 600 MiB), the gzip chunk bomb 1.06 GB,
# `info` of a 20000 x 20000 slice 3.1 GB, the external file read, the fill-only volume neither
# progressing nor cancellable for minutes.
set -u
CSGV=$(realpath "$1")
PY=${3:-/usr/bin/python3} # $2: the Volcanite fixtures (unused)
source "$(dirname "$0")/../../tool_test_lib.sh"
FX=$TMP/fx
"$PY" "$(dirname "$0")/make_hostile_memory.py" "$FX" || { echo "FAIL: fixtures"; exit 1; }

# gzip inputs read in bands of rows through one inflated slab at the file's width, not a
# brick-deep slab of uint32 labels (4000 x 4000 x 32 x 4 bytes = 2 GB): about 160 MB now.
for f in wide.vraw.gz wide.nii.gz wide_gz.nrrd; do
  expect_bounded 0 600 60 "" "compress $f (4000x4000 gzip) within 600 MiB" \
    "$CSGV" compress "$FX/$f" "$TMP/wide.csgv" --threads 2 --quiet
  expect 0 "verify $f" "$CSGV" verify "$TMP/wide.csgv" "$FX/$f"
done

# Slabs deeper than a slice: inflated once at the file's width, to a scratch file beside the
# output past 64 MiB (unlinked at once: nothing is left there).
mkdir -p "$TMP/deep"
expect_bounded 0 400 60 "" "compress deep.vraw.gz (2000x2000x33 gzip, slabs in a scratch file) within 400 MiB" \
  "$CSGV" compress "$FX/deep.vraw.gz" "$TMP/deep/deep.csgv" --threads 2 --quiet
expect 0 "verify deep.vraw.gz" "$CSGV" verify "$TMP/deep/deep.csgv" "$FX/deep.vraw.gz"
[ "$(ls "$TMP/deep" | grep -vc '^deep\.csgv')" -eq 0 ] || bad "scratch files left beside the output: $(ls "$TMP/deep")"

# A 64^3 chunk whose stored gzip stream inflates to 1 GiB: refused, naming the chunk and sizes.
expect_bounded 1 300 20 "bomb\.h5: cannot read z 0\.\.63: the chunk at \(x 0, y 0, z 0\) stores [0-9]+ bytes, more than the [0-9]+ a chunk of 262144 bytes can need" \
  "HDF5 gzip chunk bomb refused within 300 MiB" "$CSGV" compress "$FX/bomb.h5" "$TMP/bomb.csgv" --threads 2 --quiet
[ -e "$TMP/bomb.csgv" ] && bad "the refused bomb left an output"

# `info` samples a 20000 x 20000 slice by bands of rows (8 bytes a voxel of it whole: 3.2 GB).
expect_bounded 0 300 30 "" "info of a 20000x20000 gzip slice within 300 MiB" "$CSGV" info "$FX/slice20k.vraw.gz"
grep -qx "labels: 21" "$TMP/out" && grep -q "^labels_counted: estimate (1 slices, 4 bands of " "$TMP/out" \
  || bad "info of the 20000x20000 slice: $(cat "$TMP/out")"

# An input that reads whole slices only is sampled by whole slices (of at most 2^25 voxels).
expect_bounded 0 300 30 "" "info of a TIFF of 2048x1100 slices" "$CSGV" info "$FX/slices.tif"
grep -Eqx "labels: [0-9]+" "$TMP/out" && grep -qx "labels_counted: estimate (16 slices)" "$TMP/out" \
  || bad "info of the TIFF: $(cat "$TMP/out")"

# No chunk written: the volume is the fill value, served without reading; the tool says so.
expect_bounded 0 300 20 "" "info of a 65536^3 volume of fill values" "$CSGV" info "$FX/fill_only.h5"
grep -q "no chunk written (every voxel is the fill value)" "$TMP/out" && grep -qx "labels: 1" "$TMP/out" \
  || bad "info of the fill-only volume: $(cat "$TMP/out")"

# A volume of fill values compresses in time per brick, not per voxel: chunks never written are
# not read, their bricks are written constant (4096^3: 2^21 bricks in 1.3 to 2 s here, 515 s when
# every voxel was read), and it decodes to the fill value (level 5: one voxel a brick).
expect_bounded 0 300 10 "" "compress of a 4096^3 fill-only HDF5 within seconds and 300 MiB" \
  "$CSGV" compress "$FX/fill_4096.h5" "$TMP/fill4096.csgv" --threads 2 --quiet
expect 0 "decompress the 4096^3 fill-only volume at level 5" \
  "$CSGV" decompress "$TMP/fill4096.csgv" "$TMP/fill4096.nrrd" --level 5
"$PY" -c "import sys; d = open(sys.argv[1], 'rb').read(); b = d[d.index(b'\n\n') + 2:]
sys.exit(0 if len(b) == 4 * 128**3 and b == (7).to_bytes(4, 'little') * 128**3 else 1)" "$TMP/fill4096.nrrd" \
  || bad "the 4096^3 fill-only volume does not decode to 128^3 sevens at level 5"
rm -f "$TMP/fill4096.csgv" "$TMP/fill4096.nrrd"
# The same for a Zarr array whose 200-byte .zarray names 4096^3 voxels and no chunk file: missing
# chunks are fill_value, listed without reading (it took about 13 minutes).
mkdir -p "$TMP/fill4096.zarr"
printf '{"zarr_format": 2, "shape": [4096, 4096, 4096], "chunks": [64, 64, 64], "dtype": "<u4", "compressor": null, "fill_value": 7, "order": "C", "filters": null}' \
  > "$TMP/fill4096.zarr/.zarray"
expect_bounded 0 300 10 "" "compress of a 4096^3 Zarr array without chunk files within seconds and 300 MiB" \
  "$CSGV" compress "$TMP/fill4096.zarr" "$TMP/fill4096.csgv" --threads 2 --quiet
rm -rf "$TMP/fill4096.csgv" "$TMP/fill4096.zarr"
# And a Neuroglancer precomputed scale without chunk files (background): 8 s at 1024^3 before.
mkdir -p "$TMP/empty_pc/s0"
printf '{"@type": "neuroglancer_multiscale_volume", "type": "segmentation", "data_type": "uint32", "num_channels": 1, "scales": [{"key": "s0", "size": [4096, 4096, 4096], "resolution": [1, 1, 1], "voxel_offset": [0, 0, 0], "chunk_sizes": [[64, 64, 64]], "encoding": "raw"}]}' \
  > "$TMP/empty_pc/info"
expect_bounded 0 300 10 "" "compress of a 4096^3 precomputed scale without chunk files within seconds and 300 MiB" \
  "$CSGV" compress "$TMP/empty_pc" "$TMP/empty_pc.csgv" --threads 2 --quiet
rm -rf "$TMP/empty_pc.csgv" "$TMP/empty_pc"

# A brick index that cannot fit is refused at once, naming the file, the dimensions, the bytes
# and the limit: 65536^3 in bricks of 32 is 2^33 bricks, 64 GiB of index (the encoder's only
# per-brick memory for the whole volume, 8 bytes a brick); under a 800 MiB ceiling, 16384^3 (1 GiB)
# is refused too, with the brick size that fits.
expect_bounded 1 300 5 "fill_only\.h5: a 65536x65536x65536 volume in bricks of 32\^3 needs 68719476736 bytes of brick index in memory \(8 for each of its 8589934592 bricks\), more than the limit of 157286400 bytes \(half of the process's address-space limit of 300 MiB\)\$" \
  "compress of a 65536^3 fill-only HDF5 refused at once" \
  "$CSGV" compress "$FX/fill_only.h5" "$TMP/huge.csgv" --threads 2 --quiet
expect_bounded 1 800 5 "fill_16384\.h5: a 16384x16384x16384 volume in bricks of 32\^3 needs 1073741824 bytes .* more than the limit of 419430400 bytes \(half of the process's address-space limit of 800 MiB\); bricks of 64\^3 need 134217728 \(--brick-size 64\)" \
  "compress of a 16384^3 fill-only HDF5 under 800 MiB refused at once, naming a brick size that fits" \
  "$CSGV" compress "$FX/fill_16384.h5" "$TMP/huge.csgv" --threads 2 --quiet
ls "$TMP" | grep -q "^huge\.csgv" && bad "a refused compression left $(ls "$TMP" | grep '^huge\.csgv')"

# 16384^3 in bricks of 64 (2^24 bricks, tens of seconds) progresses and an interrupt ends it at once.
expect_cancel() {
  local mib=$1 what=$2; shift 2
  local before=$fails
  expect_interrupt "$what" prlimit --as=$((mib * 1024 * 1024)) -- "$@"
  [ "$fails" -eq "$before" ] || return
  grep -Eq "^csgv: error: (compression of '.*' cancelled|interrupted)" "$TMP/err" \
    || bad "$what: no cancel message: $(cat "$TMP/err")"
}
expect_cancel 800 "compress of a 16384^3 fill-only HDF5 is cancelled at once" \
  "$CSGV" compress "$FX/fill_16384.h5" "$TMP/fill.csgv" --threads 2 --brick-size 64
ls "$TMP" | grep -q "^fill\.csgv" && bad "the cancelled compression left $(ls "$TMP" | grep '^fill\.csgv')"

# External storage may name any file: outside the HDF5 file's folder it is refused (naming it)
# unless --allow-outside-paths; named relatively it is found beside the file from any folder.
expect_bounded 1 300 10 "external\.h5: dataset /labels keeps its data in the external file '[^']*/elsewhere/secret\.raw' .*outside the HDF5 file's folder.*--allow-outside-paths" \
  "HDF5 external storage outside the folder refused" "$CSGV" info "$FX/inside/external.h5"
expect_bounded 0 300 10 "" "HDF5 external storage outside the folder with --allow-outside-paths" \
  "$CSGV" info "$FX/inside/external.h5" --allow-outside-paths
grep -qx "labels: 5" "$TMP/out" || bad "external data read: $(cat "$TMP/out")"
expect_bounded 0 300 10 "" "HDF5 external storage beside the file, from another folder" \
  env -C / "$CSGV" info "$FX/inside/external_inside.h5"
grep -qx "labels: 5" "$TMP/out" || bad "external data beside the file: $(cat "$TMP/out")"

finish
