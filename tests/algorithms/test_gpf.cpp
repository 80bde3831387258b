// filter.gpf (Lu et al. 2017, section 4) and normals.bilateral (Huang et al. 2013, section 4):
// every term of one EM iteration against a brute-force transcription of eq. 3, 10 and 11 written
// in GPF's own kernel convention, omega's effect on an isolated input against a dense one (eq. 3),
// gap filling (section 6 (iii)) closing a gap, geometric properties and bad input. How GPF
// compares with WLOP and CLOP is measured by the claims suite (`scanbench claims`), not here.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "fixtures.h"
#include "gpf/gpf_internal.h"
#include "lop/projection_kernels.h"
#include "scanbench/algorithms/gpf/bilateral_normals.h"
#include "scanbench/algorithms/gpf/gpf.h"
#include "scanbench/algorithms/lop/clop.h"
#include "scanbench/algorithms/lop/lop.h"
#include "scanbench/algorithms/lop/pca_normals.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/procedural.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/simd.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::algorithms {
namespace {

// ---------------------------------------------------------------------------------------------
// Brute-force transcription of one GPF iteration, in double, in the paper's own convention:
// theta_GPF(r) = exp(-r^2 / (h_GPF/2)^2), data pairs within h_GPF/2, repulsion and densities
// within h_GPF, beta = theta(r)/r at the tangential distance r clamped below at 0.01 h where h is
// scanbench's h = 2 h_GPF (so 0.02 h_GPF).

struct BruteStep {
  std::vector<double> denominator;
  Eigen::Matrix3Xd data, repulsion, x;
  Eigen::VectorXd w, rho;
  double outlier = 0.0, s2 = 0.0, np = 0.0;
  double s2_point = 0.0;      // the point-to-point reading: |v_n - x_m'|^2 in place of eq. 11's
  Eigen::MatrixXd posterior;  // M x N
};

BruteStep brute_step(const Eigen::Matrix3Xd& v, const Eigen::Matrix3Xd& b,
                     const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& xb, double s2, double omega,
                     double mu, double h_gpf) {
  const auto n = v.cols();
  const auto m = x.cols();
  auto theta = [&](double r) { return std::exp(-r * r / ((h_gpf / 2) * (h_gpf / 2))); };
  const double r_data = h_gpf / 2, r_rep = h_gpf, clamp = 0.02 * h_gpf;
  BruteStep s;
  s.rho = Eigen::VectorXd::Ones(n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      if (j != i && (v.col(i) - v.col(j)).norm() <= r_rep)
        s.rho[i] += theta((v.col(i) - v.col(j)).norm());
  s.w = Eigen::VectorXd::Ones(m);
  for (Eigen::Index i = 0; i < m; ++i)
    for (Eigen::Index j = 0; j < m; ++j)
      if (j != i && (x.col(i) - x.col(j)).norm() <= r_rep)
        s.w[i] += theta((x.col(i) - x.col(j)).norm());
  // Eq. 3.
  s.outlier = std::pow(2 * M_PI * s2, 1.5) * omega * static_cast<double>(m) /
              ((1 - omega) * static_cast<double>(n));
  s.denominator.assign(static_cast<std::size_t>(n), s.outlier);
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index i = 0; i < m; ++i) {
      const double d = (v.col(j) - x.col(i)).norm();
      if (d <= r_data) s.denominator[static_cast<std::size_t>(j)] += std::exp(-d * d / (2 * s2));
    }
  s.posterior = Eigen::MatrixXd::Zero(m, n);
  for (Eigen::Index i = 0; i < m; ++i)
    for (Eigen::Index j = 0; j < n; ++j) {
      const double d = (v.col(j) - x.col(i)).norm();
      if (d <= r_data)
        s.posterior(i, j) =
            std::exp(-d * d / (2 * s2)) / s.denominator[static_cast<std::size_t>(j)];
    }
  // Eq. 10.
  s.data = Eigen::Matrix3Xd::Zero(3, m);
  s.repulsion = Eigen::Matrix3Xd::Zero(3, m);
  for (Eigen::Index i = 0; i < m; ++i) {
    Eigen::Vector3d num = Eigen::Vector3d::Zero();
    double den = 0;
    for (Eigen::Index j = 0; j < n; ++j) {
      const double q = s.posterior(i, j) / s.rho[j];
      num += q * (v.col(j) - x.col(i)).dot(b.col(j)) * b.col(j);
      den += q;
    }
    if (den > 0) s.data.col(i) = num / den;
    Eigen::Vector3d rn = Eigen::Vector3d::Zero();
    double rd = 0;
    for (Eigen::Index k = 0; k < m; ++k) {
      if (k == i || (x.col(i) - x.col(k)).norm() > r_rep) continue;
      const Eigen::Matrix3d c = Eigen::Matrix3d::Identity() - xb.col(k) * xb.col(k).transpose();
      const Eigen::Vector3d cd = c * (x.col(i) - x.col(k));
      const double r = std::max(cd.norm(), clamp);
      const double beta = theta(r) / r;
      rn += s.w[k] * beta * cd;
      rd += s.w[k] * beta;
    }
    if (rd > 0) s.repulsion.col(i) = rn / rd;
  }
  s.x = x + s.data + mu * s.repulsion;
  // Eq. 11.
  double num = 0, num_point = 0;
  for (Eigen::Index i = 0; i < m; ++i)
    for (Eigen::Index j = 0; j < n; ++j) {
      const double t = (v.col(j) - s.x.col(i)).dot(b.col(j));
      num += s.posterior(i, j) * t * t;
      num_point += s.posterior(i, j) * (v.col(j) - s.x.col(i)).squaredNorm();
      s.np += s.posterior(i, j);
    }
  s.s2 = num / (3 * s.np);
  s.s2_point = num_point / (3 * s.np);
  return s;
}

// A small noisy sphere of radius 0.3 (bbox diagonal about 1, GPF's working units) with noisy
// unit normals, and a perturbed half of it as particles with their normals.
struct SmallCase {
  Eigen::Matrix3Xf v, b, x, xb;
};

SmallCase small_case() {
  SmallCase c;
  const PointCloud s = fixtures::noisy_sphere(400, 0.3f, 0.01f, 21);
  c.v = s.positions;
  Rng rng(22);
  c.b.resize(3, c.v.cols());
  for (Eigen::Index i = 0; i < c.v.cols(); ++i) {
    Eigen::Vector3f nrm = c.v.col(i).normalized();
    for (int d = 0; d < 3; ++d)
      nrm[d] += static_cast<float>(rng.normal(0.0, 0.1));
    c.b.col(i) = nrm.normalized();
  }
  const Eigen::Index m = 200;
  c.x.resize(3, m);
  c.xb.resize(3, m);
  for (Eigen::Index i = 0; i < m; ++i) {
    c.x.col(i) = c.v.col(2 * i);
    for (int d = 0; d < 3; ++d)
      c.x(d, i) += static_cast<float>(rng.normal(0.0, 0.01));
    c.xb.col(i) = c.b.col(2 * i);
  }
  return c;
}

void expect_close(const Eigen::Vector3f& a, const Eigen::Vector3d& b, double tol,
                  const std::string& what) {
  EXPECT_LE((a.cast<double>() - b).norm(), tol * std::max(1.0, b.norm()))
      << what << ": got " << a.transpose() << ", expected " << b.transpose();
}

TEST(GpfStep, EveryTermMatchesBruteForceTranscription) {
  const SmallCase c = small_case();
  const double h_gpf = 0.15, s2 = 0.002, omega = 0.3, mu = 0.25;
  // Kernel conversion: GPF at h_GPF is scanbench's filter at h = 2 h_GPF.
  const gpf_detail::Problem problem(c.v, c.b, static_cast<float>(2 * h_gpf));
  const gpf_detail::Step step = gpf_detail::em_step(problem, c.x, c.xb, s2, omega, mu);
  const BruteStep ref = brute_step(c.v.cast<double>(), c.b.cast<double>(), c.x.cast<double>(),
                                   c.xb.cast<double>(), s2, omega, mu, h_gpf);
  // Input densities rho_n and particle densities w_m.
  for (Eigen::Index j = 0; j < c.v.cols(); ++j)
    ASSERT_NEAR(problem.rho()[j], ref.rho[j], 1e-4 * ref.rho[j]) << "rho " << j;
  for (Eigen::Index i = 0; i < c.x.cols(); ++i)
    ASSERT_NEAR(step.particle_weights[i], ref.w[i], 1e-4 * ref.w[i]) << "w " << i;
  // The uniform outlier term and the E-step denominators (so every posterior p_mn = e/D_n).
  EXPECT_NEAR(step.outlier_term, ref.outlier, 1e-12 * std::max(1.0, ref.outlier));
  EXPECT_GT(ref.outlier, 1e-6);  // the test exercises it
  for (Eigen::Index j = 0; j < c.v.cols(); ++j) {
    const double d = ref.denominator[static_cast<std::size_t>(j)];
    ASSERT_NEAR(step.denominator[j], d, 1e-5 * d) << "D_" << j;
  }
  EXPECT_NEAR(step.np, ref.np, 1e-4 * ref.np);
  int with_data = 0, with_rep = 0;
  for (Eigen::Index i = 0; i < c.x.cols(); ++i) {
    expect_close(step.data.col(i), ref.data.col(i), 1e-4, "data term " + std::to_string(i));
    expect_close(step.repulsion.col(i), ref.repulsion.col(i), 1e-4,
                 "repulsion " + std::to_string(i));
    expect_close(step.x.col(i), ref.x.col(i), 1e-5, "x " + std::to_string(i));
    with_data += ref.data.col(i).norm() > 1e-4;
    with_rep += ref.repulsion.col(i).norm() > 1e-4;
  }
  EXPECT_GT(with_data, 150);
  EXPECT_GT(with_rep, 150);
  EXPECT_NEAR(step.s2, ref.s2, 1e-3 * ref.s2);
  // The point-to-point reading of the s2 update (s2_update = point): the same step otherwise.
  const gpf_detail::Step point = gpf_detail::em_step(problem, c.x, c.xb, s2, omega, mu, nullptr,
                                                     gpf_detail::S2Residual::Point);
  EXPECT_TRUE(point.x.cwiseEqual(step.x).all());
  EXPECT_NEAR(point.s2, ref.s2_point, 1e-3 * ref.s2_point);
  EXPECT_GT(ref.s2_point, 1.5 * ref.s2);  // the readings differ (tangential residuals count)
}

TEST(GpfStep, S2UpdatesEqualTheirClosedFormsOnAHandCase) {
  // One particle at the origin (normal +z), four inputs at the corners of a square in x-y at
  // alternating heights c1, c2: every input has the same neighbour distances, so the same rho,
  // and with omega = 0 and one particle every posterior p_mn is 1. Eq. 10 (mu = 0) moves the
  // particle to x' = (0, 0, (c1 + c2)/2); then with delta = c1 - c2
  //   eq. 11 (point to plane): s2 = sum ((v_n - x') . b_n)^2 / (3 * 4) = delta^2 / 12,
  //   point to point:          s2 = sum |v_n - x'|^2 / (3 * 4)        = (4 a^2 + delta^2) / 12.
  const float a = 0.02f, c1 = 0.01f, c2 = -0.006f;
  Eigen::Matrix3Xf v(3, 4), b = Eigen::Matrix3Xf::Zero(3, 4);
  v << a, -a, 0, 0, 0, 0, a, -a, c1, c2, c1, c2;
  b.row(2).setOnes();
  const Eigen::Matrix3Xf x = Eigen::Matrix3Xf::Zero(3, 1);
  const Eigen::Matrix3Xf xb = b.leftCols(1);
  const gpf_detail::Problem problem(v, b, 0.2f);  // data radius 0.05 holds all four
  const double delta = static_cast<double>(c1) - c2;
  for (const double s2 : {1e-4, 4e-3}) {  // the update does not depend on the old s2 here
    const gpf_detail::Step plane = gpf_detail::em_step(problem, x, xb, s2, 0.0, 0.0);
    EXPECT_NEAR(plane.np, 4.0, 1e-5);
    EXPECT_NEAR(plane.x(2, 0), 0.5 * (c1 + c2), 1e-7);
    EXPECT_NEAR(plane.x.col(0).head<2>().norm(), 0.0, 1e-7);
    EXPECT_NEAR(plane.s2, delta * delta / 12.0, 1e-4 * delta * delta / 12.0);
    const gpf_detail::Step point =
        gpf_detail::em_step(problem, x, xb, s2, 0.0, 0.0, nullptr, gpf_detail::S2Residual::Point);
    const double expected = (4.0 * a * a + delta * delta) / 12.0;
    EXPECT_NEAR(point.s2, expected, 1e-4 * expected);
  }
}

TEST(GpfStep, KernelConversionGpfAtHIsOursAtTwoH) {
  // GPF's theta(r) = exp(-r^2/(h_GPF/2)^2) is scanbench's exp(-16 r^2/h^2) at h = 2 h_GPF.
  const float h_gpf = 0.1f;
  for (float r : {0.0f, 0.01f, 0.03f, 0.05f, 0.1f}) {
    EXPECT_NEAR(kernels::theta(r, 2 * h_gpf), std::exp(-r * r / (h_gpf / 2 * h_gpf / 2)), 1e-6);
  }
  // The filter's radii and densities follow: data pairs within h_GPF/2, densities within h_GPF.
  const SmallCase c = small_case();
  const gpf_detail::Problem problem(c.v, c.b, 2 * h_gpf);
  EXPECT_FLOAT_EQ(problem.data_radius(), h_gpf / 2);
  EXPECT_FLOAT_EQ(problem.repulsion_radius(), h_gpf);
  // Running the brute force at h_GPF (not at ours) must disagree with ours at h_GPF: the test
  // can tell the two conventions apart.
  const gpf_detail::Problem wrong(c.v, c.b, h_gpf);
  const BruteStep ref = brute_step(c.v.cast<double>(), c.b.cast<double>(), c.x.cast<double>(),
                                   c.xb.cast<double>(), 0.002, 0.02, 0.2, h_gpf);
  double worst = 0;
  for (Eigen::Index j = 0; j < c.v.cols(); ++j)
    worst = std::max(worst, std::abs(wrong.rho()[j] - ref.rho[j]));
  EXPECT_GT(worst, 0.1);
}

TEST(GpfStep, RepulsionHasNoComponentAlongTheNormal) {
  // A noisy plane z ~ 0 with normals +z (some flipped: the projection does not care).
  Rng rng(3);
  const int n = 600;
  Eigen::Matrix3Xf v(3, n), b(3, n);
  for (int i = 0; i < n; ++i) {
    v.col(i) << static_cast<float>(rng.uniform()) - 0.5f, static_cast<float>(rng.uniform()) - 0.5f,
        static_cast<float>(rng.normal(0.0, 0.02));
    b.col(i) << 0, 0, i % 3 == 0 ? -1.0f : 1.0f;
  }
  const gpf_detail::Problem problem(v, b, 0.2f);
  Eigen::Matrix3Xf x = v.leftCols(300), xb = b.leftCols(300);
  const gpf_detail::Step step = gpf_detail::em_step(problem, x, xb, 0.004, 0.02, 0.3);
  double tangential = 0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    EXPECT_EQ(step.repulsion(2, i), 0.0f) << i;
    tangential += step.repulsion.col(i).head<2>().norm();
  }
  EXPECT_GT(tangential / static_cast<double>(x.cols()), 1e-3);  // it does push, sideways
}

