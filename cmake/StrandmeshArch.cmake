# The instruction set the whole build targets (STRANDMESH_ARCH).
#
# auto (the default): x86-64-v3 (AVX2, FMA, BMI2; x86-64 processors from about 2015 on) when
#   the compiler targets x86-64 and the machine running the build supports it, else the
#   compiler's default. Measured on the bench tree (`strandmesh bench --preset large`,
#   2 threads, 2-core AMD EPYC VM): about 2.5 % more particles per second than the baseline
#   x86-64; x86-64-v4 (AVX-512) gained nothing more.
# portable: the compiler's default (binaries meant for other machines).
# anything else: passed on as -march=<value>.
#
# Floating-point contraction is off in every case (-ffp-contract=off: no fused multiply-add
# the source does not ask for), so the meshes are bit for bit the same whichever instruction
# set is chosen, and the error bounds of the floating-point filters in front of CGAL's exact
# predicates (meshcheck/checks_cgal.cpp) hold as derived.
function(strandmesh_select_arch)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    return()
  endif()
  add_compile_options(-ffp-contract=off)
  set(arch "${STRANDMESH_ARCH}")
  if(arch STREQUAL "auto")
    set(arch "")
    if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$" AND NOT CMAKE_CROSSCOMPILING)
      include(CheckCXXSourceRuns)
      # Built without the flag, so it runs (and answers no) on an older processor too.
      check_cxx_source_runs([[
        int main() {
          __builtin_cpu_init();
          return __builtin_cpu_supports("x86-64-v3") ? 0 : 1;
        }]] STRANDMESH_HOST_HAS_X86_64_V3)
      if(STRANDMESH_HOST_HAS_X86_64_V3)
        set(arch "x86-64-v3")
      endif()
    endif()
  elseif(arch STREQUAL "portable")
    set(arch "")
  endif()
  if(arch)
    add_compile_options(-march=${arch})
    message(STATUS "strandmesh: building for -march=${arch} (STRANDMESH_ARCH=${STRANDMESH_ARCH})")
  else()
    message(STATUS "strandmesh: building for the compiler's default instruction set (STRANDMESH_ARCH=${STRANDMESH_ARCH})")
  endif()
endfunction()
