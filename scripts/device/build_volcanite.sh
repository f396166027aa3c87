#!/usr/bin/env bash
# Builds Volcanite (the paper's own renderer, our peer in issue 42's table) headless from a git
# copy of its public repository, here, so a GPU machine runs it without building: bundle.sh
# (VOLCANITE=DEST) packs the binary, and volcanite_check.sh renders the rows with it.
# We only build and run it; nothing of its source enters this repository (DESIGN.md).
# Usage: bash scripts/device/build_volcanite.sh GIT_DIR [DEST]   (DEST: /tmp/volcanite-src)
#   GIT_DIR: a clone or mirror of github.com/max-pio/volcanite (e.g. the session tool `fetch`'s
#   /work/.mirror/max-pio+volcanite/repo). Blobs a mirror left out (its sqlite3.c) are skipped:
#   the build takes Debian's libsqlite3 instead.
# Volcanite reads its shaders at run time from DEST/lib/vvv/data and DEST/volcanite/data (the
# absolute paths it is built with): volcanite_check.sh puts them back there on the GPU machine.
# On lavapipe the binary stops at device set-up (a segmentation fault choosing queue families;
# Volcanite's own Dockerfile says llvmpipe cannot render with it): it is for GPUs. About 10 minutes
# on two cores.
set -euo pipefail
git_dir=${1:?usage: build_volcanite.sh GIT_DIR [DEST]}
dest=${2:-/tmp/volcanite-src}
rm -rf "$dest" && mkdir -p "$dest"
# Every blob of HEAD that the copy holds (a mirror may lack its largest files).
git -C "$git_dir" ls-tree -r HEAD | /usr/bin/python3 -c '
import os, subprocess, sys
dest = sys.argv[1]
objs = [l.rstrip("\n").split("\t", 1) for l in sys.stdin]
cat = subprocess.Popen(["git", "-C", sys.argv[2], "cat-file", "--batch"], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
missing = []
for meta, path in objs:
    mode, kind, sha = meta.split()
    if kind != "blob":
        continue
    cat.stdin.write((sha + "\n").encode()); cat.stdin.flush()
    head = cat.stdout.readline().decode().split()
    if len(head) < 3 or head[1] == "missing":
        missing.append(path); continue
    data = cat.stdout.read(int(head[2])); cat.stdout.read(1)
    out = os.path.join(dest, path)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    if mode == "120000":
        os.symlink(data.decode(), out)
    else:
        with open(out, "wb") as f: f.write(data)
        if mode == "100755": os.chmod(out, 0o755)
print("volcanite source: %d files, %d missing: %s" % (len(objs), len(missing), " ".join(missing)))
' "$dest" "$git_dir"
git -C "$git_dir" rev-parse HEAD >"$dest/COMMIT"
# What its commit (4368e5f, 2025) needs to build headless on Debian 12 (GCC 12, Vulkan headers
# 1.3.239; it is written for the Vulkan SDK's newer ones), each a build fix, nothing else changed:
# - its extern target list names targets a headless build does not make (an IDE folder property);
# - `handle == VK_NULL_HANDLE` on a vk::PipelineCache is ambiguous with these headers: `!handle`;
# - before header 255 it names vk::detail::DynamicLoader, which these headers call vk::DynamicLoader;
# - a file uses size_t without <cstddef>, and the renderer includes vvvwindow/App.hpp (headers
#   only) in a headless build too: CMAKE_CXX_FLAGS_RELEASE adds both (its CMakeLists sets
#   CMAKE_CXX_FLAGS itself).
sed -i 's/^set_target_properties(${EXT_TARGETS} PROPERTIES FOLDER extern)/# (IDE folder property dropped for a headless build)/' \
    "$dest/CMake/Dependencies.cmake"
sed -i 's/m_pipelineCache == VK_NULL_HANDLE/!m_pipelineCache/' "$dest/lib/vvv/include/vvv/core/GpuContext.hpp"
sed -i 's/static vk::detail::DynamicLoader dl;/static vk::DynamicLoader dl;/' "$dest/lib/vvv/src/core/DefaultGpuContext.cpp"
cmake -S "$dest" -B "$dest/build" -G Ninja -DHEADLESS=ON -DCMAKE_BUILD_TYPE=Release -DVOLCANITE_BUILD_TESTS=OFF \
    -DSQLITECPP_INTERNAL_SQLITE=OFF "-DCMAKE_CXX_FLAGS_RELEASE=-O3 -DNDEBUG -include cstddef -I$dest/lib/vvv-glfw-app/include" \
    >"$dest/cmake.log" 2>&1 || { tail -30 "$dest/cmake.log"; exit 1; }
ninja -C "$dest/build" volcanite
ls -l "$dest/build/volcanite/volcanite"
