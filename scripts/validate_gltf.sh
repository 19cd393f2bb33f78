#!/usr/bin/env bash
# Validates glTF files with the Khronos glTF Validator (npm package gltf-validator, run by
# Node.js), installed on first use into the git-ignored folder .tools/.
#
#   scripts/validate_gltf.sh FILE.glb [FILE.gltf ...]   print each report; exit 1 on any error
#   scripts/validate_gltf.sh --install                  only install the validator
#
# Exit codes: 0 no errors (warnings and infos are printed but accepted), 1 a file has errors
# or cannot be read, 2 usage, 77 skipped: Node.js/npm missing or the install failed (ctest
# treats 77 as "skipped").
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TOOLS="$ROOT/.tools"
VERSION="2.0.0-dev.3.10"
MODULE="$TOOLS/node_modules/gltf-validator"

say() { printf '[validate_gltf] %s\n' "$*" >&2; }

if [ $# -eq 0 ]; then
  echo "usage: $0 [--install] FILE.glb|FILE.gltf ..." >&2
  exit 2
fi

if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  say "skipped: Node.js and npm are not installed (Debian packages nodejs and npm)"
  exit 77
fi

installed_version() {
  node -e 'try { console.log(require(process.argv[1] + "/package.json").version) } catch (e) { }' "$MODULE" 2>/dev/null || true
}

if [ "$(installed_version)" != "$VERSION" ]; then
  say "installing gltf-validator@$VERSION into $TOOLS"
  mkdir -p "$TOOLS"
  # A lock directory keeps parallel callers (ctest -j) from installing at the same time.
  lock="$TOOLS/.install.lock"
  for _ in $(seq 1 300); do
    if mkdir "$lock" 2>/dev/null; then break; fi
    sleep 1
  done
  trap 'rmdir "$lock" 2>/dev/null || true' EXIT
  if [ "$(installed_version)" != "$VERSION" ]; then
    if ! npm install --prefix "$TOOLS" --no-audit --no-fund --no-save --loglevel=error "gltf-validator@$VERSION" >&2; then
      say "skipped: npm could not install gltf-validator"
      exit 77
    fi
  fi
fi

[ "$1" = "--install" ] && exit 0

# The reporter: one summary line per file, every issue message, exit 1 if any file has errors.
read -r -d '' SCRIPT <<'JS' || true
const fs = require('fs');
const path = require('path');
const validator = require(process.env.GLTF_VALIDATOR_MODULE);
(async () => {
  let failed = false;
  for (const file of process.argv.slice(1)) {
    let data;
    try {
      data = new Uint8Array(fs.readFileSync(file));
    } catch (e) {
      console.log(`${file}: cannot read: ${e.message}`);
      failed = true;
      continue;
    }
    const report = await validator.validateBytes(data, {
      uri: path.basename(file),
      maxIssues: 100,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)),
                    (err, bytes) => err ? reject(err.toString()) : resolve(new Uint8Array(bytes)));
      }),
    }).catch((e) => ({ issues: { numErrors: 1, numWarnings: 0, numInfos: 0, numHints: 0,
                                 messages: [{ code: 'EXCEPTION', message: String(e), severity: 0, pointer: '' }] } }));
    const i = report.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints`);
    const severity = ['error', 'warning', 'info', 'hint'];
    for (const m of i.messages) {
      console.log(`  ${severity[m.severity] || m.severity} ${m.code}: ${m.message}${m.pointer ? ' (' + m.pointer + ')' : ''}`);
    }
    if (i.numErrors > 0) failed = true;
  }
  process.exit(failed ? 1 : 0);
})();
JS

GLTF_VALIDATOR_MODULE="$MODULE" node -e "$SCRIPT" "$@"
