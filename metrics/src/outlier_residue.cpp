#include "scanbench/metrics/outlier_residue.h"

#include <cmath>

#include "scanbench/metrics/ground_truth.h"
#include "stats.h"

namespace scanbench::metrics {

double scan_noise_rms(const PointCloud& scan) {
  if (!scan.has_property("clean_x") || !scan.has_property("clean_y") ||
      !scan.has_property("clean_z"))
    return std::nan("");
  const auto& cx = scan.properties.at("clean_x");
  const auto& cy = scan.properties.at("clean_y");
  const auto& cz = scan.properties.at("clean_z");
  const Eigen::VectorXf* outlier =
      scan.has_property("outlier") ? &scan.properties.at("outlier") : nullptr;
  double sum = 0.0;
  std::int64_t count = 0;
  for (Eigen::Index i = 0; i < scan.size(); ++i) {
    if (outlier && (*outlier)[i] != 0.0f) continue;
    const Eigen::Vector3d d =
        scan.positions.col(i).cast<double>() - Eigen::Vector3d(cx[i], cy[i], cz[i]);
    sum += d.squaredNorm();
    ++count;
  }
  return count > 0 ? std::sqrt(sum / count) : std::nan("");
}

Json outlier_residue_metric(const MetricInput& in, const OutlierResidueParams& p) {
  if (in.output.empty()) throw InputError("outliers.residue: output has no points");
  const double diag = in.truth.diagonal();
  double sigma = p.noise * diag;
  std::string source = "declared";
  if (p.noise == 0.0) {
    if (!in.scan) throw NotApplicable("outliers.residue: noise = 0 needs the scan to estimate it");
    sigma = scan_noise_rms(*in.scan);
    source = "scan clean positions";
    if (!std::isfinite(sigma))
      throw NotApplicable(
          "outliers.residue: the scan has no clean_x/y/z properties; declare noise");
    if (!(sigma > 0.0))
      throw NotApplicable("outliers.residue: the scan is noise free; declare noise");
  }
  const double threshold = p.multiple * sigma;
  const auto closest = closest_points_of(in);
  std::int64_t far = 0;
  for (const auto& c : closest)
    if (c.distance > threshold) ++far;
  Json j = Json::object();
  j["outlier_residue"] = static_cast<double>(far) / static_cast<double>(closest.size());
  detail::put_length(j, "outlier_threshold", threshold, diag);
  detail::put_length(j, "scan_noise", sigma, diag);
  j["scan_noise_source"] = source;
  if (in.scan && !in.scan->empty()) {
    const Eigen::VectorXf d = in.truth.distances(in.scan->positions, DistancePath::Exact);
    j["scan_outlier_share"] =
        static_cast<double>((d.array() > static_cast<float>(threshold)).count()) / d.size();
  } else {
    j["scan_outlier_share"] = nullptr;
  }
  return j;
}

}  // namespace scanbench::metrics
