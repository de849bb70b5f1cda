# The documentation site: the README as its main page, every page of docs/, and the API of the
# public headers (include/meshmark and the generated version.h). `cmake --build build --target
# meshmark_doc` writes build/doc/html/index.html, and Doxygen's warnings to
# build/doc/doxygen-warnings.log (the test Docs.SiteRendersEveryPage fails on a page's warning).
# Only when Doxygen is installed.
find_package(Doxygen QUIET)
if(DOXYGEN_FOUND)
  set(MESHMARK_DOC_DIR ${PROJECT_BINARY_DIR}/doc)
  configure_file(${PROJECT_SOURCE_DIR}/docs/Doxyfile.in ${MESHMARK_DOC_DIR}/Doxyfile @ONLY)
  add_custom_target(meshmark_doc
    COMMAND ${DOXYGEN_EXECUTABLE} ${MESHMARK_DOC_DIR}/Doxyfile
    WORKING_DIRECTORY ${MESHMARK_DOC_DIR}
    COMMENT "Doxygen: the API documentation in ${MESHMARK_DOC_DIR}/html"
    VERBATIM)
endif()
