// normals.csw: on a noisy cube the continuous spherical Weiszfeld step lowers the normal error of
// PCA near the edges (where L2 fits round the normals off), keeps flat regions exact, and is
// deterministic across thread counts.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "scanbench/algorithms/lop/csw.h"
#include "scanbench/algorithms/lop/pca_normals.h"
#include "scanbench/algorithms/mixtures/hem.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {
namespace {

struct Cube {
  PointCloud cloud;
  Eigen::Matrix3Xf true_normals;
};

// n points uniform on the surface of [-1, 1]^3 with isotropic N(0, sigma) noise.
Cube noisy_cube(int n, float sigma, std::uint64_t seed) {
  Rng rng(seed);
  Cube c;
  c.cloud.positions.resize(3, n);
  c.true_normals.resize(3, n);
  for (int i = 0; i < n; ++i) {
    const int face = static_cast<int>(rng.below(6));
    const int axis = face / 2;
    const float sign = face % 2 ? 1.0f : -1.0f;
    Eigen::Vector3f p;
    for (int d = 0; d < 3; ++d)
      p(d) = static_cast<float>(rng.uniform(-1.0, 1.0));
    p(axis) = sign;
    Eigen::Vector3f noise(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                          static_cast<float>(rng.normal()));
    c.cloud.positions.col(i) = p + sigma * noise;
    c.true_normals.col(i) = Eigen::Vector3f::Unit(axis) * sign;
  }
  return c;
}

// The cloud with the mixture of mixture.hem (kernel width h of its density weights): the input of
// normals.csw, as the chain mixture.hem -> normals.csw hands it over.
StageData with_hem(const PointCloud& cloud, double h, RunContext& ctx) {
  HemParams hp;
  hp.h = h;
  StageData d = cloud;
  d.mixture = hem(cloud, hp, ctx).mixture;
  return d;
}

// Mean unoriented angle (degrees) over points within `band` of an edge (edge = true) or farther.
double mean_error(const Cube& c, const Eigen::Matrix3Xf& normals, float band, bool edge) {
  double sum = 0.0;
  int count = 0;
  for (Eigen::Index i = 0; i < normals.cols(); ++i) {
    const Eigen::Vector3f a = c.cloud.positions.col(i).cwiseAbs();
    int near_faces = 0;
    for (int d = 0; d < 3; ++d)
      if (a(d) > 1.0f - band) ++near_faces;
    if ((near_faces >= 2) != edge) continue;
    const double cosv = std::min(
        1.0, std::abs(static_cast<double>(normals.col(i).normalized().dot(c.true_normals.col(i)))));
    sum += std::acos(cosv) * 180.0 / M_PI;
    ++count;
  }
  return sum / std::max(count, 1);
}

TEST(Csw, LowersPcaNormalErrorNearCubeEdges) {
  const Cube cube = noisy_cube(12000, 0.004f, 3);
  RunContext ctx(1);
  PcaNormalsParams pp;
  pp.k = 24;
  PointCloud with_pca = pca_normals(cube.cloud, pp, ctx);
  const double pca_edge = mean_error(cube, with_pca.normals, 0.1f, true);

  CswParams p;
  p.resample = false;
  p.normal_h = 0.04;
  const PointCloud out = csw(with_hem(with_pca, 0.02, ctx), p, ctx);
  ASSERT_EQ(out.size(), cube.cloud.size());
  ASSERT_EQ(out.normals.cols(), cube.cloud.size());
  const double csw_edge = mean_error(cube, out.normals, 0.1f, true);
  const double csw_flat = mean_error(cube, out.normals, 0.1f, false);
  const double pca_flat = mean_error(cube, with_pca.normals, 0.1f, false);
  std::printf("edge band: PCA %.2f deg, CSW %.2f deg; flat: PCA %.2f, CSW %.2f\n", pca_edge,
              csw_edge, pca_flat, csw_flat);
  // Measured (12K points): PCA ~23 deg, CSW ~17 deg in the band; the HEM level-0 axes are
  // themselves PCA axes over the init radius, which bounds what the median can recover.
  EXPECT_LT(csw_edge, 0.85 * pca_edge);
  EXPECT_LT(csw_flat, pca_flat + 0.5);
  // Orientation follows the input normals.
  for (Eigen::Index i = 0; i < out.size(); ++i)
    ASSERT_GE(out.normals.col(i).dot(with_pca.normals.col(i)), 0.0f);
}

TEST(Csw, ContinuousPcaStartAndResampledParticles) {
  const Cube cube = noisy_cube(12000, 0.004f, 5);
  RunContext ctx(2);
  CswParams p;  // resample = true: normals for the CLOP particles
  p.h = 0.04;
  p.normal_h = 0.04;
  const PointCloud out = csw(with_hem(cube.cloud, 0.04, ctx), p, ctx);
  ASSERT_EQ(out.size(), 6000);
  ASSERT_EQ(out.normals.cols(), 6000);
  // On the faces' interiors every particle normal is close to the face normal.
  double sum = 0.0;
  int count = 0;
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    const Eigen::Vector3f q = out.positions.col(i);
    const Eigen::Vector3f a = q.cwiseAbs();
    Eigen::Index axis;
    a.maxCoeff(&axis);
    int near_faces = 0;
    for (int d = 0; d < 3; ++d)
      if (a(d) > 0.85f) ++near_faces;
    if (near_faces != 1) continue;
    sum += std::acos(std::min(1.0f, std::abs(out.normals(axis, i)))) * 180.0 / M_PI;
    ++count;
  }
  ASSERT_GT(count, 1000);
  EXPECT_LT(sum / count, 2.0);
}

