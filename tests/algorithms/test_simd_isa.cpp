// The SIMD paths (scanbench/core/simd.h): every kernel that takes the packet width of the active
// ISA is run on every ISA this machine and build have, compared with the sse2 (4-float) path
// within stated tolerances, and checked bit-identical at 1 and 2 threads on each ISA. On a
// machine with only sse2 the comparisons are trivially equal; on this project's CI VM (AVX2, no
// AVX-512) they compare sse2 with avx2; the avx512 path is compiled only by an avx512 build.
// The distance field's packet sampler is checked per ISA in tests/metrics/test_field_sampler.cpp.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>

#include "fixtures.h"
#include "lop/projection_kernels.h"
#include "mixtures/hem_internal.h"
#include "scanbench/algorithms/gpf/bilateral_normals.h"
#include "scanbench/algorithms/lop/clop.h"
#include "scanbench/algorithms/lop/csw.h"
#include "scanbench/algorithms/lop/lop.h"
#include "scanbench/algorithms/mixtures/hem.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/simd.h"
#include "scanbench/scanner/scanner.h"
#include "scanbench/scanner/throughput.h"
#include "spatial/neighbor_grid.h"

namespace scanbench::algorithms {
namespace {

using simd::Isa;

bool same_bits(const Eigen::Matrix3Xf& a, const Eigen::Matrix3Xf& b) {
  return a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(float) * static_cast<std::size_t>(a.size())) == 0;
}

// Largest |a - b| over all coordinates.
double max_diff(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

TEST(Simd, NamesWidthsAndAvailability) {
  EXPECT_EQ(simd::lanes(Isa::sse2), 4);
  EXPECT_EQ(simd::lanes(Isa::avx2), 8);
  EXPECT_EQ(simd::lanes(Isa::avx512), 16);
  for (Isa isa : {Isa::sse2, Isa::avx2, Isa::avx512})
    EXPECT_EQ(simd::parse(simd::name(isa), "t"), isa);
  EXPECT_THROW(simd::parse("avx3", "SCANBENCH_ISA"), ParamError);
  const auto av = simd::available();
  ASSERT_FALSE(av.empty());
  EXPECT_EQ(av.front(), Isa::sse2);
  // Without SCANBENCH_ISA the widest available path runs.
  if (std::getenv("SCANBENCH_ISA") == nullptr) {
    EXPECT_EQ(simd::active(), av.back());
  }
  EXPECT_LE(static_cast<int>(av.back()), static_cast<int>(simd::compiled()));
}

TEST(Simd, AcceptsEveryAvailableIsaAndRefusesTheOthers) {
  // Every path is checked either way: an available one is selected (and the previous one
  // restored), one this machine or build lacks is refused naming it, leaving the active path.
  const Isa before = simd::active();
  const auto av = simd::available();
  for (Isa isa : {Isa::sse2, Isa::avx2, Isa::avx512}) {
    SCOPED_TRACE(simd::name(isa));
    if (std::find(av.begin(), av.end(), isa) != av.end()) {
      EXPECT_NO_THROW(simd::select(isa));
      EXPECT_EQ(simd::active(), isa);
      simd::select(before);
      continue;
    }
    try {
      simd::select(isa);
      ADD_FAILURE() << simd::name(isa) << " was accepted";
    } catch (const ParamError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string(simd::name(isa))), std::string::npos)
          << e.what();
    }
    EXPECT_EQ(simd::active(), before);
  }
  EXPECT_EQ(simd::active(), before);
}

class SimdKernels : public ::testing::Test {
 protected:
  SimdKernels() : cloud_(fixtures::noisy_sphere(4000, 1.0f, 0.01f, 21)) {}
  PointCloud cloud_;
};

