#!/usr/bin/env bash
# Regenerates the parameter reference in docs/defaults.md (between its BEGIN/END markers) and
# configs/default.json from the stage tables: scripts/update_param_docs.sh [path/to/strandmesh].
# test_cli checks both.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="${1:-$root/build/strandmesh}"
doc="$root/docs/defaults.md"
ref="$(mktemp)"
trap 'rm -f "$ref"' EXIT
"$bin" params --markdown >"$ref"
awk -v ref="$ref" '
  /^<!-- BEGIN strandmesh params --markdown/ { print; while ((getline line < ref) > 0) print line; skip = 1; next }
  /^<!-- END strandmesh params --markdown/ { skip = 0 }
  !skip { print }
' "$doc" >"$doc.tmp"
mv "$doc.tmp" "$doc"
# configs/default.json: the printed defaults after a description line (test_cli checks it too).
cfg="$root/configs/default.json"
{
  echo '{'
  echo '  "description": "the built-in defaults, every parameter spelled out (strandmesh mesh --print-config)",'
  "$bin" mesh --print-config | tail -n +2
} >"$cfg.tmp"
mv "$cfg.tmp" "$cfg"
