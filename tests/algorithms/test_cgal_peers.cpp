// The CGAL peers run, keep their contracts, move noisy points toward the surface, and the WLOP
// adapter converts the kernel width (same kernel => same neighbourhood scale as resample.wlop).
#include <gtest/gtest.h>

#include <cmath>

#include "scanbench/algorithms/peers/cgal_peers.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {
namespace {

PointCloud noisy_sphere(int n, float sigma, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud c;
  c.positions.resize(3, n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3f d(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                      static_cast<float>(rng.normal()));
    c.positions.col(i) = d.normalized() * (1.0f + static_cast<float>(rng.normal(0.0, sigma)));
  }
  return c;
}

double mean_radial_error(const Eigen::Matrix3Xf& p) {
  double s = 0.0;
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    s += std::abs(static_cast<double>(p.col(i).norm()) - 1.0);
  return s / static_cast<double>(p.cols());
}

class CgalPeers : public ::testing::Test {
 protected:
  void SetUp() override { cloud_ = noisy_sphere(5000, 0.015f, 31); }
  PointCloud cloud_;
};

TEST_F(CgalPeers, WlopMovesParticlesTowardTheSurface) {
  CgalWlopParams p;
  p.h = 0.1;
  p.particles = 0.25;
  RunContext ctx(3);
  const PointCloud out = cgal_wlop(cloud_, p, ctx);
  EXPECT_EQ(out.size(), 1250);
  EXPECT_LT(mean_radial_error(out.positions), 0.7 * mean_radial_error(cloud_.positions));
  EXPECT_TRUE(ctx.phase_seconds().count("cgal"));
}

TEST_F(CgalPeers, WlopIsReproducibleForOneSeedAndDependsOnIt) {
  CgalWlopParams p;
  p.h = 0.1;
  p.particles = 0.2;
  p.iterations = 3;
  PointCloud a, b, c;
  {
    RunContext ctx(3, 1);
    a = cgal_wlop(cloud_, p, ctx);
  }
  {
    RunContext ctx(3, 2);
    b = cgal_wlop(cloud_, p, ctx);
  }
  {
    RunContext ctx(4);
    c = cgal_wlop(cloud_, p, ctx);
  }
  EXPECT_TRUE(a.positions == b.positions);
  EXPECT_FALSE(a.positions == c.positions);
}

TEST_F(CgalPeers, BilateralAndJetMoveEveryPointTowardTheSurface) {
  const double before = mean_radial_error(cloud_.positions);
  RunContext ctx(1);
  const PointCloud bil = cgal_bilateral(cloud_, CgalBilateralParams{}, ctx);
  ASSERT_EQ(bil.size(), cloud_.size());
  ASSERT_TRUE(bil.has_normals());
  EXPECT_LT(mean_radial_error(bil.positions), 0.7 * before);
  const PointCloud jet = cgal_jet(cloud_, CgalJetParams{}, ctx);
  ASSERT_EQ(jet.size(), cloud_.size());
  EXPECT_LT(mean_radial_error(jet.positions), 0.7 * before);
}

TEST_F(CgalPeers, BadInputAndParametersThrowTypedErrors) {
  RunContext ctx(1);
  EXPECT_THROW(cgal_wlop(PointCloud{}, CgalWlopParams{}, ctx), InputError);
  EXPECT_THROW(cgal_bilateral(PointCloud{}, CgalBilateralParams{}, ctx), InputError);
  EXPECT_THROW(cgal_jet(noisy_sphere(10, 0.0f, 1), CgalJetParams{}, ctx), InputError);
  CgalJetParams jet;
  jet.degree_monge = 3;
  EXPECT_THROW(cgal_jet(cloud_, jet, ctx), ParamError);
  jet = CgalJetParams{};
  jet.degree_fitting = 4;
  jet.k = 10;
  EXPECT_THROW(cgal_jet(cloud_, jet, ctx), ParamError);
  CgalWlopParams wl;
  wl.particles = 1e-6;
  EXPECT_THROW(cgal_wlop(cloud_, wl, ctx), ParamError);
  EXPECT_THROW(params_from_json<CgalWlopParams>(Json{{"particles", 2}}, "peer.cgal_wlop"),
               ParamError);
}

}  // namespace
}  // namespace scanbench::algorithms