// The grid kernels of LOP/WLOP/CLOP (attraction, L2 mean, repulsion, density): each ISA against
// sse2. Tolerance: 2e-5 h on the moved positions (float sums of a few hundred terms in another
// order differ by a few ulp of the partial sums) and 1e-5 relative on the densities.
TEST_F(SimdKernels, GridKernelsAgreeWithSse2) {
  const float h = 0.15f, cutoff = 0.075f;
  const Eigen::Matrix3Xf& p = cloud_.positions;
  const Eigen::Matrix3Xf q = p.leftCols(1500) * 1.003f;
  struct Out {
    Eigen::Matrix3Xf att, l2, rep;
    Eigen::VectorXf dens;
  };
  auto run = [&](Isa isa, int threads) {
    simd::ScopedIsa scoped(isa);
    RunContext ctx(1, threads);
    Out o;
    detail::NeighborGrid pg = kernels::query_grid(p, h);
    o.att = kernels::attractions(q, pg, h);
    o.l2 = kernels::l2_means(q, pg, h);
    detail::NeighborGrid qg = kernels::query_grid(q, cutoff);
    o.dens = kernels::density_weights(qg, q, h, cutoff);
    qg.set_weights(o.dens);
    o.rep = kernels::repulsions(q, qg, h, cutoff);
    return o;
  };
  const Out ref = run(Isa::sse2, 1);
  for (Isa isa : simd::available()) {
    SCOPED_TRACE(std::string(simd::name(isa)));
    const Out a = run(isa, 1), b = run(isa, 2);
    EXPECT_TRUE(same_bits(a.att, b.att));
    EXPECT_TRUE(same_bits(a.l2, b.l2));
    EXPECT_TRUE(same_bits(a.rep, b.rep));
    EXPECT_EQ(0, std::memcmp(a.dens.data(), b.dens.data(), sizeof(float) * a.dens.size()));
    EXPECT_LT(max_diff(a.att, ref.att), 2e-5 * h);
    EXPECT_LT(max_diff(a.l2, ref.l2), 2e-5 * h);
    EXPECT_LT(max_diff(a.rep, ref.rep), 2e-5 * h);
    EXPECT_LT(((a.dens - ref.dens).array().abs() / ref.dens.array()).maxCoeff(), 1e-5);
    // The kernels moved the particles (the comparison is not of unmoved inputs).
    EXPECT_GT(max_diff(a.att, q), 1e-3 * h);
  }
}

// WLOP end to end (10 iterations of the kernels above): bit-identical at 1 and 2 threads per
// ISA, within 1e-4 h of sse2 (iterations carry the rounding differences forward).
TEST_F(SimdKernels, WlopAgreesWithSse2) {
  LopParams prm;
  prm.h = 0.08;
  prm.particles = 0.3;
  prm.iterations = 10;
  auto run = [&](Isa isa, int threads) {
    simd::ScopedIsa scoped(isa);
    RunContext ctx(5, threads);
    return wlop(cloud_, prm, ctx).positions;
  };
  const double h = prm.h * cloud_.bbox().diagonal();
  const Eigen::Matrix3Xf ref = run(Isa::sse2, 1);
  for (Isa isa : simd::available()) {
    SCOPED_TRACE(std::string(simd::name(isa)));
    const Eigen::Matrix3Xf a = run(isa, 1);
    EXPECT_TRUE(same_bits(a, run(isa, 2)));
    EXPECT_LT(max_diff(a, ref), 1e-4 * h);
  }
}

// CLOP (HEM density pass, continuous attraction eq. 22/24, repulsion): per ISA bit-identical at
// 1 and 2 threads; against sse2 the mixture (HEM's density pass sums in another order: its
// fixed-point sums may differ in the last bits) and the particles within 1e-3 h.
TEST_F(SimdKernels, ClopAgreesWithSse2) {
  ClopParams prm;
  prm.particles = 0.3;
  auto run = [&](Isa isa, int threads) {
    simd::ScopedIsa scoped(isa);
    RunContext ctx(7, threads);
    return clop(cloud_, prm, ctx);
  };
  const double h = prm.h * cloud_.bbox().diagonal();
  const AlgorithmOutput ref = run(Isa::sse2, 1);
  ASSERT_TRUE(ref.mixture.has_value());
  for (Isa isa : simd::available()) {
    SCOPED_TRACE(std::string(simd::name(isa)));
    const AlgorithmOutput a = run(isa, 1), b = run(isa, 2);
    EXPECT_TRUE(same_bits(a.points.positions, b.points.positions));
    ASSERT_EQ(a.mixture->size(), ref.mixture->size());
    EXPECT_LT(max_diff(a.mixture->means, ref.mixture->means), 1e-3 * h);
    EXPECT_LT(max_diff(a.points.positions, ref.points.positions), 1e-3 * h);
  }
}

