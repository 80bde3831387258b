#include "scanbench/metrics/outlier_residue.h"

#include <cmath>

#include "scanbench/metrics/ground_truth.h"
#include "stats.h"

namespace scanbench::metrics {

std::optional<CleanHits> clean_hits(const PointCloud& scan) {
  if (!scan.has_property("clean_x") || !scan.has_property("clean_y") ||
      !scan.has_property("clean_z"))
    return std::nullopt;
  const auto& cx = scan.properties.at("clean_x");
  const auto& cy = scan.properties.at("clean_y");
  const auto& cz = scan.properties.at("clean_z");
  const Eigen::VectorXf* outlier =
      scan.has_property("outlier") ? &scan.properties.at("outlier") : nullptr;
  CleanHits h;
  for (Eigen::Index i = 0; i < scan.size(); ++i)
    if (!(outlier && (*outlier)[i] != 0.0f)) h.index.push_back(i);
  h.clean.resize(3, static_cast<Eigen::Index>(h.index.size()));
  for (Eigen::Index k = 0; k < h.clean.cols(); ++k) {
    const Eigen::Index i = h.index[static_cast<std::size_t>(k)];
    h.clean.col(k) << cx[i], cy[i], cz[i];
  }
  return h;
}

double scan_noise_rms(const PointCloud& scan) {
  const auto hits = clean_hits(scan);
  if (!hits || hits->index.empty()) return std::nan("");
  double sum = 0.0;
  for (Eigen::Index k = 0; k < hits->clean.cols(); ++k) {
    const Eigen::Vector3d d =
        scan.positions.col(hits->index[static_cast<std::size_t>(k)]).cast<double>() -
        hits->clean.col(k).cast<double>();
    sum += d.squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(hits->clean.cols()));
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
