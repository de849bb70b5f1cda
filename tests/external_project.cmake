# Installs meshmark from a build tree into a fresh prefix, then configures, builds and runs
# tests/external_project against it (find_package(meshmark), meshmark::meshmark): what another
# project does with an installed meshmark. Fails with the name of the step that failed.
#
#   cmake -DBUILD_DIR=build -DSOURCE_DIR=. -DWORK_DIR=DIR -DMESH=FILE -DVERSION=X.Y.Z
#         -DGENERATOR=Ninja -DCXX=c++ -DBUILD_TYPE=Release -DLIBDIR=lib -P tests/external_project.cmake
foreach(var BUILD_DIR SOURCE_DIR WORK_DIR MESH VERSION GENERATOR CXX BUILD_TYPE LIBDIR)
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

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
step("install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(file include/meshmark/version.h include/meshmark/embed.h ${LIBDIR}/cmake/meshmark/meshmarkConfig.cmake
        ${LIBDIR}/cmake/meshmark/meshmarkConfigVersion.cmake ${LIBDIR}/cmake/meshmark/meshmarkTargets.cmake bin/meshmark)
  if(NOT EXISTS ${prefix}/${file})
    message(FATAL_ERROR "external project: step 'install' did not install ${file}")
  endif()
endforeach()

step("installed CLI --version" ${prefix}/bin/meshmark --version)
string(STRIP "${step_output}" printed)
if(NOT printed STREQUAL "meshmark ${VERSION}")
  message(FATAL_ERROR "external project: installed CLI --version printed '${printed}', "
                      "expected 'meshmark ${VERSION}' (project(meshmark VERSION ...))")
endif()

step("configure" ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/external_project -B ${consumer}
     -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_BUILD_TYPE=${BUILD_TYPE}
     -DCMAKE_PREFIX_PATH=${prefix})
step("build" ${CMAKE_COMMAND} --build ${consumer})
file(WRITE ${consumer}/shop.key "a key the consumer and the installed CLI share")
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