// One HEM level (eq. 9-11 in double packets of the active ISA: D_KL and log L_is of every
// candidate child, one candidate per lane) from one fixed level-0 mixture: per ISA bit-identical
// at 1 and 2 threads, and against sse2 within 1e-12 relative on every weight, mean and covariance
// (each lane runs the same double operations; only the compiler's fused multiply-adds could
// differ between widths). Two levels, the second from the first's merged components.
TEST_F(SimdKernels, HemLevelAgreesWithSse2) {
  HemParams prm;
  prm.alpha = 2.0;
  const double diag = cloud_.bbox().diagonal();
  const double h = 0.04 * diag, floor = (1e-7 * diag) * (1e-7 * diag);
  const double n_points = static_cast<double>(cloud_.size());
  hem_detail::Components level0;
  {
    simd::ScopedIsa scoped(Isa::sse2);
    level0 = hem_detail::initial_mixture(cloud_.positions, prm, h, floor);
  }
  auto run = [&](Isa isa, int threads) {
    simd::ScopedIsa scoped(isa);
    RunContext ctx(1, threads);  // sets the thread count of the TBB loops
    hem_detail::Components l1 = hem_detail::cluster_level(level0, prm, 101, n_points, floor);
    return std::make_pair(l1, hem_detail::cluster_level(l1, prm, 102, n_points, floor));
  };
  auto rel = [](double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-300); };
  auto worst = [&](const hem_detail::Components& a, const hem_detail::Components& b) {
    double w = 0.0;
    for (std::size_t k = 0; k < a.size(); ++k) {
      w = std::max(w, rel(a[k].w, b[k].w));
      w = std::max(w, (a[k].mu - b[k].mu).norm() / h);
      w = std::max(w, (a[k].cov - b[k].cov).norm() / b[k].cov.norm());
    }
    return w;
  };
  auto same = [](const hem_detail::Components& a, const hem_detail::Components& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t k = 0; k < a.size(); ++k)
      if (a[k].w != b[k].w || a[k].mu != b[k].mu || a[k].cov != b[k].cov) return false;
    return true;
  };
  const auto ref = run(Isa::sse2, 1);
  // The levels merged (the comparison is not of unchanged components).
  ASSERT_LT(ref.first.size(), level0.size() * 3 / 4);
  ASSERT_LT(ref.second.size(), ref.first.size());
  for (Isa isa : simd::available()) {
    SCOPED_TRACE(std::string(simd::name(isa)));
    const auto a = run(isa, 1), b = run(isa, 2);
    EXPECT_TRUE(same(a.first, b.first));
    EXPECT_TRUE(same(a.second, b.second));
    ASSERT_EQ(a.first.size(), ref.first.size());
    ASSERT_EQ(a.second.size(), ref.second.size());
    EXPECT_LT(worst(a.first, ref.first), 1e-12);
    EXPECT_LT(worst(a.second, ref.second), 1e-12);
  }
}