TEST(GpfStep, ParticleAbovePlaneMovesOntoItAlongTheNormal) {
  // Inputs exactly on a tilted plane through c with normal nrm; one particle 0.05 above it. Its
  // posteriors concentrate on the inputs near it; every t = (v_n - x).b_n = -0.05, so the data
  // term moves it by -0.05 b: onto the plane, without tangential motion (mu = 0).
  const Eigen::Vector3f nrm = Eigen::Vector3f(0.3f, -0.2f, 1.0f).normalized();
  const Eigen::Vector3f u = nrm.unitOrthogonal(), w = nrm.cross(u);
  Eigen::Matrix3Xf v(3, 41 * 41), b(3, 41 * 41);
  int k = 0;
  for (int i = 0; i < 41; ++i)
    for (int j = 0; j < 41; ++j, ++k) {
      v.col(k) =
          (static_cast<float>(i) / 40.0f - 0.5f) * u + (static_cast<float>(j) / 40.0f - 0.5f) * w;
      b.col(k) = nrm;
    }
  const gpf_detail::Problem problem(v, b, 0.3f);
  Eigen::Matrix3Xf x(3, 1), xb(3, 1);
  x.col(0) = 0.013f * u - 0.007f * w + 0.05f * nrm;
  xb.col(0) = nrm;
  const gpf_detail::Step step = gpf_detail::em_step(problem, x, xb, 1e-4, 0.02, 0.0);
  EXPECT_NEAR(step.x.col(0).dot(nrm), 0.0f, 1e-6f);
  EXPECT_NEAR((step.x.col(0) - x.col(0)).dot(u), 0.0f, 1e-6f);
  EXPECT_NEAR((step.x.col(0) - x.col(0)).dot(w), 0.0f, 1e-6f);
  // s2 of eq. 11: every residual is 0 now, so s2 falls to its floor.
  EXPECT_LE(step.s2, 1e-8);  // from 0.05^2 / 3 = 8e-4 before the move (float moments)
}

