// A plugin whose algorithm crashes (SIGSEGV) inside a job: only that job fails.
#include <csignal>

#include "scanbench/plugin.h"

namespace {
struct NoParams {
  static void declare(scanbench::ParamDeclarer<NoParams>&) {}
};
scanbench::PointCloud crash(const scanbench::PointCloud& in, const NoParams&,
                            scanbench::RunContext&) {
  std::raise(SIGSEGV);
  return in;
}
}  // namespace

SCANBENCH_PLUGIN(r) {
  r.algorithm<NoParams>("test_plugin.crash", "raises SIGSEGV (plugin isolation test)", crash);
}
