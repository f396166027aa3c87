#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Adversarial suite, the tool's own part (issue 37 items 1, 2, 4, 5, 6, 7): hostile options and
# sidecars against `csgv`. Each case asserts the exit status, one clear error line, a memory
# ceiling and a time ceiling (expect_bounded), and that nothing of the user's is lost.
# Arguments: the csgv binary and a Volcanite fixture folder.
set -u
CSGV=$1
FIX=$2
source "$(dirname "$0")/../../tool_test_lib.sh"
export OMP_NUM_THREADS=2
SRC=$FIX/synthA.vraw.gz
cd "$TMP" || exit 1

no_temporaries() { # $1: folder, $2: what
  local left; left=$(find "$1" -name '*.tmp-*' | head -3)
  [ -z "$left" ] && pass "$2: no temporary left" || bad "$2: temporaries left: $left"
}

# --- 1. `render --video PATTERN` is never a printf format --------------------------------------
if grep -q "without VulkanBackend" <("$CSGV" render 2>&1); then
  echo "skip: render is not built (video patterns)"
else
  "$CSGV" compress "$SRC" v.csgv --quiet >/dev/null
  for p in '%s%s%s%s.png' '%n.png' 'f_%d_%d_%d.png' '%x.png' '%.png' '%999d.png' 'frame.png' '%ld.png'; do
    expect_bounded 1 4096 20 "video pattern '.*' (has|has no)" "render --video '$p' refused" \
      "$CSGV" render v.csgv r.png --video "$p" --orbit 2 --size 16x16
  done
  expect_bounded 0 8192 120 "" "render --video 'o_%%_%03d.png' writes two frames" \
    "$CSGV" render v.csgv r.png --video 'o_%%_%03d.png' --orbit 2 --size 16x16
  [ -f 'o_%_000.png' ] && [ -f 'o_%_001.png' ] && pass "video frames named o_%_000.png, o_%_001.png" \
    || bad "video frame names: $(ls o_* 2>&1)"
  # The reader of its output gone (`| head`): SIGPIPE's default action ended the tool at once and
  # left a temporary of every frame written (74 of 400 in an attack pass). Now it stops as on
  # Ctrl-C: status 130, no frame published, no temporary.
  mkdir -p pipe
  "$CSGV" render v.csgv pipe/r.png --size 32x24 --orbit 400 --frames-per-view 1 --video 'pipe/f%03d.png' \
    2>"$TMP/pipe.err" | head -2 >/dev/null
  rc=${PIPESTATUS[0]}
  [ "$rc" -eq 130 ] && grep -q "reader is gone (SIGPIPE)" "$TMP/pipe.err" \
    && pass "render --video | head: stopped by SIGPIPE with status 130 and its line" \
    || bad "render --video | head: status $rc, stderr: $(tail -2 "$TMP/pipe.err")"
  [ -z "$(ls pipe)" ] && pass "render --video | head: nothing published, no temporary" \
    || bad "render --video | head left: $(ls pipe | head -3) ($(ls pipe | wc -l) files)"
fi
printf 'an older file' > piped.csgv
"$CSGV" compress synth:400x400x400 piped.csgv 2>&1 | head -c 10 >/dev/null
rc=${PIPESTATUS[0]}
[ "$rc" -eq 130 ] && [ "$(cat piped.csgv)" = "an older file" ] && [ ! -e piped.csgv.json ] \
  && pass "compress 2>&1 | head: status 130, the old file untouched" || bad "compress 2>&1 | head: status $rc"
no_temporaries . "compress whose output's reader is gone"

