#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Installs every Debian 12 package the project needs (all layers), idempotently: when all are
# present it only checks and returns in about a second. Run as root or with sudo available.
set -euo pipefail

# Build tools and the codec (Core, Tools, Testing).
PKGS_CORE=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  zlib1g-dev libzstd-dev zstd gzip libsqlite3-dev sqlite3 libpng-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev clang libclang-rt-14-dev libomp-dev
  libcli11-dev libssl-dev
  mricron-data
  libhdf5-dev libtiff-dev libblosc-dev
  python3-numpy python3-h5py python3-tifffile python3-zarr
  valgrind
)
# Vulkan backend (lavapipe is the CPU device every GPU test runs on).
PKGS_VULKAN=(
  libvulkan-dev mesa-vulkan-drivers glslang-dev glslang-tools spirv-tools libglm-dev vulkan-tools
  vulkan-validationlayers
)
# ParaView 5.11 plugin: paraview-dev alone does not satisfy find_package(ParaView)
# (see shared/PARAVIEW-NOTES.md); never libvtk9-dev, it conflicts with python3-paraview.
PKGS_PARAVIEW=(
  paraview paraview-dev python3-paraview python3-dev
  qtbase5-dev libqt5opengl5-dev libqt5svg5-dev qttools5-dev
  libopenmpi-dev openmpi-bin libglew-dev liblz4-dev libdouble-conversion-dev libutfcpp-dev
  libnetcdf-dev libtheora-dev libgl2ps-dev libgdal-dev libavformat-dev libavcodec-dev
  libavutil-dev libswscale-dev libswresample-dev libeigen3-dev libboost-dev
  xvfb xauth xdotool
)

ALL=("${PKGS_CORE[@]}" "${PKGS_VULKAN[@]}" "${PKGS_PARAVIEW[@]}")

missing=()
for p in "${ALL[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$'; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#ALL[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "setup: done"
