#!/usr/bin/env bash
# Checks what an installed gradraster asks of its consumers (docs/decisions.md,
# "Packaging"): the CMake package and the .pc file carry nothing about the
# machine the library was built on (-march=native and other -m flags), nothing
# of Eigen (private to ops/tensor/linalg.cpp), and both carry -ffp-contract=off, so a
# find_package consumer and a pkg-config consumer compile alike. Prints each
# offending line and exits 1.
# Usage: tests/package/check_package_flags.sh PREFIX   (a `cmake --install` prefix)
set -euo pipefail
prefix="$1"
status=0
fail() { echo "FAIL: $*" >&2; status=1; }

mapfile -t cmake_files < <(find "$prefix" -path '*/cmake/gradraster/*.cmake' | sort)
pc="$(find "$prefix" -name gradraster.pc | head -n 1)"
targets="$(find "$prefix" -path '*/cmake/gradraster/gradrasterTargets.cmake' | head -n 1)"
[[ ${#cmake_files[@]} -gt 0 && -n "$targets" ]] || { echo "FAIL: no gradrasterTargets.cmake under $prefix" >&2; exit 1; }
[[ -n "$pc" ]] || { echo "FAIL: no gradraster.pc under $prefix" >&2; exit 1; }

# Machine flags: -march/-mtune/-mcpu, ISA switches (-mavx2, -mno-avx512f, -mfma,
# -msse4.2 ...), or the word native anywhere.
machine='-m(arch|tune|cpu)\b|-m(no-)?(avx|sse|fma|bmi|f16c|popcnt|lzcnt)|native'
if grep -nE -- "$machine" "${cmake_files[@]}" "$pc" >&2; then
  fail "the installed package passes the build machine's flags to consumers (lines above)"
fi
if grep -nE 'Eigen|eigen3' "${cmake_files[@]}" "$pc" | grep -vE '^[^:]*:[0-9]+:[[:space:]]*#' >&2; then
  fail "the installed package makes consumers depend on Eigen (lines above)"
fi
if grep -rnE '#[[:space:]]*include[[:space:]]*[<"]Eigen' "$prefix/include" >&2; then
  fail "an installed header includes Eigen (lines above)"
fi

# The usage requirement both routes must agree on.
grep -qE 'INTERFACE_COMPILE_OPTIONS ".*-ffp-contract=off' "$targets" ||
  fail "$targets: INTERFACE_COMPILE_OPTIONS lacks -ffp-contract=off"
grep -qE '^Cflags:.*-ffp-contract=off' "$pc" || fail "$pc: Cflags lacks -ffp-contract=off"
exit "$status"
