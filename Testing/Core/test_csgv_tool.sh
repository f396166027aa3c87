#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The `csgv` tool's fixed interface: info keys, decompress/verify results, exit codes, and that
# no bad input ends it with a signal (exit status > 128).
set -u
CSGV=$1
FIX=$2
source "$(dirname "$0")/../tool_test_lib.sh"

DEF=$FIX/synthA_b32_rans2.csgv
expect 0 "info" "$CSGV" info "$DEF"
for key in dimensions brick_size encoding operation_mask bricks max_palette bytes bits_per_voxel; do
  grep -q "^$key: " "$TMP/out" || bad "info lacks key $key"
done
grep -qx "dimensions: 133 70 194" "$TMP/out" || bad "info dimensions: $(grep dimensions "$TMP/out")"
grep -qx "bytes: 101514" "$TMP/out" || bad "info bytes: $(grep '^bytes' "$TMP/out")"
grep -qx "bricks: 105" "$TMP/out" || bad "info bricks"
grep -qx "encoding: rans2" "$TMP/out" || bad "info encoding"
grep -qx "operation_mask: 0x12f" "$TMP/out" || bad "info operation_mask"
grep -qx "bits_per_voxel: 0.4496" "$TMP/out" || bad "info bits_per_voxel: $(grep bits_per "$TMP/out")"
expect 0 "info --stats --check" "$CSGV" info --stats --check "$FIX/synthA_b32_rans2_attr.csgv"
grep -qx "distinct_labels: 222" "$TMP/out" || bad "stats distinct labels: $(grep distinct "$TMP/out")"
grep -qx "attribute_labels: 222" "$TMP/out" || bad "attribute labels"

# decompress reproduces the published hash; verify accepts every fixture against its source.
expect 0 "decompress vraw" "$CSGV" decompress "$DEF" "$TMP/a.vraw"
[ "$(sha256sum < "$TMP/a.vraw" | cut -d' ' -f1)" = 9c00e33edcd55ae78519ddbd02e71a65e84f531f26f81fef4f9ae3d587c08617 ] \
  || bad "decompressed synthA hash"
