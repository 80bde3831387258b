// A point-cloud ground truth (metrics/point_truth.h): the scores of a small case against a hand
// computation, the mesh path against a dense sampling of the same mesh, the metrics that need a
// mesh reported not applicable, alignment and crop.
#include <gtest/gtest.h>

#include <cmath>

#include "scanbench/core/procedural.h"
#include "scanbench/core/rng.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/point_truth.h"
#include "scanbench/metrics/registry.h"

namespace scanbench::metrics {
namespace {

PointCloud cloud(std::initializer_list<Eigen::Vector3f> pts) {
  PointCloud c;
  c.positions.resize(3, static_cast<Eigen::Index>(pts.size()));
  Eigen::Index i = 0;
  for (const auto& p : pts)
    c.positions.col(i++) = p;
  return c;
}

// GT: the origin and the three unit points (diagonal sqrt 3); output: three points.
//   accuracy: (0,0,0.1) -> 0.1, (1,0,0.5) -> 0.5, (3,0,0) -> 2      mean 2.6 / 3
//   completeness: (0,0,0) -> 0.1, (1,0,0) -> 0.5, (0,1,0) -> sqrt(1.01), (0,0,1) -> 0.9
//   tau = 0.3: precision 1/3, recall 1/4, F = 2 (1/3)(1/4) / (7/12) = 2/7; hausdorff 2
//   p2plane with GT normals (0,0,1): |E| = 0.1, 0.5, 0 -> mean 0.2
TEST(PointTruth, SmallCaseEqualsTheHandComputation) {
  PointCloud gt = cloud({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
  gt.normals = Eigen::Matrix3Xf::Zero(3, 4);
  gt.normals.row(2).setOnes();
  const PointCloud out = cloud({{0, 0, 0.1f}, {1, 0, 0.5f}, {3, 0, 0}});
  RunContext ctx(1, 1);
  const double diag = std::sqrt(3.0);
  Json params;
  params["accuracy.chamfer"]["tau"] = 0.3 / diag;
  const Json r = evaluate_point_truth(gt, out, {}, params, ctx);
  const double tol = 1e-6;
  EXPECT_NEAR(r["accuracy"].get<double>(), 2.6 / 3, tol);
  EXPECT_NEAR(r["completeness"].get<double>(), (0.1 + 0.5 + std::sqrt(1.01) + 0.9) / 4, tol);
  EXPECT_NEAR(r["chamfer"].get<double>(), 2.6 / 3 + (1.5 + std::sqrt(1.01)) / 4, tol);
  EXPECT_NEAR(r["hausdorff"].get<double>(), 2.0, tol);
  EXPECT_NEAR(r["precision"].get<double>(), 1.0 / 3, tol);
  EXPECT_NEAR(r["recall"].get<double>(), 0.25, tol);
  EXPECT_NEAR(r["fscore"].get<double>(), 2.0 / 7, tol);
  EXPECT_NEAR(r["accuracy_rel"].get<double>(), 2.6 / 3 / diag, tol);
  EXPECT_NEAR(r["p2plane_mean"].get<double>(), 0.2, tol);
  EXPECT_NEAR(r["p2plane_max"].get<double>(), 0.5, tol);
  EXPECT_EQ(r["gt_points"].get<int>(), 4);
  // Every other registered metric is reported not applicable, none fails.
  for (const auto& e : registry().entries()) {
    if (e.fn.run_point_truth) {
      EXPECT_FALSE(r["skipped"].contains(e.name)) << e.name;
    } else {
      ASSERT_TRUE(r["skipped"].contains(e.name)) << e.name;
      EXPECT_NE(r["skipped"][e.name].get<std::string>().find("not applicable"), std::string::npos);
    }
  }
  // Without GT normals point-to-plane does not apply; asked for by name it throws.
  gt.normals.resize(3, 0);
  const Json r2 = evaluate_point_truth(gt, out, {}, params, ctx);
  EXPECT_TRUE(r2["skipped"].contains("accuracy.p2plane"));
  EXPECT_THROW((void)evaluate_point_truth(gt, out, {"accuracy.p2plane"}, params, ctx),
               NotApplicable);
  EXPECT_THROW((void)evaluate_point_truth(gt, out, {"normals.angle"}, params, ctx), NotApplicable);
}

// The mesh's own fixed surface samples as point GT: completeness and recall are the mesh path's
// exactly (the same samples, the same kd-tree distances); accuracy, from nearest samples instead
// of the exact surface, within 5% (1e6 samples on the unit sphere: mean lateral offset to the
// nearest sample ~0.002, radial noise sigma 0.02: the excess is ~1%).
TEST(PointTruth, DenseSamplingOfTheMeshGivesTheMeshMetrics) {
  const TriangleMesh m = make_sphere({});
  const GroundTruth gt(m, 3);
  PointCloud out;
  out.positions.resize(3, 20000);
  Rng rng(5);
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
    out.positions.col(i) = (d.normalized() * (1.0 + 0.02 * rng.normal())).cast<float>();
  }
  RunContext ctx(1, 1);
  Json params;
  params["accuracy.chamfer"]["tau"] = 0.005;
  params["accuracy.chamfer"]["samples"] = 1000000;
  const Json mesh = evaluate(gt, out, nullptr, {"accuracy.chamfer"}, params, ctx);
  const PointCloud& samples = gt.surface_samples(1000000);
  const Json pts = evaluate_point_truth(samples, out, {"accuracy.chamfer"}, params, ctx);
  // The diagonal of the samples' bbox is within 1e-3 of the mesh's: compare absolute values.
  EXPECT_EQ(pts["completeness"].get<double>(), mesh["completeness"].get<double>());
  EXPECT_NEAR(pts["accuracy"].get<double>(), mesh["accuracy"].get<double>(),
              0.05 * mesh["accuracy"].get<double>());
  EXPECT_NEAR(pts["chamfer"].get<double>(), mesh["chamfer"].get<double>(),
              0.05 * mesh["chamfer"].get<double>());
  EXPECT_NEAR(pts["fscore"].get<double>(), mesh["fscore"].get<double>(), 0.05);
}

TEST(PointTruth, TransformAndCrop) {
  const Eigen::Matrix4d t = parse_transform("0 -1 0 1, 1 0 0 2, 0 0 1 3, 0 0 0 1", "t");
  PointCloud c = cloud({{1, 0, 0}, {0, 0, 5}});
  c.normals = Eigen::Matrix3Xf::Zero(3, 2);
  c.normals(0, 0) = 1;
  c.normals(2, 1) = 1;
  const PointCloud moved = transformed(c, t);
  EXPECT_TRUE(moved.positions.col(0).isApprox(Eigen::Vector3f(1, 3, 3)));
  EXPECT_TRUE(moved.normals.col(0).isApprox(Eigen::Vector3f(0, 1, 0)));
  const PointCloud kept = cropped(moved, parse_crop("0,0,0,2,4,4", "c"));
  EXPECT_EQ(kept.size(), 1);
  EXPECT_THROW((void)parse_transform("1 2 3", "t"), ParamError);
  EXPECT_THROW((void)parse_crop("1,1,1,0,0,0", "c"), ParamError);
}

}  // namespace
}  // namespace scanbench::metrics

namespace scanbench::metrics {
namespace {

// regularity.nn_dist needs no mesh (issue 49: it was skipped as "needs a ground-truth mesh"):
// on a point ground truth it runs, with all metrics and by name, and its values equal the mesh
// path's (nn_dist_mean and _var and cv do not depend on the truth; _rel divides by the truth's
// diagonal: the same bbox here, the truth being the mesh's vertices).
TEST(PointTruth, RegularityRunsWithoutAMesh) {
  const TriangleMesh m = make_sphere({});
  const GroundTruth gt(m, 3);
  PointCloud truth;
  truth.positions = m.vertices;
  PointCloud out;
  out.positions.resize(3, 3000);
  Rng rng(11);
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
    out.positions.col(i) = d.normalized().cast<float>();
  }
  RunContext ctx(1, 1);
  const Json all = evaluate_point_truth(truth, out, {}, Json::object(), ctx);
  EXPECT_FALSE(all["skipped"].contains("regularity.nn_dist")) << all["skipped"].dump();
  ASSERT_TRUE(all.contains("nn_dist_cv")) << all.dump();
  const Json named = evaluate_point_truth(truth, out, {"regularity.nn_dist"}, Json::object(), ctx);
  const Json mesh = evaluate(gt, out, nullptr, {"regularity.nn_dist"}, Json::object(), ctx);
  for (const char* k : {"nn_dist_mean", "nn_dist_var", "nn_dist_cv"}) {
    EXPECT_EQ(named[k], mesh[k]) << k;
    EXPECT_EQ(all[k], mesh[k]) << k;
  }
  EXPECT_DOUBLE_EQ(named["nn_dist_mean_rel"].get<double>(),
                   named["nn_dist_mean"].get<double>() / truth.bbox().diagonal());
  EXPECT_TRUE(named["histograms"].contains("nn_dist"));
  EXPECT_TRUE(registry().at("regularity.nn_dist").fn.run_point_truth);
}

}  // namespace
}  // namespace scanbench::metrics
