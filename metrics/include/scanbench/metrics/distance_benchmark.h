#pragma once
// The distance-path benchmark shared by `scanbench bench distance` and bench/bench_distance.cpp:
// the same query points answered by the exact oracle and by the field path (with its exact
// fallback outside the band) in one run; medians over repeats; the speed ratio and the mean
// deviation between the paths in voxels.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "scanbench/metrics/ground_truth.h"

namespace scanbench::metrics {

/// n query points like a filtered scan: a share (1 - far_share) on fixed seeded surface samples
/// moved along their face normal by N(0, sigma) with sigma = near_sigma x diagonal, the rest
/// uniform in the bounding box scaled by 1.2 (mostly outside the band). Deterministic in seed.
Eigen::Matrix3Xf distance_benchmark_queries(const GroundTruth& gt, Eigen::Index n, double far_share,
                                            double near_sigma, std::uint64_t seed);

/// What is timed: exact_seconds = GroundTruth::distances(q, Exact) (Morton sort of the queries,
/// then kd-tree bound + Embree walk per query); field_seconds = GroundTruth::distances(q, Field):
/// the leaf sort, the trilinear samples and the exact fallback for every query outside the band.
/// Both paths sort their queries spatially, so the ratio compares equally ordered passes.
/// Neither includes the one-off field build (field_build_seconds, reported apart) nor the
/// Embree/kd-tree build (done when the GroundTruth is constructed, before any timing).
/// sampling_seconds times the field's own part alone (DistanceField::distances: sort + samples,
/// no fallback), so the fallback costs about field - sampling. Throws Error when a fallback
/// answer differs from the exact path's (they must be equal bit for bit).
struct DistanceBenchmarkResult {
  Eigen::Index queries = 0;
  Eigen::Index fallbacks = 0;            ///< queries outside the band (answered exactly)
  double voxel = 0.0;                    ///< field voxel size (mesh units)
  double field_build_seconds = 0.0;      ///< one-off OpenVDB build (not in the ratio)
  std::vector<double> exact_seconds;     ///< every repeat
  std::vector<double> field_seconds;     ///< every repeat
  std::vector<double> sampling_seconds;  ///< every repeat
  double exact_median = 0.0;
  double field_median = 0.0;
  double sampling_median = 0.0;
  double exact_over_field = 0.0;       ///< exact_median / field_median
  double mean_deviation_voxels = 0.0;  ///< mean |d_field - d_exact| / voxel over all queries
  double mean_deviation_in_band_voxels = 0.0;  ///< the same over in-band queries only
  double max_deviation_voxels = 0.0;
};

/// Builds the field (timed separately), then alternates exact, field and sampling-only passes
/// `repeats` times.
DistanceBenchmarkResult measure_distance_paths(const GroundTruth& gt, const Eigen::Matrix3Xf& q,
                                               int repeats);

}  // namespace scanbench::metrics
