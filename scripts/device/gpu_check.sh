#!/usr/bin/env bash
# Runs on the lent GPU machine from the repository root, with .devbundle carried
# (scripts/device/bundle.sh): the gpu tests, then csgv render at 1920x1080 in every shading mode
# on synthetic volumes and the AAL-like fixtures. Results go to $OUT (or ./devout).
# Usage: bash scripts/device/gpu_check.sh [SIZES] [MODES]   (on the device: it puts the bundle's
# binaries into build/bin, over a local build's). After each volume's modes it renders the first
# mode once more, its shaders cached ("warm" time to first frame). Timed renders run without
# CSGV_PROFILE_DISPATCHES (its timestamp queries slow small frames); each row's stages line comes
# from a second, profiled render (PROFILE=0 skips those): mean ms a dispatch of each stage.
# static_ms: the median of the frames that decode nothing, miss no brick and sample at least 70 %
# as many pixels as the orbit's fullest frame (a still camera after its bricks are in the cache;
# "none" where every such frame decodes), with how many there were.
# Every render uses Volcanite 0.6's default orbital pose (--camera volcanite), orbited about +z.
# After the modes, a moving-camera row: MOVING (32) poses of that orbit, one frame each
# (--frames-per-view 1, previews allowed, as an interactive view and Volcanite show them): its
# median frame and the whole path's time, and how much of each pose's frame shows what its
# converged image shows (as_converged_pct: --compare-converged, a second renderer, not timed;
# COMPARE= leaves it out).
# With BUDGET_MIB (e.g. 560 for synth 2048^3): a budget row per volume, a 16-view orbit at --finest
# with GPU decoding, unconstrained and under that device-memory budget: frames, the largest view's
# working set against the brick cache (cache_holds_view), detail streams uploaded and evicted.
# The warm run's stages line gives each stage's total ms over the first frame (and its dispatch count).
# Environment: BUDGET_SIZES (the volumes that get the budget row; default all), BUDGET_TIMEOUT
# (300 s a budget render), SKIP_TESTS=1 (renders only), PROFILE=0, SIZE (1920x1080), FRAMES (16),
# ORBIT (6), MOVING (32), and RENDER_ARGS (more csgv render options, e.g. "--decode host" or
# "--decode-steps all") with TAG (a name for the logs of that variant; its summary lines append to
# the same summary.txt, its logs go to results_TAG.tgz, the images stay on the machine). With a baseline in the bundle (bundle.sh's BASE_BUILD),
# each render runs with it too, right after, and its line says "base" (compare on one machine;
# the first of the two compiles the GLSL of shaders they share: compare times to first frame warm).
set -uo pipefail
root=$(pwd)
out=${OUT:-$root/devout}; mkdir -p "$out"
res=/tmp/csgv-gpu-results; mkdir -p $res  # packed into $OUT/results.tgz after each volume (few files come back)
exec > >(tee -a "$out/summary.txt") 2>&1  # what it printed comes back even if the run is cut short
b=$root/.devbundle
source "$root/scripts/device/device_env.sh"
echo "icd: ${VK_DRIVER_FILES:-none}"; nvidia-smi -L 2>&1 | head -2
# the tests name the source tree and fixtures by the paths they were built with
mkdir -p /work
[ -e /work/main ] || ln -s "$root" /work/main
[ -e /work/shared ] || ln -s "$b/shared" /work/shared
mkdir -p build/bin && cp -f "$b"/bin/* build/bin/
export HOME=$(mktemp -d) OMP_NUM_THREADS=${OMP_NUM_THREADS:-16}
csgv=$root/build/bin/csgv
base=; [ -x "$b/base/csgv" ] && { base=$b/base/csgv; echo "baseline: $(cat "$b/base/commit" 2>/dev/null)"; }
sizes=${1:-"aal 256 512 1024"}; modes=${2:-"local shadow ao pt"}
t0=$(date +%s)
# summary KEY...: the render log's lines of those keys on one line
summary() { grep -E "^($2)" "$1" | sed 's/^device: //' | cut -c1-160 | tr '\n' ' '; }
# static LOG: median ms of full frames that decoded nothing (fields of csgv render's frame lines)
static() { sed 's/,//g' "$1" | awk '/^frame [0-9]+:/ {n++; T[n]=$3; D[n]=$6; S[n]=$10+0; M[n]=$12+0; if (S[n] > mx) mx = S[n]}
    END {for (i = 1; i <= n; i++) if (D[i]==0 && M[i]==0 && S[i] >= 0.7 * mx) print T[i]}' | sort -g |
    awk '{v[NR]=$1} END {print NR ? v[int((NR+1)/2)] " (" NR " frames)" : "none"}'; }
# stages LOG [total]: mean ms a dispatch of each stage (total: the sum and count instead)
stages() { grep -E '^dispatch [0-9]+ ' "$1" | sed -E 's/^dispatch [0-9]+ //; s/ \(.*\)//' |
    awk -F': ' -v tot="${2:-}" '{n[$1]++; s[$1] += $2} END {for (k in n) if (tot) printf "%s %.2f (%d), ", k, s[k], n[k];
        else printf "%s %.2f, ", k, s[k] / n[k]}'; }
# render NAME SECONDS ARGS...: the timed render, then (PROFILE) the same profiled; logs r_NAME[_prof].log
render() {
    local name=$1 secs=$2; shift 2
    timeout $secs "$bin" render $v "$res/s$name.png" --size ${SIZE:-1920x1080} "$@" ${RENDER_ARGS:-} >"$res/r_$name.log" 2>&1
    local rc=$?
    if [ "${PROFILE:-1}" != 0 ]; then
        local prof=() x # the stages of the timed renderer alone: no converged images beside it
        for x in "$@"; do [ "$x" = --compare-converged ] || prof+=("$x"); done
        CSGV_PROFILE_DISPATCHES=1 timeout $secs "$bin" render $v "$res/s${name}_prof.png" --size ${SIZE:-1920x1080} "${prof[@]}" \
            ${RENDER_ARGS:-} >"$res/r_${name}_prof.log" 2>&1
    fi
    return $rc
}
if [ -z "${SKIP_TESTS:-}" ]; then
    timeout 240 build/bin/csgv_gpu_tests --gtest_brief=1 >"$out/gpu_tests.log" 2>&1; echo "gpu_tests rc $?"
    grep -E "FAILED|PASSED|tests ran" "$out/gpu_tests.log" | head -30
    echo "gpu tests: $(( $(date +%s) - t0 )) s"
    timeout 90 bash Testing/VulkanBackend/test_csgv_render.sh "$csgv" /work/shared/data/volcanite-0.6 >"$res/render_tool.log" 2>&1
    echo "csgv_render_tool rc $?"
fi
for n in $sizes; do  # a number: synth:N^3; else a .csgv in .devbundle/volumes
    v=$(volume_of "$n" "$csgv") || { echo "$n: no volume"; continue; }
    for m in $modes; do
        for bin in "$csgv" ${base:+"$base"}; do
            t=${n}_$m${TAG:+_$TAG}; label=${TAG:-}
            [ "$bin" = "$csgv" ] || { t=${t}_base; label="${label:+$label }base"; }
            render $t 60 --shading $m --frames ${FRAMES:-16} --camera volcanite --orbit ${ORBIT:-6}
            echo "$n $m $label rc $?: $(summary $res/r_$t.log 'device:|setup_ms|median_frame_ms|time_to_first_frame_ms|frames|converged|device_memory_total_mib|cache_used_mib') static_ms: $(static $res/r_$t.log)"
            [ -f $res/r_${t}_prof.log ] && echo "  stages: $(stages $res/r_${t}_prof.log)"
        done
    done
    # A moving camera: one frame a pose along the orbit (the first mode).
    m=${modes%% *}; bin=$csgv; t=${n}_${m}_moving${TAG:+_$TAG}
    render $t 120 --shading $m --camera volcanite --orbit ${MOVING:-32} --frames-per-view 1 ${COMPARE---compare-converged}
    echo "$n $m moving rc $?: $(summary $res/r_$t.log 'views|median_frame_ms|path_ms|as_converged_pct')"
    [ -f $res/r_${t}_prof.log ] && echo "  stages: $(stages $res/r_${t}_prof.log)"
    # Under a device-memory budget: frames to converge a 16-view orbit against unconstrained.
    if [ -n "${BUDGET_MIB:-}" ] && [[ " ${BUDGET_SIZES:-$n} " == *" $n "* ]]; then
        for mib in 0 $BUDGET_MIB; do
            timeout ${BUDGET_TIMEOUT:-300} "$csgv" render $v "$res/s${n}_budget$mib.png" --size ${SIZE:-1920x1080} --finest --decode gpu \
                --camera volcanite --orbit 16 --device-memory-mib $mib ${RENDER_ARGS:-} >"$res/r_${n}_budget$mib.log" 2>&1
            echo "$n budget $mib rc $?: $(summary $res/r_${n}_budget$mib.log 'frames|path_ms|converged|device_memory_total_mib|view_working_set_mib|cache_holds_view|detail_uploaded_mib|detail_evicted_bricks')"
        done
    fi
    # The first mode once more: its shaders and pipelines are cached now (time to first frame warm);
    # the stages line sums each stage over the frames up to the first full one.
    t=${n}_${m}_warm${TAG:+_$TAG}
    render $t 60 --shading $m --camera volcanite --frames 1
    echo "$n $m warm: $(summary $res/r_$t.log 'setup_ms|time_to_first_frame_ms')"
    [ -f $res/r_${t}_prof.log ] && echo "  stages: $(stages $res/r_${t}_prof.log total)"
    tar czf "$out/results${TAG:+_$TAG}.tgz" -C $res --exclude='*.png' .  # the images stay (size)
done
echo "total: $(( $(date +%s) - t0 )) s"
