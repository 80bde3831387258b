// The main of every Google Benchmark executable: the program's allocator policy first, as every
// scanbench command sets it (scanbench/core/allocator.h), so the benchmarks measure what users run.
#include <benchmark/benchmark.h>

#include "scanbench/core/allocator.h"

int main(int argc, char** argv) {
  scanbench::apply_allocator_policy();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
