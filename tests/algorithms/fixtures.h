#pragma once
// Test fixtures shared by the algorithm suites: a noisy sphere and its radial error.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>

#include "scanbench/core/point_cloud.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms::fixtures {

/// n points uniform on the sphere of radius `radius` about the origin, with radial N(0, sigma)
/// noise.
inline PointCloud noisy_sphere(int n, float radius, float sigma, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud c;
  c.positions.resize(3, n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3f d;
    do {
      d = Eigen::Vector3f(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                          static_cast<float>(rng.normal()));
    } while (d.norm() < 1e-6f);
    c.positions.col(i) = d.normalized() * (radius + static_cast<float>(rng.normal(0.0, sigma)));
  }
  return c;
}

/// Mean | |p| - radius | over the columns of p.
inline double mean_radial_error(const Eigen::Matrix3Xf& p, double radius) {
  double s = 0.0;
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    s += std::abs(static_cast<double>(p.col(i).norm()) - radius);
  return s / static_cast<double>(p.cols());
}

}  // namespace scanbench::algorithms::fixtures
