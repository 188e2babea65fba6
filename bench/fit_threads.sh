#!/usr/bin/env bash
# The main example's loop speed against the thread count, as a user runs it
# (snapshots on): gradraster-fit --size S --iterations 30 --views V for each
# thread count in turn, R rounds interleaved, then the median it/s per count
# and its speed-up over the first count (docs/performance.md).
#   bench/fit_threads.sh [build dir] [size] [views] [rounds] [thread counts...]
#   bench/fit_threads.sh build 256 6 7 1 2
#   bench/fit_threads.sh build 512 12 5 1 4 8 16
set -euo pipefail
build=${1:-build}; size=${2:-256}; views=${3:-6}; rounds=${4:-5}
shift $(( $# < 4 ? $# : 4 ))
counts=("$@"); [[ ${#counts[@]} -gt 0 ]] || counts=(1 2)
fit="$build/examples/fit/gradraster-fit"
out=$(mktemp -d); trap 'rm -rf "$out"' EXIT
declare -A runs
for ((r = 0; r < rounds; r++)); do
  for t in "${counts[@]}"; do
    rate=$("$fit" --size "$size" --views "$views" --iterations 30 --threads "$t" --out "$out/o" |
           sed -n 's/^wall time: .*s, \([0-9.]*\) it\/s$/\1/p')
    runs[$t]="${runs[$t]:-} $rate"
  done
done
median() { tr ' ' '\n' | grep . | sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
base=$(echo "${runs[${counts[0]}]}" | median)
printf '%-8s %-10s %s\n' threads "it/s" "speed-up (runs:${runs[${counts[0]}]})"
for t in "${counts[@]}"; do
  m=$(echo "${runs[$t]}" | median)
  printf '%-8s %-10s %.2fx   (%s)\n' "$t" "$m" "$(awk -v m="$m" -v b="$base" 'BEGIN {print m / b}')" "${runs[$t]# }"
done
