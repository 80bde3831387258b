# Regenerates version.cpp at every build (only rewritten when the commit changes), so
# `scanbench --version` always names the commit the binary was built from.
set(SCANBENCH_VERSION_CPP "${CMAKE_BINARY_DIR}/generated/version.cpp")
add_custom_target(scanbench_version_file
  COMMAND ${CMAKE_COMMAND} -DSRC=${CMAKE_SOURCE_DIR} -DOUT=${SCANBENCH_VERSION_CPP}
          -DVERSION=${PROJECT_VERSION} -P ${CMAKE_SOURCE_DIR}/cmake/WriteVersion.cmake
  BYPRODUCTS ${SCANBENCH_VERSION_CPP}
  COMMENT "Stamping git commit")
