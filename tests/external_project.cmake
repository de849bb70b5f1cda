# Installs meshmark from a build tree into a fresh prefix, then configures, builds and runs
# tests/external_project against it (find_package(meshmark), meshmark::meshmark): what another
# project does with an installed meshmark. Fails with the name of the step that failed.
#
#   cmake -DBUILD_DIR=build -DSOURCE_DIR=. -DWORK_DIR=DIR -DMESH=FILE -DVERSION=X.Y.Z
#         -DGENERATOR=Ninja -DCXX=c++ -DBUILD_TYPE=Release -DLIBDIR=lib -DSANITIZE=OFF
#         -DSHARED=OFF -DCOMPONENTS=draco,3mf,postgres,ipopt,cgal [-DBUILD_SHARED_VARIANT=ON]
#         -P tests/external_project.cmake
#
# SHARED: whether BUILD_DIR builds shared libraries libmeshmark_core.so and libmeshmark_NAME.so
# per component (then the prefix must hold them and their soname links, and the installed CLI
# and the consumers must load them from there) or static ones (then nothing loads any
# libmeshmark). With -DBUILD_SHARED_VARIANT=ON, BUILD_DIR is first configured from SOURCE_DIR
# with -DBUILD_SHARED_LIBS=ON (the same build type and sanitizers, only the libraries and the
# CLI) and built. With -DCORE_ONLY=ON, it is first configured with every optional component OFF
# and built, where pkg-config sees only the core's module (libsodium) and CMake cannot find
# CGAL: the core builds, installs and serves tests/external_project/core without them.
#
# Every run also builds and runs tests/external_project/core against the prefix: a project
# linking meshmark::core alone, whose configure step fails when the installed link interface of
# meshmark::core names a component's library or a GPL one.
cmake_policy(SET CMP0057 NEW)  # if(... IN_LIST ...) in this script
foreach(var BUILD_DIR SOURCE_DIR WORK_DIR MESH VERSION GENERATOR CXX BUILD_TYPE LIBDIR SANITIZE SHARED
        COMPONENTS)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "external_project.cmake: -D${var}=... is required")
  endif()
endforeach()
set(prefix ${WORK_DIR}/prefix)
set(consumer ${WORK_DIR}/consumer)

