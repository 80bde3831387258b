// A plugin that registers a fresh name and then a built-in one (the loader refuses both).
#include "no_params.h"

SCANBENCH_PLUGIN(r) {
  using namespace test_plugin;
  r.algorithm<NoParams>("test_plugin.fresh", "a copy (never added: the plugin is refused)", copy);
  r.algorithm<NoParams>("resample.clop", "a second resample.clop", copy);
}