TEST(GpfStep, OmegaDiscountsAnIsolatedInputAndSparesADenseOne) {
  // Eq. 3: input n keeps the posterior mass sum_m p_mn = S_n / (S_n + c), S_n = sum_m
  // exp(-|v_n - x_m|^2 / 2 s2), c = (2 pi s2)^(3/2) omega M / ((1 - omega) N). Inputs on a grid
  // (spacing 0.01) of the plane z = 0 with a particle on each: a dense input has S about
  // 2 pi s2 / 0.01^2 = 6.3. One input 0.04 above the plane's centre is isolated: S about
  // e^-8 x 5 = 1.5e-3. As omega grows, c (1.6e-5 omega / (1 - omega) at s2 = 1e-4) overtakes
  // the isolated input's S long before a dense one's, and so the isolated input's pull on the
  // particle below it (the data term of eq. 10) fades while the plane keeps its mass.
  std::vector<Eigen::Vector3f> pts;
  for (int i = -10; i <= 10; ++i)
    for (int j = -10; j <= 10; ++j)
      pts.emplace_back(0.01f * static_cast<float>(i), 0.01f * static_cast<float>(j), 0.0f);
  const Eigen::Index m = static_cast<Eigen::Index>(pts.size());
  Eigen::Matrix3Xf v(3, m + 1), b = Eigen::Matrix3Xf::Zero(3, m + 1);
  for (Eigen::Index i = 0; i < m; ++i)
    v.col(i) = pts[static_cast<std::size_t>(i)];
  const Eigen::Index iso = m, centre = m / 2, dense = centre + 1;  // dense: beside the centre
  v.col(iso) << 0.0f, 0.0f, 0.04f;
  b.row(2).setOnes();
  const Eigen::Matrix3Xf x = v.leftCols(m), xb = b.leftCols(m);
  ASSERT_EQ(x.col(centre).norm(), 0.0f);
  const double s2 = 1e-4, h = 0.2;  // data radius h/4 = 0.05 reaches the isolated input
  const gpf_detail::Problem problem(v, b, static_cast<float>(h));
  auto mass = [](const gpf_detail::Step& st, Eigen::Index n) {
    return 1.0 - st.outlier_term / st.denominator[n];
  };
  double last_ratio = 2.0, first_pull = 0.0, last_pull = 0.0;
  for (const double omega : {0.02, 0.9, 0.99, 0.999}) {
    SCOPED_TRACE(testing::Message() << "omega " << omega);
    const gpf_detail::Step st = gpf_detail::em_step(problem, x, xb, s2, omega, 0.0);
    const BruteStep ref = brute_step(v.cast<double>(), b.cast<double>(), x.cast<double>(),
                                     xb.cast<double>(), s2, omega, 0.0, h / 2);
    // The closed form of eq. 3 for both inputs.
    for (const Eigen::Index n : {iso, dense}) {
      const double d = ref.denominator[static_cast<std::size_t>(n)];
      EXPECT_NEAR(mass(st, n), (d - ref.outlier) / d, 1e-4) << "input " << n;
    }
    const double ratio = mass(st, iso) / mass(st, dense);
    EXPECT_LT(ratio, last_ratio);
    last_ratio = ratio;
    EXPECT_GT(mass(st, dense), 0.99);
    // The isolated input's pull on the particle under it (eq. 10's data term, along +z).
    const double pull = st.data(2, centre);
    EXPECT_NEAR(pull, ref.data(2, centre), 1e-3 * std::abs(ref.data(2, centre)) + 1e-9);
    if (omega == 0.02) first_pull = pull;
    last_pull = pull;
  }
  // Both ends of the sweep, from the closed form: mass 0.9998 and 0.09 for the isolated input.
  EXPECT_GT(first_pull, 0.0);
  EXPECT_LT(last_pull, 0.2 * first_pull);
  EXPECT_LT(last_ratio, 0.2);
}

