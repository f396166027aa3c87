#!/bin/bash
# SPDX-License-Identifier: MIT
# The render pass alone, at Examples/compare_vtk.py's camera: `csgv render` turns an orbit of
# VIEWS poses about that camera, one frame a pose (a moving camera), with CSGV_PROFILE_DISPATCHES=1,
# and prints the median render dispatch (those over 2 ms: a frame's follow-ups that render a few
# pixels are left out) and the median frame, per run. For comparing shader changes on a CPU device
# run it before and after, interleaved (this machine's runs differ by 5-10 %).
#   Testing/Benchmarks/bench_render_pass.sh CSGV_TOOL VOLUME.csgv [SIZE] [VIEWS] [RUNS] [extra render options]
# e.g. Testing/Benchmarks/bench_render_pass.sh build/bin/csgv synth_512.csgv 1280x720 30 3
set -uo pipefail
if [ $# -lt 2 ]; then
    echo "usage: bench_render_pass.sh CSGV_TOOL VOLUME.csgv [SIZE] [VIEWS] [RUNS] [extra render options]" >&2
    exit 2
fi
[ -x "$1" ] || { echo "bench_render_pass.sh: $1 is not an executable csgv tool" >&2; exit 2; }
[ -f "$2" ] || { echo "bench_render_pass.sh: no volume $2" >&2; exit 2; }
tool=$1 volume=$2 size=${3:-1280x720} views=${4:-30} runs=${5:-3}
shift $(($# < 5 ? $# : 5))
dims=$("$tool" info "$volume" | awk '/^dimensions:/ {print $2, $3, $4}')
[ -n "$dims" ] || { echo "bench_render_pass.sh: $volume: no dimensions from csgv info" >&2; exit 1; }
# compare_vtk.py: the focal point at the bounds' centre, the eye at centre + (0.8, -1.2, 0.7) x the
# bounds' diagonal, up +z, a 30 degree view angle (point bounds: 0 .. dimension - 1).
read -r centre eye < <(python3 -c "
import sys
d = [float(v) - 1 for v in sys.argv[1:4]]
c = [v / 2 for v in d]
g = sum(v * v for v in d) ** 0.5
print('%g,%g,%g %g,%g,%g' % (c[0], c[1], c[2], c[0] + 0.8 * g, c[1] - 1.2 * g, c[2] + 0.7 * g))" $dims)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
median() { sort -n | awk '{a[NR] = $1} END {if (NR) print a[int((NR + 1) / 2)]; else print "-"}'; }
for run in $(seq 1 "$runs"); do
    CSGV_PROFILE_DISPATCHES=1 "$tool" render "$volume" "$out/o.png" --size "$size" --eye "$eye" --center "$centre" \
        --up 0,0,1 --fov-y 30 --frames 1 --orbit "$views" --frames-per-view 1 "$@" > "$out/log" 2>&1 ||
        { tail -3 "$out/log" >&2; exit 1; }
    render=$(grep 'render (' "$out/log" | awk '$(NF-1) > 2 {print $(NF-1)}' | median)
    frame=$(grep -E '^frame [0-9]+:' "$out/log" | awk '{print $3}' | median)
    echo "run $run: render dispatch median $render ms, frame median $frame ms ($views views, $size)"
done
