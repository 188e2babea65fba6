#!/usr/bin/env bash
# Keeps the tape-free layers tape-free (issue 14): a file in raster/ may include
# only raster/ headers and the base's; a base file only the base's. The base is
# what gradraster_base compiles (CMakeLists.txt): tensor, storage, shape, dtype,
# error, memory, parallel. Anything else from autodiff/ (tape, backward,
# gradcheck, optim, accumulate) and all of ops/ is off limits.
# Usage: scripts/check_layers.sh [SOURCE_ROOT]   (exit 0 clean, 1 with a list of offenders)
set -euo pipefail
root="${1:-$(dirname "$0")/..}"
base='autodiff/(tensor|storage|shape|dtype|error|memory|parallel)\.h'
base_files=()
for name in tensor storage shape dtype error memory parallel; do
  for ext in h cpp; do
    [[ -f "$root/autodiff/$name.$ext" ]] && base_files+=("$root/autodiff/$name.$ext")
  done
done
status=0
# check ALLOWED_REGEX FILES...: every quoted include in FILES must match ALLOWED_REGEX.
check() {
  local allowed="$1"; shift
  [[ $# -gt 0 ]] || return 0
  ALLOWED="^($allowed)\$" ROOT="$root/" awk '
    /^[ \t]*#[ \t]*include[ \t]*"/ {
      split($0, q, "\"")
      if (q[2] !~ ENVIRON["ALLOWED"]) {
        file = FILENAME
        if (index(file, ENVIRON["ROOT"]) == 1) file = substr(file, length(ENVIRON["ROOT"]) + 1)
        printf "layer violation: %s:%d includes %s\n", file, FNR, q[2] > "/dev/stderr"
        bad = 1
      }
    }
    END { exit bad }' "$@" || status=1
}
shopt -s nullglob
check "raster/[A-Za-z0-9_]+\.h|$base" "$root"/raster/*.h "$root"/raster/*.cpp
check "$base" "${base_files[@]}"
if [[ $status -eq 0 ]]; then echo "layers clean: raster/ and the base include no tape, gradcheck, optim or ops/ header"; fi
exit $status