// ---------------------------------------------------------------------------------------------
// The public filter.

PointCloud sphere_with_normals(int n, float noise, std::uint64_t seed) {
  PointCloud c = fixtures::noisy_sphere(n, 1.0f, noise, seed);
  c.normals = c.positions.colwise().normalized();
  return c;
}

TEST(Gpf, DenoisesASphereAndIsThreadIndependent) {
  const PointCloud in = sphere_with_normals(4000, 0.02f, 5);
  GpfParams p;
  p.h = 0.12;
  RunContext c1(7, 1), c2(7, 2);
  const PointCloud a = gpf(in, p, c1);
  const PointCloud b = gpf(in, p, c2);
  ASSERT_EQ(a.size(), 2000);
  ASSERT_TRUE(a.has_normals());
  EXPECT_TRUE(a.positions.cwiseEqual(b.positions).all());
  GpfParams pf = p;
  pf.s2_update = "fixed";
  RunContext c3(7);
  const PointCloud f = gpf(in, pf, c3);
  std::printf("sphere radial error: input %.5f, gpf eq11 %.5f, gpf s2 fixed %.5f\n",
              fixtures::mean_radial_error(in.positions, 1.0),
              fixtures::mean_radial_error(a.positions, 1.0),
              fixtures::mean_radial_error(f.positions, 1.0));
  // With s2 held the data term averages the inputs along their exact normals: the filter
  // smooths. How eq. 11 compares with a fixed s2 is a measurement (gpf.h), not asserted.
  EXPECT_LT(fixtures::mean_radial_error(f.positions, 1.0),
            0.5 * fixtures::mean_radial_error(in.positions, 1.0));
  for (const char* phase : {"normals", "init", "e_step", "m_step"})
    EXPECT_TRUE(c1.phase_seconds().count(phase)) << phase;
  // Output normals are those of the chosen input points.
  for (Eigen::Index i = 0; i < a.size(); ++i)
    ASSERT_NEAR(a.normals.col(i).norm(), 1.0f, 1e-5f);
}

