#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# `csgv render`'s interface: exit codes and one error line for bad input, the PNG and the
# --labels-out file (size, top row first, only labels of the volume), materials hiding labels,
# the printed summary, the orbit video, camera paths and one frame a pose.
set -u
CSGV=$1
FIX=$2
source "$(dirname "$0")/../tool_test_lib.sh"
DEF=$FIX/synthA_b32_rans2.csgv
PY=/usr/bin/python3

expect 0 "render" "$CSGV" render "$DEF" "$TMP/a.png" --size 64x48 --labels-out "$TMP/a.labels" --finest --no-jitter
for key in median_frame_ms time_to_first_frame_ms device_memory_total_mib cache_used_mib converged; do
  grep -q "^$key: " "$TMP/out" || bad "render summary lacks $key"
done
grep -q "^frame 1: " "$TMP/out" || bad "render prints each frame"
grep -q "^converged: yes$" "$TMP/out" && pass "the render converged" || bad "converged: yes expected"
grep -q "^cache_holds_view: yes$" "$TMP/out" &&
  awk '/^view_working_set_mib:/ { w = $2 } END { exit !(w > 0) }' "$TMP/out" &&
  pass "the view's working set, held by the cache" || bad "no working set, or not held"
# A cache smaller than the view's working set converges (bricks decoded again) to the same labels,
# and the summary says the cache cannot hold the view and what to raise.
expect 0 "render with a 1 MiB cache" "$CSGV" render "$DEF" "$TMP/k.png" --size 64x48 --labels-out "$TMP/k.labels" --finest \
  --no-jitter --cache-mib 1
grep -q "^cache_holds_view: no: view 0 touches .*(raise --cache-mib" "$TMP/out" && grep -q "^converged: yes$" "$TMP/out" &&
  pass "a cache too small for the view is named" || bad "a cache too small for the view is not named"
cmp -s "$TMP/a.labels" "$TMP/k.labels" && pass "a small cache leaves the labels unchanged" || bad "labels differ with a small cache"
# Issue 42: a cache that holds what an unconstrained orbit used converges within twice its frames
# (a cache under four times the volume had each view find its bricks one layer a frame: 20
# frames against 8).
expect 0 "an orbit unconstrained" "$CSGV" render "$DEF" "$TMP/o.png" --size 160x120 --finest --decode gpu --camera volcanite --orbit 8
FREE=$(awk '/^frames:/ { print $2 }' "$TMP/out"); USED=$(awk '/^cache_used_mib:/ { print int($2) + 1 }' "$TMP/out")
expect 0 "the orbit with a cache of $USED MiB" "$CSGV" render "$DEF" "$TMP/o.png" --size 160x120 --finest --decode gpu \
  --camera volcanite --orbit 8 --cache-mib "$USED"
awk -v free="$FREE" '/^frames:/ { f = $2 } /^cache_holds_view: yes$/ { h = 1 } END { exit !(free >= 8 && h && f <= 2 * free) }' "$TMP/out" &&
  pass "a cache that holds the orbit's bricks converges within twice the frames" ||
  bad "a cache of $USED MiB: $(grep -E '^(frames|cache_holds_view):' "$TMP/out" | tr '\n' ' ') against $FREE frames"
# GPU decodes carried over frames (--decode-steps): the same labels, more frames; with a cache too
# small for the view too (frames then take every step).
for cache in 0 1; do
  expect 0 "render with decodes carried over frames, cache $cache MiB" "$CSGV" render "$DEF" "$TMP/d.png" --size 64x48 \
    --labels-out "$TMP/d.labels" --finest --no-jitter --decode gpu --decode-steps 300 --cache-mib $cache
  grep -q "^converged: yes$" "$TMP/out" && cmp -s "$TMP/a.labels" "$TMP/d.labels" &&
    pass "carried decodes leave the labels unchanged (cache $cache MiB)" || bad "carried decodes change the labels (cache $cache MiB)"
done
# --compare-converged: each pose of a moving camera against its converged image; previews of bricks
# still being decoded show most of it (one label a brick showed about a fifth: lavapipe, synth 256^3).
expect 0 "a moving camera compared with its converged images" "$CSGV" render "$DEF" "$TMP/m.png" --size 64x48 --finest \
  --no-jitter --orbit 4 --frames-per-view 1 --decode gpu --decode-steps 300 --compare-converged
