#!/usr/bin/env bash
# Sanitizer CI job: builds gradraster with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer in ./build-san (GRADRASTER_SANITIZE=ON,
# GRADRASTER_FUZZ=ON), runs the whole ctest suite under the sanitizers (the
# Python tests too: the gradraster._core module is built with the sanitizers and
# the interpreter preloads the shared ASan runtime, tests/CMakeLists.txt), then
# smoke-runs each libFuzzer target (tests/fuzz) for FUZZ_SECONDS seconds from a
# temporary copy of its seed corpus (the repository's corpus is not modified).
# Installs clang and its runtime libraries if missing. Safe to run repeatedly.
#
# Environment: GRADRASTER_SAN_DIR (build folder, default build-san),
# FUZZ_SECONDS (per target; default 0: replay the corpus only), FUZZ_SEED (default 0 = random),
# CTEST_ARGS (extra ctest arguments, e.g. -R to run a subset).
set -euo pipefail
cd "$(dirname "$0")/.."

# shellcheck source=install_missing.sh
source scripts/install_missing.sh

# The library's dependencies (as scripts/setup.sh) plus clang. The sanitizer and
# libFuzzer runtimes (libclang_rt.{asan,ubsan,fuzzer}-x86_64.a) are in
# libclang-rt-N-dev, which clang only recommends: install it explicitly for the
# installed clang's major version (14 on Debian 12). It also holds the shared
# runtime (libclang_rt.asan-x86_64.so) that the Python tests preload.
install_missing cmake make pkg-config libeigen3-dev libtbb-dev libtinyobjloader-dev libstb-dev catch2 clang \
  python3-dev pybind11-dev python3-torch python3-numpy python3-pytest
clang_major=$(clang --version | sed -n 's/.*clang version \([0-9][0-9]*\).*/\1/p' | head -n 1)
install_missing "libclang-rt-${clang_major}-dev"

build_dir=${GRADRASTER_SAN_DIR:-build-san}
start=$(date +%s)
# RelWithDebInfo: optimized (the suite stays fast) with line numbers in reports.
# The tests build the fit/render/shading example libraries themselves, so the
# example programs and the benchmarks are not needed here.
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER=clang++ \
  -DGRADRASTER_SANITIZE=ON -DGRADRASTER_FUZZ=ON -DGRADRASTER_WITH_PYTHON=ON -DPython3_EXECUTABLE=/usr/bin/python3 \
  -DGRADRASTER_BUILD_BENCH=OFF -DGRADRASTER_BUILD_EXAMPLES=OFF > /dev/null
cmake --build "$build_dir" -j "$(nproc)"
echo "sanitize: build took $(( $(date +%s) - start )) s"

# Any report fails the run: UBSan is built with -fno-sanitize-recover, ASan
# aborts on its first error, LeakSanitizer reports at exit (not in the Python
# tests: the interpreter's own allocations at exit are not ours).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# Mesa's lavapipe (the [vulkan] tests' device) keeps 128 bytes reachable from
# its globals; the Vulkan loader unloads it when the last instance goes, which
# turns them into a leak report with no stack ("<unknown module>") at exit.
# Loaded from the start, it stays loaded, and only leaks of ours are reported.
# (The Python tests set LD_PRELOAD to the ASan runtime themselves.)
lavapipe=$(ls /usr/lib/*/libvulkan_lvp.so 2>/dev/null | head -n 1 || true)
start=$(date +%s)
# shellcheck disable=SC2086  # CTEST_ARGS is a list of arguments
LD_PRELOAD="${lavapipe}" ctest --test-dir "$build_dir" -j "$(nproc)" --output-on-failure ${CTEST_ARGS:-}
echo "sanitize: tests took $(( $(date +%s) - start )) s"

# By default (CI) each target replays its corpus under the sanitizers and
# stops: the same inputs every run. FUZZ_SECONDS=N explores for N seconds per
# target (FUZZ_SEED, default 0 = random); a finding is fixed and joins the
# corpus. Exploration is kept out of CI because it finds new inputs on its
# own schedule (tests/fuzz/findings/ holds the ones not fixed yet).
fuzz_seconds=${FUZZ_SECONDS:-0}
fuzz_seed=${FUZZ_SEED:-0}
if [ "$fuzz_seconds" -eq 0 ]; then
  fuzz_args=(-runs=0)
else
  fuzz_args=(-seed="$fuzz_seed" -max_total_time="$fuzz_seconds")
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for target in obj image raster shapes; do
  mkdir -p "$work/$target/corpus" "$work/$target/artifacts"
  cp tests/fuzz/corpus/"$target"/* "$work/$target/corpus/"
  echo "sanitize: fuzz_$target ${fuzz_args[*]}"
  if ! "$build_dir/fuzz/fuzz_$target" "${fuzz_args[@]}" -timeout=10 -print_final_stats=1 \
      -artifact_prefix="$work/$target/artifacts/" "$work/$target/corpus" > "$work/$target/log" 2>&1; then
    tail -n 60 "$work/$target/log"
    mkdir -p "$build_dir/fuzz-artifacts"
    cp "$work/$target/artifacts/"* "$build_dir/fuzz-artifacts/" 2>/dev/null || true
    echo "sanitize: fuzz_$target FAILED; crashing input(s) kept in $build_dir/fuzz-artifacts" >&2
    exit 1
  fi
  grep -E "^stat::number_of_executed_units|^Done" "$work/$target/log" || true
done
echo "sanitize: all passed"
