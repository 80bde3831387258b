// A plugin whose algorithm crashes (SIGSEGV) inside a job: only that job fails.
#include <csignal>

#include "no_params.h"

namespace {
scanbench::PointCloud crash(const scanbench::PointCloud& in, const test_plugin::NoParams&,
                            scanbench::RunContext&) {
  std::raise(SIGSEGV);
  return in;
}
}  // namespace

SCANBENCH_PLUGIN(r) {
  r.algorithm<test_plugin::NoParams>("test_plugin.crash", "raises SIGSEGV (plugin isolation test)",
                                     crash);
}