TEST(Csw, IdenticalAcrossThreadCounts) {
  const Cube cube = noisy_cube(6000, 0.004f, 7);
  CswParams p;
  p.h = 0.05;
  Eigen::Matrix3Xf a, b;
  {
    RunContext ctx(9, 1);
    a = csw(with_hem(cube.cloud, 0.05, ctx), p, ctx).normals;
  }
  {
    RunContext ctx(9, 2);
    b = csw(with_hem(cube.cloud, 0.05, ctx), p, ctx).normals;
  }
  ASSERT_EQ(a.cols(), b.cols());
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), sizeof(float) * 3 * a.cols()));
}

TEST(Csw, BadInputThrows) {
  CswParams p;
  RunContext ctx(1);
  EXPECT_THROW(csw(StageData(PointCloud{}), p, ctx), InputError);
  // Points without the mixture of a preceding mixture.hem: the message names the chain.
  const Cube cube = noisy_cube(100, 0.0f, 1);
  try {
    (void)csw(StageData(cube.cloud), p, ctx);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mixture.hem -> normals.csw"), std::string::npos)
        << e.what();
  }
  GaussianMixture m;
  m.resize(1);
  m.weights(0) = 1.0f;
  m.means.col(0).setZero();
  m.set_covariance(0, Eigen::Matrix3f::Identity());
  EXPECT_THROW(csw_normals(m, Eigen::Matrix3Xf::Zero(3, 2), Eigen::Matrix3Xf(), 0.1, 3, ctx),
               InputError);  // no normal axes
  EXPECT_THROW(params_from_json<CswParams>(Json{{"csw_iterations", -1}}, "t"), ParamError);
  // The HEM parameters belong to mixture.hem now.
  EXPECT_THROW(params_from_json<CswParams>(Json{{"alpha", 2.0}}, "t"), ParamError);
}

// The registered chain mixture.hem -> normals.csw gives what the functions give, and the
// registered normals.csw refuses points without a mixture.
TEST(Csw, RegisteredChainMatchesTheFunctions) {
  const Cube cube = noisy_cube(3000, 0.004f, 11);
  Eigen::Matrix3Xf direct;
  {
    // In the chain, normals.csw gets the scan's points (carried past mixture.hem) and the mixture.
    RunContext ctx(4);
    HemParams hp;
    hp.h = 0.05;
    StageData points_and_mixture = cube.cloud;
    points_and_mixture.mixture = hem(cube.cloud, hp, ctx).mixture;
    CswParams p;
    p.h = 0.05;
    direct = csw(points_and_mixture, p, ctx).normals;
  }
  RunContext ctx(4);
  const auto& hem_step = registry().at("mixture.hem").fn;
  const auto& csw_step = registry().at("normals.csw").fn;
  const StageData mixed = hem_step(StageData(cube.cloud), Json{{"h", 0.05}}, ctx);
  const StageData out = csw_step(mixed, Json{{"h", 0.05}}, ctx);
  ASSERT_TRUE(out.mixture.has_value());  // carried through from mixture.hem
  ASSERT_EQ(out.points.normals.cols(), direct.cols());
  EXPECT_EQ(
      0, std::memcmp(out.points.normals.data(), direct.data(), sizeof(float) * 3 * direct.cols()));
  EXPECT_THROW(csw_step(StageData(cube.cloud), Json::object(), ctx), InputError);
}

}  // namespace
}  // namespace scanbench::algorithms
