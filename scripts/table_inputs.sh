# Sourced by the table scripts (quality_table.sh, uv_table.sh): the build's strandmesh
# ($1/strandmesh, default build/), the skeletons of SKELETON_DIR ($2, default ../shared/skeletons)
# and the grown presets PRESETS at SEEDS (callers set their defaults first), in `inputs`;
# CONFIG_ARGS from CONFIG, and OUT, a temporary folder removed on exit.
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SM="${1:-$ROOT/build}/strandmesh"
SKELETONS="${2:-$ROOT/../shared/skeletons}"
CONFIG_ARGS=()
[ -n "${CONFIG:-}" ] && CONFIG_ARGS=(--config "$CONFIG")
OUT="$(mktemp -d)"
trap 'rm -rf "$OUT"' EXIT

inputs=()
for f in "$SKELETONS"/*.json; do [ -e "$f" ] && inputs+=("$f"); done
for p in $PRESETS; do
  for s in $SEEDS; do
    "$SM" -q grow --preset "$p" --seed "$s" -o "$OUT/${p}_$s.json"
    inputs+=("$OUT/${p}_$s.json")
  done
done