// CLOP's projection alone on one fixed mixture: per ISA against sse2 within 2e-5 h per step.
TEST_F(SimdKernels, ClopProjectionAgreesWithSse2) {
  ClopParams prm;
  prm.iterations = 1;  // the eq. 24 initial projection only
  const double h = prm.h * cloud_.bbox().diagonal();
  RunContext ctx0(3);
  const AlgorithmOutput base = clop(cloud_, prm, ctx0);
  const GaussianMixture& m = *base.mixture;
  const Eigen::Matrix3Xf q0 = cloud_.positions.leftCols(2000);
  for (const int iterations : {1, 2}) {
    ClopParams pp = prm;
    pp.iterations = iterations;
    pp.mu = 0.0;  // attraction only (eq. 24, then eq. 22)
    auto run = [&](Isa isa) {
      simd::ScopedIsa scoped(isa);
      RunContext ctx(3);
      Eigen::Matrix3Xf q = q0;
      clop_project(m, q, pp, h, ctx);
      return q;
    };
    const Eigen::Matrix3Xf ref = run(Isa::sse2);
    EXPECT_GT(max_diff(ref, q0), 1e-3 * h);
    for (Isa isa : simd::available()) {
      SCOPED_TRACE(std::string(simd::name(isa)) + " iterations " + std::to_string(iterations));
      EXPECT_LT(max_diff(run(isa), ref), 2e-5 * h);
    }
  }
}

// CSW (section 9.3, eq. 31-34; packet spatial weights, arccos, sines): per ISA bit-identical at 1
// and 2 threads; against sse2 within 2e-5 rad per normal (float sums over a few hundred
// components in another order, carried through 10 Weiszfeld steps). The steps move the normals
// far more than that from their PCA start.
TEST_F(SimdKernels, CswAgreesWithSse2) {
  ClopParams prm;
  prm.iterations = 3;
  RunContext ctx0(3);
  const GaussianMixture m = *clop(cloud_, prm, ctx0).mixture;
  const Eigen::Matrix3Xf q = cloud_.positions.leftCols(1500);
  const double nh = 0.05 * cloud_.bbox().diagonal();
  auto run = [&](Isa isa, int threads, int iterations) {
    simd::ScopedIsa scoped(isa);
    RunContext ctx(3, threads);
    return csw_normals(m, q, Eigen::Matrix3Xf(), nh, iterations, ctx);
  };
  auto max_angle = [](const Eigen::Matrix3Xf& a, const Eigen::Matrix3Xf& b) {
    double worst = 0.0;
    for (Eigen::Index i = 0; i < a.cols(); ++i) {
      const double c =
          std::abs(a.col(i).cast<double>().normalized().dot(b.col(i).cast<double>().normalized()));
      worst = std::max(worst, std::acos(std::min(1.0, c)));
    }
    return worst;
  };
  const Eigen::Matrix3Xf ref = run(Isa::sse2, 1, 10);
  EXPECT_GT(max_angle(ref, run(Isa::sse2, 1, 0)), 1e-2);
  for (Isa isa : simd::available()) {
    SCOPED_TRACE(std::string(simd::name(isa)));
    const Eigen::Matrix3Xf a = run(isa, 1, 10);
    EXPECT_TRUE(same_bits(a, run(isa, 2, 10)));
    EXPECT_LT(max_angle(a, ref), 2e-5);
  }
}

// normals.bilateral (GPF sec. 4.1's normal filter, Huang et al. 2013) sums its neighbours in
// packets of the active width: per ISA bit-identical at 1 and 2 threads, within 2e-5 rad of sse2.
// The input normals are the sphere's radial directions with every third one flipped and noise
// added, so that the sign alignment and both kernels are exercised.
TEST_F(SimdKernels, BilateralNormalsAgreeWithSse2) {
  PointCloud in = cloud_;
  in.normals = in.positions.colwise().normalized();
  Rng rng(5);
  for (Eigen::Index i = 0; i < in.size(); ++i) {
    Eigen::Vector3f n =
        in.normals.col(i) + 0.2f * Eigen::Vector3f(static_cast<float>(rng.normal()),
                                                   static_cast<float>(rng.normal()),
                                                   static_cast<float>(rng.normal()));
    in.normals.col(i) = (i % 3 == 0 ? -1.0f : 1.0f) * n.normalized();
  }
  BilateralNormalsParams prm;
  prm.iterations = 3;
  auto run = [&](Isa isa, int threads) {
    simd::ScopedIsa scoped(isa);
    RunContext ctx(3, threads);
    return bilateral_normals(in, prm, ctx).normals;
  };
  const Eigen::Matrix3Xf ref = run(Isa::sse2, 1);
  for (Isa isa : simd::available()) {
    SCOPED_TRACE(std::string(simd::name(isa)));
    const Eigen::Matrix3Xf a = run(isa, 1);
    EXPECT_TRUE(same_bits(a, run(isa, 2)));
    double worst = 0.0;
    for (Eigen::Index i = 0; i < a.cols(); ++i) {  // the angle, well conditioned near 0
      const Eigen::Vector3d u = a.col(i).cast<double>(), v = ref.col(i).cast<double>();
      worst = std::max(worst, std::atan2(u.cross(v).norm(), u.dot(v)));
    }
    EXPECT_LT(worst, 2e-5);
  }
}

