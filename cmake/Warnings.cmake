# scanbench_target_defaults(target): warnings (errors with SCANBENCH_WERROR) and full-path includes.
function(scanbench_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  if(SCANBENCH_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
