// The continuous spherical Weiszfeld step (CLOP paper section 9.3, eq. 31-34) against a
// brute-force quadrature: for each component s and fit Gaussian k, the product of the component's
// wrapped normal (variance sigma_s^2, about its axis) and alpha-hat_k (eq. 16, width sigma_k h
// with h = pi, about the particle normal n) is integrated numerically on the tangent plane of n
// in geodesic (exponential-map) coordinates, which is the paper's angular parametrisation on
// gamma_s. Its integral is omega_sk (eq. 32) and its mean the point mu_sk on gamma_s (eq. 33-34);
// the step is the normalised sum of the omega_sk mu_sk. Each component is localised by the
// spatial weight of the eq. 24 kernel of width normal_h (the continuous theta of eq. 27).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <vector>

#include "scanbench/algorithms/lop/clop.h"
#include "scanbench/algorithms/lop/csw.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

// Spatial weight of component s at q: w_s g(mu_s | q, Sigma_s + normal_h^2/32 I) up to a constant
// (eq. 24 kernel, the continuous theta of eq. 27).
double spatial_weight(const GaussianMixture& m, Eigen::Index s, const Vector3d& q, double nh) {
  const double var = nh * nh / 32.0;
  const Eigen::Matrix3d lambda = m.covariance(s).cast<double>() + var * Eigen::Matrix3d::Identity();
  const Vector3d d = m.means.col(s).cast<double>() - q;
  return m.weights(s) / std::sqrt(lambda.determinant()) *
         std::exp(-0.5 * d.dot(lambda.inverse() * d));
}

// One step from the unit normal n, integrating eq. 31 numerically per (s, k).
Vector3d brute_force_step(const GaussianMixture& m, const Vector3d& q, const Vector3d& n,
                          double nh) {
  // An orthonormal frame (e1, e2) of n's tangent plane.
  const Vector3d e1 = n.unitOrthogonal();
  const Vector3d e2 = n.cross(e1);
  const double big_h = M_PI;
  Vector3d sum = Vector3d::Zero();
  for (Eigen::Index s = 0; s < m.size(); ++s) {
    Vector3d axis = m.normal_axes.col(s).cast<double>().normalized();
    if (axis.dot(n) < 0.0) axis = -axis;  // unoriented axes: the pole nearer n
    const double dg = std::acos(std::min(1.0, axis.dot(n)));
    const Vector3d tangent = axis - axis.dot(n) * n;
    const Vector2d xs =
        tangent.norm() > 0.0
            ? Vector2d(Vector2d(tangent.dot(e1), tangent.dot(e2)) / tangent.norm() * dg)
            : Vector2d(Vector2d::Zero());
    const double sig2 = m.normal_spreads(s);
    const double ws = spatial_weight(m, s, q, nh);
    for (int k = 0; k < 3; ++k) {
      const double a2 = kClopFitSigmas[k] * kClopFitSigmas[k] * big_h * big_h;
      // Quadrature of g2(x | xs, sig2 I) * w_k exp(-|x|^2 / (2 a2)) around the product's centre.
      const double prod_sd = std::sqrt(sig2 * a2 / (sig2 + a2));
      const Vector2d centre = a2 / (sig2 + a2) * xs;
      const int steps = 201;
      const double half = 9.0 * prod_sd, dx = 2.0 * half / (steps - 1);
      double integral = 0.0;
      Vector2d first = Vector2d::Zero();
      for (int a = 0; a < steps; ++a)
        for (int b = 0; b < steps; ++b) {
          const Vector2d x = centre + Vector2d(-half + a * dx, -half + b * dx);
          const double g = std::exp(-0.5 * (x - xs).squaredNorm() / sig2) / (2.0 * M_PI * sig2);
          const double f = g * kClopFitWeights[k] * std::exp(-0.5 * x.squaredNorm() / a2) * dx * dx;
          integral += f;
          first += f * x;
        }
      const Vector2d mean = first / integral;  // on gamma_s, at angle |mean| from n
      const double ang = mean.norm();
      const Vector3d dir = ang > 0.0 ? Vector3d((mean.x() * e1 + mean.y() * e2) / ang) : e1;
      const Vector3d mu_sk = std::cos(ang) * n + std::sin(ang) * dir;
      sum += ws * integral * mu_sk;
    }
  }
  return sum.normalized();
}

