#!/usr/bin/env bash
# The before/after UV close-ups of docs/quality.md (docs/images/uv_*.png): three forks each of
# sapling_quaking_aspen, mtg_agraf and the grown conifer (seed 1), meshed by two builds and drawn
# with the viewer's UV checker from the same camera, side by side.
#
#   scripts/uv_pictures.sh BEFORE/strandmesh AFTER/strandmesh [OUT_DIR]   # default docs/images
#
# Needs xvfb-run (as scripts/screenshots.sh) and ImageMagick's convert for the side-by-side
# pictures (without it, the two halves are written as uv_*_before.png and uv_*_after.png).
# Both builds mesh the same geometry only if they differ in their UVs alone. The agraf and the
# conifer are meshed with meshing.uv_metres 0.05 (their branches are 1-4 cm thick: at the
# default 0.2 m a check of the viewer's 8 x 8 checker is about as wide as a twig).
set -euo pipefail
source "$(dirname "$0")/common.sh"
BEFORE="$1"
AFTER="$2"
OUT="${3:-$STRANDMESH_ROOT/docs/images}"
VIEW="$BUILD_DIR/strandmesh-view"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
CONVERT="$(command -v /usr/bin/convert || true)"
echo '{"meshing": {"uv_metres": 0.05}}' >"$WORK/fine.json"
"$AFTER" -q grow --preset conifer --seed 1 -o "$WORK/conifer.json"

# prepare TREE SKELETON [CONFIG]: the dump (camera) and both meshes
prepare() {
  local tree="$1" skeleton="$2" config="$3"
  mkdir -p "$WORK/$tree"
  "$AFTER" -q mesh "$skeleton" -o "$WORK/$tree/dump.ply" --dump-stages "$WORK/$tree/dump"
  "$BEFORE" -q mesh "$skeleton" -o "$WORK/$tree/before.ply"
  "$AFTER" -q mesh "$skeleton" ${config:+--config "$config"} -o "$WORK/$tree/after.ply"
}
# shot TREE NODE AROUND YAW PITCH: one picture
shot() {
  local tree="$1" node="$2" around="$3" yaw="$4" pitch="$5" name="uv_$1_$2"
  for w in before after; do
    xvfb-run -a "$VIEW" "$WORK/$tree/dump" --mesh "$WORK/$tree/$w.ply" --quiet --screenshot "$WORK/$w.png" \
      --size 600x450 --layers uv --camera "node=$node,around=$around,yaw=$yaw,pitch=$pitch"
  done
  if [ -n "$CONVERT" ]; then
    "$CONVERT" "$WORK/before.png" -gravity NorthWest -pointsize 18 -annotate +10+8 "before" "$WORK/b.png"
    "$CONVERT" "$WORK/after.png" -gravity NorthWest -pointsize 18 -annotate +10+8 "after" "$WORK/a.png"
    "$CONVERT" "$WORK/b.png" "$WORK/a.png" +append -colors 128 "PNG8:$OUT/$name.png"
  else
    cp "$WORK/before.png" "$OUT/${name}_before.png"
    cp "$WORK/after.png" "$OUT/${name}_after.png"
  fi
  echo "$OUT/$name.png"
}
prepare aspen "$STRANDMESH_ROOT/tests/data/skeletons/sapling_quaking_aspen.json" ""
prepare agraf "$STRANDMESH_ROOT/tests/data/skeletons/mtg_agraf.json" "$WORK/fine.json"
prepare conifer "$WORK/conifer.json" "$WORK/fine.json"
shot aspen 12 3 35 12
shot aspen 18 3 -60 10
shot aspen 25 3.5 120 15
shot agraf 10 4 35 12
shot agraf 14 4 35 12
shot agraf 451 5 35 12
shot conifer 12 3 35 12
shot conifer 20 3 200 12
shot conifer 1428 5 35 12
