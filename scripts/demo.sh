#!/usr/bin/env bash
# Installs what is missing, builds, grows the built-in default tree and reports on it.
set -euo pipefail
source "$(dirname "$0")/common.sh"
ensure_packages
configure_and_build
mkdir -p "$STRANDMESH_ROOT/out"
SM="$BUILD_DIR/strandmesh"
log "growing the default tree -> out/demo_skeleton.json"
"$SM" grow --seed 1 -o "$STRANDMESH_ROOT/out/demo_skeleton.json"
"$SM" info "$STRANDMESH_ROOT/out/demo_skeleton.json"
