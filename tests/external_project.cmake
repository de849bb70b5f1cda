# Installs meshmark from a build tree into a fresh prefix, then configures, builds and runs
# tests/external_project against it (find_package(meshmark), meshmark::meshmark): what another
# project does with an installed meshmark. Fails with the name of the step that failed.
#
#   cmake -DBUILD_DIR=build -DSOURCE_DIR=. -DWORK_DIR=DIR -DMESH=FILE -DVERSION=X.Y.Z
#         -DGENERATOR=Ninja -DCXX=c++ -DBUILD_TYPE=Release -DLIBDIR=lib -DSANITIZE=OFF
#         -DSHARED=OFF [-DBUILD_SHARED_VARIANT=ON] -P tests/external_project.cmake
#
# SHARED: whether BUILD_DIR builds libmeshmark.so (then the prefix must hold it and its soname
# link, and the installed CLI and the consumer must load it from there) or libmeshmark.a (then
# neither loads any libmeshmark). With -DBUILD_SHARED_VARIANT=ON, BUILD_DIR is first configured
# from SOURCE_DIR with -DBUILD_SHARED_LIBS=ON (the same build type and sanitizers, only the
# library and the CLI) and built.
foreach(var BUILD_DIR SOURCE_DIR WORK_DIR MESH VERSION GENERATOR CXX BUILD_TYPE LIBDIR SANITIZE SHARED)
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

# Fails unless the program at path loads libmeshmark.so.SOVERSION from the prefix (shared) or
# loads no libmeshmark at all (static), resolved as the dynamic linker would (RPATH, system dirs).
function(check_loads_library what path)
  file(GET_RUNTIME_DEPENDENCIES EXECUTABLES ${path} RESOLVED_DEPENDENCIES_VAR resolved
       UNRESOLVED_DEPENDENCIES_VAR unresolved)
  set(loaded "")
  foreach(lib IN LISTS resolved)
    if(lib MATCHES "libmeshmark")
      file(REAL_PATH ${lib} lib)
      list(APPEND loaded ${lib})
    endif()
  endforeach()
  list(FILTER unresolved INCLUDE REGEX "libmeshmark")  # a name the dynamic linker cannot find
  list(APPEND loaded ${unresolved})
  set(expected "")
  if(SHARED)
    file(REAL_PATH ${prefix}/${LIBDIR}/libmeshmark.so.${SOVERSION} expected)
  endif()
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
step("install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
set(installed include/meshmark/version.h include/meshmark/mark/embed.h bin/meshmark
    ${LIBDIR}/cmake/meshmark/meshmarkConfig.cmake ${LIBDIR}/cmake/meshmark/meshmarkConfigVersion.cmake
    ${LIBDIR}/cmake/meshmark/meshmarkTargets.cmake)
if(SHARED)  # the real file, the soname's link and the link-time name
  list(APPEND installed ${LIBDIR}/libmeshmark.so.${VERSION} ${LIBDIR}/libmeshmark.so.${SOVERSION}
       ${LIBDIR}/libmeshmark.so)
else()
  list(APPEND installed ${LIBDIR}/libmeshmark.a)
endif()
foreach(file IN LISTS installed)
  if(NOT EXISTS ${prefix}/${file})
    message(FATAL_ERROR "external project: step 'install' did not install ${file}")
  endif()
endforeach()

check_loads_library("the installed CLI" ${prefix}/bin/meshmark)
step("installed CLI --version" ${prefix}/bin/meshmark --version)
string(STRIP "${step_output}" printed)
if(NOT printed STREQUAL "meshmark ${VERSION}")
  message(FATAL_ERROR "external project: installed CLI --version printed '${printed}', "
                      "expected 'meshmark ${VERSION}' (project(meshmark VERSION ...))")
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
check_loads_library("the consumer" ${consumer}/meshmark_consumer)
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
