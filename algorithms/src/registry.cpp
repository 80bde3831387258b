#include "scanbench/algorithms/registry.h"

namespace scanbench::algorithms {

const AlgorithmRegistry& registry() {
  static const AlgorithmRegistry r = [] {
    AlgorithmRegistry reg("algorithm");
    // One explicit list; every entry has a create-by-name test (tests/algorithms).
    return reg;
  }();
  return r;
}

}  // namespace scanbench::algorithms
