// Google Benchmark cases of the virtual scanner (not run by ctest). `scanbench bench scanner`
// prints the same comparison as a table and JSON.
//   BM_ScannerVsBareEmbree/<triangles>: one timed scan (every artifact on; BVH excluded) per
//     iteration, with counters for the bare rtcIntersect1M rays/s measured on the same rays
//     (same order, same coherent context, same per-tile streams) in the same iteration, their
//     wall-clock ratio and their process-CPU ratio.
//   BM_ScanIncludingBuild/<triangles>: the public scan() call, BVH build included.
#include <benchmark/benchmark.h>

#include "scanbench/core/run_context.h"
#include "scanbench/scanner/scanner.h"
#include "scanbench/scanner/throughput.h"

namespace {

using namespace scanbench;

void BM_ScannerVsBareEmbree(benchmark::State& state) {
  const TriangleMesh mesh = scanner::uv_sphere(static_cast<int>(state.range(0)));
  const scanner::ScannerParams p = scanner::all_artifacts_params();
  RunContext ctx(1);
  double bare = 0, scan = 0, bare_cpu = 0, scan_cpu = 0;
  std::int64_t rays = 0;
  for (auto _ : state) {
    const scanner::ThroughputResult r = scanner::measure_throughput(mesh, p, 1, ctx);
    state.SetIterationTime(r.scanner_seconds.front());
    bare += r.bare_seconds.front();
    scan += r.scanner_seconds.front();
    bare_cpu += r.bare_cpu_seconds.front();
    scan_cpu += r.scanner_cpu_seconds.front();
    rays += r.rays_per_run;
  }
  state.counters["rays/s"] = benchmark::Counter(static_cast<double>(rays) / scan);
  state.counters["bare_rays/s"] = benchmark::Counter(static_cast<double>(rays) / bare);
  state.counters["ratio"] = bare / scan;
  state.counters["cpu_ratio"] = bare_cpu / scan_cpu;
  state.counters["triangles"] = static_cast<double>(mesh.num_faces());
}
BENCHMARK(BM_ScannerVsBareEmbree)
    ->Arg(1000)
    ->Arg(10000)
    ->Arg(100000)
    ->Arg(1000000)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

void BM_ScanIncludingBuild(benchmark::State& state) {
  const TriangleMesh mesh = scanner::uv_sphere(static_cast<int>(state.range(0)));
  const scanner::ScannerParams p = scanner::all_artifacts_params();
  RunContext ctx(1);
  std::int64_t points = 0;
  for (auto _ : state) {
    const scanner::Scan s = scanner::scan(mesh, p, ctx);
    points += s.cloud.size();
    benchmark::DoNotOptimize(s.cloud.positions.data());
  }
  const double rays_per_scan =
      static_cast<double>(p.views) * p.resolution * p.resolution * p.sub_rays;
  state.counters["rays/s"] = benchmark::Counter(
      rays_per_scan * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["points/s"] =
      benchmark::Counter(static_cast<double>(points), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ScanIncludingBuild)
    ->Arg(1000)
    ->Arg(100000)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
