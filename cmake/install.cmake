# Installation and the CMake package: `cmake --install build --prefix P` puts the library, its
# public headers, the generated version header and the CLI (bin/meshmark) under P, and a package
# that another project finds with find_package(meshmark [COMPONENTS core draco ...]) and links
# as meshmark::core, meshmark::NAME, or meshmark::meshmark for all (P/lib/cmake/meshmark).
include(CMakePackageConfigHelpers)

# A sanitized library needs its runtime at the consumer's link, and the consumer compiled with
# -fsanitize=address too: Eigen trusts glibc's malloc alignment only without __SANITIZE_ADDRESS__
# (Eigen/src/Core/util/Memory.h), so a matrix the consumer's inline Eigen code allocates with
# malloc and the library frees with Eigen's own aligned free (or the reverse) is a
# heap-buffer-overflow (the package test's first run under ASan found it).
if(MESHMARK_SANITIZE)
  target_compile_options(meshmark_core INTERFACE -fsanitize=address,undefined)
  target_link_options(meshmark_core INTERFACE -fsanitize=address,undefined)
endif()

# One export set per library: meshmarkCoreTargets.cmake for meshmark::core, and
# meshmark_NAMETargets.cmake for each component, which the package config includes only when
# asked for the component (so that a consumer of the core needs none of the components'
# dependencies).
set(MESHMARK_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/meshmark)
set_target_properties(meshmark_core PROPERTIES EXPORT_NAME core)
install(TARGETS meshmark_core EXPORT meshmarkCoreTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(EXPORT meshmarkCoreTargets NAMESPACE meshmark:: DESTINATION ${MESHMARK_CMAKE_DIR})
foreach(component IN LISTS MESHMARK_COMPONENTS)
  # A shared component finds the core beside it, wherever the prefix is.
  set_target_properties(meshmark_${component} PROPERTIES EXPORT_NAME ${component}
                        INSTALL_RPATH "$ORIGIN")
  install(TARGETS meshmark_${component} EXPORT meshmark_${component}Targets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(EXPORT meshmark_${component}Targets NAMESPACE meshmark:: DESTINATION ${MESHMARK_CMAKE_DIR})
endforeach()
# The installed CLI finds the shared libmeshmark_* beside it (prefix/lib) wherever the prefix is.
set_target_properties(meshmark_cli PROPERTIES INSTALL_RPATH "$ORIGIN/../${CMAKE_INSTALL_LIBDIR}")
install(TARGETS meshmark_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/meshmark ${PROJECT_BINARY_DIR}/include/meshmark
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.h")

# The config finds the dependencies the exported targets name: Eigen3 (public: the headers use
# it) always, and, when the libraries are static, the private ones of the core and of each
# component asked for (their link interfaces list them as $<LINK_ONLY:...>).
get_target_property(MESHMARK_LIBRARY_TYPE meshmark_core TYPE)
# The pkg-config modules each component links (PREFIX:module, PkgConfig::PREFIX in the export).
set(MESHMARK_PKG_draco DRACO:draco)
set(MESHMARK_PKG_3mf LIB3MF:lib3MF)
set(MESHMARK_PKG_postgres PQ:libpq)
set(MESHMARK_PKG_ipopt IPOPT:ipopt)
set(MESHMARK_PKG_cgal "")
set(MESHMARK_COMPONENT_MODULES "")
foreach(component IN LISTS MESHMARK_COMPONENTS)
  list(APPEND MESHMARK_COMPONENT_MODULES "${component}=${MESHMARK_PKG_${component}}")
endforeach()
list(JOIN MESHMARK_COMPONENT_MODULES " " MESHMARK_COMPONENT_MODULES)
list(JOIN MESHMARK_COMPONENTS " " MESHMARK_COMPONENT_LIST)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/meshmarkConfig.cmake.in
  ${PROJECT_BINARY_DIR}/meshmarkConfig.cmake INSTALL_DESTINATION ${MESHMARK_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/meshmarkConfigVersion.cmake
  COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/meshmarkConfig.cmake ${PROJECT_BINARY_DIR}/meshmarkConfigVersion.cmake
  DESTINATION ${MESHMARK_CMAKE_DIR})
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE ${PROJECT_SOURCE_DIR}/CHANGELOG.md
  DESTINATION ${CMAKE_INSTALL_DOCDIR})

# The data folder the installed library's campaigns read (MESHMARK_DATA_DIR): the project's own
# meshes, and libcgal-demo's when they were unpacked into the build tree.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/meshes DESTINATION ${CMAKE_INSTALL_DATADIR}/meshmark)
if(EXISTS "${MESHMARK_CGAL_DATA}")
  install(DIRECTORY ${MESHMARK_CGAL_DATA}/ DESTINATION ${CMAKE_INSTALL_DATADIR}/meshmark/cgal)
endif()

# The man page and the bash completion the CLI wrote from its option tables (target
# meshmark_cli_docs; OPTIONAL: a build of only the library and the CLI has not written them).
install(FILES ${PROJECT_BINARY_DIR}/share/meshmark.1 DESTINATION ${CMAKE_INSTALL_MANDIR}/man1
        OPTIONAL)
install(FILES ${PROJECT_BINARY_DIR}/share/meshmark.bash
        DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions RENAME meshmark OPTIONAL)
