// Google Benchmark cases of the two distance paths on the same query points: the exact oracle
// (Embree rtcPointQuery + point-triangle routine) and the OpenVDB narrow-band field with exact
// fallback. The ground truth is a procedural sphere (no files needed) or, with the environment
// variable SCANBENCH_BENCH_MESH=<file>, any mesh. `scanbench bench distance` prints the ratio
// and the deviation measured in one run; these cases give per-query times with statistics.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <memory>
#include <vector>

#include "scanbench/core/datasets.h"
#include "scanbench/core/io.h"
#include "scanbench/metrics/distance_benchmark.h"
#include "scanbench/metrics/distance_field.h"
#include "scanbench/metrics/ground_truth.h"

namespace {

using scanbench::metrics::DistancePath;
using scanbench::metrics::GroundTruth;

struct Fixture {
  std::unique_ptr<GroundTruth> gt;
  Eigen::Matrix3Xf queries;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture x;
    const char* file = std::getenv("SCANBENCH_BENCH_MESH");
    const scanbench::TriangleMesh mesh =
        file ? scanbench::read_mesh(file) : scanbench::load_dataset("sphere");
    x.gt = std::make_unique<GroundTruth>(mesh, 1);
    x.gt->field();  // build once, outside the timed loops
    x.queries = scanbench::metrics::distance_benchmark_queries(*x.gt, 1000000, 0.02, 0.002, 7);
    return x;
  }();
  return f;
}

void BM_DistanceExact(benchmark::State& state) {
  const Fixture& f = fixture();
  const Eigen::Matrix3Xf q = f.queries.leftCols(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(f.gt->distances(q, DistancePath::Exact));
  state.SetItemsProcessed(state.iterations() * q.cols());
}

void BM_DistanceField(benchmark::State& state) {
  const Fixture& f = fixture();
  const Eigen::Matrix3Xf q = f.queries.leftCols(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(f.gt->distances(q, DistancePath::Field));
  state.SetItemsProcessed(state.iterations() * q.cols());
}

// The field's own part of the field path: leaf sort and trilinear samples, no exact fallback.
void BM_FieldSampling(benchmark::State& state) {
  const Fixture& f = fixture();
  const Eigen::Matrix3Xf q = f.queries.leftCols(state.range(0));
  Eigen::VectorXf out;
  std::vector<Eigen::Index> outside;
  for (auto _ : state) {
    f.gt->field().distances(q, out, outside);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * q.cols());
}

void BM_FieldBuild(benchmark::State& state) {
  const Fixture& f = fixture();
  const float voxel = f.gt->field().voxel_size();
  for (auto _ : state) {
    scanbench::metrics::DistanceField field(
        f.gt->mesh(), voxel, f.gt->options().band_voxels,
        f.gt->closed() ? scanbench::metrics::DistanceField::Kind::Signed
                       : scanbench::metrics::DistanceField::Kind::Unsigned);
    benchmark::DoNotOptimize(field.active_voxels());
  }
}

}  // namespace

BENCHMARK(BM_DistanceExact)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_DistanceField)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_FieldSampling)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_FieldBuild)->Unit(benchmark::kMillisecond)->UseRealTime();

// main: bench_main.cpp (the program's allocator policy, then the benchmarks).
