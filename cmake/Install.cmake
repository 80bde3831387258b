# The installable package (docs/plugins.md): `cmake --install build --prefix P` installs the
# public headers, the three shared libraries a plugin links (scanbench::core, ::algorithms,
# ::metrics), the scanbench binary and a CMake package config, so that an out-of-tree project
# (examples/plugin) does find_package(scanbench CONFIG REQUIRED).
#
# Public is only what a plugin needs: the stage data and its types, declared parameters, the run
# context, the registries (scanbench/plugin.h), the kd-tree and the neighbour grid, the metrics'
# input and ground-truth oracle. Every other header stays in the source tree. The libraries are
# shared so that the binary and its plugins use one copy of the registries; their SOVERSION is
# the ABI version of core/include/scanbench/core/abi.h.
include(CMakePackageConfigHelpers)

file(STRINGS "${PROJECT_SOURCE_DIR}/core/include/scanbench/core/abi.h" scanbench_abi_line
     REGEX "^#define SCANBENCH_ABI_VERSION [0-9]+$")
string(REGEX REPLACE "^.* ([0-9]+)$" "\\1" SCANBENCH_ABI_VERSION "${scanbench_abi_line}")
if(NOT SCANBENCH_ABI_VERSION MATCHES "^[0-9]+$")
  message(FATAL_ERROR "core/include/scanbench/core/abi.h: no #define SCANBENCH_ABI_VERSION N line")
endif()

set(scanbench_public_headers
  core/include/scanbench/core/abi.h
  core/include/scanbench/core/bbox.h
  core/include/scanbench/core/closest_point.h
  core/include/scanbench/core/covariance_mesh.h
  core/include/scanbench/core/errors.h
  core/include/scanbench/core/gaussian_mixture.h
  core/include/scanbench/core/kdtree.h
  core/include/scanbench/core/params.h
  core/include/scanbench/core/point_cloud.h
  core/include/scanbench/core/polygon_faces.h
  core/include/scanbench/core/registry.h
  core/include/scanbench/core/rng.h
  core/include/scanbench/core/run_context.h
  core/include/scanbench/core/stage_data.h
  core/include/scanbench/core/triangle_mesh.h
  core/include/scanbench/core/version.h
  algorithms/include/scanbench/algorithms/registry.h
  metrics/include/scanbench/metrics/closest_point.h
  metrics/include/scanbench/metrics/distance_field.h
  metrics/include/scanbench/metrics/ground_truth.h
  metrics/include/scanbench/metrics/metric_input.h
  metrics/include/scanbench/metrics/registry.h
  harness/include/scanbench/plugin.h)
foreach(h IN LISTS scanbench_public_headers)
  string(REGEX REPLACE "^[a-z]+/include/" "" rel "${h}")
  get_filename_component(dir "${rel}" DIRECTORY)
  install(FILES "${h}" DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/${dir}" COMPONENT dev)
endforeach()
# The neighbour grid lives with the algorithms' sources (spatial/neighbor_grid.h, namespace
# scanbench::algorithms::detail); it is header-plus-library and self-contained (TBB, Eigen).
install(FILES algorithms/src/spatial/neighbor_grid.h
        DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/scanbench/algorithms" COMPONENT dev)

foreach(t core algorithms metrics)
  set_target_properties(scanbench_${t} PROPERTIES
    EXPORT_NAME ${t}
    VERSION ${PROJECT_VERSION}
    SOVERSION ${SCANBENCH_ABI_VERSION}
    INSTALL_RPATH "$ORIGIN")
  # The public headers use C++20 (concepts in core/registry.h): consumers compile as C++20 too.
  target_compile_features(scanbench_${t} PUBLIC cxx_std_20)
endforeach()
# A plugin compiles for the instruction set of the libraries (cmake/Simd.cmake): Eigen's alignment
# of the shared types (EIGEN_MAX_ALIGN_BYTES, 64 with AVX-512) follows it, and memory one side
# allocates the other frees. The loader refuses a plugin whose alignment differs.
target_compile_options(scanbench_core INTERFACE "$<INSTALL_INTERFACE:${SCANBENCH_SIMD_FLAGS}>")
set_target_properties(scanbench PROPERTIES INSTALL_RPATH "$ORIGIN/../${CMAKE_INSTALL_LIBDIR}")
# The binary's own libraries (shared: FindOpenVDB sets BUILD_SHARED_LIBS), installed beside the
# public ones but neither exported nor with headers.
set(scanbench_private_libs)
foreach(t scanbench_scanner scanbench_harness)
  get_target_property(type ${t} TYPE)
  if(type STREQUAL "SHARED_LIBRARY")
    set_target_properties(${t} PROPERTIES INSTALL_RPATH "$ORIGIN")
    list(APPEND scanbench_private_libs ${t})
  endif()
endforeach()

install(TARGETS scanbench_core scanbench_algorithms scanbench_metrics
  EXPORT scanbenchTargets
  LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}"
  INCLUDES DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
install(TARGETS scanbench ${scanbench_private_libs}
  RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}" LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}")

set(scanbench_cmake_dir "${CMAKE_INSTALL_LIBDIR}/cmake/scanbench")
install(EXPORT scanbenchTargets NAMESPACE scanbench:: DESTINATION "${scanbench_cmake_dir}")
configure_package_config_file(cmake/scanbenchConfig.cmake.in
  "${CMAKE_BINARY_DIR}/generated/scanbenchConfig.cmake" INSTALL_DESTINATION "${scanbench_cmake_dir}")
# 0.x: a minor version may change the interface (the ABI version says whether it did).
write_basic_package_version_file("${CMAKE_BINARY_DIR}/generated/scanbenchConfigVersion.cmake"
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES "${CMAKE_BINARY_DIR}/generated/scanbenchConfig.cmake"
              "${CMAKE_BINARY_DIR}/generated/scanbenchConfigVersion.cmake"
              cmake/scanbenchPlugin.cmake
        DESTINATION "${scanbench_cmake_dir}")
