# Shared by scripts/test.sh --sanitize and scripts/fuzz.sh: the sanitizer build (clang,
# AddressSanitizer + UndefinedBehaviorSanitizer, the libFuzzer targets) in build-asan.
SANITIZE_PACKAGES=(clang libclang-rt-dev)
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1:check_initialization_order=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"

configure_and_build_sanitized() {
  BUILD_DIR="${STRANDMESH_ASAN_BUILD_DIR:-$STRANDMESH_ROOT/build-asan}"
  BUILD_TYPE=RelWithDebInfo
  ensure_packages "${SANITIZE_PACKAGES[@]}"
  CC=clang CXX=clang++ configure_and_build -DSTRANDMESH_SANITIZE=address,undefined -DSTRANDMESH_BUILD_FUZZ=ON \
    -DSTRANDMESH_BUILD_VIEWER=OFF -DSTRANDMESH_BUILD_BENCH=OFF -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang \
    "$@"
}
