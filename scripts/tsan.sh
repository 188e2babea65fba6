#!/usr/bin/env bash
# Builds the test suite with ThreadSanitizer and runs the threaded tests
# (docs/determinism.md). Usage:
#   scripts/tsan.sh              # the threaded subset (below)
#   scripts/tsan.sh all          # every test
#   scripts/tsan.sh "[texture]"  # any Catch2 test spec
# Environment: GRADRASTER_TSAN_BUILD_DIR (default build-tsan), CXX (default
# clang++ if installed, else g++), JOBS (default nproc).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=${GRADRASTER_TSAN_BUILD_DIR:-build-tsan}
if [[ -z "${CXX:-}" ]]; then
  if command -v clang++ > /dev/null; then CXX=clang++; CC=clang; else CXX=g++; CC=gcc; fi
fi
jobs=${JOBS:-$(nproc)}

# -O1 keeps TSan's slowdown moderate; -g gives file:line in reports.
CC=${CC:-} CXX=$CXX cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="-fsanitize=thread -g -O1" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" \
  -DGRADRASTER_BUILD_BENCH=OFF -DGRADRASTER_BUILD_EXAMPLES=OFF > /dev/null
cmake --build "$build" --target gradraster_tests -j "$jobs"

# The tests that run parallel loops: the thread wrapper, the determinism
# checks (1, 2 and 8 threads), the rasterizer and its adjoint, interpolation,
# antialiasing, texturing, SSR, elementwise ops and reductions, the whole
# pipeline and the fit example.
subset='[parallel],[determinism],[rasterize],[interpolate],[antialias],[texture],[ssr],[elementwise],[reduce],[pipeline],[fit]'
spec=${1:-$subset}
args=("$spec")
[[ "$spec" == all ]] && args=()

export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$root/tests/tsan.supp ${TSAN_OPTIONS:-}"
# Catch2's own output only; TSan reports go to stderr and stop the run.
"$build/tests/gradraster_tests" "${args[@]}"
