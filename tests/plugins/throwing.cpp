// A plugin whose registration throws after adding an entry (the loader adds nothing).
#include <stdexcept>

#include "no_params.h"

SCANBENCH_PLUGIN(r) {
  using namespace test_plugin;
  r.algorithm<NoParams>("test_plugin.before_throw", "never added", copy);
  throw std::runtime_error("registration failed on purpose");
}