GaussianMixture test_mixture(std::uint64_t seed) {
  Rng rng(seed);
  GaussianMixture m;
  const int k = 7;
  m.resize(k);
  m.normal_axes.resize(3, k);
  m.normal_spreads.resize(k);
  for (int s = 0; s < k; ++s) {
    m.weights(s) = static_cast<float>(rng.uniform(0.05, 0.3));
    // One draw per statement: the order of a constructor's argument evaluations is unspecified
    // (GCC goes right to left, clang left to right), and the data must not depend on the compiler.
    // z first keeps the mixture this test was written against (GCC's order).
    const float z = static_cast<float>(rng.uniform(-0.01, 0.01));
    const float y = static_cast<float>(rng.uniform(-0.05, 0.05));
    const float x = static_cast<float>(rng.uniform(-0.05, 0.05));
    m.means.col(s) = Eigen::Vector3f(x, y, z);
    Eigen::Matrix3f c = Eigen::Matrix3f::Zero();
    c.diagonal() << static_cast<float>(rng.uniform(5e-4, 2e-3)),
        static_cast<float>(rng.uniform(5e-4, 2e-3)), static_cast<float>(rng.uniform(1e-5, 1e-4));
    m.set_covariance(s, c);
    // Axes 10-50 degrees from +z in varied directions, some flipped (unoriented), spreads from
    // tight to wide.
    const double tilt = rng.uniform(10.0, 50.0) * M_PI / 180.0, az = rng.uniform(0.0, 2.0 * M_PI);
    Eigen::Vector3f axis(static_cast<float>(std::sin(tilt) * std::cos(az)),
                         static_cast<float>(std::sin(tilt) * std::sin(az)),
                         static_cast<float>(std::cos(tilt)));
    if (s % 3 == 1) axis = -axis;
    m.normal_axes.col(s) = axis;
    m.normal_spreads(s) = static_cast<float>(std::exp(rng.uniform(std::log(2e-3), std::log(0.3))));
  }
  return m;
}

TEST(CswOracle, StepMatchesQuadratureOfEq31) {
  const GaussianMixture m = test_mixture(11);
  const double nh = 0.2;
  Eigen::Matrix3Xf q(3, 4), n0(3, 4);
  q << 0.0f, 0.03f, -0.02f, 0.01f, 0.0f, -0.01f, 0.02f, 0.04f, 0.0f, 0.0f, 0.005f, -0.005f;
  n0 << 0.1f, -0.3f, 0.2f, 0.05f, 0.05f, 0.1f, -0.25f, 0.3f, 1.0f, 0.9f, 0.95f, -1.0f;
  for (Eigen::Index i = 0; i < n0.cols(); ++i)
    n0.col(i).normalize();
  for (const int iterations : {1, 3}) {
    RunContext ctx(1);
    const Eigen::Matrix3Xf got = csw_normals(m, q, n0, nh, iterations, ctx);
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
      Vector3d n = n0.col(i).cast<double>();
      for (int it = 0; it < iterations; ++it)
        n = brute_force_step(m, q.col(i).cast<double>(), n, nh);
      if (n.dot(n0.col(i).cast<double>()) < 0.0) n = -n;  // oriented like the initial normal
      const double angle = std::acos(std::min(1.0, n.dot(got.col(i).cast<double>().normalized())));
      // float arithmetic (acos of a float dot product) in the code: 1e-4 rad.
      EXPECT_LT(angle, 1e-4) << "particle " << i << ", " << iterations << " iterations";
      // The step moves the normal by far more than the tolerance.
      EXPECT_GT(std::acos(std::min(1.0, n.dot(n0.col(i).cast<double>()))), 0.02);
    }
  }
}

}  // namespace
}  // namespace scanbench::algorithms
