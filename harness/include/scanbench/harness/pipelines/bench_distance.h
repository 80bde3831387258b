#pragma once
// The distance benchmark (`scanbench bench distance`): the exact closest-point oracle (Embree
// rtcPointQuery + point-triangle routine) against the OpenVDB narrow-band field path (exact
// fallback outside the band) on the same query points in one run: medians over repeats, the speed
// ratio exact/field and the mean deviation in voxels.
#include <cstdint>
#include <string>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct DistanceBenchOptions {
  std::string
      dataset;       ///< ground-truth dataset; "" with no mesh: bunny when extracted, else sphere
  std::string mesh;  ///< ground-truth mesh file (instead of a dataset)
  std::int64_t points = 1000000;  ///< query points
  int repeats = 5;                ///< timed repeats per path (medians)
  int threads = 0;                ///< worker threads (0 = all)
  double far_share = 0.02;        ///< share of queries uniform in 1.2 x bbox
  double near_sigma = 0.002;      ///< normal offset sigma of the near queries (diagonal fraction)
  double field_voxel = 1.0 / 512.0;  ///< field voxel (diagonal fraction)
  std::uint64_t seed = 1;            ///< seed of the query points
};

struct DistanceBenchResult {
  Json json;         ///< what `--json` writes: context, inputs, timings, ratios, deviations
  std::string text;  ///< the printed summary
  const Json& to_json() const { return json; }
};

DistanceBenchResult run_distance_bench(const DistanceBenchOptions& o);

}  // namespace scanbench::harness
