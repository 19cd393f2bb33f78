# Shared set-up for scripts/demo.sh and scripts/test.sh: install what is missing (Debian
# packages only), then configure and build. Idempotent: a second run installs nothing and
# rebuilds only what changed.

STRANDMESH_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${STRANDMESH_BUILD_DIR:-$STRANDMESH_ROOT/build}"
BUILD_TYPE="${STRANDMESH_BUILD_TYPE:-Release}"

# Every dependency, from Debian's packages.
STRANDMESH_PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libglm-dev libnanoflann-dev libcgal-dev libgmp-dev libmpfr-dev libtinygltf-dev
  nlohmann-json3-dev libcli11-dev libtbb-dev libmeshoptimizer-dev libmatio-dev zlib1g-dev libopenvdb-dev libboost-iostreams-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libimgui-dev libglfw3-dev libgl-dev libstb-dev
  xvfb xauth libgl1-mesa-dri
  parallel time
)
# Node.js and npm run the Khronos glTF validator (scripts/validate_gltf.sh). Installed only when
# missing: a machine may already have a newer Node.js whose npm conflicts with Debian's.
command -v npm >/dev/null 2>&1 || STRANDMESH_PACKAGES+=(nodejs npm)
# The real clients the `clients` tests load our files in (scripts/check_threejs.sh,
# scripts/check_blender.sh). test.sh installs them so those tests run rather than skip;
# STRANDMESH_NO_CLIENTS=1 leaves them out (the two tests then skip).
CLIENT_PACKAGES=(chromium blender python3-numpy)

log() { printf '\033[1m[strandmesh]\033[0m %s\n' "$*" >&2; }

as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"
  elif command -v sudo >/dev/null 2>&1; then sudo "$@"
  else log "need root to run: $*"; return 1
  fi
}

ensure_packages() {
  local missing=()
  for p in "${STRANDMESH_PACKAGES[@]}" "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then
    log "all packages present"
    return 0
  fi
  log "installing: ${missing[*]}"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

jobs() { nproc 2>/dev/null || echo 2; }

configure_and_build() {
  local gen=()
  command -v ninja >/dev/null 2>&1 && gen=(-G Ninja)
  if [ ! -f "$BUILD_DIR/CMakeCache.txt" ]; then
    log "configuring $BUILD_TYPE build in $BUILD_DIR"
    cmake -S "$STRANDMESH_ROOT" -B "$BUILD_DIR" "${gen[@]}" -DCMAKE_BUILD_TYPE="$BUILD_TYPE" "$@"
  fi
  log "building with $(jobs) jobs"
  cmake --build "$BUILD_DIR" -j "$(jobs)"
}
