#!/usr/bin/env bash
# A forest plot: grows trees with the growers (presets and seeds in turn), places them on a
# grid (or at given coordinates) through a batch manifest, and meshes the plot with
# `strandmesh batch`. Output: out/forest/ (meshes at their plot positions, thumbnails,
# index.html, summary.csv), with the run's figures (trees per minute, peak memory).
#
#   scripts/forest.sh                              # 16 trees, 4 x 4 grid, 10 m apart
#   scripts/forest.sh --trees 64 --spacing 6 --jobs 2
#   scripts/forest.sh --positions plot.txt         # lines "x y [preset] [seed]", metres
#   scripts/forest.sh --presets oak,conifer --config configs/default.json --out out/oaks
#
# Presets: configs/grow (strandmesh grow --list-presets) and "random" (the built-in random
# grower). Meshed with configs/preview.json unless --config says otherwise. Rerunning resumes:
# trees whose skeleton, position and settings did not change are not meshed again.
set -euo pipefail
source "$(dirname "$0")/common.sh"

TREES=16 SPACING=10 JOBS=2 POSITIONS="" PRESETS="broadleaf,conifer,oak,bush"
CONFIG="$STRANDMESH_ROOT/configs/preview.json" OUT="$STRANDMESH_ROOT/out/forest" BUILD=1
while [ $# -gt 0 ]; do
  case "$1" in
    --trees) TREES="$2"; shift 2 ;;
    --spacing) SPACING="$2"; shift 2 ;;
    --jobs) JOBS="$2"; shift 2 ;;
    --positions) POSITIONS="$2"; shift 2 ;;
    --presets) PRESETS="$2"; shift 2 ;;
    --config) CONFIG="$2"; shift 2 ;;
    --out) OUT="$2"; shift 2 ;;
    --no-build) BUILD=0; shift ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    *) log "unknown option $1 (see --help)"; exit 2 ;;
  esac
done
if [ "$BUILD" -eq 1 ]; then
  ensure_packages
  configure_and_build
fi
SM="$BUILD_DIR/strandmesh"
mkdir -p "$OUT/skeletons"

# Where the trees stand: the --positions file, or a square grid with a little jitter (the
# same for every run, so a rerun resumes).
if [ -n "$POSITIONS" ]; then
  grep -vE '^\s*(#|$)' "$POSITIONS" >"$OUT/positions.txt"
else
  awk -v n="$TREES" -v d="$SPACING" 'BEGIN {
    side = int(sqrt(n)); if (side * side < n) side++;
    for (i = 0; i < n; i++) {
      jx = ((i * 7919) % 100) / 100 - 0.5; jy = ((i * 104729) % 100) / 100 - 0.5;
      printf "%.2f %.2f\n", (i % side) * d + 0.4 * d * jx, int(i / side) * d + 0.4 * d * jy }
  }' >"$OUT/positions.txt"
fi
IFS=, read -r -a preset_list <<<"$PRESETS"

log "growing $(grep -c . "$OUT/positions.txt") trees ($PRESETS) -> $OUT/skeletons"
start=$SECONDS
i=0
entries=()
while read -r x y preset seed; do
  preset="${preset:-${preset_list[$((i % ${#preset_list[@]}))]}}"
  seed="${seed:-$((i / ${#preset_list[@]} + 1))}"
  name=$(printf 'tree_%03d_%s_%s' "$i" "$preset" "$seed")
  skeleton="$OUT/skeletons/$name.json"
  if [ ! -f "$skeleton" ]; then
    if [ "$preset" = random ]; then "$SM" -q grow --seed "$seed" -o "$skeleton"
    else "$SM" -q grow --preset "$preset" --seed "$seed" -o "$skeleton"; fi
  fi
  entries+=("{\"input\": \"skeletons/$name.json\", \"name\": \"$name\", \"offset\": [$x, $y, 0]}")
  i=$((i + 1))
done <"$OUT/positions.txt"
grow_seconds=$((SECONDS - start))
{
  echo '{"trees": ['
  for k in "${!entries[@]}"; do printf '  %s%s\n' "${entries[$k]}" "$([ "$k" -lt $((${#entries[@]} - 1)) ] && echo ,)"; done
  echo ']}'
} >"$OUT/plot.json"

log "meshing the plot: strandmesh batch $OUT/plot.json --jobs $JOBS --config $(basename "$CONFIG")"
start=$SECONDS
status=0
/usr/bin/time -f '%M' -o "$OUT/peak_kb.txt" \
  "$SM" batch "$OUT/plot.json" -o "$OUT" --jobs "$JOBS" --config "$CONFIG" --title "strandmesh forest ($i trees)" ||
  status=$?
mesh_seconds=$((SECONDS - start))
peak_mb=$(( $(tail -1 "$OUT/peak_kb.txt") / 1024 ))
tpm=$(awk -v n="$i" -v s="$mesh_seconds" 'BEGIN {printf "%.1f", 60 * n / (s > 0 ? s : 1)}')
log "grew $i trees in ${grow_seconds} s; meshed in ${mesh_seconds} s ($tpm trees/min, peak memory ${peak_mb} MB in one process, --jobs $JOBS, $(nproc) cores)"
log "plot: $OUT/index.html (meshes at their plot positions: $OUT/tree_*.glb)"
exit "$status"
