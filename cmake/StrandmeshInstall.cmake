# Installing the library: `cmake --install BUILD --prefix PREFIX` puts the public header
# (include/strandmesh/strandmesh.h), the static stage libraries it needs with their headers
# (include/strandmesh/<stage>/...), and a CMake package so that `find_package(strandmesh)`
# gives the target strandmesh::strandmesh (see examples/mesh_tree).

include(CMakePackageConfigHelpers)

# The strandmesh targets `target` links, directly or through others (aliases resolved).
function(strandmesh_linked_targets target out)
  set(seen "")
  set(todo ${target})
  while(todo)
    list(POP_FRONT todo t)
    get_target_property(aliased ${t} ALIASED_TARGET)
    if(aliased)
      set(t ${aliased})
    endif()
    if(t IN_LIST seen)
      continue()
    endif()
    list(APPEND seen ${t})
    get_target_property(links ${t} LINK_LIBRARIES)
    get_target_property(interface_links ${t} INTERFACE_LINK_LIBRARIES)
    foreach(dep IN LISTS links interface_links)
      string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" dep "${dep}")
      if(dep MATCHES "^(sm::|sm_)" AND TARGET ${dep})
        list(APPEND todo ${dep})
      endif()
    endforeach()
  endwhile()
  set(${out} ${seen} PARENT_SCOPE)
endfunction()

# strandmesh_install(<target>): installs <target> and every strandmesh library it links,
# each with the headers of its folder, and the package files.
function(strandmesh_install target)
  strandmesh_linked_targets(${target} targets)
  install(TARGETS ${targets} EXPORT strandmeshTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  foreach(t IN LISTS targets)
    get_target_property(dir ${t} SOURCE_DIR)
    file(RELATIVE_PATH folder ${PROJECT_SOURCE_DIR} ${dir})
    if(folder STREQUAL "api")
      continue()  # its header is include/strandmesh/strandmesh.h (api/CMakeLists.txt)
    endif()
    install(DIRECTORY ${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/strandmesh/${folder}
            FILES_MATCHING PATTERN "*.h")
  endforeach()
  set(cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/strandmesh)
  install(EXPORT strandmeshTargets NAMESPACE strandmesh:: DESTINATION ${cmake_dir})
  configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/strandmeshConfig.cmake.in
    ${PROJECT_BINARY_DIR}/strandmeshConfig.cmake INSTALL_DESTINATION ${cmake_dir})
  write_basic_package_version_file(${PROJECT_BINARY_DIR}/strandmeshConfigVersion.cmake
    COMPATIBILITY SameMinorVersion)
  install(FILES ${PROJECT_BINARY_DIR}/strandmeshConfig.cmake ${PROJECT_BINARY_DIR}/strandmeshConfigVersion.cmake
          DESTINATION ${cmake_dir})
endfunction()
