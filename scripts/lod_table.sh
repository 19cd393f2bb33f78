#!/usr/bin/env bash
# The levels-of-detail table of docs/export.md: meshes each tree with `--lods 4` (one glTF file,
# MSFT_lod) and with `--lods 4 --lod-files` (a file per level, for the bytes per level), checks
# every level with `strandmesh check --lod K` and prints one markdown row per tree and level.
#
#   scripts/lod_table.sh STRANDMESH OUT_DIR TREE.json ...
#
# Exit codes: 0 every level of every tree passes its check, 1 some level fails (rows say which),
# 2 usage.
set -euo pipefail
[ $# -ge 3 ] || { echo "usage: $0 STRANDMESH OUT_DIR TREE.json ..." >&2; exit 2; }
SM="$1"; OUT="$2"; shift 2
mkdir -p "$OUT/files"
echo '| tree | level | triangles | .glb bytes (`--lod-files`) | made by | closed, manifold | self-intersecting pairs | check |'
echo '| --- | ---: | ---: | ---: | --- | --- | ---: | --- |'
status=0
for tree in "$@"; do
  name="$(basename "$tree" .json)"
  "$SM" mesh "$tree" -o "$OUT/$name.glb" --lods 4 > "$OUT/$name.log" 2>&1
  "$SM" -q mesh "$tree" -o "$OUT/files/$name.glb" --lods 4 --lod-files
  for k in 0 1 2 3; do
    "$SM" check "$OUT/$name.glb" --lod "$k" --json > "$OUT/$name.$k.json" || status=1
    file="$OUT/files/$name.glb"
    [ "$k" = 0 ] || file="$OUT/files/${name}_lod$k.glb"
    python3 - "$name" "$k" "$OUT/$name.$k.json" "$file" "$OUT/$name.log" <<'PY'
import json, os, re, sys
name, k, report, file, log = sys.argv[1:]
r = json.load(open(report))
made = "pipeline"
for line in open(log):
    m = re.match(r"\s+level (\d+): .*\(level (\d+) simplified", line)
    if m and m.group(1) == k:
        made = f"level {m.group(2)} simplified"
yes = lambda b: "yes" if b else "NO"
print(f"| {name} | {k} | {r['triangles']:,} | {os.path.getsize(file):,} | {made} | "
      f"{yes(r['closed'])}, {yes(r['edge_manifold'] and r['vertex_manifold'])} | "
      f"{r['self_intersecting_pairs']} | {'ok' if r['ok'] else 'FAILED'} |")
PY
  done
  echo "| $name | all, one file | | $(stat -c %s "$OUT/$name.glb" | python3 -c 'print(f"{int(input()):,}")') | | | | |"
done
exit $status
