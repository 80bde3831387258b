// A plugin whose algorithm reports its progress (plugin.h, report_progress): three phases with
// their fractions, then the copy. `scanbench algo --progress` shows them (test_honest_tables).
#include "no_params.h"

namespace {

scanbench::PointCloud staged_copy(const scanbench::PointCloud& in, const test_plugin::NoParams&,
                                  scanbench::RunContext& ctx) {
  for (int i = 1; i <= 3; ++i)
    scanbench::report_progress(ctx, "stage " + std::to_string(i) + "/3", i / 3.0);
  return in;
}

}  // namespace

SCANBENCH_PLUGIN(r) {
  r.algorithm<test_plugin::NoParams>("test_plugin.progress",
                                     "copies its input, reporting three phases", staged_copy);
}
