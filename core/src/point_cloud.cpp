#include "scanbench/core/point_cloud.h"

#include <fmt/format.h>

#include "scanbench/core/errors.h"

namespace scanbench {

void PointCloud::resize(Eigen::Index n) {
  positions.resize(3, n);
  normals.resize(3, 0);
  weights.resize(0);
  scan_ids.resize(0);
  properties.clear();
}

void PointCloud::validate(std::string_view where) const {
  const Eigen::Index n = size();
  auto size_error = [&](std::string_view what, Eigen::Index got) {
    throw InputError(fmt::format("{}: {} has {} entries for {} points", where, what, got, n));
  };
  if (normals.cols() != 0 && normals.cols() != n) size_error("normals", normals.cols());
  if (weights.size() != 0 && weights.size() != n) size_error("weights", weights.size());
  if (scan_ids.size() != 0 && scan_ids.size() != n) size_error("scan_ids", scan_ids.size());
  for (const auto& [name, values] : properties) {
    if (values.size() != n) size_error("property '" + name + "'", values.size());
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!positions.col(i).allFinite()) {
      throw InputError(fmt::format("{}: point {} has a non-finite coordinate", where, i));
    }
  }
  if (has_normals()) {
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!normals.col(i).allFinite()) {
        throw InputError(fmt::format("{}: normal {} is not finite", where, i));
      }
    }
  }
  if (has_scan_ids() && n > 0) {
    const int lo = scan_ids.minCoeff();
    const int hi = scan_ids.maxCoeff();
    if (lo < 0) throw InputError(fmt::format("{}: negative scan id {}", where, lo));
    if (sensor_origins.cols() > 0 && hi >= sensor_origins.cols()) {
      throw InputError(fmt::format("{}: scan id {} has no sensor origin ({} sensors)", where, hi,
                                   sensor_origins.cols()));
    }
  }
}

PointCloud PointCloud::subset(const std::vector<Eigen::Index>& indices) const {
  PointCloud out;
  const auto m = static_cast<Eigen::Index>(indices.size());
  out.positions.resize(3, m);
  if (has_normals()) out.normals.resize(3, m);
  if (has_weights()) out.weights.resize(m);
  if (has_scan_ids()) out.scan_ids.resize(m);
  for (const auto& [name, values] : properties)
    out.properties[name].resize(m);
  for (Eigen::Index k = 0; k < m; ++k) {
    const Eigen::Index i = indices[static_cast<std::size_t>(k)];
    out.positions.col(k) = positions.col(i);
    if (has_normals()) out.normals.col(k) = normals.col(i);
    if (has_weights()) out.weights[k] = weights[i];
    if (has_scan_ids()) out.scan_ids[k] = scan_ids[i];
    for (const auto& [name, values] : properties)
      out.properties[name][k] = values[i];
  }
  out.sensor_origins = sensor_origins;
  out.origin = origin;
  return out;
}

}  // namespace scanbench
