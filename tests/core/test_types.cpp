#include <gtest/gtest.h>

#include <cmath>

#include "scanbench/core/errors.h"
#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench {
namespace {

TriangleMesh tetrahedron() {
  TriangleMesh m;
  m.vertices.resize(3, 4);
  m.vertices << 0, 1, 0, 0,  //
      0, 0, 1, 0,            //
      0, 0, 0, 1;
  m.faces.resize(3, 4);
  m.faces << 0, 0, 0, 1,  //
      2, 1, 3, 2,         //
      1, 3, 2, 3;
  return m;
}

TEST(TriangleMesh, ClosedOrientedVolume) {
  const TriangleMesh m = tetrahedron();
  EXPECT_NO_THROW(m.validate("tet"));
  EXPECT_TRUE(m.is_closed_and_oriented());
  EXPECT_NEAR(m.signed_volume(), 1.0 / 6.0, 1e-9);
  EXPECT_EQ(m.count_degenerate_faces(), 0);
  TriangleMesh open = m;
  open.faces.conservativeResize(3, 3);
  EXPECT_FALSE(open.is_closed_and_oriented());
}

TEST(TriangleMesh, ValidateErrors) {
  TriangleMesh m = tetrahedron();
  m.vertices(0, 2) = std::nanf("");
  EXPECT_THROW(m.validate("t"), InputError);
  m = tetrahedron();
  m.faces(0, 0) = 9;
  EXPECT_THROW(m.validate("t"), InputError);
  EXPECT_THROW(TriangleMesh{}.validate("t"), InputError);
}

TEST(PointCloud, ValidateAndSubset) {
  PointCloud c;
  c.positions = Eigen::Matrix3Xf::Random(3, 5);
  c.weights = Eigen::VectorXf::Ones(5);
  c.properties["outlier"] = Eigen::VectorXf::Zero(5);
  EXPECT_NO_THROW(c.validate("c"));
  const PointCloud s = c.subset({4, 1});
  EXPECT_EQ(s.size(), 2);
  EXPECT_EQ(s.positions.col(0), c.positions.col(4));
  EXPECT_EQ(s.properties.at("outlier").size(), 2);
  c.weights.resize(4);
  EXPECT_THROW(c.validate("c"), InputError);
  c.weights = Eigen::VectorXf::Ones(5);
  c.positions(1, 3) = INFINITY;
  EXPECT_THROW(c.validate("c"), InputError);
}

TEST(GaussianMixture, CovarianceStorage) {
  GaussianMixture g;
  g.resize(1);
  Eigen::Matrix3f c;
  c << 1, 2, 3, 2, 4, 5, 3, 5, 6;
  g.set_covariance(0, c);
  g.weights[0] = 1;
  g.means.col(0).setZero();
  EXPECT_EQ(g.covariance(0), c);
  EXPECT_NO_THROW(g.validate("g"));
  g.weights[0] = -1;
  EXPECT_THROW(g.validate("g"), InputError);
}

TEST(RunContext, StreamsAndPhases) {
  RunContext a(42), b(42), c(43);
  EXPECT_EQ(a.stream_seed("scan"), b.stream_seed("scan"));
  EXPECT_NE(a.stream_seed("scan"), a.stream_seed("hem"));
  EXPECT_NE(a.stream_seed("scan"), c.stream_seed("scan"));
  { auto t = a.phase("init"); }
  a.add_phase_time("init", 1.0);
  EXPECT_GE(a.phase_seconds().at("init"), 1.0);
  EXPECT_NO_THROW(a.check_cancelled("x"));
  a.cancel();
  EXPECT_THROW(a.check_cancelled("x"), Cancelled);
}

}  // namespace
}  // namespace scanbench
