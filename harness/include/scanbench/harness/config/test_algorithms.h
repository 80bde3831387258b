#pragma once
// Algorithm lookup for the harness, with test-only algorithms.
//
// The harness resolves algorithm names in algorithms::registry() and, only when the environment
// variable SCANBENCH_TEST_ALGORITHMS is set to 1, also in a small registry of test algorithms
// used by the harness tests to prove job isolation. They never appear in `scanbench list` and
// cannot be run by a config unless the variable is set:
//   test.crash  raises SIGSEGV after `delay_s` seconds
//   test.hang   sleeps forever (until the per-job timeout kills it)
//   test.oom    allocates and touches memory in `chunk_mb` steps until allocation fails
//   test.subsample  keeps every `stride`-th point, with an optional busy `work_ms` per call
//                   (phases "select" and "work"; deterministic)
#include "scanbench/algorithms/registry.h"

namespace scanbench::harness {

/// True when SCANBENCH_TEST_ALGORITHMS=1.
bool test_algorithms_enabled();
/// The test registry (always built; only consulted when enabled).
const algorithms::AlgorithmRegistry& test_algorithms();
/// An algorithm by name: the real registry first, then (if enabled) the test one. Throws
/// UnknownNameError listing the known names.
const algorithms::AlgorithmRegistry::Entry& algorithm_entry(std::string_view name);

}  // namespace scanbench::harness
