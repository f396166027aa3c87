#!/bin/bash
# SPDX-License-Identifier: MIT
# Open to first image, ParaView against `csgv render` (issue 40's target: ParaView within 1.5x of
# csgv render's set-up plus first frame). A benchmark: it prints figures and asserts nothing.
#
#   bash Testing/Benchmarks/bench_open_to_first_image.sh BUILD FILE.csgv [RUNS] [--cold]
#
# Alternates `csgv render FILE --size 640x360 --frames 1` (its time_to_first_frame_ms: process
# start to the first frame read back) with bench_host_copies.py in pvpython (OpenDataFile to the
# first Segmentation Volume still render of one frame, 640x360), RUNS times each, and prints each
# pair and the median ratio. --cold drops the page cache before every run (root only): the file is
# then read from disk by both. Both use the same HOME, so both find their shaders compiled.
set -u
build=$1 file=$2 runs=${3:-3} cold=${4:-}
plugin=$build/lib/paraview-5.11/plugins/CSGV/CSGV.so
here=$(cd "$(dirname "$0")" && pwd)
drop() { if [ "$cold" = "--cold" ]; then sync; echo 3 > /proc/sys/vm/drop_caches; fi; }
ratios=()
for i in $(seq 1 "$runs"); do
  drop
  c=$("$build/bin/csgv" render "$file" /tmp/bench_otfi.png --size 640x360 --frames 1 2>/dev/null |
      awk '/^time_to_first_frame_ms:/ {print $2 / 1000}')
  drop
  p=$(xvfb-run -a -s "-screen 0 1280x1024x24" pvpython "$here/bench_host_copies.py" "$plugin" "$file" 2>/dev/null |
      awk '/^open_to_first_image_seconds:/ {print $2}')
  r=$(awk -v p="$p" -v c="$c" 'BEGIN { printf "%.2f", p / c }')
  echo "run $i: csgv_render_first_frame_s $c paraview_open_to_first_image_s $p ratio $r"
  ratios+=("$r")
done
printf '%s\n' "${ratios[@]}" | sort -n | awk '{ a[NR] = $1 } END { print "median_ratio:", a[int((NR + 1) / 2)] }'
