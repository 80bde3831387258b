# The instruction set the whole build (our kernels, Eigen, CGAL's peers, everything) is compiled
# for. SCANBENCH_SIMD:
#   native  (default) the widest x86-64 level this build machine has: avx512, avx2 or sse2
#   avx512  -march=x86-64-v4 (AVX-512 F/BW/CD/DQ/VL, with AVX2 and FMA): 16-float packets
#   avx2    -march=x86-64-v3 (AVX2, FMA, BMI1/2, F16C): 8-float packets
#   sse2    -march=x86-64 (the portable baseline every x86-64 CPU runs): 4-float packets
# The cost of compiling for the build machine: the binary runs only on CPUs with that level
# (scanbench refuses to start on one without it, with a one-line error, instead of crashing on an
# illegal instruction); build with -DSCANBENCH_SIMD=sse2 for a binary that runs anywhere.
# Within one build the kernels are instantiated for every packet width up to the compiled one and
# chosen at run time (SCANBENCH_ISA=sse2|avx2|avx512 selects a narrower path); see
# core/include/scanbench/core/simd.h. Compiling everything with one set of flags means no inline
# function is ever compiled twice with different instruction sets (no ODR hazard).
set(SCANBENCH_SIMD "native" CACHE STRING "Instruction set of the build: native, avx512, avx2, sse2")
set_property(CACHE SCANBENCH_SIMD PROPERTY STRINGS native avx512 avx2 sse2)

set(_sb_simd "${SCANBENCH_SIMD}")
if(_sb_simd STREQUAL "native")
  set(_sb_simd "sse2")
  if(CMAKE_SYSTEM_PROCESSOR MATCHES "x86_64|AMD64" AND EXISTS /proc/cpuinfo)
    file(STRINGS /proc/cpuinfo _sb_flags REGEX "^flags" LIMIT_COUNT 1)
    if(_sb_flags MATCHES " avx2" AND _sb_flags MATCHES " fma" AND _sb_flags MATCHES " bmi2"
       AND _sb_flags MATCHES " f16c")
      set(_sb_simd "avx2")
      if(_sb_flags MATCHES " avx512f" AND _sb_flags MATCHES " avx512vl"
         AND _sb_flags MATCHES " avx512bw" AND _sb_flags MATCHES " avx512dq"
         AND _sb_flags MATCHES " avx512cd")
        set(_sb_simd "avx512")
      endif()
    endif()
  endif()
endif()
if(_sb_simd STREQUAL "avx512")
  set(SCANBENCH_SIMD_FLAGS -march=x86-64-v4)
elseif(_sb_simd STREQUAL "avx2")
  set(SCANBENCH_SIMD_FLAGS -march=x86-64-v3)
elseif(_sb_simd STREQUAL "sse2")
  set(SCANBENCH_SIMD_FLAGS -march=x86-64)
else()
  message(FATAL_ERROR "SCANBENCH_SIMD must be native, avx512, avx2 or sse2, got '${SCANBENCH_SIMD}'")
endif()
set(SCANBENCH_BUILD_ISA "${_sb_simd}")
string(JOIN " " SCANBENCH_SIMD_FLAGS_TEXT ${SCANBENCH_SIMD_FLAGS})
message(STATUS "scanbench: compiled for ${SCANBENCH_BUILD_ISA} (${SCANBENCH_SIMD_FLAGS_TEXT})")
add_compile_options(${SCANBENCH_SIMD_FLAGS})

# Google Highway's kernels (the `HWY_NAMESPACE` code of foreach_target.h translation units) are
# compiled for every target Highway can attain on x86-64, not only those at or above this build's
# level: EMU128 (Highway's portable scalar reference of the same source), SSE4 (4 floats), AVX2
# (8) and AVX3 (AVX-512, 16). The active one follows SCANBENCH_ISA / simd::select() (sse2 -> SSE4,
# avx2 -> AVX2, avx512 -> AVX3), so every compiled target can be run and tested on one machine.
# SSSE3 is left out: no x86-64 CPU of the last fifteen years lacks SSE4, and it would only double
# the 4-float code. The same definitions in every translation unit keep Highway's inline functions
# one definition per target.
add_compile_definitions(HWY_COMPILE_ALL_ATTAINABLE "HWY_DISABLED_TARGETS=HWY_SSSE3")
