# scanbench_target_defaults(target): warnings (errors with SCANBENCH_WERROR) and full-path includes.
# -Wno-restrict: GCC 12 reports false -Wrestrict positives inside libstdc++ for `"literal" +
# std::string` at -O2 and above (GCC bug 105329); the warning is off so that idiom stays usable.
# -Wno-use-after-free: with AVX (-march=x86-64-v3, cmake/Simd.cmake) Eigen aligns to 32 bytes, more
# than malloc gives, and its handmade_aligned_realloc reads the old pointer's offset after realloc
# (Eigen/src/Core/util/Memory.h); GCC 12 flags that arithmetic although the old block is not read.
function(scanbench_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wno-restrict -Wno-use-after-free)
  endif()
  if(SCANBENCH_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  scanbench_apply_sanitizers(${target})  # cmake/Sanitizers.cmake
endfunction()
