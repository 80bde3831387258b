# scanbench_target_defaults(target): warnings (errors with SCANBENCH_WERROR) and full-path includes.
# -Wno-restrict: GCC 12 reports false -Wrestrict positives inside libstdc++ for `"literal" +
# std::string` at -O2 and above (GCC bug 105329); the warning is off so that idiom stays usable.
function(scanbench_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
  if(SCANBENCH_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  scanbench_apply_sanitizers(${target})  # cmake/Sanitizers.cmake
endfunction()
