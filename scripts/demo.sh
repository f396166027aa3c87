#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The main job on a fresh Debian 12 machine: install, build the ParaView plugin, then run the
# pvpython demo (Examples/render_aal.py): the AAL brain atlas from NIfTI to .csgv, shown as a
# Segmentation Volume with an opaque slice through it, saved with local shading and with path
# tracing. Usage: scripts/demo.sh [OUTPUT_DIR] (default: $BUILD/demo); extra options after the
# folder go to the example (e.g. --size 1280x720 --pt-frames 64).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD=${BUILD:-build}
SHARED=${CSGV_SHARED_DIR:-$(cd .. && pwd)/shared}
OUT=${1:-$BUILD/demo}
shift || true
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCSGV_SHARED_DIR="$SHARED" \
  -DPython3_EXECUTABLE=/usr/bin/python3
cmake --build "$BUILD" -j "${JOBS:-2}" --target csgv CSGV
PLUGIN="$PWD/$BUILD/lib/paraview-5.11/plugins/CSGV/CSGV.so"
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
# ParaView and Mesa write caches under HOME: keep them out of the user's.
DEMO_HOME=$(mktemp -d)
trap 'rm -rf "$DEMO_HOME"' EXIT
HOME="$DEMO_HOME" xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" \
  pvpython --force-offscreen-rendering Examples/render_aal.py "$OUT" --plugin "$PLUGIN" "$@"
echo "PNGs: $OUT/aal_local.png $OUT/aal_pathtraced.png (and the .csgv: $OUT/aal.csgv)"
