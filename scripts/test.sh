#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Installs, builds everything and runs the whole test suite (this is what CI runs).
# Tests run under one Xvfb (the ParaView tests need a display) with HOME in a temporary folder,
# because ParaView and Mesa write caches there.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD=${BUILD:-build}
SHARED=${CSGV_SHARED_DIR:-$(cd .. && pwd)/shared}
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCSGV_SHARED_DIR="$SHARED"
cmake --build "$BUILD" -j "${JOBS:-2}"
TEST_HOME=$(mktemp -d)
trap 'rm -rf "$TEST_HOME"' EXIT
cd "$BUILD"
HOME="$TEST_HOME" xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" \
  ctest --output-on-failure -j "${JOBS:-2}" "$@"
