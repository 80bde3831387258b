#include "scanbench/metrics/distance_benchmark.h"

#include <algorithm>
#include <chrono>

#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/timing.h"
#include "scanbench/metrics/distance_field.h"
#include "scanbench/metrics/surface_sampling.h"

namespace scanbench::metrics {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

Eigen::Matrix3Xf distance_benchmark_queries(const GroundTruth& gt, Eigen::Index n, double far_share,
                                            double near_sigma, std::uint64_t seed) {
  if (n < 1) throw ParamError("distance benchmark: points must be >= 1");
  if (!(far_share >= 0.0 && far_share <= 1.0))
    throw ParamError("distance benchmark: far share must be in [0, 1]");
  const auto n_far = static_cast<Eigen::Index>(far_share * static_cast<double>(n));
  const Eigen::Index n_near = n - n_far;
  const PointCloud s = sample_surface(gt.mesh(), n_near, derive_seed(seed, "near"));
  Eigen::Matrix3Xf q(3, n);
  const double sigma = near_sigma * gt.diagonal();
  for (Eigen::Index i = 0; i < n_near; ++i) {
    Rng rng(derive_seed(seed, static_cast<std::uint64_t>(i)));
    q.col(i) = s.positions.col(i) + static_cast<float>(rng.normal(0.0, sigma)) * s.normals.col(i);
  }
  const BoundingBox box = gt.bbox().scaled(1.2f);
  Rng far(derive_seed(seed, "far"));
  for (Eigen::Index i = n_near; i < n; ++i)
    for (int k = 0; k < 3; ++k)
      q(k, i) = static_cast<float>(far.uniform(box.min[k], box.max[k]));
  return q;
}

DistanceBenchmarkResult measure_distance_paths(const GroundTruth& gt, const Eigen::Matrix3Xf& q,
                                               int repeats) {
  if (repeats < 1) throw ParamError("distance benchmark: repeats must be >= 1");
  DistanceBenchmarkResult r;
  r.queries = q.cols();
  auto t0 = std::chrono::steady_clock::now();
  r.voxel = gt.field().voxel_size();
  r.field_build_seconds = seconds_since(t0);
  Eigen::VectorXf exact, field;
  for (int k = 0; k < repeats; ++k) {
    t0 = std::chrono::steady_clock::now();
    exact = gt.distances(q, DistancePath::Exact);
    r.exact_seconds.push_back(seconds_since(t0));
    t0 = std::chrono::steady_clock::now();
    field = gt.distances(q, DistancePath::Field, &r.fallbacks);
    r.field_seconds.push_back(seconds_since(t0));
    Eigen::VectorXf sampled;
    std::vector<Eigen::Index> outside;
    t0 = std::chrono::steady_clock::now();
    gt.field().distances(q, sampled, outside);
    r.sampling_seconds.push_back(seconds_since(t0));
  }
  r.exact_median = median(r.exact_seconds);
  r.field_median = median(r.field_seconds);
  r.sampling_median = median(r.sampling_seconds);
  r.exact_over_field = r.exact_median / r.field_median;
  // Which queries the field answers itself (the others fell back to the exact path).
  Eigen::VectorXf unused;
  std::vector<Eigen::Index> outside;
  gt.field().distances(q, unused, outside);
  std::vector<std::uint8_t> inside(static_cast<std::size_t>(q.cols()), 1);
  for (const Eigen::Index i : outside) {
    inside[static_cast<std::size_t>(i)] = 0;
    // The fallback is the exact path: the same answer, bit for bit.
    if (field[i] != exact[i])
      throw Error("distance benchmark: a fallback answer differs from the exact path's");
  }
  double sum = 0.0, sum_in = 0.0, mx = 0.0;
  Eigen::Index in_band = 0;
  for (Eigen::Index i = 0; i < q.cols(); ++i) {
    const double d = std::abs(double(field[i]) - double(exact[i])) / r.voxel;
    sum += d;
    mx = std::max(mx, d);
    if (inside[static_cast<std::size_t>(i)]) {
      sum_in += d;
      ++in_band;
    }
  }
  r.mean_deviation_voxels = sum / static_cast<double>(q.cols());
  r.mean_deviation_in_band_voxels = in_band > 0 ? sum_in / static_cast<double>(in_band) : 0.0;
  r.max_deviation_voxels = mx;
  return r;
}

}  // namespace scanbench::metrics
