#!/usr/bin/env bash
# Every tool and bench program (issue 30 item 12): --help prints a usage text
# and exits 0 without doing any work; an unknown option, and a number that is
# not a whole, plain number ("1e3", "64abc"), are usage errors (exit 2) before
# any work: nothing runs for long (each call has a timeout) and nothing is
# written in the working directory.
# Usage: test_command_lines.sh NAME=PROGRAM...   (NAME selects the bad-number arguments below)
set -uo pipefail
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1

# Arguments with a malformed number, per program (none: the program takes no number).
bad_number() {
  case "$1" in
    gradraster-render) echo "--builtin cube --width 1e3" ;;
    gradraster-fit) echo "--size 1e3" ;;
    gradraster-ssr) echo "--width 64abc" ;;
    gradraster-intersection) echo "--size 1e3" ;;
    time_error_plateau) echo "--order 8x" ;;
    stress_report) echo "--threads 1e3" ;;
    long_run) echo "--size 64abc" ;;
    ssr_tradeoff) echo "plot.png 5x" ;;
    exact_reference_torus) echo "1e3" ;;
    peer_libtorch) echo "--reps 1e3" ;;
    peer_llvmpipe) echo "--size 1e3" ;;
    *) echo "" ;;
  esac
}

failures=0
expect() {  # EXPECTED_STATUS DESCRIPTION PROGRAM ARGS...
  local expected="$1" what="$2"; shift 2
  local status=0
  timeout 30 "$@" > out.log 2>&1 || status=$?
  if [[ $status -ne $expected ]]; then
    echo "FAILED: $what: exit $status, expected $expected (124 = still running after 30 s)"; sed 's/^/    /' out.log | head -5
    failures=$((failures + 1))
  fi
  if [[ $expected -eq 0 ]] && ! grep -qi "usage" out.log; then
    echo "FAILED: $what printed no usage text"; failures=$((failures + 1))
  fi
  rm -f out.log
  if [[ -n "$(ls -A)" ]]; then
    echo "FAILED: $what wrote into the working directory:"; ls -A; rm -rf ./* ./.[!.]* 2>/dev/null
    failures=$((failures + 1))
  fi
}

for pair in "$@"; do
  name="${pair%%=*}" program="${pair#*=}"
  expect 0 "$name --help" "$program" --help
  expect 2 "$name --no-such-option" "$program" --no-such-option
  bad=$(bad_number "$name")
  # shellcheck disable=SC2086  # the arguments are split on purpose
  [[ -n "$bad" ]] && expect 2 "$name $bad" "$program" $bad
done
[[ $failures -eq 0 ]] || exit 1
echo "$# programs: --help exits 0, unknown options and malformed numbers exit 2, nothing runs or is written"
