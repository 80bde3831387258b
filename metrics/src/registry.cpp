#include "scanbench/metrics/registry.h"

namespace scanbench::metrics {

const MetricRegistry& registry() {
  static const MetricRegistry r = [] {
    MetricRegistry reg("metric");
    // One explicit list; every entry has a create-by-name test (tests/metrics).
    return reg;
  }();
  return r;
}

}  // namespace scanbench::metrics
