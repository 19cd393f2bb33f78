#!/usr/bin/env bash
# Installs what is missing, builds (Release), and runs every default-label test.
# Slow cases are opt-in: ctest --test-dir build -L slow
set -euo pipefail
source "$(dirname "$0")/common.sh"
start=$(date +%s)
ensure_packages
configure_and_build
"$STRANDMESH_ROOT/scripts/validate_gltf.sh" --install || log "glTF validator unavailable: its test will be skipped"
log "running tests"
ctest --test-dir "$BUILD_DIR" -LE 'slow' --output-on-failure -j "$(jobs)" --timeout 900
log "done in $(( $(date +%s) - start )) s"
