# Helpers shared by every strandmesh target.

# strandmesh_warnings(<target>): turn on warnings for one of our own targets only
# (third-party headers are included as SYSTEM and stay quiet).
function(strandmesh_warnings target)
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow
      -Wnon-virtual-dtor -Wcast-align -Woverloaded-virtual
      -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
    # GCC 12 counts the members a designated initializer leaves at their defaults as missing,
    # which is what options structs ({.seed = 2}) are for.
    if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
      target_compile_options(${target} PRIVATE -Wno-missing-field-initializers)
    endif()
    if(STRANDMESH_WARNINGS_AS_ERRORS)
      target_compile_options(${target} PRIVATE -Werror)
    endif()
  elseif(MSVC)
    target_compile_options(${target} PRIVATE /W4 /permissive-)
  endif()
endfunction()

# strandmesh_library(<name> SOURCES ... [DEPS ...] [PRIVATE_DEPS ...])
# Defines the stage library target sm_<name> (alias sm::<name>) with the repository
# root as include root, so code includes "stage/header.h".
function(strandmesh_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  set(target sm_${name})
  add_library(${target} STATIC ${ARG_SOURCES})
  add_library(sm::${name} ALIAS ${target})
  # Installed, the headers keep their folders under include/strandmesh (StrandmeshInstall.cmake).
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/strandmesh>)
  target_link_libraries(${target} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  target_compile_features(${target} PUBLIC cxx_std_20)
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON EXPORT_NAME ${name})
  strandmesh_warnings(${target})
endfunction()

# strandmesh_use_cgal(<target>): CGAL is header-heavy and slow to compile; only the few
# translation units that need it (mesh checks) link it, with the flags CGAL wants.
function(strandmesh_use_cgal target)
  target_link_libraries(${target} PRIVATE CGAL::CGAL)
  target_compile_definitions(${target} PRIVATE CGAL_DISABLE_ROUNDING_MATH_CHECK=1)
endfunction()
