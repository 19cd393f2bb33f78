#!/usr/bin/env bash
# A forest of 200 grown trees (STRANDMESH_FOREST_TREES) plus a broken file, meshed three ways:
# `batch --jobs 2`; GNU parallel running 2 shards and a merge; a run killed with SIGKILL and
# resumed after a fifth of the trees. All three give the same bytes; the resumed run redoes no
# finished tree.
#   tests/batch/scale_out.sh build/strandmesh SCRATCH      (ctest -L slow runs it)
source "$(dirname "$0")/forest_common.sh"
command -v parallel >/dev/null || { say "GNU parallel not installed: skipped"; exit 77; }
grow_forest

say "batch --jobs 2"
t0=$SECONDS
rc=0
/usr/bin/time -f '%M KB peak' -o "$WORK/time_jobs2" "$SM" -q batch "$WORK/in" --config "$CONFIG" --jobs 2 -o "$WORK/jobs2" || rc=$?
[ "$rc" -eq 5 ] || fail "batch --jobs 2 exited $rc, expected 5 (some failed: the broken input)"
secs=$((SECONDS - t0))
check_summary "$WORK/jobs2"
say "$((TREES + 1)) inputs in ${secs} s ($(awk -v n="$TREES" -v s="$secs" 'BEGIN {printf "%.0f", 60 * n / (s > 0 ? s : 1)}') trees/min), $(tail -1 "$WORK/time_jobs2")"

say "GNU parallel, 2 shards, then --merge"
t0=$SECONDS
parallel -j 2 /usr/bin/time -f '%M' -o "$WORK/time_shard{}" "$SM" -q --threads 1 batch "$WORK/in" --config "$CONFIG" \
  -o "$WORK/parallel" --shard {}/2 ::: 0 1 || true
rc=0
"$SM" -q batch --merge -o "$WORK/parallel" || rc=$?
[ "$rc" -eq 5 ] || fail "merge exited $rc, expected 5"
say "parallel: $((SECONDS - t0)) s, peak $(tail -qn1 "$WORK"/time_shard* | sort -n | tail -1) KB per process"
same_outputs "$WORK/jobs2" "$WORK/parallel"

kill_at=$((TREES / 5 > 2 ? TREES / 5 : 2))
say "a run killed after $kill_at trees, then resumed"
"$SM" -q batch "$WORK/in" --config "$CONFIG" --jobs 2 -o "$WORK/resumed" &
pid=$!
while [ "$(find "$WORK/resumed" -maxdepth 1 -name '*.stats.json' 2>/dev/null | wc -l)" -lt "$kill_at" ]; do
  kill -0 "$pid" 2>/dev/null || fail "the run ended before it could be killed"
  sleep 0.05
done
kill -KILL "$pid"
wait "$pid" 2>/dev/null || true
# Trees finished at the kill (their record written last), with their meshes' modification times.
(cd "$WORK/resumed" && for r in *.stats.json; do n="${r%.stats.json}"; [ -f "$n.glb" ] && stat -c '%n %Y.%y' "$n.glb"; done) | sort >"$WORK/before"
done_before=$(grep -c . "$WORK/before")
[ "$done_before" -ge $((kill_at - 1)) ] || fail "only $done_before meshes at the kill"
sleep 1
rc=0
"$SM" batch "$WORK/in" --config "$CONFIG" --jobs 2 -o "$WORK/resumed" 2>"$WORK/resume.log" || rc=$?
[ "$rc" -eq 5 ] || fail "the resumed run exited $rc"
(cd "$WORK/resumed" && while read -r f _; do stat -c '%n %Y.%y' "$f"; done <"$WORK/before") | sort >"$WORK/after"
cmp -s "$WORK/before" "$WORK/after" || fail "finished trees were meshed again: $(diff "$WORK/before" "$WORK/after" | head -3)"
grep -q "($done_before done before)" "$WORK/resume.log" || fail "the resumed run did not count $done_before trees as done: $(tail -1 "$WORK/resume.log")"
say "resumed: $done_before trees kept as they were, the rest meshed: $(tail -1 "$WORK/resume.log")"
same_outputs "$WORK/jobs2" "$WORK/resumed"
say "ok"