# Runs one step; on failure stops with the step's name, its exit code and its output.
function(step name)
  message(STATUS "external project: ${name}")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    list(JOIN ARGN " " command)
    message(FATAL_ERROR "external project: step '${name}' failed (${rc}): ${command}\n${out}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

# Fails unless the program at path loads exactly the shared libmeshmark_NAME.so.SOVERSION of
# each NAME in `libraries` from the prefix (shared) or loads no libmeshmark at all (static),
# resolved as the dynamic linker would (RPATH, system dirs); and, with FORBID, none whose name
# matches that regular expression.
function(check_loads_library what path libraries)
  cmake_parse_arguments(PARSE_ARGV 3 arg "" "FORBID" "")
  file(GET_RUNTIME_DEPENDENCIES EXECUTABLES ${path} RESOLVED_DEPENDENCIES_VAR resolved
       UNRESOLVED_DEPENDENCIES_VAR unresolved)
  set(loaded "")
  foreach(lib IN LISTS resolved)
    if(lib MATCHES "libmeshmark")
      file(REAL_PATH ${lib} lib)
      list(APPEND loaded ${lib})
    endif()
    if(arg_FORBID AND lib MATCHES "${arg_FORBID}")
      message(FATAL_ERROR "external project: ${what} loads ${lib}")
    endif()
  endforeach()
  list(FILTER unresolved INCLUDE REGEX "libmeshmark")  # a name the dynamic linker cannot find
  list(APPEND loaded ${unresolved})
  set(expected "")
  if(SHARED)
    foreach(name IN LISTS libraries)
      file(REAL_PATH ${prefix}/${LIBDIR}/libmeshmark_${name}.so.${SOVERSION} real)
      list(APPEND expected ${real})
    endforeach()
  endif()
  list(SORT loaded)
  list(SORT expected)
  if(NOT "${loaded}" STREQUAL "${expected}")
    message(FATAL_ERROR "external project: ${what} loads libmeshmark from '${loaded}', "
                        "expected '${expected}'")
  endif()
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
string(REGEX MATCH "^[0-9]+\\.[0-9]+" SOVERSION "${VERSION}")  # MAJOR.MINOR (CMakeLists.txt)
if(BUILD_SHARED_VARIANT)
  step("configure the shared library" ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${BUILD_DIR}
       -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_BUILD_TYPE=${BUILD_TYPE}
       -DBUILD_SHARED_LIBS=ON -DMESHMARK_SANITIZE=${SANITIZE} -DMESHMARK_BUILD_TESTS=OFF
       -DMESHMARK_BUILD_BENCH=OFF -DMESHMARK_BUILD_PYTHON=OFF)
  step("build the shared library" ${CMAKE_COMMAND} --build ${BUILD_DIR} --parallel 2
       --target meshmark meshmark_cli)
endif()
if(CORE_ONLY)
  # pkg-config sees the core's module alone; CMake cannot find CGAL.
  set(pkgdir ${WORK_DIR}/pkgconfig)
  file(MAKE_DIRECTORY ${pkgdir})
  execute_process(COMMAND pkg-config --variable=pcfiledir libsodium OUTPUT_VARIABLE sodium_dir
                  OUTPUT_STRIP_TRAILING_WHITESPACE)
  file(COPY ${sodium_dir}/libsodium.pc DESTINATION ${pkgdir})
  set(restricted ${CMAKE_COMMAND} -E env PKG_CONFIG_LIBDIR=${pkgdir} PKG_CONFIG_PATH=)
  step("configure the core alone" ${restricted} ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${BUILD_DIR}
       -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_BUILD_TYPE=${BUILD_TYPE}
       -DMESHMARK_SANITIZE=${SANITIZE} -DMESHMARK_BUILD_TESTS=OFF -DMESHMARK_BUILD_BENCH=OFF
       -DMESHMARK_BUILD_PYTHON=OFF -DMESHMARK_WITH_DRACO=OFF -DMESHMARK_WITH_3MF=OFF
       -DMESHMARK_WITH_POSTGRES=OFF -DMESHMARK_WITH_IPOPT=OFF -DMESHMARK_WITH_CGAL=OFF
       -DCMAKE_DISABLE_FIND_PACKAGE_CGAL=ON)
  step("build the core alone" ${CMAKE_COMMAND} --build ${BUILD_DIR} --parallel 2
       --target meshmark_core meshmark_cli)
  set(libraries core)
else()
  set(restricted "")
  # The libraries this build has: the core and its components (COMPONENTS, comma-separated).
  string(REPLACE "," ";" libraries "core,${COMPONENTS}")
endif()
step("install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
set(installed include/meshmark/version.h include/meshmark/mark/embed.h bin/meshmark
    ${LIBDIR}/cmake/meshmark/meshmarkConfig.cmake ${LIBDIR}/cmake/meshmark/meshmarkConfigVersion.cmake
    ${LIBDIR}/cmake/meshmark/meshmarkCoreTargets.cmake)
foreach(name IN LISTS libraries)
  if(NOT name STREQUAL "core")
    list(APPEND installed ${LIBDIR}/cmake/meshmark/meshmark_${name}Targets.cmake)
  endif()
  if(SHARED)  # the real file, the soname's link and the link-time name
    list(APPEND installed ${LIBDIR}/libmeshmark_${name}.so.${VERSION}
         ${LIBDIR}/libmeshmark_${name}.so.${SOVERSION} ${LIBDIR}/libmeshmark_${name}.so)
  else()
    list(APPEND installed ${LIBDIR}/libmeshmark_${name}.a)
  endif()
endforeach()
foreach(file IN LISTS installed)
  if(NOT EXISTS ${prefix}/${file})
    message(FATAL_ERROR "external project: step 'install' did not install ${file}")
  endif()
endforeach()

check_loads_library("the installed CLI" ${prefix}/bin/meshmark "${libraries}")
step("installed CLI --version" ${prefix}/bin/meshmark --version)
string(STRIP "${step_output}" printed)
if(NOT printed STREQUAL "meshmark ${VERSION}")
  message(FATAL_ERROR "external project: installed CLI --version printed '${printed}', "
                      "expected 'meshmark ${VERSION}' (project(meshmark VERSION ...))")
endif()


# A project linking the core alone, configured where (CORE_ONLY) pkg-config and CMake find only
# the core's dependencies; its configure step reads the installed link interface of
# meshmark::core and fails on a component's or a GPL library.
set(core_consumer ${WORK_DIR}/core_consumer)
step("configure the core's consumer" ${restricted} ${CMAKE_COMMAND}
     -S ${SOURCE_DIR}/tests/external_project/core -B ${core_consumer} -G ${GENERATOR}
     -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_BUILD_TYPE=${BUILD_TYPE} -DCMAKE_PREFIX_PATH=${prefix}
     -DCMAKE_DISABLE_FIND_PACKAGE_CGAL=ON)
step("build the core's consumer" ${CMAKE_COMMAND} --build ${core_consumer})
check_loads_library("the core's consumer" ${core_consumer}/meshmark_core_consumer core
                    FORBID "CGAL|gmp|mpfr|draco|3MF|libpq|ipopt")
file(MAKE_DIRECTORY ${core_consumer}/work)
step("run the core's consumer" ${core_consumer}/meshmark_core_consumer ${MESH}
     ${core_consumer}/work)
message(STATUS "${step_output}")

if(CORE_ONLY)
  # The CLI of a build without the cgal component refuses its attacks as a usage error (exit
  # code 1, docs/cli.md), naming the component.
  execute_process(COMMAND ${prefix}/bin/meshmark attack simplify ${MESH}
                  ${WORK_DIR}/simplified.off --strength 0.5 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 1 OR NOT out MATCHES "component 'cgal'")
    message(FATAL_ERROR "external project: the core's CLI ran simplify (${rc}):\n${out}")
  endif()
  return()
endif()

step("configure" ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/external_project -B ${consumer}
     -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_BUILD_TYPE=${BUILD_TYPE}
     -DCMAKE_PREFIX_PATH=${prefix})
# A component the package does not have leaves it not found (check_required_components).
file(WRITE ${WORK_DIR}/no_such_component/CMakeLists.txt
     "cmake_minimum_required(VERSION 3.22)\nproject(c LANGUAGES CXX)\n"
     "find_package(meshmark REQUIRED COMPONENTS cgal no-such-component)\n")
execute_process(COMMAND ${CMAKE_COMMAND} -S ${WORK_DIR}/no_such_component
                -B ${WORK_DIR}/no_such_component/build -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX}
                -DCMAKE_PREFIX_PATH=${prefix}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(rc EQUAL 0 OR NOT out MATCHES "no-such-component")
  message(FATAL_ERROR "external project: find_package(meshmark COMPONENTS no-such-component) "
                      "did not fail naming it (${rc}):\n${out}")
endif()
step("build" ${CMAKE_COMMAND} --build ${consumer})
# It asks for COMPONENTS cgal OPTIONAL_COMPONENTS ipopt: meshmark::meshmark is those and the core.
set(consumer_libraries core cgal)
if("ipopt" IN_LIST libraries)
  list(APPEND consumer_libraries ipopt)
endif()
check_loads_library("the consumer" ${consumer}/meshmark_consumer "${consumer_libraries}")
file(WRITE ${consumer}/shop.key "a key the consumer and the installed CLI share")
# A key file only its owner reads, as keygen writes it (the CLI warns about any other).
file(CHMOD ${consumer}/shop.key PERMISSIONS OWNER_READ OWNER_WRITE)
step("run" ${consumer}/meshmark_consumer ${MESH} ${consumer}/marked.off ${consumer}/shop.key
     ${consumer}/issued.ply)
message(STATUS "${step_output}")
# The copy the consumer issued through the library reads back with the installed CLI: the same
# protocol on both sides.
step("installed CLI reads the consumer's copy" ${prefix}/bin/meshmark extract
     ${consumer}/issued.ply --coded --key-file ${consumer}/shop.key)
if(NOT step_output MATCHES "^id 4242 ")
  message(FATAL_ERROR "external project: the installed CLI read '${step_output}' from the "
                      "consumer's copy, expected 'id 4242 ...'")
endif()
