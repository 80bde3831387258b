# scanbench_add_plugin(name source...): a scanbench plugin (scanbench/plugin.h, docs/plugins.md)
# as a MODULE library: C++20, linked to scanbench::algorithms and scanbench::metrics, position
# independent. Load it with
# `scanbench --plugin $<TARGET_FILE:name> ...`, "plugins" in an experiment or SCANBENCH_PLUGIN_PATH.
function(scanbench_add_plugin name)
  add_library(${name} MODULE ${ARGN})
  target_link_libraries(${name} PRIVATE scanbench::algorithms scanbench::metrics)
  target_compile_features(${name} PRIVATE cxx_std_20)
endfunction()
