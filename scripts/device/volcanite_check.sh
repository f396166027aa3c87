#!/usr/bin/env bash
# Volcanite's side of issue 42's table, on the same machine, files and image size as gpu_check.sh:
# the headless Volcanite that bundle.sh packed (VOLCANITE=DIR, built by build_volcanite.sh)
# renders each volume in each shading mode from its own default camera (the pose `csgv render
# --camera volcanite` takes) to an image, and its evaluation log gives the frames it rendered and
# their median, mean and first times; the wall time of the whole run (start-up, reading, the
# frames) is printed beside them.
# Usage (from a copy of the repository with .devbundle/): bash scripts/device/volcanite_check.sh
#   [VOLUMES] [MODES]   (as gpu_check.sh's: numbers are synth:N^3, made with csgv compress if
#   gpu_check.sh has not; names are .devbundle/volumes/NAME.csgv; modes local shadow ao pt)
# Environment: SIZE (1920x1080), OUT (./devout), VTIMEOUT (120 s a render), VARGS (more Volcanite
# arguments).
set -uo pipefail
root=$(pwd)
out=${OUT:-$root/devout}; mkdir -p "$out"
res=/tmp/csgv-gpu-results; mkdir -p $res
exec > >(tee -a "$out/summary.txt") 2>&1
b=$root/.devbundle
[ -x "$b/volcanite/volcanite" ] || { echo "no Volcanite in the bundle (VOLCANITE=DIR bash scripts/device/bundle.sh)"; exit 1; }
source "$root/scripts/device/device_env.sh"
# Its shaders where it was built to read them.
tar -C / -xf "$b/volcanite/data.tar"
echo "volcanite $(cat "$b/volcanite/commit" 2>/dev/null), icd ${VK_DRIVER_FILES:-none}"
csgv=$b/bin/csgv
log=$res/volcanite_eval.txt
# The evaluation log's format line (Volcanite appends a line a run in it).
echo "#fmt:{name} frames {rendered_frames} med_ms {frame_med_ms:.3} avg_ms {frame_avg_ms:.3} first_ms {frame_ms_00:.3} min_spp {min_spp} gpu_mb {mem_total_mb:.1}" >"$log"
declare -A preset=([local]=local-shading [shadow]=global-shadows [ao]=ambient-occlusion [pt]=path-tracing)
for n in ${1:-"aal 256 512 1024"}; do
    v=$(volume_of "$n" "$csgv") || { echo "$n: no volume"; continue; }
    for m in ${2:-"local shadow ao pt"}; do
        t0=$(date +%s.%N)
        timeout ${VTIMEOUT:-120} "$b/volcanite/volcanite" --headless -r ${SIZE:-1920x1080} --config "${preset[$m]}" \
            -i "$res/volcanite_${n}_$m.png" --eval-logfiles "$log" --eval-name "volcanite $n $m" ${VARGS:-} "$v" \
            >"$res/volcanite_${n}_$m.log" 2>&1
        rc=$?
        wall=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.2f", b - a }')
        echo "volcanite $n $m rc $rc wall_s $wall: $(grep "^volcanite $n $m " "$log" | tail -1 | cut -d' ' -f4-)"
        [ $rc = 0 ] || tail -3 "$res/volcanite_${n}_$m.log"
    done
done
tar -C $res -czf "$out/volcanite_logs.tgz" $(cd $res && ls volcanite_*.log volcanite_eval.txt 2>/dev/null)
