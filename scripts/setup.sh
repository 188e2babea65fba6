#!/usr/bin/env bash
# Installs the Debian packages gradraster needs (only those missing) and
# configures + builds a Release build in ./build. Safe to run repeatedly.
set -euo pipefail
cd "$(dirname "$0")/.."

# shellcheck source=install_missing.sh
source scripts/install_missing.sh
install_missing g++ cmake make pkg-config libeigen3-dev libtbb-dev libtinyobjloader-dev libstb-dev zlib1g-dev catch2 libbenchmark-dev \
  libopenmpi-dev openmpi-bin \
  python3-dev pybind11-dev python3-torch python3-numpy python3-pytest \
  python3-venv python3-pip python3-setuptools python3-wheel \
  libvulkan-dev glslc mesa-vulkan-drivers

build_dir=${GRADRASTER_BUILD_DIR:-build}
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release ${GRADRASTER_CMAKE_ARGS:-} > /dev/null
cmake --build "$build_dir" -j "$(nproc)"
