#!/usr/bin/env bash
# UV quality per tree (docs/quality.md, "UVs"): meshes every skeleton of SKELETON_DIR and the
# grown presets at the given seeds, checks each against its skeleton and prints one Markdown row
# per tree with the UV figures of `strandmesh check --json` (seams, stretch, flips).
#
#   scripts/uv_table.sh [BUILD_DIR] [SKELETON_DIR]     # defaults: build, ../shared/skeletons
#   PRESETS="conifer" SEEDS="1 2" scripts/uv_table.sh    # other grown trees (PRESETS="": none)
#   CONFIG=configs/closeup.json scripts/uv_table.sh      # with a config
#   MESH_WITH=/path/to/other/strandmesh scripts/uv_table.sh  # mesh with another build (before/after)
set -euo pipefail
PRESETS="${PRESETS-broadleaf conifer}"
SEEDS="${SEEDS-1}"
source "$(dirname "$0")/table_inputs.sh"
MESH_SM="${MESH_WITH:-$SM}"

echo "| tree | triangles | seam edges: around / other | at junctions: around / other | anisotropy p95 (junctions) | density p95 x median (junctions) | flipped / collapsed |"
echo "|---|---|---|---|---|---|---|"
for f in "${inputs[@]}"; do
  name="$(basename "$f" .json)"
  if ! "$MESH_SM" -q mesh "$f" "${CONFIG_ARGS[@]}" -o "$OUT/$name.glb" 2> "$OUT/$name.err"; then
    echo "| $name | mesh failed: $(tail -1 "$OUT/$name.err") |"
    continue
  fi
  "$SM" -q check --json --no-self-intersections --skeleton "$f" "$OUT/$name.glb" > "$OUT/$name.check.json" || true
  python3 - "$OUT/$name.check.json" "$name" <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); u = j["uv"]
print(f"| {sys.argv[2]} | {j['triangles']} | {u['around_seams']} / {u['other_seams']} | "
      f"{u['junction_around_seams']} / {u['junction_other_seams']} | {u['anisotropy_p95']:.2f} ({u['junction_anisotropy_p95']:.2f}) | "
      f"{u['density_p95']:.2f} ({u['junction_density_p95']:.2f}) | {u['flipped']} / {u['collapsed']} |")
PY
done
