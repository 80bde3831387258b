# scanbench_target_defaults(target): warnings (errors with SCANBENCH_WERROR) and full-path includes.
# -Wno-restrict: GCC 12 reports false -Wrestrict positives inside libstdc++ for `"literal" +
# std::string` at -O2 and above (GCC bug 105329); the warning is off so that idiom stays usable.
function(scanbench_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wno-restrict)
    # GCC 12's AVX-512 intrinsics initialise their "undefined" vectors as `__m512d __Y = __Y;`,
    # which GCC 12.2 itself then reports as (maybe-)uninitialized wherever Eigen's AVX-512
    # packets are inlined (GCC bug 105593, fixed in GCC 13): ~1,000 reports per build, all in
    # avx512fintrin.h. Off only for that combination.
    if(SCANBENCH_BUILD_ISA STREQUAL "avx512" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
      target_compile_options(${target} PRIVATE -Wno-uninitialized -Wno-maybe-uninitialized)
    endif()
    # A unity batch #includes each source, so GCC sees a source's anonymous-namespace types as
    # if they came from a header and reports every struct or lambda that holds one
    # (-Wsubobject-linkage); in a one-source unit the warning never fires.
    if(CMAKE_UNITY_BUILD)
      target_compile_options(${target} PRIVATE -Wno-subobject-linkage)
    endif()
  endif()
  if(SCANBENCH_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  scanbench_apply_sanitizers(${target})  # cmake/Sanitizers.cmake
endfunction()