TEST(Gpf, ScaleInvariant) {
  // Lengths are in units of the bbox diagonal: a scaled and shifted input gives the scaled
  // and shifted output.
  const PointCloud in = sphere_with_normals(1500, 0.02f, 8);
  PointCloud big = in;
  big.positions = (in.positions * 1000.0f).colwise() + Eigen::Vector3f(5000, -300, 20);
  GpfParams p;
  RunContext c1(1), c2(1);
  const PointCloud a = gpf(in, p, c1);
  const PointCloud b = gpf(big, p, c2);
  const Eigen::Matrix3Xf back = (b.positions.colwise() - Eigen::Vector3f(5000, -300, 20)) / 1000.0f;
  EXPECT_LT((back - a.positions).cwiseAbs().maxCoeff(), 1e-3f);
}

TEST(Gpf, CpdUnitsScaleS2AndTheOutlierTermByTheRmsRadius) {
  // units = cpd works in CPD's normalisation (unit root-mean-square distance to the mean), diag in
  // units of the bbox diagonal. With r = rms / diag, a cpd run at s2_init s equals a diag run at
  // s2_init s r^2 whose omega' gives the same outlier term (2 pi s2)^(3/2) omega M/((1 - omega) N)
  // of eq. 3: omega' / (1 - omega') = omega / (1 - omega) / r^3.
  const PointCloud in = sphere_with_normals(1500, 0.02f, 8);
  const Eigen::Vector3d mean = in.positions.cast<double>().rowwise().mean();
  const double rms =
      std::sqrt((in.positions.cast<double>().colwise() - mean).colwise().squaredNorm().mean());
  const double r = rms / static_cast<double>(in.bbox().diagonal());
  ASSERT_LT(r, 0.5);  // the two unit systems differ by far more than the tolerance below
  GpfParams cpd;
  cpd.units = "cpd";
  cpd.omega = 0.3;
  cpd.s2_init = 0.004;
  cpd.s2_update = "fixed";
  GpfParams diag = cpd;
  diag.units = "diag";
  diag.s2_init = cpd.s2_init * r * r;
  const double odds = cpd.omega / (1.0 - cpd.omega) / (r * r * r);
  diag.omega = odds / (1.0 + odds);
  RunContext c1(1), c2(1), c3(1);
  const PointCloud a = gpf(in, cpd, c1);
  const PointCloud b = gpf(in, diag, c2);
  EXPECT_LT((a.positions - b.positions).cwiseAbs().maxCoeff(), 1e-4f);
  // Not a vacuous equality: the same parameters in diag units give another result.
  GpfParams same = cpd;
  same.units = "diag";
  const PointCloud c = gpf(in, same, c3);
  EXPECT_GT((a.positions - c.positions).cwiseAbs().maxCoeff(), 1e-3f);
}

