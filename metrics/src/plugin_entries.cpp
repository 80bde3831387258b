#include "scanbench/metrics/registry.h"

namespace scanbench::metrics {

// registry()'s object is a non-const static (registry.cpp), so writing through the const
// reference it returns is defined behaviour.
void add_plugin_entry(MetricRegistry::Entry e) {
  const_cast<MetricRegistry&>(registry()).add(std::move(e));
}

}  // namespace scanbench::metrics
