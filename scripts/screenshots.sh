#!/usr/bin/env bash
# Regenerates the stage screenshots of docs/viewer.md and the README (docs/images/*.png) with strandmesh-view
# --screenshot under xvfb-run (Mesa's software OpenGL): one run of the pipeline on a sample
# tree is dumped with --dump-stages, then every picture is rendered from that dump.
#
#   ./scripts/screenshots.sh [SKELETON]     # default: tests/data/skeletons/sapling_quaking_aspen.json
#
# Installs what is missing and builds first (like demo.sh and test.sh); with
# STRANDMESH_SKIP_BUILD=1 it uses the binaries already in $STRANDMESH_BUILD_DIR (default build/).
# STRANDMESH_SCREENSHOT_NODE=N picks the node the close-ups frame.
set -euo pipefail
source "$(dirname "$0")/common.sh"

VIEW="$BUILD_DIR/strandmesh-view"
OUT="$STRANDMESH_ROOT/docs/images"
SIZE=640x480

# Second stage: called by itself under xvfb-run with the dump directory and the close-up node.
if [ "${1:-}" = "--inside-xvfb" ]; then
  DUMP="$2"
  FORK="$3"
  CAM="yaw=35,pitch=12,dist=0.9"
  CLOSE="yaw=35,pitch=12,node=$FORK,around=${STRANDMESH_SCREENSHOT_AROUND:-5}"
  ACROSS="yaw=120,pitch=40,node=$FORK,around=3"  # looking into the cross-sections
  shot() {  # shot NAME LAYERS CAMERA [extra args]
    local name="$1" layers="$2" camera="$3"
    shift 3
    "$VIEW" "$DUMP" --quiet --screenshot "$OUT/$name.png" --size "${SHOT_SIZE:-$SIZE}" --layers "$layers" \
      --camera "$camera" "$@"
    printf '  %-24s %7d bytes\n' "$name.png" "$(stat -c %s "$OUT/$name.png")" >&2
  }
  shot stage_skeleton    skeleton,discs,legend          "$CAM"
  shot stage_frames      skeleton,discs,frames,legend   "$ACROSS"
  shot stage_particles   skeleton,discs,particles,legend "$ACROSS"
  shot stage_strands     strands,legend                 "$CAM"
  shot stage_strands_tip strands,legend                 "$CLOSE" --color-by tip
  shot stage_contours    contours,skeleton,legend       "$CLOSE"
  shot stage_mesh        mesh,legend                    "$CAM"
  shot stage_wireframe   mesh,wireframe,legend          "$CLOSE"
  shot stage_uv          uv,legend                      "$CLOSE"
  SHOT_SIZE=1200x720 shot viewer_ui mesh,legend "yaw=35,pitch=12,dist=0.9" --ui --select "$FORK"
  # The problems layer needs a tree with problems (the aspen has none): a folded whorl of the
  # small pine (docs/viewer.md).
  "$VIEW" "$STRANDMESH_ROOT/tests/data/skeletons/sapling_small_pine.json" --quiet --screenshot "$OUT/problems.png" \
    --size 640x400 --layers mesh,problems,legend --camera node=1012,around=3,yaw=0
  printf '  %-24s %7d bytes\n' "problems.png" "$(stat -c %s "$OUT/problems.png")" >&2
  exit 0
fi

if [ "${STRANDMESH_SKIP_BUILD:-0}" != 1 ]; then
  ensure_packages
  configure_and_build
fi

SKELETON="${1:-$STRANDMESH_ROOT/tests/data/skeletons/sapling_quaking_aspen.json}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
mkdir -p "$OUT"

if [ ! -f "$SKELETON" ]; then
  log "$SKELETON not found; growing a tree instead"
  SKELETON="$WORK/tree.json"
  "$BUILD_DIR/strandmesh" grow --seed 1 -o "$SKELETON"
fi

NAME="$(basename "${SKELETON%.*}")"
DUMP="$WORK/$NAME"  # the panels show the dump's name as given, so it is relative below
mkdir -p "$DUMP"
log "meshing $NAME and dumping its stages"
"$BUILD_DIR/strandmesh" --quiet mesh "$SKELETON" -o "$DUMP/$NAME.glb" --dump-stages "$DUMP"

# The node the close-ups frame: a plain binary fork (neither its parent nor its children are
# forks, so not part of a whorl split into a chain of forks) whose thinner child is thickest;
# else any fork with the thickest thinner child. Read from the dumped, sanitized skeleton.
FORK="${STRANDMESH_SCREENSHOT_NODE:-}"
if [ -z "$FORK" ]; then
  FORK=$(python3 - "$DUMP/skeleton.json" <<'EOF' 2>/dev/null || echo 0
import json, sys
nodes = json.load(open(sys.argv[1]))["nodes"]
radius = {n["id"]: n["radius"] for n in nodes}
parent = {n["id"]: n["parent"] for n in nodes}
children = {}
for n in nodes:
    children.setdefault(n["parent"], []).append(n["id"])
fork = lambda i: len(children.get(i, [])) == 2
forks = [(min(radius[c] for c in children[p]), p) for p in children if p >= 0 and fork(p)]
plain = [f for f in forks if not fork(parent[f[1]]) and not any(fork(c) for c in children[f[1]])]
print(max(plain or forks)[1] if forks else 0)
EOF
)
fi
log "rendering under xvfb-run (close-ups frame node $FORK)"
SELF="$(cd "$(dirname "$0")" && pwd)/$(basename "$0")"
(cd "$WORK" && xvfb-run -a -s '-screen 0 1280x1024x24' "$SELF" --inside-xvfb "$NAME" "$FORK")
log "done: $OUT"