// A plane z = 0 sampled on a grid of spacing 0.01 (normals +z), with a strip |x| < `gap`
// left empty. The largest distance from the strip's centre line (x = 0, |y| <= 0.3) to the
// nearest output point: the radius of the largest empty disc in the gap.
double gap_radius(const PointCloud& out) {
  double worst = 0;
  for (int k = -30; k <= 30; ++k) {
    const Eigen::Vector3f c(0.0f, 0.01f * static_cast<float>(k), 0.0f);
    worst = std::max(
        worst, static_cast<double>((out.positions.colwise() - c).colwise().norm().minCoeff()));
  }
  return worst;
}

PointCloud plane_with_gap(float gap) {
  std::vector<Eigen::Vector3f> pts;
  for (int i = -50; i <= 50; ++i)
    for (int j = -50; j <= 50; ++j) {
      const float x = 0.01f * static_cast<float>(i);
      if (std::abs(x) > gap - 1e-4f) pts.emplace_back(x, 0.01f * static_cast<float>(j), 0.0f);
    }
  PointCloud c;
  c.positions.resize(3, static_cast<Eigen::Index>(pts.size()));
  for (std::size_t i = 0; i < pts.size(); ++i)
    c.positions.col(static_cast<Eigen::Index>(i)) = pts[i];
  c.normals = Eigen::Matrix3Xf::Zero(3, c.positions.cols());
  c.normals.row(2).setOnes();
  return c;
}

