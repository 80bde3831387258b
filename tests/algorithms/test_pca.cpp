// normals.pca against analytic normals (plane, sphere) and its orientation rules.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "scanbench/algorithms/lop/pca_normals.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {
namespace {

PointCloud plane(int n, const Eigen::Vector3f& normal, std::uint64_t seed) {
  // Points on the plane n.x = 0.25 (uniform in a square of its basis).
  Rng rng(seed);
  const Eigen::Vector3f nn = normal.normalized();
  const Eigen::Vector3f u = nn.unitOrthogonal();
  const Eigen::Vector3f v = nn.cross(u);
  PointCloud c;
  c.positions.resize(3, n);
  for (int i = 0; i < n; ++i) {
    c.positions.col(i) = 0.25f * nn + static_cast<float>(rng.uniform(-1, 1)) * u +
                         static_cast<float>(rng.uniform(-1, 1)) * v;
  }
  return c;
}

PointCloud sphere(int n, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud c;
  c.positions.resize(3, n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3f d(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                      static_cast<float>(rng.normal()));
    c.positions.col(i) = d.normalized() + Eigen::Vector3f(0.3f, -0.2f, 0.1f);
  }
  return c;
}

TEST(PcaNormals, PlaneMatchesAnalyticNormal) {
  const Eigen::Vector3f n0 = Eigen::Vector3f(-0.3f, -0.2f, 1.0f).normalized();
  const PointCloud c = plane(2000, n0, 1);
  PcaNormalsParams p;
  p.orientation = "none";
  RunContext ctx(1);
  const PointCloud out = pca_normals(c, p, ctx);
  ASSERT_TRUE(out.has_normals());
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    EXPECT_NEAR(out.normals.col(i).norm(), 1.0f, 1e-5f);
    EXPECT_GT(std::abs(out.normals.col(i).dot(n0)), 0.99999f) << "point " << i;
  }
}

TEST(PcaNormals, SphereNormalsAreRadialAndOutward) {
  const PointCloud c = sphere(4000, 2);
  const Eigen::Vector3f centre(0.3f, -0.2f, 0.1f);
  for (const char* mode : {"auto", "propagate", "centroid"}) {
    PcaNormalsParams p;
    p.orientation = mode;
    RunContext ctx(1);
    const PointCloud out = pca_normals(c, p, ctx);
    double worst = 1.0;
    for (Eigen::Index i = 0; i < out.size(); ++i) {
      const Eigen::Vector3f radial = (c.positions.col(i) - centre).normalized();
      worst = std::min<double>(worst, out.normals.col(i).dot(radial));
    }
    // k = 16 neighbours on 4000 samples of the unit sphere: curvature tilts the fit slightly.
    EXPECT_GT(worst, 0.99) << mode;
  }
}

TEST(PcaNormals, OrientedTowardTheSensor) {
  PointCloud c = plane(1000, Eigen::Vector3f::UnitZ(), 3);
  c.scan_ids = Eigen::VectorXi::Zero(c.size());
  c.scan_ids.tail(500).setOnes();
  c.sensor_origins.resize(3, 2);
  c.sensor_origins.col(0) = Eigen::Vector3f(0, 0, 5);
  c.sensor_origins.col(1) = Eigen::Vector3f(0, 0, -5);
  for (const char* mode : {"auto", "sensor"}) {
    PcaNormalsParams p;
    p.orientation = mode;
    RunContext ctx(1);
    const PointCloud out = pca_normals(c, p, ctx);
    for (Eigen::Index i = 0; i < out.size(); ++i) {
      const float expected = c.scan_ids[i] == 0 ? 1.0f : -1.0f;
      EXPECT_NEAR(out.normals(2, i), expected, 1e-5f) << mode << " point " << i;
    }
    EXPECT_TRUE(out.scan_ids == c.scan_ids);  // attributes kept
  }
}

TEST(PcaNormals, DeterministicAcrossThreadCounts) {
  const PointCloud c = sphere(3000, 4);
  PcaNormalsParams p;
  PointCloud a, b;
  {
    RunContext ctx(1, 1);
    a = pca_normals(c, p, ctx);
  }
  {
    RunContext ctx(1, 2);
    b = pca_normals(c, p, ctx);
  }
  EXPECT_TRUE(a.normals == b.normals);
}

TEST(PcaNormals, BadInputThrowsTypedErrors) {
  RunContext ctx(1);
  PcaNormalsParams p;
  PointCloud two;
  two.positions = Eigen::Matrix3Xf::Random(3, 2);
  EXPECT_THROW(pca_normals(two, p, ctx), InputError);
  p.orientation = "sensor";
  EXPECT_THROW(pca_normals(sphere(100, 1), p, ctx), InputError);
  Json bad = {{"orientation", "up"}};
  EXPECT_THROW(params_from_json<PcaNormalsParams>(bad, "normals.pca"), ParamError);
  bad = {{"k", 2}};
  EXPECT_THROW(params_from_json<PcaNormalsParams>(bad, "normals.pca"), ParamError);
}

}  // namespace
}  // namespace scanbench::algorithms
