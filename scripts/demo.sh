#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The main job on a fresh Debian 12 machine: install, build, then open a real segmentation
# written by Volcanite, check every brick and print its statistics.
# (Later issues turn this into the ParaView demo: compress, render through the plugin, write an image.)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD=${BUILD:-build}
SHARED=${CSGV_SHARED_DIR:-$(cd .. && pwd)/shared}
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCSGV_SHARED_DIR="$SHARED"
cmake --build "$BUILD" --target csgv
"$BUILD"/bin/csgv info --check --stats "$SHARED/data/volcanite-0.6/synthA_b32_rans2.csgv"
