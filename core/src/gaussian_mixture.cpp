#include "scanbench/core/gaussian_mixture.h"

#include <fmt/format.h>

#include <cmath>

#include "scanbench/core/errors.h"

namespace scanbench {

void GaussianMixture::resize(Eigen::Index k) {
  weights.resize(k);
  means.resize(3, k);
  covariances.resize(6, k);
  normal_axes.resize(3, 0);
  normal_spreads.resize(0);
}

Eigen::Matrix3f GaussianMixture::covariance(Eigen::Index i) const {
  const auto c = covariances.col(i);
  Eigen::Matrix3f m;
  m << c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5];
  return m;
}

void GaussianMixture::set_covariance(Eigen::Index i, const Eigen::Matrix3f& c) {
  covariances.col(i) << c(0, 0), 0.5f * (c(0, 1) + c(1, 0)), 0.5f * (c(0, 2) + c(2, 0)), c(1, 1),
      0.5f * (c(1, 2) + c(2, 1)), c(2, 2);
}

PointCloud GaussianMixture::component_points() const {
  PointCloud c;
  c.positions = means;
  c.normals = normal_axes;
  c.weights = weights;
  c.origin = origin;
  return c;
}

void GaussianMixture::validate(std::string_view where) const {
  const Eigen::Index k = size();
  if (weights.size() != k || covariances.cols() != k) {
    throw InputError(fmt::format("{}: mixture has {} means, {} weights, {} covariances", where, k,
                                 weights.size(), covariances.cols()));
  }
  if (normal_axes.cols() != 0 && (normal_axes.cols() != k || normal_spreads.size() != k)) {
    throw InputError(
        fmt::format("{}: mixture normal axes/spreads do not match {} components", where, k));
  }
  for (Eigen::Index i = 0; i < k; ++i) {
    if (!means.col(i).allFinite() || !covariances.col(i).allFinite() ||
        !std::isfinite(weights[i])) {
      throw InputError(fmt::format("{}: component {} is not finite", where, i));
    }
    if (weights[i] < 0.0f) {
      throw InputError(
          fmt::format("{}: component {} has negative weight {}", where, i, weights[i]));
    }
  }
}

}  // namespace scanbench
