#!/bin/bash
# SPDX-License-Identifier: MIT
# Instructions lavapipe's JIT code executes for a `csgv render` (valgrind's callgrind, one lavapipe
# thread): a deterministic figure for comparing shader changes on CPU devices, where frame times
# on a noisy machine move by 10 % between runs. Prints "JIT M of total M" (millions).
#   Testing/Benchmarks/jit_instructions.sh CSGV_TOOL VOLUME [SIZE] [SHADING] [FRAMES] [extra render options]
# e.g. Testing/Benchmarks/jit_instructions.sh build/bin/csgv /tmp/s.csgv 640x360 local 4 --no-denoise
# Run it once before measuring: the first run also compiles the shaders (Mesa and csgv cache them).
set -euo pipefail
if [ $# -lt 2 ]; then
    echo "usage: jit_instructions.sh CSGV_TOOL VOLUME [SIZE] [SHADING] [FRAMES] [extra render options]" >&2
    exit 2
fi
[ -x "$1" ] || { echo "jit_instructions.sh: $1 is not an executable csgv tool" >&2; exit 2; }
[ -f "$2" ] || { echo "jit_instructions.sh: no volume $2" >&2; exit 2; }
tool=$1 volume=$2 size=${3:-640x360} shading=${4:-local} frames=${5:-4}
shift $(($# < 5 ? $# : 5))
command -v valgrind > /dev/null || { echo "jit_instructions.sh: valgrind is not installed" >&2; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
LP_NUM_THREADS=1 valgrind --tool=callgrind --smc-check=all-non-file --callgrind-out-file="$out/cg" \
    "$tool" render "$volume" "$out/image.png" --size "$size" --shading "$shading" --frames "$frames" "$@" > "$out/log" 2>&1 ||
    { tail -5 "$out/log" >&2; exit 1; }
# JIT code has no object file: callgrind names it "???".
callgrind_annotate --inclusive=no --threshold=100 "$out/cg" 2> /dev/null | awk '
    /\?\?\?:0x.*\[\?\?\?\]/ { gsub(",", "", $1); jit += $1 }
    / PROGRAM TOTALS/ { gsub(",", "", $1); total = $1 }
    END { printf "JIT %.1f M of %.1f M instructions\n", jit / 1e6, total / 1e6 }'
