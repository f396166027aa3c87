#!/usr/bin/env bash
# Issue 42's table in one call on a lent GPU, both peers on the same machine, volume by volume:
# the gpu tests first, then for each volume Volcanite's modes (volcanite_check.sh), ours as
# Volcanite renders them (STILL: one pose, Volcanite's frame count in that mode, the whole run's
# wall time; its first frame's time apart), then gpu_check.sh's rows (an orbit, a moving camera,
# the warm first frame), so a call cut short still returns whole rows. Needs a bundle with
# Volcanite (VOLUMES=aal.csgv VOLCANITE=/tmp/volcanite-src bash scripts/device/bundle.sh).
# Usage: bash scripts/device/side_by_side.sh [VOLUMES] [MODES]   (default "aal 256 512 1024 2048",
#   "local shadow ao pt"; BIG_MODES (default local) for 2048, whose encoding takes a minute to make)
# With a baseline in the bundle (BASE_BUILD), ours as Volcanite renders them runs it too ("base").
# Environment: as the two scripts' (VTIMEOUT defaults to 20 s a Volcanite render here, PROFILE to
# 0); ORBITS=0 leaves gpu_check.sh's rows out, STILL=0 ours as Volcanite renders, PEER= Volcanite.
# STILL_ARGS (e.g. "--lod-bias 0.5"): ours as Volcanite renders once more with those options
# ("var"); IMAGES (e.g. "2048"): those volumes' still images, both peers', come back in images/
# (to compare the level of detail each draws: lavapipe, 2048^3 at 1920x1080, took 22-31 % less
# render time with --lod-bias 0.5, a level coarser where a voxel is 1-1.4 pixels wide).
set -uo pipefail
root=$(pwd)
vols=${1:-"aal 256 512 1024 2048"}; modes=${2:-"local shadow ao pt"}
export VTIMEOUT=${VTIMEOUT:-20} PROFILE=${PROFILE:-0}
out=${OUT:-$root/devout}; mkdir -p "$out"; peer=${PEER-1}
res=/tmp/csgv-gpu-results; mkdir -p $res; touch $res/.started
b=$root/.devbundle
source "$root/scripts/device/device_env.sh"
csgv=$b/bin/csgv
base=; [ -x "$b/base/csgv" ] && base=$b/base/csgv  # bundle.sh's BASE_BUILD
# The frames Volcanite 0.6's presets render from a still camera (its evaluation log on an H200):
# 128 in local shading and shadows, 1024 with ambient occlusion and path tracing.
declare -A vframes=([local]=128 [shadow]=128 [ao]=1024 [pt]=1024)
[ -n "${SKIP_TESTS:-}" ] || bash scripts/device/gpu_check.sh none
for n in $vols; do
    m=$modes; [ "$n" = 2048 ] && m=${BIG_MODES:-local}
    [ -n "$peer" ] && bash scripts/device/volcanite_check.sh "$n" "$m"
    # Two of Volcanite's renders past their time: the rest would be too (they cost the lease).
    late=$(grep -c '^volcanite .* rc 124 ' "$out/summary.txt" 2>/dev/null); [ "${late:-0}" -ge 2 ] && peer=
    if [ "${STILL:-1}" != 0 ] && v=$(volume_of "$n" "$csgv"); then
        for s in $m; do
            for bin in "$csgv" ${base:+"$base"} ${STILL_ARGS:+var}; do  # a baseline, a variant right after
                t=still_${n}_$s; who=ours; extra=()
                [ "$bin" = var ] && { bin=$csgv; t=${t}_var; who=ours_var; read -ra extra <<<"$STILL_ARGS"; }
                [ "$bin" = "$csgv" ] || { t=${t}_base; who=base; }
                t0=$(date +%s.%N)
                timeout 60 "$bin" render "$v" "$res/$t.png" --size ${SIZE:-1920x1080} --shading $s \
                    --frames ${vframes[$s]} --camera volcanite ${extra[@]+"${extra[@]}"} >"$res/$t.log" 2>&1
                rc=$?
                wall=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.2f", b - a }')
                echo "$who $n $s rc $rc wall_s $wall${extra[*]+ (${extra[*]})}: $(grep -E '^(frames|median_frame_ms|time_to_first_frame_ms|setup_ms):' \
                    "$res/$t.log" | cut -c1-60 | tr '\n' ' ')" | tee -a "$out/summary.txt"
            done
        done
        tar -C $res -czf "$out/still_logs.tgz" $(cd $res && ls still_*.log)
        if [[ " ${IMAGES:-} " == *" $n "* ]]; then
            mkdir -p "$out/images"
            for f in $res/still_${n}_*.png $res/volcanite_${n}_*.png; do
                [ "$f" -nt "$res/.started" ] || continue  # not an earlier call's
                [ -f "$f" ] && cp -f "$f" "$out/images/" || echo "$n: no image $f"
            done
        fi
    fi
    [ "${ORBITS:-1}" != 0 ] && SKIP_TESTS=1 bash scripts/device/gpu_check.sh "$n" "$m"
done