expect 0 "decompress attr vraw" "$CSGV" decompress "$FIX/synthA_b32_rans2_attr.csgv" "$TMP/attr.vraw" --threads 1
cmp -s "$TMP/a.vraw" "$TMP/attr.vraw" || bad "_attr file does not decode to original labels"
expect 0 "decompress nrrd level 2" "$CSGV" decompress "$DEF" "$TMP/a.nrrd" --level 2
head -c 200 "$TMP/a.nrrd" | grep -q "sizes: 34 18 49" || bad "nrrd level 2 sizes"
for f in "$FIX"/*.csgv; do
  b=$(basename "$f"); src=$FIX/${b%%_*}.vraw.gz
  expect 0 "verify $b" "$CSGV" verify "$f" "$src"
done
expect 1 "verify against the wrong source" "$CSGV" verify "$DEF" "$FIX/denseB.vraw.gz"
"$CSGV" decompress "$DEF" "$TMP/b.vraw" >/dev/null
printf '\x07' | dd of="$TMP/b.vraw" bs=1 seek=5000 conv=notrunc status=none
expect 1 "verify against a changed voxel" "$CSGV" verify "$DEF" "$TMP/b.vraw"
grep -q "level 0, voxel" "$TMP/err" || bad "verify mismatch message: $(cat "$TMP/err")"

# compress: Volcanite's default settings on its own source give a file no larger than its own,
# that verify accepts; every option reaches the file header.
expect 0 "compress synthA" "$CSGV" compress "$FIX/synthA.vraw.gz" "$TMP/s.csgv"
grep -qx "relabelled: no" "$TMP/out" || bad "compress relabelled line"
ours=$(stat -c %s "$TMP/s.csgv")
[ "$ours" -le 101514 ] || bad "our synthA file is $ours bytes, Volcanite's is 101514"
expect 0 "verify our synthA" "$CSGV" verify "$TMP/s.csgv" "$FIX/synthA.vraw.gz"
[ -f "$TMP/s.csgv.json" ] || bad "compress wrote no metadata"
expect 0 "compress with options" "$CSGV" compress "$FIX/denseB.vraw.gz" "$TMP/d.csgv" --brick-size 16 --encoding nibble --ops pnlds --threads 1
expect 0 "info of options" "$CSGV" info "$TMP/d.csgv"
grep -qx "brick_size: 16" "$TMP/out" && grep -qx "encoding: nibble" "$TMP/out" && grep -qx "operations: pnlds" "$TMP/out" \
  || bad "compress options not in the header: $(cat "$TMP/out")"
expect 0 "verify options" "$CSGV" verify "$TMP/d.csgv" "$FIX/denseB.vraw.gz"
expect 0 "compress relabel" "$CSGV" compress "$FIX/synthA.vraw.gz" "$TMP/r.csgv" --relabel
[ -f "$TMP/r_csgv.db3" ] || bad "relabelled compress wrote no database"
expect 0 "verify relabelled" "$CSGV" verify "$TMP/r.csgv" "$FIX/synthA.vraw.gz"
expect 0 "compress synth" "$CSGV" compress synth:40x30x20:3 "$TMP/p.csgv" --encoding rans1
grep -qx "passes: 1" "$TMP/out" || bad "synth compress passes: $(grep passes "$TMP/out")"
grep -q "^streamed:" "$TMP/out" && bad "compress still prints the constant streamed line"
expect 0 "bench" "$CSGV" bench synth:48x40x32 --threads 2
for key in csgv_bits_per_voxel csgv_encode_mvoxels_per_second csgv_decode_mvoxels_per_second zstd19_bits_per_voxel gzip9_bits_per_voxel; do
  grep -q "^$key: " "$TMP/out" || bad "bench lacks $key"
done
expect 1 "compress bad brick size" "$CSGV" compress synth:8x8x8 "$TMP/x.csgv" --brick-size 12
expect 1 "compress bad encoding" "$CSGV" compress synth:8x8x8 "$TMP/x.csgv" --encoding zip
expect 1 "compress bad ops" "$CSGV" compress synth:8x8x8 "$TMP/x.csgv" --ops pq
expect 1 "compress bad synth" "$CSGV" compress synth:8x8 "$TMP/x.csgv"
expect 1 "compress missing input" "$CSGV" compress "$TMP/none.nii.gz" "$TMP/x.csgv"
expect 1 "compress unknown input" "$CSGV" compress "$TMP/s.csgv.json" "$TMP/x.csgv"
expect 1 "compress to non-csgv" "$CSGV" compress synth:8x8x8 "$TMP/x.vraw"
[ -e "$TMP/x.csgv" ] && bad "a failed compress left a file"

# Geometry survives compress and decompress: a NRRD's spacing and origin come back unchanged.
printf 'NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 3 2\nencoding: raw\nspace dimension: 3\nspace directions: (0.5,0,0) (0,2,0) (0,0,1.5)\nspace origin: (-90,-125,-71)\n\n' > "$TMP/g.nrrd"
head -c 24 /dev/zero | tr '\0' '\3' >> "$TMP/g.nrrd"
expect 0 "compress nrrd with geometry" "$CSGV" compress "$TMP/g.nrrd" "$TMP/g.csgv"
expect 0 "decompress nrrd with geometry" "$CSGV" decompress "$TMP/g.csgv" "$TMP/g2.nrrd"
grep -aq "space origin: (-90,-125,-71)" "$TMP/g2.nrrd" || bad "origin lost: $(grep -a 'space origin' "$TMP/g2.nrrd")"
grep -aq "space directions: (0.5,0,0) (0,2,0) (0,0,1.5)" "$TMP/g2.nrrd" || bad "spacing lost: $(grep -a 'space directions' "$TMP/g2.nrrd")"
expect 0 "verify nrrd" "$CSGV" verify "$TMP/g.csgv" "$TMP/g.nrrd"


# Every input form: NRRD and NIfTI with labels that do not fit (negative int16, int32 with
# 0xFFFFFFFF-like wide values) are relabelled in two streamed passes and verify slab by slab.
/usr/bin/python3 - "$TMP" <<'PY'
import struct, sys
import numpy as np
d = sys.argv[1]
z, y, x = np.mgrid[0:9, 0:10, 0:12]
a16 = ((x // 3 + 4 * (y // 4) + 12 * (z // 3)) % 23 - 11).astype('<i2')
with open(d + '/n16.nrrd', 'wb') as f:
    f.write(b'NRRD0004\ntype: int16\ndimension: 3\nsizes: 12 10 9\nencoding: raw\nendian: little\n'
            b'space dimension: 3\nspace directions: (0.5,0,0) (0,2,0) (0,0,1.5)\nspace origin: (1,2,3)\n\n')
    f.write(a16.tobytes())
a32 = np.where((x + y + z) % 5 == 0, 0, (x // 4 + 3 * (y // 5)) * 100000 - 7).astype('<i4')
def nifti(path, arr, code, bits):
    h = bytearray(352)
    struct.pack_into('<i', h, 0, 348)
    struct.pack_into('<8h', h, 40, 3, 12, 10, 9, 1, 1, 1, 1)
    struct.pack_into('<hh', h, 70, code, bits)
    struct.pack_into('<8f', h, 76, 1, 0.5, 0.5, 2, 1, 1, 1, 1)
    struct.pack_into('<f', h, 108, 352)
    struct.pack_into('<f', h, 112, 1)
    h[344:348] = b'n+1\0'
    with open(path, 'wb') as f:
        f.write(bytes(h) + arr.tobytes())
nifti(d + '/n32.nii', a32, 8, 32)
b32 = a32.copy(); b32[4, 5, 6] += 1
nifti(d + '/n32b.nii', b32, 8, 32)
PY
expect 0 "info nrrd input" "$CSGV" info "$TMP/n16.nrrd"
grep -qx "format: NRRD" "$TMP/out" && grep -qx "dimensions: 12 10 9" "$TMP/out" && grep -qx "type: int16" "$TMP/out" \
  && grep -qx "spacing: 0.5 2 1.5" "$TMP/out" && grep -qx "origin: 1 2 3" "$TMP/out" \
  && grep -qx "labels: 23" "$TMP/out" && grep -q "^labels_counted: exact" "$TMP/out" \
  || bad "info of a NRRD input: $(cat "$TMP/out")"
expect 0 "compress nrrd int16" "$CSGV" compress "$TMP/n16.nrrd" "$TMP/n16.csgv" --brick-size 8
grep -qx "relabelled: yes" "$TMP/out" && grep -qx "labels: 23" "$TMP/out" && grep -qx "input_format: NRRD" "$TMP/out" \
  || bad "compress of int16 NRRD: $(cat "$TMP/out")"
grep -q "^progress: .*% encoding .* Mvoxels/s" "$TMP/err" || bad "no encoding progress lines: $(cat "$TMP/err")"
[ -f "$TMP/n16_csgv.db3" ] || bad "relabelled NRRD compress wrote no database"
expect 0 "verify nrrd int16" "$CSGV" verify "$TMP/n16.csgv" "$TMP/n16.nrrd"
expect 0 "compress nrrd --quiet" "$CSGV" compress "$TMP/n16.nrrd" "$TMP/q.csgv" --quiet
[ -s "$TMP/err" ] && bad "--quiet still wrote to stderr: $(cat "$TMP/err")"
expect 0 "compress nrrd --relabel" "$CSGV" compress "$TMP/n16.nrrd" "$TMP/q.csgv" --relabel
grep -q "^progress: .*% relabelling" "$TMP/err" || bad "no relabelling progress: $(cat "$TMP/err")"
grep -qx "passes: 2" "$TMP/out" || bad "forced relabelling passes: $(grep passes "$TMP/out")"
expect 0 "info nifti input" "$CSGV" info "$TMP/n32.nii"
grep -qx "format: NIfTI" "$TMP/out" && grep -qx "type: int32" "$TMP/out" && grep -qx "dimensions: 12 10 9" "$TMP/out" \
  || bad "info of a NIfTI input: $(cat "$TMP/out")"
expect 0 "compress nifti int32" "$CSGV" compress "$TMP/n32.nii" "$TMP/n32.csgv"
grep -qx "relabelled: yes" "$TMP/out" || bad "negative int32 NIfTI not relabelled"
expect 0 "verify nifti int32" "$CSGV" verify "$TMP/n32.csgv" "$TMP/n32.nii"
expect 1 "verify nifti with a changed voxel" "$CSGV" verify "$TMP/n32.csgv" "$TMP/n32b.nii"
grep -q "voxel (6, 5, 4)" "$TMP/err" || bad "verify of changed NIfTI voxel: $(cat "$TMP/err")"
# Labels that do not fit uint32 (negative int32) extract to .vti as Int64 original labels, 0 elsewhere.
expect 0 "extract negative labels to vti" "$CSGV" extract "$TMP/n32.csgv" "$TMP/n32.vti" --labels -7,99993
/usr/bin/python3 - "$TMP/n32.vti" "$TMP/n32.nii" <<'PY' && pass "vti: Int64 original labels" || bad "vti of labels that do not fit uint32"
import re, sys
import numpy as np
t = open(sys.argv[1], 'rb').read()
head = t[:t.index(b'_', t.index(b'<AppendedData')) + 1].decode()
assert 'type="Int64" Name="Label"' in head, head
e = [int(v) for v in re.search(r'WholeExtent="([^"]+)"', head).group(1).split()]
n = (e[1] - e[0]) * (e[3] - e[2]) * (e[5] - e[4])
off = len(head)
assert int.from_bytes(t[off:off + 8], 'little') == 8 * n
got = np.frombuffer(t[off + 8:off + 8 + 8 * n], '<i8').reshape(e[5] - e[4], e[3] - e[2], e[1] - e[0])
src = np.frombuffer(open(sys.argv[2], 'rb').read()[352:], '<i4').reshape(9, 10, 12)
crop = src[e[4]:e[5], e[2]:e[3], e[0]:e[1]]
want = np.where(np.isin(crop, [-7, 99993]), crop, 0)
assert np.array_equal(got, want), (np.unique(got), np.unique(want))
assert set(np.unique(got)) == {0, -7, 99993}
PY
expect 1 "verify against a source of other dimensions" "$CSGV" verify "$TMP/n32.csgv" "$TMP/g.nrrd"
grep -q "dimensions differ" "$TMP/err" || bad "dimension mismatch message: $(cat "$TMP/err")"
expect 0 "verify against synth" "$CSGV" verify "$TMP/p.csgv" synth:40x30x20:3
expect 0 "info synth estimate" "$CSGV" info synth:256x256x300:2
grep -Eqx "labels: [0-9]+" "$TMP/out" && grep -qx "labels_counted: estimate (16 slices)" "$TMP/out" \
  || bad "label estimate of a large input: $(cat "$TMP/out")"
# Few but huge slices are sampled too (never read whole into the set): 2 of 2 slices here.
expect 0 "info of few huge slices" "$CSGV" info synth:4097x4097x2:2
grep -qx "labels_counted: estimate (2 slices)" "$TMP/out" || bad "few huge slices: $(cat "$TMP/out")"
# Every line is `key: value` with the value starting with a number or a word, nothing else.
expect 0 "info input keys" "$CSGV" info "$TMP/n16.nrrd"
grep -Evq '^[a-z_]+: [^ ]' "$TMP/out" && bad "info INPUT has a line that is not key: value: $(cat "$TMP/out")"
expect 1 "info INPUT --stats" "$CSGV" info "$TMP/n16.nrrd" --stats
grep -q -- "--stats applies to a .csgv file" "$TMP/err" || bad "--stats on an input: $(cat "$TMP/err")"
expect 1 "info INPUT --check" "$CSGV" info synth:8x8x8 --check
grep -q -- "--check applies to a .csgv file" "$TMP/err" || bad "--check on an input: $(cat "$TMP/err")"
# A name with a newline cannot forge a second error line.
expect 1 "info, a name with a newline" "$CSGV" info "$(printf '%s/a\ncsgv: error: FAKE.nii' "$TMP")"
[ "$(grep -c 'csgv: error:' "$TMP/err")" = 1 ] && grep -q 'a\\ncsgv: error: FAKE.nii' "$TMP/err" ||
  bad "a newline in a name: $(cat "$TMP/err")"
# Nor can a name in info's own lines, a terminal escape, a C1 control or a right-to-left override.
FORGED="$TMP/$(printf 'x\nbits_per_voxel: 0.0\033[2J.csgv')"
cp "$DEF" "$FORGED"
expect 0 "info, a name with a newline and an escape" "$CSGV" info "$FORGED"
[ "$(grep -c '^bits_per_voxel:' "$TMP/out")" = 1 ] && ! grep -q "$(printf '\033')" "$TMP/out" ||
  bad "a forged info line: $(cat "$TMP/out")"
rm -f "$FORGED"
expect 1 "info, C1 and bidi controls" "$CSGV" info "$(printf '%s/a\302\233b\342\200\256c.csgv' "$TMP")"
grep -q 'a\\u009Bb\\u202Ec.csgv' "$TMP/err" || bad "C1 and bidi controls: $(cat "$TMP/err")"
# A header whose largest palette (bytes 33..36) no brick has: --check says so (readers size by it).
cp "$DEF" "$TMP/pal.csgv"
printf '\377\377\377\377' | dd of="$TMP/pal.csgv" bs=1 seek=33 conv=notrunc status=none
expect 1 "info --check, a false largest palette" "$CSGV" info "$TMP/pal.csgv" --check
grep -q "the header says the largest palette holds 4294967295 labels, but the largest brick palette holds" "$TMP/err" ||
  bad "false largest palette: $(cat "$TMP/err")"

# SIGINT during compress cancels through the progress callback: exit 130, one message, no
# temporary or output files left.
mkdir "$TMP/int"
"$CSGV" compress synth:512x512x512:5 "$TMP/int/i.csgv" --threads 1 >"$TMP/int.out" 2>"$TMP/int.err" &
pid=$!
for _ in $(seq 1 200); do grep -q "^progress:" "$TMP/int.err" 2>/dev/null && break; sleep 0.05; done
kill -INT "$pid"
wait "$pid"; rc=$?
if [ "$rc" -eq 130 ] && grep -Eq "^csgv: error: .*(cancelled|interrupted)" "$TMP/int.err" && [ -z "$(ls -A "$TMP/int")" ]; then
  pass "SIGINT cancels compress and leaves no file"
else
  bad "SIGINT during compress: exit $rc, files: $(ls -A "$TMP/int"), stderr: $(tail -2 "$TMP/int.err")"
fi
expect 1 "info of a missing input" "$CSGV" info "$TMP/none.nrrd"
"$CSGV" --help | grep -q "DIR.zarr" || bad "usage lacks the input forms"

# extract: a label image equals the decompressed volume's voxels of the label in the reported box
# (cut out of the full decode); a mask; key lines; bad selections leave no file.
ATTR=$FIX/synthA_b32_rans2_attr.csgv
expect 0 "extract labels" "$CSGV" extract "$DEF" "$TMP/x.vraw" --labels 1223801393,743171196
for key in bricks_decoded bricks_total labels voxels box seconds; do
  grep -q "^$key: " "$TMP/out" || bad "extract lacks key $key"
done
grep -qx "bricks_total: 105" "$TMP/out" || bad "extract bricks_total: $(grep bricks_total "$TMP/out")"
grep -qx "bricks_decoded: 4" "$TMP/out" || bad "extract bricks_decoded: $(grep bricks_decoded "$TMP/out")"
box=$(sed -n 's/^box: //p' "$TMP/out")
"$CSGV" decompress "$DEF" "$TMP/full.vraw" >/dev/null
/usr/bin/python3 - "$TMP/full.vraw" "$TMP/x.vraw" $box <<'PY' || bad "extract differs from the decompressed volume"
import sys, numpy as np
def vraw(p):
    b = open(p, 'rb').read(); l1 = b.index(b'\n'); l2 = b.index(b'\n', l1 + 1)
    w, h, d = map(int, b[:l1].split()); t = b[l1 + 1:l2].decode()
    return np.frombuffer(b[l2 + 1:], dtype=t).reshape(d, h, w)
full, got = vraw(sys.argv[1]), vraw(sys.argv[2])
x0, y0, z0, x1, y1, z1 = map(int, sys.argv[3:9])
cut = full[z0:z1, y0:y1, x0:x1]
want = np.where(np.isin(cut, [1223801393, 743171196]), cut, 0)
sel = np.isin(full, [1223801393, 743171196])
zs, ys, xs = np.nonzero(sel)
assert (zs.min(), ys.min(), xs.min(), zs.max() + 1, ys.max() + 1, xs.max() + 1) == (z0, y0, x0, z1, y1, x1), "box not tight"
assert got.shape == want.shape and (got == want).all()
PY
expect 0 "extract mask nrrd level 1" "$CSGV" extract "$ATTR" "$TMP/m.nrrd" --labels 1223801393 --mask --level 1 --threads 1
grep -aq "^type: uint8" "$TMP/m.nrrd" || bad "extract mask type"
grep -aq "space directions: (2,0,0) (0,2,0) (0,0,2)" "$TMP/m.nrrd" || bad "extract level 1 spacing"
expect 0 "extract query" "$CSGV" extract "$ATTR" "$TMP/q.nrrd" --query "voxels > 5000 and kind = 3" --mask
expect 0 "extract with geometry" "$CSGV" extract "$TMP/g.csgv" "$TMP/g3.nrrd" --labels 3 --box 1,1,1,4,3,2
grep -aq "space origin: (-89.5,-123,-69.5)" "$TMP/g3.nrrd" || bad "extract origin: $(grep -a 'space origin' "$TMP/g3.nrrd")"
rm -f "$TMP"/e.*
expect 1 "extract without a selection" "$CSGV" extract "$DEF" "$TMP/e.nrrd"
expect 1 "extract empty selection" "$CSGV" extract "$DEF" "$TMP/e.nrrd" --labels ,
expect 1 "extract unknown labels" "$CSGV" extract "$DEF" "$TMP/e.nrrd" --labels 1223801393,5,6
grep -q "2 of the 3 selected labels occur nowhere.*: 5, 6" "$TMP/err" || bad "unknown labels message: $(cat "$TMP/err")"
expect 1 "extract unknown labels (database)" "$CSGV" extract "$ATTR" "$TMP/e.nrrd" --labels 7
expect 1 "extract box outside" "$CSGV" extract "$DEF" "$TMP/e.nrrd" --labels 1223801393 --box 0,0,0,134,10,10
expect 1 "extract bad box" "$CSGV" extract "$DEF" "$TMP/e.nrrd" --labels 1223801393 --box 0,0,0,10,10
expect 1 "extract too many labels" "$CSGV" extract "$DEF" "$TMP/e.nrrd" --labels 1223801393,743171196 --max-labels 1
expect 1 "extract over the output limit" "$CSGV" extract "$DEF" "$TMP/e.nrrd" --labels 0 --max-output-mib 1
grep -q "more than the output limit" "$TMP/err" || bad "output limit message: $(cat "$TMP/err")"
expect 1 "extract empty result" "$CSGV" extract "$DEF" "$TMP/e.nrrd" --labels 1223801393 --box 0,0,0,2,2,2
grep -q "nothing written" "$TMP/err" || bad "empty result message: $(cat "$TMP/err")"
expect 1 "extract bad query" "$CSGV" extract "$ATTR" "$TMP/e.nrrd" --query "voxels >"
expect 1 "extract query without database" "$CSGV" extract "$DEF" "$TMP/e.nrrd" --query "voxels > 1"
expect 1 "extract labels and query" "$CSGV" extract "$ATTR" "$TMP/e.nrrd" --query "voxels > 1" --labels 1
expect 1 "extract bad extension" "$CSGV" extract "$DEF" "$TMP/e.raw" --labels 1223801393
ls "$TMP"/e.* >/dev/null 2>&1 && bad "a failed extract left a file"

# extract to meshes: key lines, formats, counts; --mask, unknown labels and an unwritable path
# leave no file (test_mesh.cpp checks the faces against the decoded volume).
for ext in obj ply stl; do
  expect 0 "extract mesh $ext" "$CSGV" extract "$DEF" "$TMP/mesh.$ext" --labels 1223801393,743171196
  for key in output type labels labels_with_voxels vertices faces triangles seconds; do
    grep -q "^$key: " "$TMP/out" || bad "extract mesh $ext lacks key $key"
  done
done
[ "$(grep -c '^g label_' "$TMP/mesh.obj")" = 2 ] || bad "extract obj groups"
faces=$(sed -n 's/^triangles: //p' "$TMP/out")
[ "$(grep -c '^f ' "$TMP/mesh.obj")" = "$faces" ] || bad "extract obj triangle count"
head -c 200 "$TMP/mesh.ply" | grep -aq "element face $faces" || bad "extract ply face count"
[ "$(stat -c %s "$TMP/mesh.stl")" = "$((84 + 50 * faces))" ] || bad "extract stl size"
expect 1 "extract mesh with --mask" "$CSGV" extract "$DEF" "$TMP/e.obj" --labels 1223801393 --mask
grep -q "no --mask" "$TMP/err" || bad "mesh --mask message: $(cat "$TMP/err")"
expect 1 "extract mesh unknown label" "$CSGV" extract "$DEF" "$TMP/e.ply" --labels 1223801393,5
expect 1 "extract mesh unwritable" "$CSGV" extract "$DEF" "$TMP/none/e.stl" --labels 1223801393
expect 1 "extract mesh empty result" "$CSGV" extract "$DEF" "$TMP/e.stl" --labels 1223801393 --box 0,0,0,2,2,2
ls "$TMP"/e.* "$TMP"/*.tmp-* >/dev/null 2>&1 && bad "a failed mesh extract left a file"

# User errors.
expect 1 "no arguments" "$CSGV"
expect 0 "help" "$CSGV" --help
expect 1 "unknown command" "$CSGV" frobnicate
expect 1 "unknown option" "$CSGV" info "$DEF" --bogus
expect 1 "missing file" "$CSGV" info "$TMP/nope.csgv"
expect 1 "level out of range" "$CSGV" decompress "$DEF" "$TMP/c.vraw" --level 6
expect 1 "bad level value" "$CSGV" decompress "$DEF" "$TMP/c.vraw" --level -1
expect 1 "bad output extension" "$CSGV" decompress "$DEF" "$TMP/c.raw"
expect 1 "output folder missing" "$CSGV" decompress "$DEF" "$TMP/no/dir/c.vraw"
[ -e "$TMP/c.vraw" ] && bad "a failed decompress left a file"
ls "$TMP" | grep -q tmp- && bad "a temporary file was left behind"

# tile: a volume of whole bricks repeated, decoding cleanly; refusals leave no file.
expect 0 "compress a whole-brick volume" "$CSGV" compress synth:64x64x64 "$TMP/w.csgv" --quiet
expect 0 "tile 2,1,3" "$CSGV" tile "$TMP/w.csgv" "$TMP/wt.csgv" --times 2,1,3 --quiet
grep -q "^dimensions: 128 64 192" "$TMP/out" || bad "tile dimensions: $(cat "$TMP/out")"
expect 0 "the tiled volume decodes" "$CSGV" info "$TMP/wt.csgv" --check
grep -q "^check: ok (48 bricks" "$TMP/out" || bad "tile check: $(cat "$TMP/out")"
expect 1 "tile of partial bricks" "$CSGV" tile "$DEF" "$TMP/pt.csgv" --times 2,2,2
grep -q "not a multiple of the brick size" "$TMP/err" || bad "partial-brick message: $(cat "$TMP/err")"
expect 1 "tile without --times" "$CSGV" tile "$TMP/w.csgv" "$TMP/pt.csgv"
expect 1 "tile with a zero count" "$CSGV" tile "$TMP/w.csgv" "$TMP/pt.csgv" --times 2,0,2
expect 1 "tile past the output limit" "$CSGV" tile "$TMP/w.csgv" "$TMP/pt.csgv" --times 8,8,8 --max-output-mib 1
[ -e "$TMP/pt.csgv" ] && bad "a refused tile left a file"

# Malformed files: never a signal, always one clear message.
head -c 5000 "$DEF" > "$TMP/trunc.csgv"
expect 1 "truncated file" "$CSGV" info "$TMP/trunc.csgv"
grep -q truncated "$TMP/err" || bad "truncation message: $(cat "$TMP/err")"
head -c 20000 /dev/urandom > "$TMP/noise.csgv"
expect 1 "random bytes" "$CSGV" info "$TMP/noise.csgv"
(head -c 12 "$DEF"; head -c 20000 /dev/urandom) > "$TMP/noise2.csgv"
expect 1 "random bytes after the magic" "$CSGV" decompress "$TMP/noise2.csgv" "$TMP/n.vraw"
# Corrupt the encoding arrays (past the header) at many places: the tool must exit 0 or 1.
size=$(stat -c %s "$DEF")
for i in $(seq 1 40); do
  cp "$DEF" "$TMP/m.csgv"
  off=$(( (i * 2477) % (size - 600) + 560 ))
  printf "\\x$(printf %02x $(( (i * 37) % 256 )))" | dd of="$TMP/m.csgv" bs=1 seek=$off conv=notrunc status=none
  "$CSGV" verify "$TMP/m.csgv" "$FIX/synthA.vraw.gz" >/dev/null 2>&1; rc=$?
  [ $rc -le 1 ] || bad "corruption at $off: exit $rc"
done
pass "40 corruptions without a signal"

finish
