# All dependencies come from Debian 12 packages (scripts/setup.sh installs them).
# Order matters: the OpenVDB Find module folder also holds a FindTBB.cmake that would shadow
# TBBConfig, so the config-mode finds run first and the OpenVDB module path is appended last.
find_package(Eigen3 3.4 REQUIRED CONFIG)
find_package(TBB REQUIRED CONFIG)
find_package(embree 3.13 REQUIRED CONFIG)
find_package(nlohmann_json 3.11 REQUIRED CONFIG)
find_package(fmt REQUIRED CONFIG)
find_package(spdlog REQUIRED CONFIG)
find_package(CLI11 REQUIRED CONFIG)
find_package(nanoflann REQUIRED CONFIG HINTS /usr/share/nanoflann/cmake)
find_package(tinyobjloader REQUIRED CONFIG)
find_package(OpenImageIO REQUIRED CONFIG)
find_package(CGAL REQUIRED CONFIG)
# Open3D 0.16 (libopen3d-dev): the peer.open3d_* entries; OpenMP to pin its thread count.
# Its version file accepts only an exact version, hence the check after the find.
find_package(Open3D REQUIRED CONFIG)
if(Open3D_VERSION VERSION_LESS 0.16)
  message(FATAL_ERROR "Open3D ${Open3D_VERSION} found, 0.16 or newer needed (libopen3d-dev)")
endif()
find_package(OpenMP REQUIRED COMPONENTS CXX)
find_package(Threads REQUIRED)
find_package(SQLite3 REQUIRED)  # CMake's FindSQLite3: the results history (harness)
# libcrypto's SHA-256 (libssl-dev): the hash of every plugin file in the records (harness).
find_package(OpenSSL REQUIRED COMPONENTS Crypto)
find_package(ZLIB REQUIRED)  # the PDF figure's image streams (harness figure.cpp)
# Google Highway (libhwy-dev): the SIMD kernels, compiled for several targets and dispatched at run
# time (cmake/Simd.cmake, core/include/scanbench/core/simd.h).
find_package(hwy 1.0 REQUIRED CONFIG)

list(APPEND CMAKE_MODULE_PATH /usr/lib/x86_64-linux-gnu/cmake/OpenVDB)
find_package(OpenVDB REQUIRED)

if(SCANBENCH_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(SCANBENCH_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
