#!/usr/bin/env bash
# gradraster-fit under mpirun (issue 15): a small fit (12 views of 64x64, 20
# iterations) gives byte-identical outputs (fitted.obj with every float32 in
# full, the loss curve plot, the last snapshot) without MPI and with P = 1, 2,
# 3 and 4 processes; a process that fails ends the job with a non-zero exit,
# its rank and message, and leaves no output folder behind; processes started
# with different options (issue 30 item 8) all stop at once with exit code 2,
# naming the option, before any work or output; a rank killed by SIGKILL ends
# the job and the others leave neither their output folder nor a staging
# folder (issue 30 item 6).
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

# Processes started with different options: every process stops before any
# work (no hang: each try has a timeout), exit 2, the option named, no outputs.
mismatch() {  # NAME EXPECTED_TEXT ARGS_OF_PROCESS_0 -- ARGS_OF_PROCESS_1
  local name="$1" expected="$2"; shift 2
  local first=() second=()
  while [[ "$1" != "--" ]]; do first+=("$1"); shift; done
  shift
  second=("$@")
  local status=0
  timeout 60 "$mpirun" --oversubscribe -np 1 "$fit" "${first[@]}" --out "$work/$name" : \
    -np 1 "$fit" "${second[@]}" --out "$work/$name" > "$work/$name.log" 2>&1 || status=$?
  if [[ $status -ne 2 ]]; then
    echo "FAILED: $name gave exit status $status, expected 2 (124 = hang)"; cat "$work/$name.log"; exit 1
  fi
  grep -qF -- "$expected" "$work/$name.log" ||
    { echo "FAILED: $name: the message does not say: $expected"; cat "$work/$name.log"; exit 1; }
  [[ ! -e "$work/$name" ]] || { echo "FAILED: $name left $work/$name behind"; exit 1; }
  echo "$name: every process stopped with exit 2: $expected"
}
small=(--views 2 --size 32 --threads 1)
mismatch iterations "--iterations is 8 on process 1 but 5 on process 0" \
  "${small[@]}" --iterations 5 -- "${small[@]}" --iterations 8
mismatch mode "--mode is pose on process 1 but shape on process 0" \
  "${small[@]}" --mode shape -- "${small[@]}" --mode pose
mismatch views "--views is 3 on process 1 but 2 on process 0" \
  --views 2 --size 32 --threads 1 -- --views 3 --size 32 --threads 1
mismatch usage_error "the command line is the error '--size: expected an integer, got '1e3''" \
  "${small[@]}" -- --views 2 --size 1e3 --threads 1

# A rank killed by SIGKILL mid-run: mpirun ends the job; process 0 is stopped
# by a signal while its staging folder exists and removes it and the output
# folder it created.
timeout 120 "$mpirun" --oversubscribe -np 2 "$fit" --views 2 --size 32 --threads 1 --iterations 1000000 \
  --out "$work/killed/out" > "$work/killed.log" 2>&1 &
job=$!
for _ in $(seq 600); do
  compgen -G "$work/killed/out/.gr*.staging" > /dev/null && break
  sleep 0.1
done
compgen -G "$work/killed/out/.gr*.staging" > /dev/null || { echo "FAILED: no staging folder appeared"; cat "$work/killed.log"; exit 1; }
victim=""
for child in $(pgrep -P "$job") $(for p in $(pgrep -P "$job"); do pgrep -P "$p"; done); do
  if tr '\0' '\n' < "/proc/$child/environ" 2>/dev/null | grep -qx "OMPI_COMM_WORLD_RANK=1"; then victim=$child; fi
done
[[ -n "$victim" ]] || { echo "FAILED: rank 1 not found among the children of mpirun"; exit 1; }
kill -KILL "$victim"
status=0
wait "$job" || status=$?
if [[ $status -eq 0 || $status -eq 124 ]]; then echo "FAILED: the killed job gave exit status $status"; exit 1; fi
[[ ! -e "$work/killed" ]] || { echo "FAILED: the killed job left:"; find "$work/killed"; exit 1; }
echo "a rank killed by SIGKILL ends the job (exit $status) and leaves no output or staging folder"
