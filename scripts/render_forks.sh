#!/usr/bin/env bash
# The before/after fork close-ups of docs/quality.md (docs/images/fork_*.png, issue 32): three
# forks each of sapling_quaking_aspen, mtg_agraf and the grown conifer (seed 1), meshed by two
# builds and drawn by each build's viewer from the same camera. One picture per fork: mesh and
# wireframe on top, the UV checker below, before on the left, after on the right.
#
#   scripts/render_forks.sh BEFORE_BUILD AFTER_BUILD [OUT_DIR]   # default docs/images
#
# BEFORE_BUILD and AFTER_BUILD are build directories holding strandmesh and strandmesh-view
# (docs/quality.md: before = main at b39e8d7, legacy rings and one normal per vertex; after =
# ring_edge 6 / min_ring_vertices 7 by default and split normals). BEFORE_CONFIG=FILE meshes the
# "before" side with that config (e.g. configs/legacy_rings.json with the after build, a
# stand-in for the old geometry only). ONLY="aspen_12 agraf_9" renders just those forks.
# Needs xvfb-run (as scripts/screenshots.sh) and Python 3 with PIL (python3-pil; PYTHON=...).
# The agraf and the conifer are meshed with meshing.uv_metres 0.05: their branches are 1-4 cm
# thick, and at the default 0.2 m one check of the viewer's 8 x 8 checker is as wide as a twig.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BEFORE="$(cd "$1" && pwd)"
AFTER="$(cd "$2" && pwd)"
OUT="${3:-$ROOT/docs/images}"
PYTHON="${PYTHON:-python3}"
BEFORE_CONFIG="${BEFORE_CONFIG:-}"
ONLY="${ONLY:-}"
"$PYTHON" -c 'import PIL' 2>/dev/null || { echo "render_forks.sh: $PYTHON has no PIL (apt-get install python3-pil)" >&2; exit 1; }
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

# config SIDE TREE: the config file each side meshes a tree with ("" for none).
config() {
  local side="$1" tree="$2" fine="{}" base="{}"
  [ "$tree" != aspen ] && fine='{"meshing": {"uv_metres": 0.05}}'
  [ "$side" = before ] && [ -n "$BEFORE_CONFIG" ] && base="$(cat "$BEFORE_CONFIG")"
  "$PYTHON" - "$base" "$fine" >"$WORK/$side.$tree.config.json" <<'EOF'
import json, sys
def merge(a, b):
    for k, v in b.items():
        a[k] = merge(a.get(k, {}), v) if isinstance(v, dict) and isinstance(a.get(k), dict) else v
    return a
print(json.dumps(merge(json.loads(sys.argv[1]), json.loads(sys.argv[2]))))
EOF
  echo "$WORK/$side.$tree.config.json"
}

# prepare TREE SKELETON: each side's mesh (.glb, with its UVs and normals) and stage dump (camera).
prepare() {
  local tree="$1" skeleton="$2" side bin
  for side in before after; do
    bin="$BEFORE"; [ "$side" = after ] && bin="$AFTER"
    "$bin/strandmesh" -q mesh "$skeleton" --config "$(config "$side" "$tree")" \
      -o "$WORK/$side.$tree.glb" --dump-stages "$WORK/$side.$tree.dump"
  done
}

# fork TREE NODE AROUND YAW PITCH: docs/images/fork_TREE_NODE.png
fork() {
  local tree="$1" node="$2" camera="node=$2,around=$3,yaw=$4,pitch=$5" side bin layers shots=()
  if [ -n "$ONLY" ] && [[ " $ONLY " != *" ${tree}_${node} "* ]]; then return 0; fi
  for layers in mesh,wireframe uv; do
    for side in before after; do
      bin="$BEFORE"; [ "$side" = after ] && bin="$AFTER"
      xvfb-run -a "$bin/strandmesh-view" "$WORK/$side.$tree.dump" --mesh "$WORK/$side.$tree.glb" --no-checks \
        --quiet --screenshot "$WORK/$side.$layers.png" --size 600x450 --layers "$layers" --camera "$camera"
      shots+=("$WORK/$side.$layers.png")
    done
  done
  "$PYTHON" - "$OUT/fork_${tree}_${node}.png" "$tree, camera $camera" "${shots[@]}" <<'EOF'
import sys
from PIL import Image, ImageDraw, ImageFont
out, title, paths = sys.argv[1], sys.argv[2], sys.argv[3:]
try:
    font = ImageFont.truetype("DejaVuSans.ttf", 16)
except OSError:
    font = ImageFont.load_default()
ims = [Image.open(p).convert("RGB") for p in paths]
w, h = ims[0].size
canvas = Image.new("RGB", (2 * w, 2 * h), "white")
draw = ImageDraw.Draw(canvas)
for i, im in enumerate(ims):
    x, y = (i % 2) * w, (i // 2) * h
    canvas.paste(im, (x, y))
    label = ("before" if i % 2 == 0 else "after") + (", mesh + wireframe" if i < 2 else ", UV checker")
    for k, text in enumerate([label, title] if i == 0 else [label]):
        box = draw.textbbox((x + 10, y + 8 + 22 * k), text, font=font)
        draw.rectangle((box[0] - 4, box[1] - 3, box[2] + 4, box[3] + 3), fill="white")
        draw.text((x + 10, y + 8 + 22 * k), text, fill="black", font=font)
draw.line([(w, 0), (w, 2 * h)], fill="black", width=2)
draw.line([(0, h), (2 * w, h)], fill="black", width=2)
canvas.quantize(colors=128, method=Image.Quantize.MEDIANCUT).save(out, optimize=True)
EOF
  echo "$OUT/fork_${tree}_${node}.png"
}

"$AFTER/strandmesh" -q grow --preset conifer --seed 1 -o "$WORK/conifer.json"
prepare aspen "$ROOT/tests/data/skeletons/sapling_quaking_aspen.json"
prepare agraf "$ROOT/tests/data/skeletons/mtg_agraf.json"
prepare conifer "$WORK/conifer.json"
# TREE NODE AROUND YAW PITCH (node ids as `strandmesh info SKELETON --export F` writes them)
fork aspen 12 3 35 12      # a lateral leaving the trunk (radius 5 cm from 11 cm)
fork aspen 34 3 35 12      # a twig fork near the top (2.6 and 1.9 cm from 2.5 cm)
fork aspen 32 3 35 20      # a crotch of two nearly equal stems (3.1 and 2.8 cm)
fork agraf 9 3 35 12       # laterals of a whorl leaving the main stem (1.5 cm)
fork agraf 293 5 35 12     # a twig fork (2.7 and 2.3 mm from 3.2 mm)
fork agraf 15 3 125 12     # a crotch (1.0 and 0.9 cm from 1.4 cm)
fork conifer 12 3 35 12    # a lateral leaving the trunk (1.2 cm from 4.1 cm)
fork conifer 224 4 35 12   # a twig fork (2.1 and 2.1 mm from 3.0 mm)
fork conifer 718 3.5 35 12  # a right-angled crotch on a branch (4.2 and 4.2 mm from 6.0 mm)