TEST(Gpf, GapFillingClosesAGap) {
  // Section 6 (iii), Fig. 21: the widened iterations spread the particles along the surface into
  // a gap the ordinary ones leave. The gap (0.12 wide, 8 particle spacings) holds no input, so
  // only the tangential repulsion can move particles there. Measured: input 0.060, after the 5
  // ordinary iterations 0.045, with 10 gap-filling iterations at gap_scale 2: 0.015 (the
  // particles' own spacing is about 0.014; the same 10 iterations without widening: 0.018).
  const float gap = 0.06f;
  const PointCloud in = plane_with_gap(gap);
  GpfParams p;
  p.iterations = 5;
  p.mu = 0.3;
  RunContext c1(1), c2(1);
  const PointCloud open = gpf(in, p, c1);
  p.gap_iterations = 10;
  p.gap_scale = 2.0;
  const PointCloud filled = gpf(in, p, c2);
  std::printf("gap radius: input %.4f, without gap filling %.4f, with %.4f\n", gap_radius(in),
              gap_radius(open), gap_radius(filled));
  // The case has a gap that the ordinary iterations leave open ...
  ASSERT_GT(gap_radius(open), 0.6 * gap);
  // ... and gap filling closes it to about the particle spacing.
  EXPECT_LT(gap_radius(filled), 0.3 * gap);
  // The particles stay on the plane.
  EXPECT_LT(filled.positions.row(2).cwiseAbs().maxCoeff(), 1e-4f);
}