[ "$(grep -c '^view [0-3] as converged: ' "$TMP/out")" = 4 ] &&
  awk '/^as_converged_pct:/ { a = $2; p = $7 + 0 } END { exit !(a >= 40 && a <= 100 && p >= 40) }' "$TMP/out" &&
  pass "each view compared, most pixels as converged" || bad "--compare-converged: $(grep as_converged "$TMP/out")"
expect 1 "--compare-converged without --frames-per-view" "$CSGV" render "$DEF" "$TMP/n.png" --compare-converged
grep -q "compare-converged needs --frames-per-view" "$TMP/err" && [ ! -e "$TMP/n.png" ] &&
  pass "--compare-converged alone is refused" || bad "--compare-converged alone: $(cat "$TMP/err")"
# --prefetch-voxels: a small volume's every visible brick decoded at the first frame (automatic,
# GPU decoding too), its first frame complete; 0: the rays find them a layer a frame; the same labels.
for pv in auto 0; do
  expect 0 "render with --prefetch-voxels $pv" "$CSGV" render "$DEF" "$TMP/p.png" --size 64x48 --finest --no-jitter \
    --decode gpu --labels-out "$TMP/p_$pv.labels" --prefetch-voxels $pv
  cp "$TMP/out" "$TMP/p_$pv.out"
done
grep -q "^frame 1: .* missing 0, min samples 1$" "$TMP/p_auto.out" && grep -q "^frames: 1$" "$TMP/p_auto.out" &&
  awk '/^frames:/ { exit !($2 > 1) }' "$TMP/p_0.out" && cmp -s "$TMP/p_auto.labels" "$TMP/p_0.labels" &&
  cmp -s "$TMP/a.labels" "$TMP/p_auto.labels" &&
  pass "prefetched bricks: a complete first frame, the same labels" ||
  bad "--prefetch-voxels: $(grep -hE '^(frame 1|frames):' "$TMP/p_auto.out" "$TMP/p_0.out" | tr '\n' ' ')"
for pv in x -1 1e16 ""; do
  expect 1 "render with --prefetch-voxels '$pv'" "$CSGV" render "$DEF" "$TMP/c.png" --prefetch-voxels "$pv"
  grep -q "option --prefetch-voxels (a number of voxels, or auto)" "$TMP/err" || bad "the error does not name --prefetch-voxels ('$pv')"
done
for steps in 0 -3 x 2000000 1e3 ""; do
  expect 1 "render with --decode-steps '$steps'" "$CSGV" render "$DEF" "$TMP/c.png" --decode-steps "$steps"
  grep -q "decode-steps expects auto, all or a number" "$TMP/err" || bad "the error does not name --decode-steps ('$steps')"
done
[ ! -e "$TMP/c.png" ] && pass "no image after --decode-steps errors" || bad "an image after --decode-steps errors"
# A device-memory budget bounds the whole device memory and leaves the labels as they were; one
# too small for the image is one error line naming the budget.
expect 0 "render under a budget" "$CSGV" render "$DEF" "$TMP/b.png" --size 64x48 --labels-out "$TMP/b.labels" --finest \
  --no-jitter --device-memory-mib 3
awk '/^device_memory_total_mib:/ { t = $2 } /^device_memory_budget_mib:/ { b = $2 } END { exit !(b == 3 && t <= b) }' \
  "$TMP/out" && pass "device memory within --device-memory-mib" || bad "device memory past --device-memory-mib"
cmp -s "$TMP/a.labels" "$TMP/b.labels" && pass "a budget leaves the labels unchanged" || bad "labels differ under a budget"
# GPU decoding under a budget that the encoding takes more than half of streams the finest
# level's streams (a 2.8 MiB encoding under 5 MiB): the labels of the volume held whole (decoded
# on the host here), streams uploaded, the budget kept.
expect 0 "compress a 384^3 volume" "$CSGV" compress synth:384x384x384 "$TMP/s.csgv"
expect 0 "render it whole" "$CSGV" render "$TMP/s.csgv" "$TMP/w.png" --size 64x48 --labels-out "$TMP/w.labels" --finest \
  --no-jitter --decode host
expect 0 "render streaming detail" "$CSGV" render "$TMP/s.csgv" "$TMP/d.png" --size 64x48 --labels-out "$TMP/d.labels" \
  --finest --no-jitter --device-memory-mib 5 --decode gpu