// normals.bilateral is a Highway kernel (gpf/bilateral_normals.cpp): every target this CPU runs
// is bit-identical at 1 and 2 threads and within 2e-5 rad of the one-lane SCALAR reference.
TEST_F(SimdKernels, BilateralNormalsAgreeWithTheScalarTarget) {
  PointCloud in = cloud_;
  in.normals = in.positions.colwise().normalized();
  Rng rng(5);
  for (Eigen::Index i = 0; i < in.size(); ++i) {
    Eigen::Vector3f n =
        in.normals.col(i) + 0.2f * Eigen::Vector3f(static_cast<float>(rng.normal()),
                                                   static_cast<float>(rng.normal()),
                                                   static_cast<float>(rng.normal()));
    in.normals.col(i) = (i % 3 == 0 ? -1.0f : 1.0f) * n.normalized();
  }
  BilateralNormalsParams prm;
  prm.iterations = 3;
  auto run = [&](const std::string& target, int threads) {
    simd::ScopedTarget scoped(target);
    RunContext ctx(3, threads);
    return bilateral_normals(in, prm, ctx).normals;
  };
  const Eigen::Matrix3Xf ref = run(simd::scalar_target(), 1);
  for (const std::string& target : simd::runnable_targets()) {
    SCOPED_TRACE(target);
    const Eigen::Matrix3Xf a = run(target, 1);
    EXPECT_TRUE(same_bits(a, run(target, 2)));
    double worst = 0.0;
    for (Eigen::Index i = 0; i < a.cols(); ++i) {  // the angle, well conditioned near 0
      const Eigen::Vector3d u = a.col(i).cast<double>(), v = ref.col(i).cast<double>();
      worst = std::max(worst, std::atan2(u.cross(v).norm(), u.dot(v)));
    }
    EXPECT_LT(worst, 2e-5);
  }
}

// The scanner's ray directions are a Highway kernel (scanner-sim/src/ray_directions.cpp) with the
// same IEEE operations in every lane of every target: the scans are bit-identical on every ISA
// (positions and every property).
TEST(SimdScanner, ScansAreIdenticalOnEveryIsa) {
  scanner::ScannerParams p = scanner::all_artifacts_params();
  p.resolution = 64;
  p.views = 3;
  const TriangleMesh mesh = scanner::uv_sphere(2000);
  auto run = [&](Isa isa) {
    simd::ScopedIsa scoped(isa);
    RunContext ctx(11);
    return scanner::scan(mesh, p, ctx).cloud;
  };
  const PointCloud ref = run(Isa::sse2);
  ASSERT_GT(ref.size(), 1000);
  for (Isa isa : simd::available()) {
    SCOPED_TRACE(std::string(simd::name(isa)));
    const PointCloud c = run(isa);
    EXPECT_TRUE(same_bits(c.positions, ref.positions));
    for (const auto& [name, values] : ref.properties) {
      ASSERT_TRUE(c.properties.count(name)) << name;
      EXPECT_EQ(0, std::memcmp(values.data(), c.properties.at(name).data(),
                               sizeof(float) * values.size()))
          << name;
    }
  }
}

}  // namespace
}  // namespace scanbench::algorithms
