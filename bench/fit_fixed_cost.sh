#!/usr/bin/env bash
# The main example's fixed cost per iteration (issue 31): the loop time of
# gradraster-fit --size S --views V --iterations 30 at several sizes S, R
# rounds interleaved, then per thread count a least-squares line through the
# median ms per iteration against the pixels per view:
#   ms/iteration = fixed + per_pixel * S^2
# `fixed` is what the iteration costs whatever the image size (docs/performance.md).
#   bench/fit_fixed_cost.sh [build dir] [views] [rounds] [thread counts...]
#   bench/fit_fixed_cost.sh build 6 3 1 2
set -euo pipefail
build=${1:-build}; views=${2:-6}; rounds=${3:-3}
shift $(( $# < 3 ? $# : 3 ))
counts=("$@"); [[ ${#counts[@]} -gt 0 ]] || counts=(1 2)
sizes=(128 192 256 320)
fit="$build/examples/fit/gradraster-fit"
out=$(mktemp -d); trap 'rm -rf "$out"' EXIT
declare -A runs
for ((r = 0; r < rounds; r++)); do
  for s in "${sizes[@]}"; do
    for t in "${counts[@]}"; do
      rate=$("$fit" --size "$s" --views "$views" --iterations 30 --threads "$t" --out "$out/o" |
             sed -n 's/^wall time: .*s, \([0-9.]*\) it\/s$/\1/p')
      runs[$t,$s]="${runs[$t,$s]:-} $rate"
    done
  done
done
for t in "${counts[@]}"; do
  for s in "${sizes[@]}"; do echo "$t $s ${runs[$t,$s]}"; done
done > "$out/runs"
/usr/bin/python3 - "$out/runs" <<'PY'
import collections, statistics, sys
rows = collections.defaultdict(list)
for line in open(sys.argv[1]):
    t, s, *rates = line.split()
    rows[t].append((int(s) ** 2, 1000.0 / statistics.median(float(r) for r in rates), rates))
print("threads   fixed ms  us/pixel   ms/iteration by size (it/s runs)")
for t, pts in rows.items():
    n = len(pts)
    mx = sum(p for p, _, _ in pts) / n
    my = sum(m for _, m, _ in pts) / n
    slope = sum((p - mx) * (m - my) for p, m, _ in pts) / sum((p - mx) ** 2 for p, _, _ in pts)
    detail = "  ".join(f"{int(p ** 0.5)}: {m:.2f} ({','.join(r)})" for p, m, r in pts)
    print(f"{t:8s} {my - slope * mx:9.2f} {slope * 1000:9.3f}   {detail}")
PY
