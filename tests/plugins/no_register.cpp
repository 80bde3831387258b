// A library with the ABI symbol but no registration function (the loader refuses it).
#include "scanbench/plugin.h"

extern "C" __attribute__((visibility("default"))) int scanbench_plugin_abi_version() {
  return SCANBENCH_ABI_VERSION;
}
