#!/usr/bin/env bash
# Runs every libFuzzer target (fuzz/) for SECONDS each under AddressSanitizer and
# UndefinedBehaviorSanitizer; builds them first in build-asan (clang).
#
#   ./scripts/fuzz.sh SECONDS [TARGET...]     # e.g. ./scripts/fuzz.sh 60 fuzz_skeleton_json
#
# Each target starts from its seeds (fuzz/corpus/<name>/, the samples) and keeps what it
# learns in build-asan/fuzz/corpus/<name>/. A crash, sanitizer report, internal error,
# rejection naming no place (fuzz/fuzz_reader.h), hang (60 s) or memory blow-up (4 GB) is a
# finding: its input is saved to build-asan/fuzz/findings/ and the script exits 1.
set -euo pipefail
source "$(dirname "$0")/common.sh"
source "$STRANDMESH_ROOT/scripts/sanitize_env.sh"
SECONDS_EACH="${1:?usage: scripts/fuzz.sh SECONDS [TARGET...]}"
shift
if [ "${STRANDMESH_SKIP_BUILD:-0}" != 1 ]; then
  configure_and_build_sanitized
else
  BUILD_DIR="${STRANDMESH_ASAN_BUILD_DIR:-$STRANDMESH_ROOT/build-asan}"
fi
FUZZ="$BUILD_DIR/fuzz"
mkdir -p "$FUZZ/findings"
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for f in "$FUZZ"/*.seeds; do targets+=("$(basename "$f" .seeds)"); done
fi
failed=0
for t in "${targets[@]}"; do
  seeds=()
  max_len=65536
  while IFS= read -r line; do
    case "$line" in
      max_len=*) max_len="${line#max_len=}" ;;
      "") ;;
      *) [ -d "$line" ] && seeds+=("$line") ;;
    esac
  done < "$FUZZ/$t.seeds"
  mkdir -p "$FUZZ/corpus/$t"
  log "$t: ${SECONDS_EACH} s from ${#seeds[@]} seed folder(s)"
  status=0
  ( cd "$FUZZ" && "./$t" -max_total_time="$SECONDS_EACH" -timeout=60 -rss_limit_mb=4096 -max_len="$max_len" \
      -print_final_stats=1 -artifact_prefix="$FUZZ/findings/$t-" "corpus/$t" "${seeds[@]}" ) \
      > "$FUZZ/$t.log" 2>&1 || status=$?
  grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$FUZZ/$t.log" | sed "s/^/  /" >&2 || true
  if [ "$status" -ne 0 ]; then
    log "$t: FINDING (exit $status); see $FUZZ/$t.log and $FUZZ/findings/"
    tail -40 "$FUZZ/$t.log" >&2
    failed=1
  fi
done
[ "$failed" -eq 0 ] && log "no findings" || log "findings: see above"
exit "$failed"
