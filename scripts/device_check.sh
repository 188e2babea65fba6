#!/usr/bin/env bash
# Runs on a lent GPU machine over the files scripts/device_pack.sh put in
# .devcarry/ (docs/gpu.md, "Measuring on a GPU"): the machine, the [vulkan]
# tests on its GPU, bench_gpu_rasterize (GPU against CPU, tri_id compared), bench_gpu_texture,
# bench_gpu_op_chain (the ops' chain, and a batch's calls deferred against waited for), and the
# fit example's thread scaling (bench/fit_threads.sh). Writes logs to
# $OUT (or ./device-out). Usage: scripts/device_check.sh [fit rounds]
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-device-out}; mkdir -p "$out"
rounds=${1:-3}
export LD_LIBRARY_PATH=$PWD/.devcarry/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export GRADRASTER_BENCH_BUNNY=$PWD/.devcarry/bunny.obj
bin=.devcarry/build/bench
{
  date -u; nproc; lscpu | grep -m1 'Model name'
  nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1
} | tee "$out/machine.txt"
# NVIDIA's Vulkan driver loads through glvnd: unpack Debian's loader and glvnd
# libraries, fetched into .gl/ by device_pack.sh (the image has none).
for f in .gl/*.deb; do [[ -f $f ]] && dpkg -x "$f" /; done
ldconfig
# The loader finds NVIDIA's driver through its ICD file; where the image keeps it elsewhere, name it.
for f in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json; do
  [[ -f $f ]] && export VK_DRIVER_FILES=$f VK_ICD_FILENAMES=$f
done
if ! timeout 120 "$bin/vulkan_tests" '[vulkan]' > "$out/vulkan_tests.txt" 2>&1 || grep -q 'no Vulkan device' "$out/vulkan_tests.txt"; then
  for f in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json \
           /etc/vulkan/icd.d/nvidia_icd.json; do
    [[ -f $f ]] && export VK_DRIVER_FILES=$f VK_ICD_FILENAMES=$f && break
  done
  echo "retrying with VK_DRIVER_FILES=${VK_DRIVER_FILES:-none}" | tee -a "$out/machine.txt"
  timeout 120 "$bin/vulkan_tests" '[vulkan]' > "$out/vulkan_tests.txt" 2>&1
fi
tail -3 "$out/vulkan_tests.txt"
# The SM clock before and after (an idle GPU runs slower; docs/gpu.md).
nvidia-smi --query-gpu=clocks.sm,clocks.max.sm --format=csv,noheader 2>&1 | sed 's/^/clock before: /' | tee -a "$out/machine.txt"
timeout 300 "$bin/bench_gpu_rasterize" --benchmark_min_time=0.1 --benchmark_repetitions=5 \
  --benchmark_report_aggregates_only=true --benchmark_out="$out/gpu_rasterize.json" 2>&1 | tee "$out/gpu_rasterize.txt" |
  grep -E 'median|Benchmark|rror'
nvidia-smi --query-gpu=clocks.sm,clocks.max.sm --format=csv,noheader 2>&1 | sed 's/^/clock after: /' | tee -a "$out/machine.txt"
timeout 120 "$bin/bench_gpu_texture" --benchmark_min_time=0.1 --benchmark_repetitions=5 \
  --benchmark_report_aggregates_only=true --benchmark_out="$out/gpu_texture.json" 2>&1 | tee "$out/gpu_texture.txt" |
  grep -E 'median|Benchmark|rror'
timeout 180 "$bin/bench_gpu_op_chain" --benchmark_filter='BatchChain|OpChain/backend:1' --benchmark_min_time=0.1 \
  --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true --benchmark_report_aggregates_only=true \
  --benchmark_out="$out/gpu_op_chain.json" 2>&1 | tee "$out/gpu_op_chain.txt" | grep -E 'median|Benchmark|rror'
bench/fit_threads.sh .devcarry/build 512 12 "$rounds" 1 4 8 16 2>&1 | tee "$out/fit_threads.txt"
