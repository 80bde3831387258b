# What a build costs (README "Build and test times"): the heavy third-party headers are parsed
# once per target instead of once per file.
#
#   CMAKE_UNITY_BUILD=ON  (scripts/build.sh and scripts/test.sh set it; plain cmake leaves it off
#                         for incremental rebuilds) each target's sources are compiled in batches
#                         of UNITY_BUILD_BATCH_SIZE (8): Eigen, fmt, nlohmann-json, CLI11 and
#                         GoogleTest are parsed, and their inline functions compiled, once per
#                         batch. Sources with their own compile options or definitions stay out
#                         of the batches (CMake's rule).
#   SCANBENCH_PCH=ON      (default) without unity batches, scanbench_precompile(target ...)
#                         precompiles those headers once per target of two or more sources.
#
# Floating-point results: the build has no -ffast-math, but GCC 12 fuses a product and a sum
# into one FMA wherever the target has FMA (x86-64-v3 and v4 builds): its -ffp-contract=fast
# default holds for C++ at any -std (the ISO "off" default is for C only; checked with
# `g++ -std=c++20 -march=x86-64-v4 -S` on `a * b + c`). Fusing happens after inlining, so a
# batch that inlines a function from another file may round differently from a build without
# batches: results are reproducible bit for bit per build configuration (compiler, ISA level,
# these options), as tests/data/clop_reference.json records them. The sanitizer tree builds
# with -ffp-contract=off (cmake/Sanitizers.cmake).
option(SCANBENCH_PCH "Precompile the heavy third-party headers once per target" ON)

# Used by (nearly) every source of every module; all are reached through scanbench_core's
# public link interface (Eigen, fmt, nlohmann-json).
set(SCANBENCH_PCH_COMMON
    <algorithm> <array> <cmath> <cstdint> <filesystem> <functional> <map> <memory> <optional>
    <string> <string_view> <vector> <Eigen/Core> <fmt/format.h> <nlohmann/json.hpp>)

if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
  # A PCH without a timestamp, so that ccache can cache what includes it (ccache manual).
  set(scanbench_pch_flags -Xclang -fno-pch-timestamp)
endif()

# scanbench_precompile(target [HEADERS h ...]): the common headers plus the target's own heavy
# ones, precompiled for the target. A target of one translation unit gains nothing (the PCH is
# one more parse), so it is skipped.
function(scanbench_precompile target)
  cmake_parse_arguments(P "" "" "HEADERS" ${ARGN})
  if(NOT SCANBENCH_PCH)
    return()
  endif()
  get_target_property(srcs ${target} SOURCES)
  list(FILTER srcs INCLUDE REGEX "\\.(cpp|cc|cxx)$")
  list(LENGTH srcs n)
  # Measured (cold, 2-core AVX-512 EPYC, GCC 12, whole Release tree): per-file 1,880 CPU s,
  # unity batches 1,124 CPU s, unity batches with these PCHs 1,127 CPU s: inside a unity build the
  # PCH saves nothing, so it is used only for per-file builds (a developer's incremental rebuilds).
  if(CMAKE_UNITY_BUILD OR n LESS 2)
    return()
  endif()
  target_precompile_headers(${target} PRIVATE ${SCANBENCH_PCH_COMMON} ${P_HEADERS})
  if(scanbench_pch_flags)
    target_compile_options(${target} PRIVATE ${scanbench_pch_flags})
  endif()
endfunction()