# --- 2. Publishing is all or nothing: a full disk keeps the old set byte-identical -------------
# A small tmpfs (root only; elsewhere this case says it skipped). The new compression's volume
# fits, its attribute database (4097 labels, about nine times the volume) does not.
many_labels() { # $1: NRRD to write, $2: an offset that makes other labels: 64^3, one label per 4^3 block
  python3 - "$1" "$2" <<'EOF2'
import struct, sys
n, b, off = 64, 4, int(sys.argv[2])
vals = [((z // b) * 256 + (y // b) * 16 + (x // b)) * 7919 + off for z in range(n) for y in range(n) for x in range(n)]
with open(sys.argv[1], 'wb') as f:
    f.write(b"NRRD0004\ntype: uint32\ndimension: 3\nsizes: 64 64 64\nencoding: raw\nendian: little\n\n")
    f.write(struct.pack('<%dI' % len(vals), *vals))
EOF2
}
many_labels m1.nrrd 1; many_labels m2.nrrd 2
mkdir -p fs
if mount -t tmpfs -o size=4m tmpfs fs 2>/dev/null; then
  trap 'umount "$TMP/fs" 2>/dev/null; rm -rf "$TMP"' EXIT
  "$CSGV" compress m1.nrrd fs/x.csgv --relabel --quiet >/dev/null || bad "first compression"
  old=$(cat fs/x.csgv fs/x.csgv.json fs/x_csgv.db3 | sha256sum)
  # The new set's sizes, from the same compression elsewhere.
  mkdir dry && "$CSGV" compress m2.nrrd dry/x.csgv --relabel --quiet >/dev/null
  pages() { echo $((($(stat -c %s "$1") + 4095) / 4096)); }
  vol=$(pages dry/x.csgv); js=$(pages dry/x.csgv.json); db=$(pages dry/x_csgv.db3)
  [ "$db" -ge $((4 * vol)) ] || bad "fixture: the database ($db pages) is too small against the volume ($vol)"
  # Fill the disk but leave room for the volume (twice: the encoder's scratch beside it), its
  # metadata and half its database.
  avail=$(($(stat -f -c '%a' fs)))
  dd if=/dev/zero of=fs/filler bs=4096 count=$((avail - 2 * vol - js - db / 2)) status=none 2>/dev/null
  expect_bounded 1 4096 60 "attribute database 'fs/x_csgv.db3'.*(space|full)" \
    "compress --relabel over an old set on a full disk fails" \
    "$CSGV" compress m2.nrrd fs/x.csgv --relabel --quiet
  [ "$(cat fs/x.csgv fs/x.csgv.json fs/x_csgv.db3 | sha256sum)" = "$old" ] \
    && pass "the old .csgv, .csgv.json and _csgv.db3 are byte-identical" || bad "the old set changed"
  no_temporaries fs "full disk"
  # With no room at all the encoding itself fails: the old set stays too.
  dd if=/dev/zero of=fs/filler2 bs=4096 count=100000 status=none 2>/dev/null
  expect_bounded 1 4096 60 "x.csgv" "compress on a disk with no room fails" \
    "$CSGV" compress m2.nrrd fs/x.csgv --quiet
  [ "$(cat fs/x.csgv fs/x.csgv.json fs/x_csgv.db3 | sha256sum)" = "$old" ] \
    && pass "no room: the old set is byte-identical" || bad "no room: the old set changed"
  no_temporaries fs "no room"
  rm -f fs/filler fs/filler2
  # And with room, the new set replaces the old one (no stale database without relabelling).
  expect_bounded 0 4096 60 "" "compress over the old set with room" "$CSGV" compress "$SRC" fs/x.csgv --quiet
  [ ! -e fs/x_csgv.db3 ] && pass "the stale database is gone" || bad "a stale database stayed beside a new volume"
  expect_bounded 0 4096 60 "" "the new set verifies" "$CSGV" verify fs/x.csgv "$SRC"
  umount fs
else
  echo "skip: cannot mount a small tmpfs here (not root): full-disk publishing"
fi

# --- 4. Ctrl-C ends the tool within a second with status 130 and no partial output ------------
expect_interrupt "compress synth:1024^3 interrupted" "$CSGV" compress synth:1024x1024x1024 big.csgv --threads 2
[ ! -e big.csgv ] && [ ! -e big.csgv.json ] && pass "interrupted compress wrote nothing" || bad "interrupted compress left output"
no_temporaries . "interrupted compress"
# A decode has no progress callback to ask: the watchdog ends it and removes the temporary.
"$CSGV" compress synth:640x640x640:2 d.csgv --quiet >/dev/null
expect_interrupt "decompress interrupted inside the decoder" "$CSGV" decompress d.csgv d.nrrd --threads 1
[ ! -e d.nrrd ] && pass "interrupted decompress wrote nothing" || bad "interrupted decompress left d.nrrd"
no_temporaries . "interrupted decompress"
printf 'an older file' > keep.nrrd
expect_interrupt "decompress over an existing output interrupted" "$CSGV" decompress d.csgv keep.nrrd --threads 1
[ "$(cat keep.nrrd)" = "an older file" ] && pass "the existing output is untouched" || bad "the existing output changed"
# A terminal closed (SIGHUP) is an interrupt too; under nohup (SIGHUP ignored) the work goes on.
INTERRUPT_SIGNAL=HUP expect_interrupt "decompress over an existing output hung up (SIGHUP)" "$CSGV" decompress d.csgv keep.nrrd --threads 1
grep -q "hung up (SIGHUP)" "$TMP/err" && pass "SIGHUP's line names it" || bad "SIGHUP's line: $(cat "$TMP/err")"
[ "$(cat keep.nrrd)" = "an older file" ] && pass "the existing output is untouched after SIGHUP" || bad "the existing output changed after SIGHUP"
no_temporaries . "decompress hung up"
(trap '' HUP; exec "$CSGV" compress synth:1024x1024x1024 nohup.csgv --threads 2 >/dev/null 2>"$TMP/err") &
pid=$!
sleep 0.5
kill -HUP "$pid"
sleep 0.6
if kill -0 "$pid" 2>/dev/null; then
  pass "an ignored SIGHUP (nohup) stays ignored"
  kill -INT "$pid"
else
  bad "an ignored SIGHUP ended the tool ($(cat "$TMP/err"))"
fi
wait "$pid"
no_temporaries . "compress under nohup, interrupted"

# --- 5. A relabelled volume without its database is an error, not ids -------------------------
"$CSGV" compress "$SRC" r.csgv --relabel --quiet >/dev/null
mv r_csgv.db3 r_saved.db3
expect_bounded 1 2048 20 "r_csgv.db3.*missing" "decompress of a relabelled volume without its database" \
  "$CSGV" decompress r.csgv r.vraw
[ ! -e r.vraw ] && pass "no output from a volume without its database" || bad "r.vraw written"
mkdir r_csgv.db3
expect_bounded 1 2048 20 "r_csgv.db3.*not a regular file" "the database is a directory" "$CSGV" decompress r.csgv r.vraw
rmdir r_csgv.db3; mkfifo r_csgv.db3
expect_bounded 1 2048 20 "r_csgv.db3.*not a regular file" "the database is a FIFO (never opened)" "$CSGV" decompress r.csgv r.vraw
rm r_csgv.db3; ln -s nowhere_csgv.db3 r_csgv.db3
expect_bounded 1 2048 20 "r_csgv.db3.*link to nothing" "the database is a dangling link" "$CSGV" info r.csgv
rm r_csgv.db3; mv r_saved.db3 r_csgv.db3
expect_bounded 0 2048 20 "" "with its database it decodes" "$CSGV" verify r.csgv "$SRC"

# --- 6. Clear messages ------------------------------------------------------------------------
cp r.csgv.json r_saved.json
python3 - r.csgv.json <<'EOF'
import json, sys
p = sys.argv[1]; j = json.load(open(p)); j["dimensions"] = [10, 20, 30]; json.dump(j, open(p, "w"))
EOF
expect_bounded 1 2048 20 "10x20x30 volume.*133x70x194" ".csgv.json size mismatch names both sizes" "$CSGV" info r.csgv
python3 - r.csgv.json <<'EOF'
import json, sys
p = sys.argv[1]; j = json.load(open(p)); j["dimensions"] = [2**32 + 133, 70, 194]; json.dump(j, open(p, "w"))
EOF
expect_bounded 1 2048 20 "dimensions.*4294967429.*whole number" "7: dimensions of 2^32+133 do not wrap to 133" "$CSGV" info r.csgv
mv r_saved.json r.csgv.json
bad_name=$(printf 'odd\xff\xfename')
mkdir "$bad_name"
expect_bounded 0 2048 30 "" "compress to a non-UTF-8 path" "$CSGV" compress "$SRC" "$bad_name/o.csgv" --quiet
python3 -c 'import json,sys; json.load(open(sys.argv[1], "rb"))' "$bad_name/o.csgv.json" \
  && pass "its metadata is valid JSON" || bad "metadata of a non-UTF-8 path is not JSON"
expect_bounded 0 2048 30 "" "the non-UTF-8 volume verifies" "$CSGV" verify "$bad_name/o.csgv" "$SRC"
expect_bounded 1 300 60 "'decompress' of 'd.csgv' needs more memory.*limit is 300 MiB" \
  "out of memory names the command, the input and the limit" "$CSGV" decompress d.csgv d2.vraw

# --- 7. Sidecars are only read: a WAL-mode database gets no -shm/-wal beside it ---------------
python3 - r_csgv.db3 <<'EOF'
import sqlite3, sys
c = sqlite3.connect(sys.argv[1]); c.execute("PRAGMA journal_mode=WAL"); c.commit(); c.close()
EOF
rm -f r_csgv.db3-shm r_csgv.db3-wal
chmod a-w . 2>/dev/null
expect_bounded 0 2048 20 "" "a WAL-mode database is read" "$CSGV" verify r.csgv "$SRC"
chmod u+w .
expect_bounded 0 2048 20 "" "a WAL-mode database is read in a writable folder" "$CSGV" info r.csgv --stats
[ ! -e r_csgv.db3-shm ] && [ ! -e r_csgv.db3-wal ] && pass "no -shm/-wal written beside the database" \
  || bad "files written beside a sidecar: $(ls r_csgv.db3-* 2>&1)"

# --- A file that crashes libhdf5 itself (1.10.8): refused after a child process met the crash ----
tail -c +2 "$(dirname "$0")/../../Fuzz/crashers/hdf5/h5oopen_local_heap_null_memcpy" > crash.h5
for target in crash.h5 crash.h5:/data; do
  expect_bounded 1 2048 30 "crash\.h5.*libhdf5 crashed \(Segmentation fault\).*separate process" \
    "$target: libhdf5's crash stays in a child" "$CSGV" info "$target"
done
expect_bounded 1 2048 30 "libhdf5 crashed" "compress of it too" "$CSGV" compress crash.h5 crash.csgv
[ ! -e crash.csgv ] && [ -z "$(ls core* 2>/dev/null)" ] && pass "no output and no core file" || bad "crash.csgv or a core file left"

# The immutable URI keeps every path a path: '?', '#', '%' in folder names, and '//' in front.
mkdir -p 'q?#%x' && cp r.csgv r.csgv.json r_csgv.db3 'q?#%x/'
expect_bounded 0 2048 20 "" "a database in a folder named 'q?#%x' is read" "$CSGV" verify 'q?#%x/r.csgv' "$SRC"
expect_bounded 0 2048 20 "" "a database under a path starting with //" "$CSGV" verify "/$TMP/r.csgv" "$SRC"

finish
