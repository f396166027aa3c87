#!/usr/bin/env bash
# Packs what the GPU checks need into .devbundle/ (ignored by git) for a machine that has an
# NVIDIA driver but neither our build dependencies nor a Vulkan loader: the built csgv tool and
# GPU tests, the shared libraries they load beyond the C and C++ runtimes, the Vulkan loader and
# glvnd's dispatch libraries from this machine, and the Volcanite fixtures.
# Usage: bash scripts/device/bundle.sh [BUILD_DIR]   (then carry .devbundle, run gpu_check.sh)
# BASE_BUILD=DIR also packs DIR/bin/csgv (another commit's build, same libraries) as the baseline
# that gpu_check.sh renders beside this one, on the same machine. VOLCANITE=DIR packs a headless
# Volcanite (scripts/device/build_volcanite.sh) for volcanite_check.sh.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
out=$root/.devbundle
grep -qx '/.devbundle/' "$root/.git/info/exclude" 2>/dev/null || echo /.devbundle/ >>"$root/.git/info/exclude"
rm -rf "$out" && mkdir -p "$out/bin" "$out/lib" "$out/shared/data"
cp "$build/bin/csgv" "$build/bin/csgv_gpu_tests" "$out/bin/"
# the C/C++ runtimes stay the target's own (a newer libstdc++ serves older binaries)
skip='^(linux-vdso|ld-linux|libc\.|libm\.|libpthread|libdl\.|librt\.|libstdc\+\+|libgcc_s)'
for b in "$out"/bin/*; do
    ldd "$b" | awk '$3 ~ /^\// {print $1, $3}' | while read -r name path; do
        [[ $name =~ $skip ]] || cp -Lu "$path" "$out/lib/$name"
    done
done
for l in libvulkan.so.1 libGLdispatch.so.0 libGLX.so.0 libEGL.so.1 libOpenGL.so.0; do
    cp -L "/lib/x86_64-linux-gnu/$l" "$out/lib/"
done
cp -r "$root/../shared/data/volcanite-0.6" "$out/shared/data/"
# volumes to render besides synthetic ones: VOLUMES="a.csgv b.csgv" (with their .json)
mkdir -p "$out/volumes"
for v in ${VOLUMES:-}; do cp "$v" "$v.json" "$out/volumes/" 2>/dev/null || cp "$v" "$out/volumes/"; done
if [ -n "${BASE_BUILD:-}" ]; then
    mkdir -p "$out/base" && cp "$BASE_BUILD/bin/csgv" "$out/base/csgv"
    strip --strip-unneeded "$out/base/csgv"
    (cd "$BASE_BUILD/.." && git rev-parse --short HEAD 2>/dev/null) >"$out/base/commit" || true
fi
# VOLCANITE=DIR (a headless build by build_volcanite.sh): the peer renderer for volcanite_check.sh,
# its libraries, and the shader folders it reads by the absolute paths it was built with.
if [ -n "${VOLCANITE:-}" ]; then
    mkdir -p "$out/volcanite"
    cp "$VOLCANITE/build/volcanite/volcanite" "$out/volcanite/"
    strip --strip-unneeded "$out/volcanite/volcanite"
    ldd "$out/volcanite/volcanite" | awk '$3 ~ /^\// {print $1, $3}' | while read -r name path; do
        [[ $name =~ $skip ]] || cp -Lu "$path" "$out/lib/$name"
    done
    tar -C / -cf "$out/volcanite/data.tar" "${VOLCANITE#/}/lib/vvv/data" "${VOLCANITE#/}/volcanite/data"
    cp "$VOLCANITE/COMMIT" "$out/volcanite/commit" 2>/dev/null || true
fi
strip --strip-unneeded "$out"/bin/*
du -sh "$out"
