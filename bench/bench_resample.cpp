// Google Benchmark cases of the resampling operators (not run by ctest). `scanbench bench
// resample` runs the paper's Camel case with metrics and ratios; these cases need no data files:
// a noisy unit sphere (radial noise 0.5% of the radius) of range(0) points, particles = half the
// points, h = 4% of the bbox diagonal, 10 iterations, seed 1.
//   BM_Hem/<points>:  mixture.hem alone (alpha 2).
//   BM_Clop/<points>: resample.clop (weighted, alpha 2, interleaved repulsion, HEM included).
//   BM_Wlop/<points>: resample.wlop at the same kernel width.
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/run_context.h"

namespace {

using namespace scanbench;

PointCloud noisy_sphere(std::int64_t n) {
  Rng rng(1);
  PointCloud c;
  c.positions.resize(3, n);
  for (std::int64_t i = 0; i < n; ++i) {
    Eigen::Vector3f d(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                      static_cast<float>(rng.normal()));
    c.positions.col(i) = d.normalized() * static_cast<float>(1.0 + rng.normal(0.0, 0.005));
  }
  return c;
}

void run(benchmark::State& state, const std::string& name, const Json& given) {
  const PointCloud in = noisy_sphere(state.range(0));
  const auto& entry = algorithms::registry().at(name);
  const Json params = entry.params.validate(given, name);
  std::int64_t out_points = 0;
  for (auto _ : state) {
    RunContext ctx(1);
    const algorithms::AlgorithmOutput out = entry.fn(in, params, ctx);
    out_points = out.points.size();
    if (out.mixture) state.counters["components"] = static_cast<double>(out.mixture->size());
    benchmark::DoNotOptimize(out.points.positions.data());
  }
  state.counters["points"] = static_cast<double>(in.size());
  state.counters["output"] = static_cast<double>(out_points);
}

void BM_Hem(benchmark::State& state) {
  run(state, "mixture.hem", Json{{"h", 0.04}, {"alpha", 2.0}});
}
void BM_Clop(benchmark::State& state) {
  run(state, "resample.clop",
      Json{{"h", 0.04}, {"iterations", 10}, {"particles", 0.5}, {"alpha", 2.0}, {"mu", 0.4}});
}
void BM_Wlop(benchmark::State& state) {
  run(state, "resample.wlop",
      Json{{"h", 0.04}, {"iterations", 10}, {"particles", 0.5}, {"mu", 0.4}});
}

BENCHMARK(BM_Hem)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Clop)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Wlop)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

// main: bench_main.cpp (the program's allocator policy, then the benchmarks).
