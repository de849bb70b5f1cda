# Installation and the CMake package: `cmake --install build --prefix P` puts the library, its
# public headers, the generated version header and the CLI (bin/meshmark) under P, and a package
# that another project finds with find_package(meshmark) and links as meshmark::meshmark
# (P/lib/cmake/meshmark).
include(CMakePackageConfigHelpers)

# A sanitized library needs its runtime at the consumer's link, and the consumer compiled with
# -fsanitize=address too: Eigen trusts glibc's malloc alignment only without __SANITIZE_ADDRESS__
# (Eigen/src/Core/util/Memory.h), so a matrix the consumer's inline Eigen code allocates with
# malloc and the library frees with Eigen's own aligned free (or the reverse) is a
# heap-buffer-overflow (the package test's first run under ASan found it).
if(MESHMARK_SANITIZE)
  target_compile_options(meshmark INTERFACE -fsanitize=address,undefined)
  target_link_options(meshmark INTERFACE -fsanitize=address,undefined)
endif()

set(MESHMARK_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/meshmark)
install(TARGETS meshmark EXPORT meshmarkTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# The installed CLI finds a shared libmeshmark beside it (prefix/lib) wherever the prefix is.
set_target_properties(meshmark_cli PROPERTIES INSTALL_RPATH "$ORIGIN/../${CMAKE_INSTALL_LIBDIR}")
install(TARGETS meshmark_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/meshmark ${PROJECT_BINARY_DIR}/include/meshmark
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.h")
install(EXPORT meshmarkTargets NAMESPACE meshmark:: DESTINATION ${MESHMARK_CMAKE_DIR})

# The config finds the dependencies the exported target names: Eigen3 (public: the headers use
# it) always, and the private ones too when the library is static (its link interface lists them
# as $<LINK_ONLY:...>).
get_target_property(MESHMARK_LIBRARY_TYPE meshmark TYPE)
# The pkg-config modules meshmark links (PREFIX:module, PkgConfig::PREFIX in the export).
set(MESHMARK_PKG_MODULES SODIUM:libsodium PQ:libpq DRACO:draco LIB3MF:lib3MF)
if(MESHMARK_WITH_IPOPT)
  list(APPEND MESHMARK_PKG_MODULES IPOPT:ipopt)
endif()
list(JOIN MESHMARK_PKG_MODULES " " MESHMARK_PKG_MODULES)
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
