#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Issue 42's budget goal: an orbit under a brick cache that holds its largest view converges within
# twice the frames it takes unconstrained. For each volume, image size and shading mode, `csgv
# render` orbits (ORBIT views, Volcanite's default pose, GPU decoding) unconstrained, reads the
# largest view's working set from its summary (view_working_set_mib), and orbits again with a
# cache of that size times each of MULTS (rounded up to a MiB). Prints one row a run and the
# largest ratio of frames.
# Usage: bash Testing/Benchmarks/bench_budget_grid.sh build/bin/csgv VOLUME.csgv...
# Environment: SIZES ("160x120 480x270"), MODES ("local shadow"), ORBIT (8), MULTS ("1.02 1.25"),
# LEVELS ("--finest"; "" lets the distance choose each brick's level).
set -uo pipefail
csgv=${1:?usage: bench_budget_grid.sh CSGV VOLUME...}; shift
[ $# -gt 0 ] || { echo "usage: bench_budget_grid.sh CSGV VOLUME..." >&2; exit 2; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
worst=0
field() { awk -v k="$1:" '$1 == k { print $2; exit }' "$2"; }
for v in "$@"; do
    for size in ${SIZES:-160x120 480x270}; do
        for m in ${MODES:-local shadow}; do
            args=(--size "$size" ${LEVELS---finest} --decode gpu --camera volcanite --orbit "${ORBIT:-8}" --shading "$m")
            "$csgv" render "$v" "$tmp/o.png" "${args[@]}" >"$tmp/free.log" 2>&1 || { echo "$v $size $m: render failed"; continue; }
            free=$(field frames "$tmp/free.log"); ws=$(field view_working_set_mib "$tmp/free.log")
            # (a cache of 0 MiB would be the automatic one: no row without a working set)
            [ "${free:-0}" -gt 0 ] 2>/dev/null && awk -v w="${ws:-0}" 'BEGIN { exit !(w > 0) }' ||
                { echo "$v $size $m: no frame count or working set in the summary"; continue; }
            for mult in ${MULTS:-1.02 1.25}; do
                mib=$(awk -v w="$ws" -v m="$mult" 'BEGIN { c = w * m; print (c == int(c)) ? c : int(c) + 1 }')
                "$csgv" render "$v" "$tmp/o.png" "${args[@]}" --cache-mib "$mib" >"$tmp/c.log" 2>&1 ||
                    { echo "$v $size $m: render with a $mib MiB cache failed"; continue; }
                frames=$(field frames "$tmp/c.log"); holds=$(grep -o '^cache_holds_view: [a-z]*' "$tmp/c.log" | cut -d' ' -f2)
                ratio=$(awk -v a="$frames" -v b="$free" 'BEGIN { printf "%.2f", a / b }')
                worst=$(awk -v a="$ratio" -v b="$worst" 'BEGIN { print (a > b) ? a : b }')
                echo "$(basename "$v") $size $m: $free frames unconstrained (largest view $ws MiB); cache $mib MiB: $frames frames (holds the view: $holds), ratio $ratio"
            done
        done
    done
done
echo "largest ratio: $worst"
