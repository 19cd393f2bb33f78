#!/usr/bin/env bash
# Blender client check (ctest label `clients`): meshes a sample tree as .glb and .obj, imports
# both with Blender's own importers (blender -b; Debian's blender, whose glTF importer needs
# python3-numpy) and checks that each comes in as one mesh, upright (z-up in Blender, taller
# than wide, the base at the bottom), with its origin at the base of the trunk, and with the
# triangle and welded vertex counts of `strandmesh mesh --stats`.
#
#   scripts/check_blender.sh STRANDMESH
#
# Exit codes: 0 ok, 1 a check failed, 2 usage, 77 skipped (Blender or python3-numpy missing).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
say() { printf '[check_blender] %s\n' "$*" >&2; }
[ $# -ge 1 ] || { echo "usage: $0 STRANDMESH" >&2; exit 2; }
STRANDMESH="$1"
command -v blender >/dev/null 2>&1 || { say "skipped: Blender is not installed (Debian package blender)"; exit 77; }
blender -b --factory-startup --python-exit-code 1 --python-expr 'import numpy' >/dev/null 2>&1 ||
  { say "skipped: Blender's Python has no numpy (Debian package python3-numpy; its glTF importer needs it)"; exit 77; }

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
# The aspen sapling moved off the origin, so that "origin at the trunk's base" means something.
TREE="$WORK/aspen_moved.json"
python3 - "$ROOT/tests/data/skeletons/sapling_quaking_aspen.json" "$TREE" <<'PY'
import json, sys
doc = json.load(open(sys.argv[1]))
for n in doc["nodes"]:
    n["position"] = [n["position"][0] + 5.0, n["position"][1] - 3.0, n["position"][2] + 2.0]
json.dump(doc, open(sys.argv[2], "w"))
PY
"$STRANDMESH" mesh "$TREE" -o "$WORK/tree.glb" --stats "$WORK/stats.json" -q
"$STRANDMESH" mesh "$TREE" -o "$WORK/tree.obj" -q
"$STRANDMESH" mesh "$TREE" -o "$WORK/wind.glb" --attributes normal,uv,wind,color,uv1 -q
timeout 300 blender -b --factory-startup --python-exit-code 1 --python "$ROOT/scripts/blender_import.py" -- \
  "$WORK/blender.json" "$WORK/tree.glb" "$WORK/tree.obj" "$WORK/wind.glb" > "$WORK/blender.log" 2>&1 ||
  { tail -30 "$WORK/blender.log" >&2; say "Blender failed"; exit 1; }
python3 - "$WORK/blender.json" "$WORK/stats.json" "$TREE" <<'PY'
import json, sys
results = json.load(open(sys.argv[1]))
stats = json.load(open(sys.argv[2]))
nodes = json.load(open(sys.argv[3]))["nodes"]
root = next(n["position"] for n in nodes if n["parent"] == -1)
bad = []
for r in results:
    name = r["file"].rsplit("/", 1)[-1]
    print(f'{name}: {r["mesh_objects"]} mesh object(s), {r.get("triangles")} triangles, '
          f'{r.get("welded_vertices")} welded vertices, origin {[round(x, 3) for x in r.get("origin", [])]}, '
          f'bounds {[round(x, 2) for x in r.get("lo", [])]} .. {[round(x, 2) for x in r.get("hi", [])]}, '
          f'UV maps {r.get("uv_layers")}, colour attributes {r.get("color_attributes")}')
    if r["mesh_objects"] != 1:
        bad.append(f"{name}: {r['mesh_objects']} mesh objects"); continue
    if r["triangles"] != stats["triangles"] or r["welded_vertices"] != stats["vertices"]:
        bad.append(f"{name}: {r['triangles']} triangles / {r['welded_vertices']} vertices, --stats says "
                   f"{stats['triangles']} / {stats['vertices']}")
    lo, hi, o = r["lo"], r["hi"], r["origin"]
    height = hi[2] - lo[2]
    if not (height > hi[0] - lo[0] and height > hi[1] - lo[1]):
        bad.append(f"{name}: not upright (z extent {height:.2f} m is not the largest)")
    if abs(o[2] - lo[2]) > 0.02 * height:
        bad.append(f"{name}: the origin (z {o[2]:.3f}) is not at the base (z {lo[2]:.3f})")
    # The glTF node keeps the root's position; the OBJ sits with its root on the origin.
    want = root if name.endswith(".glb") else [0.0, 0.0, 0.0]
    if max(abs(a - b) for a, b in zip(o, want)) > 1e-3:
        bad.append(f"{name}: origin {o}, expected the trunk's base {want}")
    if name == "wind.glb" and (len(r["uv_layers"]) < 2 or not r["color_attributes"]):
        bad.append(f"{name}: the packed attributes did not arrive (UV maps {r['uv_layers']}, colours {r['color_attributes']})")
if bad:
    sys.exit("check_blender: " + "; ".join(bad))
print("check_blender: .glb and .obj import upright, origin at the trunk's base, counts as --stats")
PY
