#include "scanbench/metrics/normal_angle.h"

#include <algorithm>
#include <cmath>

#include "scanbench/metrics/ground_truth.h"
#include "stats.h"

namespace scanbench::metrics {

Json normal_angle_metric(const MetricInput& in, const NormalAngleParams& p) {
  if (!in.output.has_normals()) throw NotApplicable("normals.angle: output has no normals");
  if (in.output.empty()) throw InputError("normals.angle: output has no points");
  const auto closest = closest_points_of(in);
  const Eigen::Index n = in.output.size();
  Eigen::VectorXf deg(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d v = in.output.normals.col(i).cast<double>();
    const double len = v.norm();
    if (!(len > 0.0))
      throw InputError("normals.angle: output normal " + std::to_string(i) + " is zero");
    const double c =
        std::abs(v.dot(closest[static_cast<std::size_t>(i)].normal.cast<double>()) / len);
    deg[i] = static_cast<float>(std::acos(std::min(1.0, c)) * 180.0 / M_PI);
  }
  double sq = 0.0;
  for (Eigen::Index i = 0; i < n; ++i)
    sq += double(deg[i]) * deg[i];
  Json j = Json::object();
  j["normal_angle_mean_deg"] = detail::ordered_sum(deg) / n;
  j["normal_angle_rms_deg"] = std::sqrt(sq / n);
  j["normal_pgp5"] = static_cast<double>((deg.array() < 5.0f).count()) / n;
  j["normal_pgp10"] = static_cast<double>((deg.array() < 10.0f).count()) / n;
  j["histograms"]["normal_angle"] = detail::histogram(deg, 0.0, 90.0 + 1e-9, p.bins, "deg");
  return j;
}

}  // namespace scanbench::metrics
