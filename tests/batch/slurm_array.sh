#!/usr/bin/env bash
# The forest of scale_out.sh through a Slurm job array of 4 tasks on a single-node cluster
# started here (scripts/slurm_localhost.sh: slurm-wlm and munge on localhost), merged, against
# `batch --jobs 2`: the same bytes, and every tree meshed by exactly one task.
#   tests/batch/slurm_array.sh build/strandmesh SCRATCH    (ctest -L slurm runs it)
source "$(dirname "$0")/forest_common.sh"
SLURM_SH="$SRC/scripts/slurm_localhost.sh"
export STRANDMESH_SLURM_DIR="$2.cluster"
command -v sbatch >/dev/null || { say "slurm-wlm not installed ($SLURM_SH install): skipped"; exit 77; }
rc=0
"$SLURM_SH" start || rc=$?
[ "$rc" -eq 0 ] || { [ "$rc" -eq 77 ] && exit 77; fail "could not start the local cluster (rc $rc)"; }
trap '"$SLURM_SH" stop' EXIT
eval "$("$SLURM_SH" env)"
grow_forest

say "batch --jobs 2 (the reference)"
rc=0
"$SM" -q batch "$WORK/in" --config "$CONFIG" --jobs 2 -o "$WORK/jobs2" || rc=$?
[ "$rc" -eq 5 ] || fail "batch --jobs 2 exited $rc"

say "sbatch --array=0-3 scripts/slurm_batch.sbatch, then --merge"
t0=$SECONDS
mkdir -p "$WORK/logs"
STRANDMESH="$SM" sbatch --wait --array=0-3 --output="$WORK/logs/%A_%a.out" \
  "$SRC/scripts/slurm_batch.sbatch" "$WORK/in" --config "$CONFIG" -o "$WORK/slurm" >"$WORK/sbatch.out" || true
say "$(cat "$WORK/sbatch.out"), array done in $((SECONDS - t0)) s"
[ "$(find "$WORK/slurm/shards" -name '*-of-4.csv' | wc -l)" -eq 4 ] || fail "not all 4 shards wrote their summary: $(ls "$WORK/slurm/shards" 2>&1)"
rc=0
"$SM" -q batch --merge -o "$WORK/slurm" || rc=$?
[ "$rc" -eq 5 ] || fail "merge exited $rc"
same_outputs "$WORK/jobs2" "$WORK/slurm"
check_summary "$WORK/slurm"
# Every tree meshed once: each name appears in exactly one task's log, as done by that task.
cat "$WORK"/logs/*.out | grep -oE '\] tree_[0-9a-z]+: (ok|check_failed|failed)' | sort | uniq -c | awk '$1 != 1 {bad++} END {exit bad > 0}' ||
  fail "a tree was meshed by more than one task"
n=$(cat "$WORK"/logs/*.out | grep -cE '\] tree_[0-9a-z]+: (ok|check_failed|failed)')
[ "$n" -eq $((TREES + 1)) ] || fail "$n trees meshed by the array, expected $((TREES + 1))"
say "every one of the $n inputs meshed by exactly one of the 4 tasks; ok"
