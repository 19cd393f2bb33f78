#!/usr/bin/env bash
# Installs the library from a build tree into a temporary prefix, builds examples/mesh_tree
# against the installed package, meshes a sample skeleton with it and checks that the file is
# the one `strandmesh mesh` writes for the same skeleton and seed (byte for byte).
#
#   scripts/test_install.sh BUILD_DIR [CXX_COMPILER] [COMPILER_LAUNCHER]
#
# Run by ctest (test install_example) after the build.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="$(cd "${1:?usage: $0 BUILD_DIR [CXX_COMPILER] [COMPILER_LAUNCHER]}" && pwd)"
CXX_COMPILER="${2:-}"
LAUNCHER="${3:-}"
WORK="$(mktemp -d "${TMPDIR:-/tmp}/strandmesh_install.XXXXXX")"
trap 'rm -rf "$WORK"' EXIT
SKELETON="$ROOT/tests/data/skeletons/sapling_quaking_aspen.json"

cmake --install "$BUILD" --prefix "$WORK/prefix" >"$WORK/install.log"
test -f "$WORK/prefix/include/strandmesh/strandmesh.h"
test -f "$WORK/prefix/lib/cmake/strandmesh/strandmeshConfig.cmake" ||
  test -f "$WORK"/prefix/lib/*/cmake/strandmesh/strandmeshConfig.cmake

args=(-S "$ROOT/examples/mesh_tree" -B "$WORK/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$WORK/prefix")
if command -v ninja >/dev/null 2>&1; then args+=(-G Ninja); fi
if [ -n "$CXX_COMPILER" ]; then args+=(-DCMAKE_CXX_COMPILER="$CXX_COMPILER"); fi
if [ -n "$LAUNCHER" ]; then args+=(-DCMAKE_CXX_COMPILER_LAUNCHER="$LAUNCHER"); fi
# A sanitizer build (scripts/test.sh --sanitize) installs sanitized libraries: the example
# must link the sanitizer runtimes too.
SANITIZE="$(sed -n 's/^STRANDMESH_SANITIZE:STRING=//p' "$BUILD/CMakeCache.txt")"
if [ -n "$SANITIZE" ]; then
  args+=(-DCMAKE_CXX_FLAGS="-fsanitize=$SANITIZE" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=$SANITIZE")
fi
cmake "${args[@]}" >"$WORK/configure.log" || { cat "$WORK/configure.log"; exit 1; }
cmake --build "$WORK/build" >"$WORK/build.log" || { cat "$WORK/build.log"; exit 1; }

"$WORK/build/mesh_tree" "$SKELETON" "$WORK/example.glb" 3
"$BUILD/strandmesh" --quiet mesh "$SKELETON" -o "$WORK/cli.glb" --seed 3
test -s "$WORK/example.glb"
cmp "$WORK/example.glb" "$WORK/cli.glb"
echo "install_example: mesh_tree, built against the installed package, wrote the same $(stat -c %s "$WORK/example.glb") bytes as strandmesh mesh"
