#!/usr/bin/env bash
# Installs what is missing, builds (Release), and runs every default-label test.
# Slow cases are opt-in: ctest --test-dir build -L slow
# Also installs Chromium and Blender for the client tests (STRANDMESH_NO_CLIENTS=1: skip them).
#   ./scripts/test.sh --sanitize   the same suite built with clang, -fsanitize=address,undefined
#                                  (in build-asan; the first sanitizer report fails the test)
set -euo pipefail
source "$(dirname "$0")/common.sh"
start=$(date +%s)
if [ "${1:-}" = "--sanitize" ]; then
  source "$STRANDMESH_ROOT/scripts/sanitize_env.sh"
  configure_and_build_sanitized
  log "running tests under AddressSanitizer and UndefinedBehaviorSanitizer"
  ctest --test-dir "$BUILD_DIR" -LE 'slow|viewer' --output-on-failure -j "$(jobs)" --timeout 1800
  log "done in $(( $(date +%s) - start )) s"
  exit 0
fi
if [ "${STRANDMESH_NO_CLIENTS:-0}" = 1 ]; then ensure_packages; else ensure_packages "${CLIENT_PACKAGES[@]}"; fi
configure_and_build
"$STRANDMESH_ROOT/scripts/validate_gltf.sh" --install || log "glTF validator unavailable: its test will be skipped"
log "running tests"
ctest --test-dir "$BUILD_DIR" -LE 'slow' --output-on-failure -j "$(jobs)" --timeout 900
log "done in $(( $(date +%s) - start )) s"
