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

# shellcheck source=install_missing.sh
source scripts/install_missing.sh
install_missing cmake make pkg-config libeigen3-dev libtbb-dev libtinyobjloader-dev libstb-dev catch2 clang
clang_major=$(clang --version | sed -n 's/.*clang version \([0-9][0-9]*\).*/\1/p' | head -n 1)
install_missing "libclang-rt-${clang_major}-dev"
build=${GRADRASTER_TSAN_BUILD_DIR:-build-tsan}
if [[ -z "${CXX:-}" ]]; then
  if command -v clang++ > /dev/null; then CXX=clang++; CC=clang; else CXX=g++; CC=gcc; fi
fi
jobs=${JOBS:-$(nproc)}

# -O1 keeps TSan's slowdown moderate; -g gives file:line in reports.
CC=${CC:-} CXX=$CXX cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="-fsanitize=thread -g -O1" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" \
  -DGRADRASTER_BUILD_BENCH=OFF -DGRADRASTER_BUILD_EXAMPLES=OFF -DGRADRASTER_WITH_PYTHON=OFF > /dev/null
cmake --build "$build" --target gradraster_tests -j "$jobs"

# The tests that run parallel loops: the thread wrapper, the determinism
# checks (1, 2 and 8 threads), the rasterizer and its adjoint, interpolation,
# antialiasing, texturing, SSR, elementwise ops and reductions, the whole
# pipeline and the fit example; and the tape (its saved versions) and the
# temporaries' registry, which other threads and a signal handler read.
subset='[parallel],[determinism],[rasterize],[interpolate],[antialias],[texture],[ssr],[elementwise],[reduce],[pipeline],[fit],[tape],[versions],[temporaries]'
spec=${1:-$subset}
args=("$spec")
[[ "$spec" == all ]] && args=()

# Kernels with more mmap randomization than clang 14's TSan expects make every
# TSan binary die at start ("unexpected memory mapping"); then run without
# address randomization (setarch -R), which TSan supports.
run=()
if ! "$build/tests/gradraster_tests" --list-test-names-only > /dev/null 2>&1; then
  run=(setarch "$(uname -m)" -R)
  echo "tsan: this kernel's address randomization is too wide for TSan; running under setarch -R"
fi

export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$root/tests/tsan.supp ${TSAN_OPTIONS:-}"
# Catch2's own output only; TSan reports go to stderr and stop the run.
"${run[@]}" "$build/tests/gradraster_tests" "${args[@]}"
