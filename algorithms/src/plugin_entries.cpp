#include "scanbench/algorithms/registry.h"

namespace scanbench::algorithms {

// registry()'s object is a non-const static (registry.cpp), so writing through the const
// reference it returns is defined behaviour.
void add_plugin_entry(AlgorithmRegistry::Entry e) {
  const_cast<AlgorithmRegistry&>(registry()).add(std::move(e));
}

}  // namespace scanbench::algorithms
