#!/usr/bin/env bash
# Installs what is missing, builds, grows the built-in default tree, meshes it into
# out/demo.glb and checks the mesh (report in out/demo_check.txt).
set -euo pipefail
source "$(dirname "$0")/common.sh"
ensure_packages
configure_and_build
OUT="$STRANDMESH_ROOT/out"
mkdir -p "$OUT"
SM="$BUILD_DIR/strandmesh"
log "growing the default tree -> out/demo_skeleton.json"
"$SM" grow --seed 1 -o "$OUT/demo_skeleton.json"
"$SM" info "$OUT/demo_skeleton.json"
log "meshing -> out/demo.glb (figures in out/demo_stats.json)"
"$SM" --verbose mesh "$OUT/demo_skeleton.json" -o "$OUT/demo.glb" --stats "$OUT/demo_stats.json"
log "checking the mesh -> out/demo_check.txt"
status=0
"$SM" check "$OUT/demo.glb" --skeleton "$OUT/demo_skeleton.json" | tee "$OUT/demo_check.txt" || status=$?
if [ "$status" -ne 0 ]; then log "the check found problems (exit $status)"; exit "$status"; fi
log "done: out/demo.glb"
