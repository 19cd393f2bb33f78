#!/usr/bin/env bash
# Triangle quality per sample (docs/quality.md): meshes every skeleton of SKELETON_DIR and the
# grown presets at seeds 1-3 with the default settings, checks each against its skeleton and
# prints one Markdown row per tree (the figures of `strandmesh check --json`).
#
#   scripts/quality_table.sh [BUILD_DIR] [SKELETON_DIR]   # defaults: build, ../shared/skeletons
#   PRESETS="oak conifer" SEEDS="1" scripts/quality_table.sh   # fewer grown trees (PRESETS="": none)
#   CONFIG=configs/closeup.json scripts/quality_table.sh        # with a config
set -euo pipefail
PRESETS="${PRESETS-broadleaf conifer oak bush}"
SEEDS="${SEEDS-1 2 3}"
source "$(dirname "$0")/table_inputs.sh"

echo "| tree | triangles | < 1° | < 5° | < 10° | aspect p95 | dihedral p99 / max | at junctions p99 / max | backward normals | self-int. pairs | fidelity p95 | mesh s | result |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for f in "${inputs[@]}"; do
  name="$(basename "$f" .json)"
  start=$(date +%s.%N)
  if ! "$SM" -q mesh "$f" "${CONFIG_ARGS[@]}" -o "$OUT/$name.glb" 2> "$OUT/$name.err"; then
    echo "| $name | mesh failed: $(tail -1 "$OUT/$name.err") |"
    continue
  fi
  secs=$(echo "$(date +%s.%N) - $start" | bc)
  "$SM" -q check --json --skeleton "$f" "$OUT/$name.glb" > "$OUT/$name.check.json" || true
  python3 - "$OUT/$name.check.json" "$name" "$secs" <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); q = j["quality"]
pct = lambda x: f"{100 * x:.2f} %"
print(f"| {sys.argv[2]} | {j['triangles']} | {pct(q['share_under_1'])} ({q['under_1']}) | {pct(q['share_under_5'])} | "
      f"{pct(q['share_under_10'])} | {q['aspect_p95']:.2f} | {q['dihedral_p99']:.1f} / {q['dihedral_max']:.1f} | "
      f"{q.get('junction_dihedral_p99', 0):.1f} / {q.get('junction_dihedral_max', 0):.1f} | {q['backward_normals']} | "
      f"{j.get('self_intersecting_pairs', '-')} | {j.get('fidelity', {}).get('p95', float('nan')):.3f} | {float(sys.argv[3]):.1f} | "
      f"{'ok' if j['ok'] else 'FAILED'} |")
PY
done
