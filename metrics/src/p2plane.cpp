#include "scanbench/metrics/p2plane.h"

#include <algorithm>
#include <cmath>

#include "stats.h"

namespace scanbench::metrics {

Eigen::VectorXf point_to_plane_errors(const Eigen::Matrix3Xf& q,
                                      const std::vector<ClosestPoint>& closest) {
  Eigen::VectorXf e(q.cols());
  for (Eigen::Index i = 0; i < q.cols(); ++i) {
    const ClosestPoint& c = closest[static_cast<std::size_t>(i)];
    e[i] = (q.col(i) - c.point).dot(c.normal);
  }
  return e;
}

Json p2plane_metric(const MetricInput& in, const P2PlaneParams& p) {
  if (in.output.empty()) throw InputError("accuracy.p2plane: output has no points");
  const auto closest = closest_points_of(in);
  return p2plane_scores(point_to_plane_errors(in.output.positions, closest).cwiseAbs(),
                        in.truth.diagonal(), p);
}

Json p2plane_scores(const Eigen::VectorXf& abs_e, double diag, const P2PlaneParams& p) {
  const double n = static_cast<double>(abs_e.size());
  std::vector<float> sorted(abs_e.data(), abs_e.data() + abs_e.size());
  std::sort(sorted.begin(), sorted.end());
  double sq = 0.0;
  for (Eigen::Index i = 0; i < abs_e.size(); ++i)
    sq += double(abs_e[i]) * abs_e[i];
  Json j = Json::object();
  detail::put_length(j, "p2plane_mean", detail::ordered_sum(abs_e) / n, diag);
  detail::put_length(j, "p2plane_rms", std::sqrt(sq / n), diag);
  detail::put_length(j, "p2plane_max", sorted.back(), diag);
  detail::put_length(j, "p2plane_p50", detail::quantile_sorted(sorted, 0.50), diag);
  detail::put_length(j, "p2plane_p90", detail::quantile_sorted(sorted, 0.90), diag);
  detail::put_length(j, "p2plane_p99", detail::quantile_sorted(sorted, 0.99), diag);
  j["histograms"]["p2plane"] =
      detail::histogram(abs_e / static_cast<float>(diag), 0.0, p.hist_max, p.bins, "diag");
  return j;
}

}  // namespace scanbench::metrics
