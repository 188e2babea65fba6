#!/usr/bin/env bash
# Packs what scripts/device_check.sh runs on a lent GPU machine (docs/gpu.md,
# "Measuring on a GPU") into .devcarry/ (git-ignored): a portable x86-64-v3
# build of gradraster-fit, bench_gpu_rasterize, bench_gpu_texture, bench_gpu_op_chain and the [vulkan] tests, the
# shared libraries they load (TBB, Google Benchmark, tinyobjloader, stb, the
# Vulkan loader) and the glmark2 bunny; and into .gl/ Debian's Vulkan loader
# and glvnd packages (both git-ignored). Run it with `carry: [".devcarry", ".gl"]`. Usage: scripts/device_pack.sh [build dir]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-/tmp/gradraster-devbuild}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DGRADRASTER_NATIVE=OFF -DCMAKE_CXX_FLAGS=-march=x86-64-v3 \
  -DGRADRASTER_WITH_PYTHON=OFF -DGRADRASTER_WITH_MPI=OFF -DGRADRASTER_BUILD_TESTS=ON > /dev/null
# gradraster_vulkan_tests: the [vulkan] Catch2 cases alone (tests/CMakeLists.txt;
# the full test binary is not needed there), linked as the test binary is.
cmake --build "$build" -j "$(nproc)" --target gradraster-fit bench_gpu_rasterize bench_gpu_texture \
  bench_gpu_op_chain gradraster_vulkan_tests
rm -rf .devcarry
mkdir -p .devcarry/build/examples/fit .devcarry/build/bench .devcarry/lib
cp "$build/examples/fit/gradraster-fit" .devcarry/build/examples/fit/
cp "$build/bench/bench_gpu_rasterize" "$build/bench/bench_gpu_texture" "$build/bench/bench_gpu_op_chain" \
  .devcarry/build/bench/
cp "$build/tests/gradraster_vulkan_tests" .devcarry/build/bench/vulkan_tests
for lib in libtbb.so.12 libbenchmark.so.1debian libtinyobjloader.so.2rc10 libstb.so.0 libvulkan.so.1; do
  cp -L "/lib/x86_64-linux-gnu/$lib" .devcarry/lib/
done
cp /usr/share/glmark2/models/bunny.obj .devcarry/
# Debian's Vulkan loader and glvnd, unpacked there by device_check.sh (NVIDIA's
# driver needs glvnd's libraries, which the GPU image lacks).
rm -rf .gl && mkdir -p .gl /tmp/amd64/partial
apt_amd64=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64)
apt-get "${apt_amd64[@]}" update > /dev/null
(cd .gl && apt-get "${apt_amd64[@]}" download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
du -sh .devcarry
