#!/usr/bin/env bash
# gradraster-fit under mpirun (issue 15): a small fit (12 views of 64x64, 20
# iterations) gives byte-identical outputs (fitted.obj with every float32 in
# full, the loss curve plot, the last snapshot) without MPI and with P = 1, 2,
# 3 and 4 processes; a process that fails ends the job with a non-zero exit,
# its rank and message, and leaves no output folder behind.
# Usage: test_fit_processes.sh GRADRASTER_FIT MPIRUN   (exit 77 = skipped)
set -euo pipefail
fit="$1"
mpirun="${2:-}"
if [[ -z "$mpirun" || ! -x "$mpirun" ]]; then
  echo "skipped: mpirun not found (install openmpi-bin; scripts/setup.sh does)"
  exit 77
fi
# Open MPI refuses root unless told; CI containers run as root.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# Keep Open MPI off the network: shared memory and self only.
export OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
args=(--iterations 20 --views 12 --size 64 --threads 1)

"$fit" "${args[@]}" --out "$work/plain" > "$work/plain.log"
for p in 1 2 3 4; do
  timeout 300 "$mpirun" --oversubscribe -np "$p" "$fit" "${args[@]}" --out "$work/p$p" > "$work/p$p.log" 2>&1 ||
    { echo "FAILED: P=$p exited non-zero"; cat "$work/p$p.log"; exit 1; }
  for f in fitted.obj loss.png snapshot_0020.png; do
    cmp "$work/plain/$f" "$work/p$p/$f" || { echo "FAILED: $f differs between the plain run and P=$p"; exit 1; }
  done
  echo "P=$p: fitted.obj, loss.png and snapshot_0020.png identical to the run without MPI"
done

# Rank 1 of 3 fails in its first view.
status=0
GRADRASTER_FIT_FAIL_RANK=1 timeout 120 "$mpirun" --oversubscribe -np 3 "$fit" "${args[@]}" --out "$work/failed" \
  > "$work/failed.log" 2>&1 || status=$?
if [[ $status -eq 0 || $status -eq 124 ]]; then
  echo "FAILED: a failing process gave exit status $status (0 = ignored, 124 = hang)"; cat "$work/failed.log"; exit 1
fi
grep -q "process 1 of 3 failed: fit: process 1 was asked to fail" "$work/failed.log" ||
  { echo "FAILED: the failing rank's message is missing"; cat "$work/failed.log"; exit 1; }
[[ ! -e "$work/failed" ]] || { echo "FAILED: the failed job left $work/failed behind"; exit 1; }
echo "a failing process ends the job (exit $status) with its rank and message, and no outputs"