grep -q "^detail_separated: yes$" "$TMP/out" && grep -q "^detail_streaming: yes$" "$TMP/out" &&
  awk '/^detail_uploaded_bricks:/ { n = $2 } /^device_memory_total_mib:/ { t = $2 } END { exit !(n > 0 && t <= 5) }' "$TMP/out" &&
  pass "detail streamed within the budget" || bad "no detail streaming under --decode gpu"
cmp -s "$TMP/w.labels" "$TMP/d.labels" && pass "streaming leaves the labels unchanged" || bad "labels differ with detail streaming"
# A host-memory budget below the encoding (2.8 MiB) keeps the coarse levels in memory (2 MiB) or
# none (1 MiB) and reads the rest from the file: the same labels, by host and by GPU decoding.
for dec in host gpu; do
  for mib in 2 1; do
    expect 0 "render with $mib MiB of host memory, $dec decoding" "$CSGV" render "$TMP/s.csgv" "$TMP/h.png" --size 64x48 \
      --labels-out "$TMP/h.labels" --finest --no-jitter --decode $dec --host-memory-mib $mib
    grep -q "^finest_level_on_disk: yes$" "$TMP/out" &&
      awk -v mib=$mib '/^host_coarse_mib:/ { c = $2 } /^file_read_mib:/ { r = $2 } END { exit !((mib == 2 ? c > 0 : c == 0) && c <= mib && r > 0) }' "$TMP/out" &&
      pass "$mib MiB, $dec: the finest level read from the file" || bad "$mib MiB, $dec: no tiers"
    cmp -s "$TMP/w.labels" "$TMP/h.labels" && pass "$mib MiB, $dec: the same labels" || bad "$mib MiB, $dec: labels differ"
  done
