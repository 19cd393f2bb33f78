# Shared by the scale-out tests: a forest of small grown trees and helpers.
# Trees: the built-in random grower (`strandmesh grow --seed N`, 470-1100 nodes), meshed with
# configs/preview.json; plus one broken file that must be reported while the others are meshed.
set -euo pipefail
SM="$1"                      # the strandmesh binary
WORK="$2"                    # a scratch folder (emptied)
SRC="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
TREES="${STRANDMESH_FOREST_TREES:-200}"
CONFIG="$SRC/configs/preview.json"
say() { printf '[%s] %s\n' "$(basename "$0" .sh)" "$*" >&2; }
fail() { say "FAILED: $*"; exit 1; }

grow_forest() {
  rm -rf "$WORK"
  mkdir -p "$WORK/in"
  local t0=$SECONDS
  seq 1 "$TREES" | xargs -P 2 -I{} sh -c '"$0" -q grow --seed {} -o "$1/in/tree_$(printf %03d {}).json"' "$SM" "$WORK"
  printf '{"nodes": [{"id": 0, "parent": -1, "position": [0, 0, 0], "radius": 0.1},\n {"id": 1, "parent": 0, "position": [0, 0, oops]}]}\n' \
    >"$WORK/in/tree_broken.json"
  say "grew $TREES trees in $((SECONDS - t0)) s"
}

# Runs `batch` with the forest's inputs and settings; extra arguments follow.
run_batch() { "$SM" batch "$WORK/in" --config "$CONFIG" "$@"; }

# The products of a batch folder (meshes, thumbnails, records, summaries; not shards/ or
# hidden temporary files) must be byte-identical in $1 and $2.
same_outputs() {
  diff -r -q -x shards -x '.*' "$1" "$2" >/dev/null || { diff -r -q -x shards -x '.*' "$1" "$2" | head >&2; fail "$1 and $2 differ"; }
  local n
  n=$(find "$1" -maxdepth 1 -name '*.glb' | wc -l)
  say "$1 and $2: the same $(find "$1" -maxdepth 1 -type f ! -name '.*' | wc -l) files ($n meshes)"
}

# The summary has a row for every input: the broken one failed, naming its line; every grown
# tree was meshed (its status, ok or not, is the pipeline's business, and is counted here).
check_summary() {
  local csv="$1/summary.csv" rows
  rows=$(($(grep -c . "$csv") - 1))
  [ "$rows" -eq $((TREES + 1)) ] || fail "$rows rows in $csv, expected $((TREES + 1))"
  grep -q '^[0-9]*,tree_broken,.*,failed,.*tree_broken.json:2:' "$csv" || fail "the broken input is not reported with its line"
  say "$csv: $(grep -c ',ok,' "$csv") ok, $(grep -c ',check_failed,' "$csv") failing a check, $(grep -c ',failed,' "$csv") failed:" \
    "$(grep -E ',(check_failed|failed),' "$csv" | grep -v tree_broken | cut -d, -f2,4 | tr '\n' ' ')"
}
