#!/usr/bin/env bash
# three.js client check (ctest label `clients`): meshes a sample tree with the wind attributes
# as plain, quantized and meshopt-compressed .glb, and with three levels of detail in one .glb
# (MSFT_lod), loads them all in headless Chromium with
# three.js (GLTFLoader + MeshoptDecoder, npm package `three`, installed on first use into the
# git-ignored folder .tools/threejs/) through examples/wind/index.html, and checks that each loaded
# with its vertex and triangle counts and wind attributes, that the levels of detail load from
# their nodes, coarser and coarser, and that the tree was drawn.
#
#   scripts/check_threejs.sh STRANDMESH [SCREENSHOT.png]
#
# Exit codes: 0 ok, 1 a check failed, 2 usage, 77 skipped (no Chromium, Node.js or npm; ctest
# treats 77 as "skipped").
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TOOLS="$ROOT/.tools/threejs"  # its own npm prefix: another install into .tools would prune it
THREE_VERSION="0.187.0"
say() { printf '[check_threejs] %s\n' "$*" >&2; }

[ $# -ge 1 ] || { echo "usage: $0 STRANDMESH [SCREENSHOT.png]" >&2; exit 2; }
STRANDMESH="$1"
SHOT="${2:-}"
CHROMIUM="$(command -v chromium || command -v chromium-browser || true)"
if [ -z "$CHROMIUM" ]; then say "skipped: Chromium is not installed (Debian package chromium)"; exit 77; fi
if ! command -v npm >/dev/null 2>&1 || ! command -v node >/dev/null 2>&1; then say "skipped: no Node.js/npm"; exit 77; fi

installed() { node -e 'try { console.log(require(process.argv[1] + "/package.json").version) } catch (e) { }' "$TOOLS/node_modules/three" 2>/dev/null || true; }
if [ "$(installed)" != "$THREE_VERSION" ]; then
  say "installing three@$THREE_VERSION into $TOOLS"
  mkdir -p "$TOOLS"
  npm install --prefix "$TOOLS" --no-audit --no-fund --no-save --loglevel=error "three@$THREE_VERSION" >&2 ||
    { say "skipped: npm could not install three"; exit 77; }
fi

WORK="$(mktemp -d)"
SERVER=""
cleanup() { [ -n "$SERVER" ] && kill "$SERVER" 2>/dev/null; rm -rf "$WORK"; }
trap cleanup EXIT
cp "$ROOT/examples/wind/index.html" "$WORK/"
ln -s "$TOOLS/node_modules" "$WORK/node_modules"
TREE="$ROOT/tests/data/skeletons/sapling_quaking_aspen.json"
ATTR="normal,uv,branch_id,wind,tangent"
"$STRANDMESH" mesh "$TREE" -o "$WORK/plain.glb" --attributes "$ATTR" -q
"$STRANDMESH" mesh "$TREE" -o "$WORK/quantized.glb" --attributes "$ATTR" --quantize -q
"$STRANDMESH" mesh "$TREE" -o "$WORK/meshopt.glb" --attributes "$ATTR" --quantize --compress meshopt -q
"$STRANDMESH" mesh "$TREE" -o "$WORK/lods.glb" --attributes "$ATTR" --quantize --compress meshopt --lods 3 -q
"$STRANDMESH" mesh "$TREE" -o "$WORK/stats.glb" --stats "$WORK/stats.json" -q

PORT="$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
(cd "$WORK" && exec python3 -m http.server "$PORT" --bind 127.0.0.1 >/dev/null 2>&1) &
SERVER=$!
for _ in $(seq 1 50); do python3 -c "import socket; socket.create_connection(('127.0.0.1', $PORT), 0.2)" 2>/dev/null && break; sleep 0.1; done
URL="http://127.0.0.1:$PORT/index.html?models=lods.glb,plain.glb,quantized.glb,meshopt.glb&time=1.3"
FLAGS=(--no-sandbox --disable-gpu-sandbox --enable-unsafe-swiftshader --use-angle=swiftshader
       --ignore-gpu-blocklist --window-size=900,1000 --user-data-dir="$WORK/profile")
# Waits in real time (up to 180 s) for the page's report (scripts/headless_page.py).
"$ROOT/scripts/headless_page.py" "$URL" "$WORK/status.json" -- "$CHROMIUM" "${FLAGS[@]}" ||
  say "the page had not reported within 180 s"
python3 - "$WORK/status.json" "$WORK/stats.json" <<'PY'
import json, sys
text = open(sys.argv[1]).read()
if text == "loading":
    sys.exit("check_threejs: the page did not report (#status still loading)")
status = json.loads(text)
print(json.dumps(status, indent=1)[:3000])
if not status.get("ok"):
    sys.exit("check_threejs: the page failed: " + status.get("error", "?"))
triangles = json.load(open(sys.argv[2]))["triangles"]
bad = []
for r in status["models"]:
    if r["triangles"] != triangles: bad.append(f'{r["name"]}: {r["triangles"]} triangles, --stats says {triangles}')
    if not r["wind"]: bad.append(f'{r["name"]}: wind attributes missing ({r["attributes"]})')
if status["centre_pixel"][:3] == [0xdf, 0xe8, 0xef]: bad.append("nothing drawn at the centre of the view")
if len(status["models"]) != 4: bad.append("not every model loaded")
for r in status["models"]:
    lods = r.get("lod_triangles", [])
    if r["name"] == "lods.glb":
        # MSFT_lod: level 0 in the scene (what three.js shows), levels 1 and 2 beside it, coarser.
        if len(lods) != 2 or not (triangles > lods[0] > lods[1] > 0): bad.append(f"lods.glb: levels {lods}")
        if "MSFT_lod" not in r["extensions"]: bad.append("lods.glb: MSFT_lod not in extensionsUsed")
        if len(r.get("screen_coverage", [])) != 3: bad.append(f'lods.glb: MSFT_screencoverage {r.get("screen_coverage")}')
    elif lods: bad.append(f'{r["name"]}: levels of detail {lods} in a file without them')
if bad: sys.exit("check_threejs: " + "; ".join(bad))
print("check_threejs: plain, quantized, meshopt and levels-of-detail .glb loaded and drawn")
PY
if [ -n "$SHOT" ]; then
  rm -rf "$WORK/profile"
  "$ROOT/scripts/headless_page.py" --screenshot "$SHOT" "${URL/models=lods.glb,plain.glb,quantized.glb,meshopt.glb/models=meshopt.glb}" \
    "$WORK/shot_status.json" -- "$CHROMIUM" "${FLAGS[@]}" || true
  [ -s "$SHOT" ] && say "screenshot: $SHOT"
fi
