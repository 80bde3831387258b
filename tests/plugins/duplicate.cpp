// A plugin that registers a fresh name and then a built-in one (the loader refuses both).
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
  r.algorithm<NoParams>("test_plugin.fresh", "a copy (never added: the plugin is refused)", copy);
  r.algorithm<NoParams>("resample.clop", "a second resample.clop", copy);
}
