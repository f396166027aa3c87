#!/usr/bin/env bash
# Runs on the lent GPU machine from the repository root, with .devbundle carried
# (scripts/device/bundle.sh): the gpu tests, then csgv render at 1920x1080 in every shading mode
# on synthetic volumes and the AAL-like fixtures. Results go to $OUT (or ./devout).
# Usage: bash scripts/device/gpu_check.sh [SIZES] [MODES]   (on the device: it puts the bundle's
# binaries into build/bin, over a local build's). After each volume's modes it renders the first
# mode once more, its shaders cached ("warm" time to first frame), and it prints each render's
# mean dispatch time by stage.
# Every render uses Volcanite 0.6's default orbital pose (--camera volcanite), orbited about +z.
# After the modes, a moving-camera row: MOVING (32) poses of that orbit, one frame each
# (--frames-per-view 1, previews allowed, as an interactive view and Volcanite show them): its
# median frame and the whole path's time.
# With BUDGET_MIB (e.g. 560 for synth 2048^3): a budget row per volume, a 16-view orbit at --finest
# with GPU decoding, unconstrained and under that device-memory budget: frames, the largest view's
# working set against the brick cache (cache_holds_view), detail streams uploaded and evicted.
# Environment: SKIP_TESTS=1 (renders only), SIZE (1920x1080), FRAMES (16), ORBIT (6), MOVING (32), and
# RENDER_ARGS (more csgv render options, e.g. "--decode host --cache-mib 256") with TAG (a name
# for the logs and images of that variant). With a baseline in the bundle (bundle.sh's BASE_BUILD),
# each render runs with it too, right after, and its line says "base" (compare on one machine;
# the first of the two compiles the GLSL of shaders they share: compare times to first frame warm).
set -uo pipefail
root=$(pwd)
out=${OUT:-$root/devout}; mkdir -p "$out"
res=/tmp/csgv-gpu-results; mkdir -p $res  # packed into $OUT/results.tgz (few files come back)
b=$root/.devbundle
export LD_LIBRARY_PATH=$b/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
for j in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json \
         /etc/vulkan/icd.d/nvidia_icd.json; do
    [ -f "$j" ] && { export VK_DRIVER_FILES=$j VK_ICD_FILENAMES=$j; break; }
done
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
if [ -z "${SKIP_TESTS:-}" ]; then
    timeout 240 build/bin/csgv_gpu_tests --gtest_brief=1 >"$out/gpu_tests.log" 2>&1; echo "gpu_tests rc $?"
    grep -E "FAILED|PASSED|tests ran" "$out/gpu_tests.log" | head -30
    echo "gpu tests: $(( $(date +%s) - t0 )) s"
    bash Testing/VulkanBackend/test_csgv_render.sh "$csgv" /work/shared/data/volcanite-0.6 >"$res/render_tool.log" 2>&1
    echo "csgv_render_tool rc $?"
fi
for n in $sizes; do  # a number: synth:N^3; else a .csgv in .devbundle/volumes
    v=/tmp/s$n.csgv
    if [ -f "$b/volumes/$n.csgv" ]; then v=$b/volumes/$n.csgv
    else [ -f $v ] || "$csgv" compress synth:${n}x${n}x${n} $v --quiet || continue; fi
    for m in $modes; do
        for bin in "$csgv" ${base:+"$base"}; do
            t=${n}_$m${TAG:+_$TAG}; label=${TAG:-}
            [ "$bin" = "$csgv" ] || { t=${t}_base; label="${label:+$label }base"; }
            CSGV_PROFILE_DISPATCHES=1 timeout 60 "$bin" render $v "$res/s$t.png" --size ${SIZE:-1920x1080} \
                --shading $m --frames ${FRAMES:-16} --camera volcanite --orbit ${ORBIT:-6} ${RENDER_ARGS:-} >"$res/r_$t.log" 2>&1
            echo "$n $m $label rc $?: $(grep -E '^(device:|setup_ms|median_frame_ms|time_to_first_frame_ms|frames|converged|device_memory_total_mib|cache_used_mib)' $res/r_$t.log | sed 's/^device: //' | tr '\n' ' ')"
            # Mean ms a dispatch of each stage over the orbit's frames (frames that decode included).
            echo "  stages: $(grep -E '^dispatch [0-9]+ ' $res/r_$t.log | sed -E 's/^dispatch [0-9]+ //; s/ \(.*\)//' |
                awk -F': ' '{n[$1]++; s[$1] += $2} END {for (k in n) printf "%s %.2f, ", k, s[k] / n[k]}')"
        done
    done
    # A moving camera: one frame a pose along the orbit (the first mode).
    m=${modes%% *}
    timeout 120 "$csgv" render $v "$res/s${n}_${m}_moving.png" --size ${SIZE:-1920x1080} --shading $m --camera volcanite \
        --orbit ${MOVING:-32} --frames-per-view 1 ${RENDER_ARGS:-} >"$res/r_${n}_${m}_moving.log" 2>&1
    echo "$n $m moving rc $?: $(grep -E '^(views|median_frame_ms|path_ms)' $res/r_${n}_${m}_moving.log | tr '\n' ' ')"
    # Under a device-memory budget: frames to converge a 16-view orbit against unconstrained.
    if [ -n "${BUDGET_MIB:-}" ]; then
        for mib in 0 $BUDGET_MIB; do
            timeout 300 "$csgv" render $v "$res/s${n}_budget$mib.png" --size ${SIZE:-1920x1080} --finest --decode gpu \
                --camera volcanite --orbit 16 --device-memory-mib $mib ${RENDER_ARGS:-} >"$res/r_${n}_budget$mib.log" 2>&1
            echo "$n budget $mib rc $?: $(grep -E '^(frames|path_ms|converged|device_memory_total_mib|view_working_set_mib|cache_holds_view|detail_uploaded_mib|detail_evicted_bricks)' $res/r_${n}_budget$mib.log | cut -c1-160 | tr '\n' ' ')"
        done
    fi
    # The first mode once more: its shaders and pipelines are cached now (time to first frame warm).
    CSGV_PROFILE_DISPATCHES=1 timeout 60 "$csgv" render $v "$res/s${n}_${m}_warm.png" --size ${SIZE:-1920x1080} --shading $m \
        --camera volcanite --frames 1 ${RENDER_ARGS:-} >"$res/r_${n}_${m}_warm.log" 2>&1
    echo "$n $m warm: $(grep -E '^(setup_ms|time_to_first_frame_ms)' $res/r_${n}_${m}_warm.log | tr '\n' ' ')"
done
echo "total: $(( $(date +%s) - t0 )) s"
tar czf "$out/results${TAG:+_$TAG}.tgz" -C $res .
