// A plugin whose registration throws after adding an entry (the loader adds nothing).
#include <stdexcept>

#include "scanbench/plugin.h"

namespace {
struct NoParams {
  static void declare(scanbench::ParamDeclarer<NoParams>&) {}
};
scanbench::PointCloud copy(const scanbench::PointCloud& in, const NoParams&,
                           scanbench::RunContext&) {
  return in;
}
}  // namespace

SCANBENCH_PLUGIN(r) {
  r.algorithm<NoParams>("test_plugin.before_throw", "never added", copy);
  throw std::runtime_error("registration failed on purpose");
}
