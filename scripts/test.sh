#!/usr/bin/env bash
# Sets everything up, builds, and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
ctest --test-dir "${GRADRASTER_BUILD_DIR:-build}" -j "$(nproc)" --output-on-failure
