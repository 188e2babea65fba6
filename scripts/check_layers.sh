#!/usr/bin/env bash
# Keeps the tape-free layers tape-free (issue 14): a file in raster/ (its io/
# and detail/ folders included) may include only raster/ headers and the
# base's; a base file (autodiff/base/: tensor, storage, shape, dtype, error,
# memory, parallel) only the base's. Anything else from autodiff/ (tape,
# backward, gradcheck, optim, accumulate) and all of ops/ is off limits.
# Usage: scripts/check_layers.sh [SOURCE_ROOT]   (exit 0 clean, 1 with a list of offenders)
set -euo pipefail
root="${1:-$(dirname "$0")/..}"
base='autodiff/base/[A-Za-z0-9_]+\.h'
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
check "raster/((io|detail)/)?[A-Za-z0-9_]+\.h|$base" "$root"/raster/*.{h,cpp} "$root"/raster/{io,detail}/*.{h,cpp}
check "$base" "$root"/autodiff/base/*.{h,cpp}
if [[ $status -eq 0 ]]; then echo "layers clean: raster/ and the base include no tape, gradcheck, optim or ops/ header"; fi
exit $status