std::string error_of(const PointCloud& in, const GpfParams& p) {
  RunContext ctx(1);
  try {
    gpf(in, p, ctx);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Gpf, BadInput) {
  PointCloud in = sphere_with_normals(100, 0.0f, 1);
  PointCloud bare = in;
  bare.normals.resize(3, 0);
  std::string e = error_of(bare, {});
  EXPECT_NE(e.find("filter.gpf: the input has no normals"), std::string::npos) << e;
  EXPECT_NE(e.find("normals.pca -> normals.bilateral -> filter.gpf"), std::string::npos) << e;
  PointCloud zero = in;
  zero.normals.col(17).setZero();
  e = error_of(zero, {});
  EXPECT_NE(e.find("point 17 has zero length"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos);
  PointCloud one = in.subset({3});
  e = error_of(one, {});
  EXPECT_NE(e.find("zero diagonal"), std::string::npos) << e;
  PointCloud same = in.subset({3, 3, 3, 3});
  e = error_of(same, {});
  EXPECT_NE(e.find("zero diagonal"), std::string::npos) << e;
  GpfParams many;
  many.particles = 101;
  RunContext ctx(1);
  EXPECT_THROW(gpf(in, many, ctx), ParamError);
  EXPECT_THROW(gpf(PointCloud{}, {}, ctx), InputError);
}

// ---------------------------------------------------------------------------------------------
// normals.bilateral

// On every Highway target this CPU runs (the kernel is gpf/bilateral_normals.cpp), the one-lane
// SCALAR reference among them.
TEST(BilateralNormals, OneIterationMatchesBruteForceAndPointsStay) {
  for (const std::string& target : simd::runnable_targets()) {
    SCOPED_TRACE(target);
    simd::ScopedTarget scoped(target);
    const SmallCase c = small_case();
    PointCloud in;
    in.positions = c.v;
    in.normals = c.b;
    in.normals.col(5) *= -1.0f;  // an arbitrary sign: aligned before filtering
    BilateralNormalsParams p;
    p.h = 0.2;
    p.iterations = 1;
    RunContext ctx(1);
    const PointCloud out = bilateral_normals(in, p, ctx);
    EXPECT_TRUE(out.positions.cwiseEqual(in.positions).all());
    const double h = p.h * static_cast<double>(in.bbox().diagonal());
    const double sharp = 1.0 - std::cos(p.sigma_n * M_PI / 180.0);
    for (Eigen::Index i = 0; i < in.size(); ++i) {
      const Eigen::Vector3d ni = in.normals.col(i).cast<double>();
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (Eigen::Index j = 0; j < in.size(); ++j) {
        const double r = (in.positions.col(i) - in.positions.col(j)).cast<double>().norm();
        if (r > h) continue;
        Eigen::Vector3d nj = in.normals.col(j).cast<double>();
        if (ni.dot(nj) < 0) nj = -nj;
        const double a = (1 - ni.dot(nj)) / sharp;
        sum += std::exp(-16 * r * r / (h * h)) * std::exp(-a * a) * nj;
      }
      expect_close(out.normals.col(i), sum.normalized(), 1e-4, "normal " + std::to_string(i));
    }
    EXPECT_LT(out.normals.col(5).dot(c.b.col(5)), 0.0f);  // keeps its own sign
  }
}

TEST(BilateralNormals, PreservesACreaseBetterThanPca) {
  // Two planes meeting at a right-angle crease (the cube edge y = z = 0.5 of the unit cube's
  // faces z = 0.5 and y = 0.5), noisy: PCA blurs the normals near the crease, bilateral filtering
  // sharpens them.
  Rng rng(4);
  PointCloud in;
  const int n = 4000;
  in.positions.resize(3, n);
  Eigen::Matrix3Xf truth(3, n);
  for (int i = 0; i < n; ++i) {
    const float s = static_cast<float>(rng.uniform()), t = static_cast<float>(rng.uniform());
    const float noise = static_cast<float>(rng.normal(0.0, 0.004));
    if (i % 2) {
      in.positions.col(i) << s, t * 0.5f, 0.5f + noise;
      truth.col(i) << 0, 0, 1;
    } else {
      in.positions.col(i) << s, 0.5f + noise, t * 0.5f;
      truth.col(i) << 0, 1, 0;
    }
  }
  RunContext ctx(1);
  PcaNormalsParams pp;
  pp.orientation = "none";
  const PointCloud pca = pca_normals(in, pp, ctx);
  const PointCloud bil = bilateral_normals(pca, {}, ctx);
  auto mean_angle = [&](const Eigen::Matrix3Xf& nn) {
    double s = 0;
    for (int i = 0; i < n; ++i)
      s += std::acos(std::min(1.0f, std::abs(nn.col(i).dot(truth.col(i))))) * 180.0 / M_PI;
    return s / n;
  };
  EXPECT_LT(mean_angle(bil.normals), 0.7 * mean_angle(pca.normals))
      << "pca " << mean_angle(pca.normals) << " bilateral " << mean_angle(bil.normals);
}

TEST(BilateralNormals, BadInput) {
  RunContext ctx(1);
  PointCloud in = fixtures::noisy_sphere(50, 1.0f, 0.0f, 1);
  try {
    bilateral_normals(in, {}, ctx);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("normals.pca -> normals.bilateral"), std::string::npos);
  }
  in.normals = in.positions;
  const PointCloud one = bilateral_normals(in.subset({0}), {}, ctx);
  EXPECT_TRUE(one.normals.isApprox(in.normals.col(0).normalized()));
  EXPECT_THROW(bilateral_normals(in.subset({1, 1, 1}), {}, ctx), InputError);
}

}  // namespace
}  // namespace scanbench::algorithms
