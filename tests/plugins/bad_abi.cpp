// A plugin that reports another ABI version than this scanbench's (the loader refuses it).
#include "scanbench/plugin.h"

extern "C" __attribute__((visibility("default"))) int scanbench_plugin_abi_version() {
  return SCANBENCH_ABI_VERSION + 1;
}
extern "C" __attribute__((visibility("default"))) void scanbench_plugin_register(
    scanbench::PluginRegistrar&) {}
