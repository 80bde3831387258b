# Sanitizer and fuzzing builds (README "Hardening"; CI: scripts/test.sh builds a second tree).
#
#   SCANBENCH_SANITIZE=ON  targets compiled and linked with AddressSanitizer and
#                          UndefinedBehaviorSanitizer (-fno-sanitize-recover: any UB report aborts,
#                          so a test that triggers it fails). Works with GCC and clang.
#   SCANBENCH_FUZZ=ON      (clang only, implies SCANBENCH_SANITIZE) additionally instruments them
#                          for libFuzzer coverage (-fsanitize=fuzzer-no-link) and builds the
#                          libFuzzer targets of tests/fuzz, which link the real libraries.
#   SCANBENCH_SANITIZE_SCOPE
#                          all (default): every target. input: only the code that reads untrusted
#                          bytes and its tests (core/, harness/, tests/); algorithms/, metrics/ and
#                          scanner-sim/ are then compiled plainly at -O0, since the sanitized
#                          targets use only their registries (the config loader looks names up in
#                          them). CI (scripts/test.sh) uses `all` and runs the whole test suite.
#
# One sanitized tree serves both: the test executables run under ASan/UBSan (the libFuzzer
# coverage hooks are no-ops outside a fuzz target) and the fuzz targets link -fsanitize=fuzzer.
# scanbench_target_defaults (cmake/Warnings.cmake) applies the flags per target.
option(SCANBENCH_SANITIZE "Build with AddressSanitizer + UndefinedBehaviorSanitizer" OFF)
option(SCANBENCH_FUZZ "Build the libFuzzer targets (clang only; implies SCANBENCH_SANITIZE)" OFF)
set(SCANBENCH_SANITIZE_SCOPE "all" CACHE STRING "Sanitized targets: all | input")
set_property(CACHE SCANBENCH_SANITIZE_SCOPE PROPERTY STRINGS all input)
if(SCANBENCH_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "SCANBENCH_FUZZ=ON needs clang (-DCMAKE_CXX_COMPILER=clang++)")
  endif()
  set(SCANBENCH_SANITIZE ON)
endif()
set(scanbench_san_flags -fsanitize=address,undefined -fno-sanitize-recover=undefined
                        -fno-omit-frame-pointer)
# libFuzzer's coverage hooks, only on the code the fuzz targets explore (core's readers and
# parameters, the harness's config loader); the algorithms, metrics and scanner behind the
# registries are only looked up by name there, and coverage would cost compile and test time.
set(scanbench_fuzz_cov_flags)
if(SCANBENCH_FUZZ)
  set(scanbench_fuzz_cov_flags -fsanitize=fuzzer-no-link)
endif()
if(SCANBENCH_SANITIZE)
  # Code that must behave differently under ASan (RLIMIT_AS cannot cap a process whose shadow
  # memory alone reserves terabytes of address space) tests this macro.
  add_compile_definitions(SCANBENCH_SANITIZE=1)
  # No fusing of a*b+c into FMA (clang's and GCC's C++ default where the target has FMA): the
  # sanitizer tree rounds every product and sum as written, whichever compiler builds it. Its
  # results therefore differ from the Release tree's in the last bits (the Release tree fuses,
  # cmake/BuildCost.cmake), and the tests that pin bits skip it.
  add_compile_options(-ffp-contract=off)
endif()

# Build type "Sanitize" (scripts/test.sh): -O1 (fast enough to run the tests, cheaper to compile
# than -O3), line tables for symbolised reports, assertions on (no NDEBUG).
if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
  set(CMAKE_CXX_FLAGS_SANITIZE "-O1 -gline-tables-only" CACHE STRING "" FORCE)
else()
  set(CMAKE_CXX_FLAGS_SANITIZE "-O1 -g1" CACHE STRING "" FORCE)
endif()

# Called by scanbench_target_defaults for every target.
function(scanbench_apply_sanitizers target)
  if(NOT SCANBENCH_SANITIZE)
    return()
  endif()
  get_target_property(dir ${target} SOURCE_DIR)
  if(SCANBENCH_SANITIZE_SCOPE STREQUAL "input" AND dir MATCHES "/(algorithms|metrics|scanner-sim)$")
    # Registries only: plain -O0, and clang's warnings there are not errors (the GCC Release
    # tree checks these sources with -Werror).
    target_compile_options(${target} PRIVATE -O0 -Wno-error)
    return()
  endif()
  target_compile_options(${target} PRIVATE ${scanbench_san_flags})
  target_link_options(${target} PRIVATE ${scanbench_san_flags})
  if(NOT dir MATCHES "/(algorithms|metrics|scanner-sim)$")
    target_compile_options(${target} PRIVATE ${scanbench_fuzz_cov_flags})
    target_link_options(${target} PRIVATE ${scanbench_fuzz_cov_flags})
  endif()
endfunction()

# Third-party undefined behaviour, listed with its upstream report in cmake/sanitizer-ignorelist.txt,
# exempted only in the targets that instantiate the offending header (today: OpenVDB's trees, whose
# accessor registry is a tbb::concurrent_hash_map). GCC has no ignore lists: it drops the whole
# alignment check for those targets instead.
function(scanbench_sanitizer_ignore_third_party target)
  if(NOT SCANBENCH_SANITIZE)
    return()
  endif()
  if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    target_compile_options(
      ${target} PRIVATE -fsanitize-ignorelist=${PROJECT_SOURCE_DIR}/cmake/sanitizer-ignorelist.txt)
  else()
    target_compile_options(${target} PRIVATE -fno-sanitize=alignment)
  endif()
endfunction()