done
expect 0 "render with a budget the encoding fits" "$CSGV" render "$TMP/s.csgv" "$TMP/h.png" --size 64x48 --host-memory-mib 64
grep -q "^finest_level_on_disk: no$" "$TMP/out" && pass "a budget the encoding fits keeps it whole" || bad "tiers within the budget"
expect 1 "render with a negative host budget" "$CSGV" render "$TMP/s.csgv" "$TMP/h.png" --host-memory-mib -1
grep -q "host-memory-mib" "$TMP/err" && pass "the error names --host-memory-mib" || bad "no --host-memory-mib in the error"
expect 1 "render with an unknown decoder" "$CSGV" render "$DEF" "$TMP/c.png" --decode fpga
grep -q "decode expects auto, gpu or host" "$TMP/err" && pass "the error names --decode" || bad "no --decode in the error"
expect 1 "render with a budget too small" "$CSGV" render "$DEF" "$TMP/c.png" --size 640x480 --device-memory-mib 2
grep -q "budget of 2.0 MiB" "$TMP/err" && pass "the error names the budget" || bad "no budget in the error"
[ "$(head -c 8 "$TMP/a.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] && pass "PNG signature" || bad "PNG signature"
[ "$(stat -c %s "$TMP/a.labels")" -eq $((64 * 48 * 4)) ] && pass "labels-out size" || bad "labels-out size"
# Every label hit is a label of the volume (decompressed here), and something is hit.
"$CSGV" decompress "$DEF" "$TMP/v.vraw" >/dev/null 2>&1 || bad "decompress"
$PY - "$TMP/a.labels" "$TMP/v.vraw" <<'PYEOF' && pass "labels-out holds the volume's labels" || bad "labels-out content"
import struct, sys
px = struct.unpack("<%dI" % (64 * 48), open(sys.argv[1], "rb").read())
raw = open(sys.argv[2], "rb").read()
head = raw.split(b"\n", 2)
labels = set(struct.unpack("<%dI" % ((len(head[2])) // 4), head[2]))
hit = [p for p in px if p != 0xFFFFFFFF]
assert len(hit) > 64 * 48 // 10, "too few hits"
assert len(hit) < 64 * 48, "no background"
assert all(p in labels and p != 0 for p in hit), "a label not in the volume"
PYEOF
# Materials: hide the most frequent label in the image; it must vanish from the labels.
TOP=$($PY -c "
import struct,collections,sys
px=struct.unpack('<%dI'%(64*48),open('$TMP/a.labels','rb').read())
print(collections.Counter(p for p in px if p!=0xFFFFFFFF).most_common(1)[0][0])")
cat > "$TMP/m.json" <<JSON
{"version": 1, "materials": [
  {"name": "hidden", "filter": {"attribute": "label", "min": $TOP, "max": $TOP}, "opacity": 0},
  {"name": "rest", "filter": {"attribute": "label", "min": 1, "max": 4294967294},
   "color": {"mode": "colormap", "attribute": "label", "min": 0, "max": 4294967295, "colormap": "Turbo"}}]}
JSON
expect 0 "render with materials" "$CSGV" render "$DEF" "$TMP/b.png" --size 64x48 --labels-out "$TMP/b.labels" --finest --no-jitter --materials "$TMP/m.json"
$PY -c "
import struct
px=struct.unpack('<%dI'%(64*48),open('$TMP/b.labels','rb').read())
assert $TOP not in px
" && pass "a hidden label is gone" || bad "hidden label still visible"
# The label overlays as ParaView draws them: "hidden" takes the label away, and "selected" with
# the style "dim" leaves only the selected label opaque (the others at 15 % opacity).
echo "{\"hidden\": [$TOP]}" > "$TMP/hid.json"
expect 0 "render with a hidden overlay" "$CSGV" render "$DEF" "$TMP/h.png" --size 64x48 --labels-out "$TMP/h.labels" --finest --no-jitter --materials "$TMP/hid.json"
$PY -c "
import struct
px=struct.unpack('<%dI'%(64*48),open('$TMP/h.labels','rb').read())
assert $TOP not in px
" && pass "an overlay's hidden label is gone" || bad "the hidden overlay is not drawn"
echo "{\"selected\": [$TOP], \"selectionStyle\": \"dim\"}" > "$TMP/sel.json"
expect 0 "render with a dimmed selection" "$CSGV" render "$DEF" "$TMP/s.png" --size 64x48 --labels-out "$TMP/s.labels" --finest --no-jitter --materials "$TMP/sel.json"
$PY -c "
import struct
a=struct.unpack('<%dI'%(64*48),open('$TMP/a.labels','rb').read())
s=struct.unpack('<%dI'%(64*48),open('$TMP/s.labels','rb').read())
# The selected label is opaque; elsewhere the label image holds the first (dimmed) surface, or the
# selected label behind it.
assert all(y == $TOP for x, y in zip(a, s) if x == $TOP)
assert all(y == x or y == $TOP for x, y in zip(a, s))
assert sum(1 for x, y in zip(a, s) if x != y) > 0
" && pass "a dimmed selection: only the selected label is opaque" || bad "the selection overlay is not drawn"
# Errors: one line, exit 1.
expect 1 "missing input" "$CSGV" render "$TMP/nope.csgv" "$TMP/x.png"
expect 1 "bad size" "$CSGV" render "$DEF" "$TMP/x.png" --size 0x10
expect 1 "bad shading" "$CSGV" render "$DEF" "$TMP/x.png" --shading fancy
expect 1 "bad eye" "$CSGV" render "$DEF" "$TMP/x.png" --eye 1,2
expect 1 "unknown option" "$CSGV" render "$DEF" "$TMP/x.png" --frobnicate
expect 1 "video without orbit" "$CSGV" render "$DEF" "$TMP/x.png" --video "$TMP/f%02d.png"
echo '{"version": 1, "materials": [{"filter": {"attribute": "size", "min": 0, "max": 1}}]}' > "$TMP/bad.json"
expect 1 "material attribute the file lacks" "$CSGV" render "$DEF" "$TMP/x.png" --materials "$TMP/bad.json"
echo '{"version": 1, "materials": [{"colour": 1}]}' > "$TMP/bad2.json"
expect 1 "unknown material key" "$CSGV" render "$DEF" "$TMP/x.png" --materials "$TMP/bad2.json"
head -c 3000 "$DEF" > "$TMP/trunc.csgv"
expect 1 "truncated file" "$CSGV" render "$TMP/trunc.csgv" "$TMP/x.png"
[ ! -e "$TMP/x.png" ] && pass "no image after errors" || bad "an image was written after an error"
# Orbit video: N frames, parallel projection, shading modes.
expect 0 "orbit video" "$CSGV" render "$DEF" "$TMP/v.png" --size 32x24 --video "$TMP/f%02d.png" --orbit 3 --parallel-scale 80 --shading shadow
[ -e "$TMP/f00.png" ] && [ -e "$TMP/f02.png" ] && [ ! -e "$TMP/f03.png" ] && pass "3 video frames" || bad "video frames"
# Outputs never replace what is not a plain, writable file (found by an attack pass: a device
# such as /dev/null became a PNG), and are refused before any rendering.
mkfifo "$TMP/fifo.png"; ln -s v.png "$TMP/link.png"; cp "$TMP/v.png" "$TMP/ro.png"; chmod 444 "$TMP/ro.png"
expect_bounded 1 4096 60 "fifo.png' is a FIFO" "image output on a FIFO" "$CSGV" render "$DEF" "$TMP/fifo.png" --size 8x8
expect_bounded 1 4096 60 "link.png' is a symbolic link" "labels output through a symbolic link" "$CSGV" render "$DEF" "$TMP/y.png" --size 8x8 --labels-out "$TMP/link.png"
expect_bounded 1 4096 60 "ro.png' is write-protected" "image output on a write-protected file" "$CSGV" render "$DEF" "$TMP/ro.png" --size 8x8
[ -p "$TMP/fifo.png" ] && [ -L "$TMP/link.png" ] && cmp -s "$TMP/v.png" "$TMP/ro.png" && [ ! -e "$TMP/y.png" ] &&
  pass "the FIFO, the link and the protected file are as they were" || bad "an output replaced a FIFO, link or protected file"
# An interrupted video leaves the old frames whole (found by an attack pass: 4 new frames among 36
# old ones): the frames, the image and the labels are published together at the end.
cp "$TMP/f00.png" "$TMP/f00.before"
expect_interrupt "SIGINT during a video" "$CSGV" render "$DEF" "$TMP/v2.png" --size 128x96 --video "$TMP/f%02d.png" --orbit 5000
cmp -s "$TMP/f00.png" "$TMP/f00.before" && [ ! -e "$TMP/f03.png" ] && [ ! -e "$TMP/v2.png" ] &&
  [ -z "$(ls "$TMP" | grep -F .tmp-)" ] && pass "the interrupted video left the old set and no temporaries" ||
  bad "an interrupted video changed the old frames or left files: $(ls "$TMP" | grep -E 'f0[0-9]|tmp' | head)"
for m in ao pt; do
  expect 0 "shading $m" "$CSGV" render "$DEF" "$TMP/$m.png" --size 32x24 --shading $m --frames 2 --subsampling 2
done
# Camera paths (issue 42): a one-pose path renders exactly what the same pose given by --eye,
# --center, --up and --fov-y renders; a 3-pose path with one frame a pose renders 3 frames and 3
# images; Volcanite's default pose renders; bad paths are one error line naming file and line.
echo "# eye, centre, up, fov-y" > "$TMP/one.path"
echo "-60 130 160, 66 35 97, 0 0 1, 40" >> "$TMP/one.path"
expect 0 "one-pose camera path" "$CSGV" render "$DEF" "$TMP/p1.png" --size 48x32 --labels-out "$TMP/p1.labels" --finest --no-jitter --camera-path "$TMP/one.path"
expect 0 "the same pose by options" "$CSGV" render "$DEF" "$TMP/p2.png" --size 48x32 --labels-out "$TMP/p2.labels" --finest --no-jitter \
  --eye -60,130,160 --center 66,35,97 --up 0,0,1 --fov-y 40
cmp -s "$TMP/p1.labels" "$TMP/p2.labels" && pass "a path pose renders as the same options do" || bad "camera path pose differs"
printf '%s\n' "-60 130 160 66 35 97 0 0 1 40" "190 130 160 66 35 97 0 0 1 40" "66 35 400 66 35 97 0 1 0 30" > "$TMP/three.path"
expect 0 "3-pose path, one frame a pose" "$CSGV" render "$DEF" "$TMP/p3.png" --size 32x24 --camera-path "$TMP/three.path" \
  --frames-per-view 1 --frames 4 --video "$TMP/pv%d.png"
grep -q "^views: 3$" "$TMP/out" && grep -q "^frames: 3$" "$TMP/out" && grep -q "^frames_per_view: 1$" "$TMP/out" &&
  grep -q "^path_ms: " "$TMP/out" && grep -q "^converged: no (--frames-per-view" "$TMP/out" &&
  pass "one frame a pose: 3 frames for 3 views, not converged at 4 samples" || bad "frames-per-view summary: $(grep -E '^(views|frames|converged)' "$TMP/out" | tr '\n' ' ')"
[ -e "$TMP/pv0.png" ] && [ -e "$TMP/pv2.png" ] && [ ! -e "$TMP/pv3.png" ] && pass "an image per pose" || bad "path images"
expect 0 "Volcanite's default pose, orbited" "$CSGV" render "$DEF" "$TMP/vc.png" --size 32x24 --camera volcanite --orbit 2 --frames-per-view 2
grep -q "^views: 2$" "$TMP/out" && pass "--orbit without --video renders its views" || bad "orbit views"
bad_path() { printf '%s\n' "$2" > "$TMP/bad.path"; expect 1 "camera path: $1" "$CSGV" render "$DEF" "$TMP/x.png" --camera-path "$TMP/bad.path"
  grep -q "bad.path" "$TMP/err" || bad "camera path: $1: the error does not name the file"; }
bad_path "nine numbers" "1 2 3 4 5 6 0 0 1"
# Found by an attack pass: a path's field of view took what --fov-y refuses (a flat image), a
# valid but tiny up vector drew nothing, and unused --attributes / --derive went unread.
bad_path "a field of view --fov-y refuses" "0 0 9 0 0 0 0 1 0 1e-300"
printf '%s\n' "-60 130 160 66 35 97 0 1e-170 1e-170 40" > "$TMP/tiny_up.path"
expect 0 "an up vector of 1e-170" "$CSGV" render "$DEF" "$TMP/tu.png" --size 32x24 --camera-path "$TMP/tiny_up.path" --labels-out "$TMP/tu.labels"
$PY -c "
import struct
d = open('$TMP/tu.labels', 'rb').read()
assert sum(1 for p in struct.unpack('<%dI' % (len(d) // 4), d) if p != 0xFFFFFFFF) > 50
" && pass "a tiny up vector renders the volume" || bad "a tiny up vector rendered nothing"
expect_bounded 1 4096 60 "nonexistent.csv" "an unused attribute file that does not exist" "$CSGV" render "$DEF" "$TMP/x.png" --size 8x8 --attributes "$TMP/nonexistent.csv"
expect_bounded 1 4096 60 "derived attribute 'x'" "an unused derived attribute that is not SQL" "$CSGV" render "$DEF" "$TMP/x.png" --size 8x8 --derive "x=this is not sql"
bad_path "a word" "1 2 3 4 5 6 0 0 1 x"
bad_path "nan" "1 2 3 4 5 6 0 0 1 nan"
bad_path "eye at the centre" "1 2 3 1 2 3 0 0 1 30"
printf '1e-300 0 0 0 0 0 0 0 1 30\n' > "$TMP/tiny.path"
# The direction of an eye 1e-300 from the centre is well defined (normalize scales it first).
expect 0 "camera path: an eye 1e-300 from the centre" "$CSGV" render "$DEF" "$TMP/tiny.png" --size 16x16 --camera-path "$TMP/tiny.path"
bad_path "eye beyond double range from the centre" "1e308 0 0 -1e308 0 0 0 0 1 30"
grep -q "too far" "$TMP/err" && pass "a distance that overflows is named as such" || bad "overflowing distance: $(cat "$TMP/err")"
bad_path "up along the view" "0 0 0 0 0 5 0 0 1 30"
bad_path "zero field of view" "0 0 9 0 0 0 0 1 0 0"
bad_path "field of view 180" "0 0 9 0 0 0 0 1 0 180"
grep -q "line 1: " "$TMP/err" && pass "the error names the line" || bad "camera path error without its line: $(cat "$TMP/err")"
bad_path "no pose" "# only a comment"
printf '0 0 9 0 0 0 0 1 0 30\n%.0s' $(seq 1 100001) > "$TMP/bad.path"
expect 1 "camera path: too many poses" "$CSGV" render "$DEF" "$TMP/x.png" --camera-path "$TMP/bad.path"
expect 1 "camera path: missing file" "$CSGV" render "$DEF" "$TMP/x.png" --camera-path "$TMP/nope.path"
expect 1 "camera path with --orbit" "$CSGV" render "$DEF" "$TMP/x.png" --camera-path "$TMP/one.path" --orbit 3
expect 1 "--camera volcanite with --eye" "$CSGV" render "$DEF" "$TMP/x.png" --camera volcanite --eye 1,2,3
expect 1 "--camera of another name" "$CSGV" render "$DEF" "$TMP/x.png" --camera paraview
# Options that contradict each other or cannot mean anything are refused, not ignored (attack
# pass 6): the view's angle with a parallel view, or with a pose that gives its own; a colour
# beyond [0, 1]; an empty file name; and a bound is written as a person writes it.
RB() { expect_bounded 1 4096 60 "$1" "$2" "$CSGV" render "$DEF" "$TMP/x.png" --size 16x16 "${@:3}"; }
RB "give one" "--fov-y with --parallel-scale" --fov-y 30 --parallel-scale 3
RB "takes no --eye, --center, --up or --fov-y" "--camera volcanite with --fov-y" --camera volcanite --fov-y 40
RB "takes no --eye, --center, --up or --fov-y" "--camera volcanite with --up" --camera volcanite --up 0,1,0
RB "takes no .*--up or --fov-y" "a camera path with --fov-y" --camera-path "$TMP/one.path" --fov-y 40
RB "--background: expected red, green and blue from 0 to 1" "--background 2,2,2" --background 2,2,2
RB "--materials expects a file name" "--materials ''" --materials ''
RB "--labels-out expects a file name" "--labels-out ''" --labels-out ''
RB "--attributes expects a file name" "--attributes ''" --attributes ''
RB "from 1e-09 to 1e\\+12, not '0'" "--parallel-scale 0" --parallel-scale 0
RB "cannot create '/proc/0.png'" "a video frame where no file can be made names the frame" --orbit 2 --video /proc/%d.png
RB "\\.\\.\\. \\([0-9]+ characters left out\\) \\.\\.\\." "a name of 100,000 characters is not echoed whole" \
  --attributes "$TMP/$(printf 'a%.0s' $(seq 1 100000)).csv"
[ "$(wc -c < "$TMP/err")" -lt 4096 ] && pass "the error line stays under 4 KiB" || bad "the error line is $(wc -c < "$TMP/err") bytes"
expect 1 "--frames-per-view 0" "$CSGV" render "$DEF" "$TMP/x.png" --frames-per-view 0
[ ! -e "$TMP/x.png" ] && pass "no image after camera errors" || bad "an image was written after a camera error"
# Attributes from a text table and a derived SQL attribute drive materials: the AAL atlas with
# only the left hemisphere (region names ending in _L) visible.
AAL=/usr/share/mricron/templates/aal.nii.gz
if [ -e "$AAL" ]; then
  expect 0 "compress AAL" "$CSGV" compress "$AAL" "$TMP/aal.csgv"
  cat > "$TMP/hemi.json" <<'JSON'
{"version": 1, "materials": [
  {"name": "left", "filter": {"attribute": "hemisphere", "min": 0, "max": 0}, "color": {"mode": "random"}}]}
JSON
  expect 0 "render with --attributes and --derive" "$CSGV" render "$TMP/aal.csgv" "$TMP/aal.png" --size 48x40 \
    --attributes "${AAL%.nii.gz}.nii.txt" --derive "hemisphere=CASE WHEN name LIKE '%\_L' ESCAPE '\\' THEN 0 WHEN name LIKE '%\_R' ESCAPE '\\' THEN 1 END" \
    --materials "$TMP/hemi.json" --labels-out "$TMP/aal.labels" --eye 0,-400,150 --center 0,-18,18
  $PY -c "
import struct
px=[p for p in struct.unpack('<%dI'%(48*40),open('$TMP/aal.labels','rb').read()) if p!=0xFFFFFFFF]
assert len(px) > 100, len(px)
assert all(p % 2 == 1 for p in px), 'a right-hemisphere (even) label is visible'
" && pass "only left-hemisphere labels are hit" || bad "hemisphere materials"
  expect 1 "derived attribute with bad SQL" "$CSGV" render "$TMP/aal.csgv" "$TMP/x.png" --size 8x8 \
    --attributes "${AAL%.nii.gz}.nii.txt" --derive "hemisphere=CASE WHEN" --materials "$TMP/hemi.json"
fi
finish
