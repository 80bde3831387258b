// edges.p2plane / edges.normals (sharp_edges.h): hand-placed points on the cube against the
// analytic answer (which points are near an edge, their offsets and normal angles).
#include <gtest/gtest.h>

#include <cmath>

#include "scanbench/core/errors.h"
#include "scanbench/core/procedural.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/metrics/sharp_edges.h"
#include "scanbench/metrics/surface_sampling.h"
#include "test_meshes.h"

namespace scanbench::metrics {
namespace {

TEST(SharpEdgeMetrics, CubePointsNearAndFarFromEdges) {
  const TriangleMesh cube = make_cube({});
  const GroundTruth gt(cube, 1);
  const Eigen::Vector3f lo = cube.vertices.rowwise().minCoeff();
  const Eigen::Vector3f hi = cube.vertices.rowwise().maxCoeff();
  const float diag = (hi - lo).norm();
  const Eigen::Vector3f mid = 0.5f * (lo + hi);
  PointCloud out;
  out.positions.resize(3, 3);
  // 0: above the top face, 0.005 diag from the edge x = hi.x (inside the 0.02 band), 0.01 up.
  out.positions.col(0) << hi.x() - 0.005f * diag, mid.y(), hi.z() + 0.01f;
  // 1: above the top face's centre, 0.03 up: far from every edge.
  out.positions.col(1) << mid.x(), mid.y(), hi.z() + 0.03f;
  // 2: 0.005 below the top face (its closest face), 0.01 diag from the edge y = lo.y.
  out.positions.col(2) << mid.x(), lo.y() + 0.01f * diag, hi.z() - 0.005f;
  out.normals.resize(3, 3);
  const float a = 20.0f * static_cast<float>(M_PI) / 180.0f;
  out.normals.col(0) << std::sin(a), 0.0f, std::cos(a);  // 20 degrees off the top normal
  out.normals.col(1) << 1.0f, 0.0f, 0.0f;                // 90 degrees, but not near an edge
  out.normals.col(2) << 0.0f, 0.0f, -1.0f;               // 0 degrees (unoriented)
  RunContext ctx(1);
  const Json r =
      evaluate(gt, out, nullptr, {"edges.p2plane", "edges.normals"}, Json::object(), ctx);
  EXPECT_EQ(r["edge_points"], 2);
  EXPECT_NEAR(r["edge_p2plane_mean"].get<double>(), 0.0075, 1e-6);
  EXPECT_NEAR(r["edge_p2plane_mean_rel"].get<double>(), 0.0075 / diag, 1e-6);
  EXPECT_NEAR(r["edge_share"].get<double>(), 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(r["edge_normal_angle_mean_deg"].get<double>(), 10.0, 1e-3);
  EXPECT_NEAR(r["edge_normal_pgp10"].get<double>(), 0.5, 1e-12);
  // A narrower band leaves out point 2 (0.01 diag from its edge).
  const Json r2 = evaluate(gt, out, nullptr, {"edges.p2plane"},
                           Json{{"edges.p2plane", {{"band", 0.008}}}}, ctx);
  EXPECT_EQ(r2["edge_points"], 1);
  EXPECT_NEAR(r2["edge_p2plane_mean"].get<double>(), 0.01, 1e-6);
}

TEST(SharpEdgeMetrics, SmoothTruthHasNothingToScore) {
  const GroundTruth gt(testing::icosphere(3), 1);
  PointCloud out;
  out.positions = Eigen::Matrix3Xf::Zero(3, 2);
  out.positions(0, 0) = 1.0f;
  out.positions(1, 1) = 1.0f;
  RunContext ctx(1);
  EXPECT_THROW(evaluate(gt, out, nullptr, {"edges.p2plane"}, Json::object(), ctx), NotApplicable);
  const Json r = evaluate(gt, out, nullptr, {}, Json::object(), ctx);
  EXPECT_TRUE(r["skipped"].contains("edges.p2plane")) << r.dump();
}

// Issue 49: edges.* only where sharp edges are features. The cube's 12 edges are: both metrics
// run, with their measured shares. A low-poly sphere (resolution 2: 48 triangles, every edge a
// fold of more than 30 degrees) is faceted: skipped with the stated rule when all metrics run,
// NotApplicable when named. A band so wide that it covers most of the cube: skipped by the area
// rule.
TEST(SharpEdgeMetrics, OnlyWhereSharpEdgesAreFeatures) {
  RunContext ctx(1);
  const TriangleMesh cube = make_cube({});
  const GroundTruth cube_gt(cube, 1);
  PointCloud out = sample_surface(cube, 4000, 2);
  const Json kept = evaluate(cube_gt, out, nullptr, {}, Json::object(), ctx);
  EXPECT_FALSE(kept["skipped"].contains("edges.p2plane")) << kept["skipped"].dump();
  EXPECT_FALSE(kept["skipped"].contains("edges.normals")) << kept["skipped"].dump();
  // The band of 0.02 diag around the 12 edges: 1 - (1 - 2 x 0.02 sqrt 3)^2 of each face.
  const double strip = 2.0 * 0.02 * std::sqrt(3.0);
  EXPECT_NEAR(kept["edge_band_area"].get<double>(), 1.0 - (1.0 - strip) * (1.0 - strip), 0.01);
  EXPECT_LT(kept["edge_sharp_length"].get<double>(), 0.1);
  EXPECT_GT(kept["edge_points"].get<int>(), 0);

  SphereParams low;
  low.resolution = 2;
  const TriangleMesh sphere = make_sphere(low);
  const GroundTruth sphere_gt(sphere, 1);
  out = sample_surface(sphere, 4000, 2);
  const Json faceted = evaluate(sphere_gt, out, nullptr, {}, Json::object(), ctx);
  ASSERT_TRUE(faceted["skipped"].contains("edges.p2plane")) << faceted.dump();
  const std::string why = faceted["skipped"]["edges.p2plane"].get<std::string>();
  EXPECT_NE(why.find("faceted"), std::string::npos) << why;
  EXPECT_NE(why.find("max_sharp_length 50%"), std::string::npos) << why;
  EXPECT_TRUE(faceted["skipped"].contains("edges.normals"));
  EXPECT_FALSE(faceted.contains("edge_p2plane_mean"));
  EXPECT_GT(sharp_edge_length_share(sphere_gt, {}), 0.5);
  EXPECT_THROW(evaluate(sphere_gt, out, nullptr, {"edges.p2plane"}, Json::object(), ctx),
               NotApplicable);
  // The same sphere scored when the rule is relaxed: the rule, not the geometry, skips it.
  const Json relaxed = evaluate(sphere_gt, out, nullptr, {"edges.p2plane"},
                                Json{{"edges.p2plane", {{"max_sharp_length", 1.0}}}}, ctx);
  EXPECT_TRUE(relaxed.contains("edge_p2plane_mean")) << relaxed.dump();

  out = sample_surface(cube, 4000, 2);
  const Json wide = evaluate(cube_gt, out, nullptr, {"edges.p2plane"}, Json::object(), ctx);
  EXPECT_TRUE(wide.contains("edge_p2plane_mean"));
  try {
    evaluate(cube_gt, out, nullptr, {"edges.p2plane"}, Json{{"edges.p2plane", {{"band", 0.2}}}},
             ctx);
    ADD_FAILURE() << "a band covering most of the cube was scored";
  } catch (const NotApplicable& e) {
    EXPECT_NE(std::string(e.what()).find("max_band_area 50%"), std::string::npos) << e.what();
  }
}

// Issue 50: the distance at a convex edge is to the edge itself. A point q on the bisector
// outside the cube's edge {x = hi.x, z = hi.z}, at distance d from it, has its closest point p
// on the edge: edge_p2s = |q - p| = d, while the point-to-plane error takes one face's normal
// (x or z), |<q - p, N_p>| = d / sqrt(2). Two offsets, one inside and one beyond the band: the
// closest point is on the edge either way.
TEST(SharpEdgeMetrics, ConvexEdgeBisectorPointToSurfaceAndToPlane) {
  const TriangleMesh cube = make_cube({});
  const GroundTruth gt(cube, 1);
  const Eigen::Vector3f lo = cube.vertices.rowwise().minCoeff();
  const Eigen::Vector3f hi = cube.vertices.rowwise().maxCoeff();
  const double diag = (hi - lo).cast<double>().norm();
  const double d[2] = {0.01 * diag, 0.05 * diag};
  PointCloud out;
  out.positions.resize(3, 4);
  for (int i = 0; i < 4; ++i) {
    const float off = static_cast<float>(d[i % 2] / std::sqrt(2.0));
    const float y = lo.y() + (hi.y() - lo.y()) * (0.2f + 0.2f * static_cast<float>(i));
    out.positions.col(i) << hi.x() + off, y, hi.z() + off;
  }
  RunContext ctx(1);
  const Json r = evaluate(gt, out, nullptr, {"edges.p2plane"}, Json::object(), ctx);
  const double mean = 0.5 * (d[0] + d[1]);
  EXPECT_EQ(r["edge_points"], 4);
  EXPECT_NEAR(r["edge_p2s_mean"].get<double>(), mean, 1e-6 * diag);
  EXPECT_NEAR(r["edge_p2s_mean_rel"].get<double>(), mean / diag, 1e-6);
  EXPECT_NEAR(r["edge_p2plane_mean"].get<double>(), mean / std::sqrt(2.0), 1e-6 * diag);
  EXPECT_NEAR(r["edge_band_rel"].get<double>(), 0.02, 1e-12);
  EXPECT_NEAR(r["edge_band"].get<double>(), 0.02 * diag, 1e-6 * diag);
}

// The band grows with the scan noise: B = max(band, band_noise_multiple x sigma), sigma declared
// or measured on the scan (RMS |p - clean| of its inliers). A point 0.025 diag from an edge (its
// closest point on the top face) is outside the default band and inside B = 0.03.
TEST(SharpEdgeMetrics, BandGrowsWithTheNoiseMultiple) {
  const TriangleMesh cube = make_cube({});
  const GroundTruth gt(cube, 1);
  const Eigen::Vector3f lo = cube.vertices.rowwise().minCoeff();
  const Eigen::Vector3f hi = cube.vertices.rowwise().maxCoeff();
  const float diag = (hi - lo).norm();
  const Eigen::Vector3f mid = 0.5f * (lo + hi);
  PointCloud out;
  out.positions.resize(3, 2);
  out.positions.col(0) << hi.x() - 0.025f * diag, mid.y(), hi.z() + 0.004f;  // 0.025 from the edge
  out.positions.col(1) << hi.x() - 0.005f * diag, mid.y(), hi.z() + 0.002f;  // 0.005 from it
  RunContext ctx(1);
  const auto run = [&](const Json& params, const PointCloud* scan) {
    return evaluate(gt, out, scan, {"edges.p2plane"}, Json{{"edges.p2plane", params}}, ctx);
  };
  const Json narrow = run(Json::object(), nullptr);
  EXPECT_EQ(narrow["edge_points"], 1);
  EXPECT_NEAR(narrow["edge_p2plane_mean"].get<double>(), 0.002, 1e-6);
  // Declared noise 0.03 diag: multiple 1 widens the band to 0.03, 0.5 leaves it at 0.02.
  const Json wide = run({{"band_noise_multiple", 1.0}, {"noise", 0.03}}, nullptr);
  EXPECT_NEAR(wide["edge_band_rel"].get<double>(), 0.03, 1e-12);
  EXPECT_EQ(wide["edge_points"], 2);
  EXPECT_NEAR(wide["edge_p2plane_mean"].get<double>(), 0.003, 1e-6);
  EXPECT_NEAR(wide["edge_p2s_mean"].get<double>(), 0.003, 1e-6);
  const Json half = run({{"band_noise_multiple", 0.5}, {"noise", 0.03}}, nullptr);
  EXPECT_NEAR(half["edge_band_rel"].get<double>(), 0.02, 1e-12);
  EXPECT_EQ(half["edge_points"], 1);
  // The band's wider area is what the features rule sees (edge_band_area of the cube).
  const double strip = 2.0 * 0.03 * std::sqrt(3.0);
  EXPECT_NEAR(wide["edge_band_area"].get<double>(), 1.0 - (1.0 - strip) * (1.0 - strip), 0.01);

  // Measured noise: every scan point sigma = 0.03 diag from its clean position; an outlier (far
  // off) is left out of the RMS.
  PointCloud scan = sample_surface(cube, 400, 3);
  scan.properties.clear();
  const float sigma = 0.03f * diag;
  scan.properties["clean_x"] = scan.positions.row(0).transpose();
  scan.properties["clean_y"] = scan.positions.row(1).transpose();
  scan.properties["clean_z"] = scan.positions.row(2).transpose();
  scan.positions.row(2).array() += sigma;
  scan.properties["outlier"] = Eigen::VectorXf::Zero(scan.size());
  scan.properties["outlier"][0] = 1.0f;
  scan.positions.col(0) << 9.0f, 9.0f, 9.0f;
  const Json measured = run({{"band_noise_multiple", 1.0}}, &scan);
  EXPECT_NEAR(measured["edge_band_rel"].get<double>(), 0.03, 1e-6);
  EXPECT_EQ(measured["edge_points"], 2);
  // edges.normals shares the band (here 2 sigma = 0.06 diag).
  PointCloud with_normals = out;
  with_normals.normals = Eigen::Matrix3Xf::Zero(3, 2);
  with_normals.normals.row(2).setOnes();
  const Json normals = evaluate(gt, with_normals, &scan, {"edges.normals"},
                                Json{{"edges.normals", {{"band_noise_multiple", 2.0}}}}, ctx);
  EXPECT_NEAR(normals["edge_band_rel"].get<double>(), 0.06, 2e-6);
  EXPECT_EQ(normals["edge_points"], 2);
  EXPECT_NEAR(normals["edge_normal_angle_mean_deg"].get<double>(), 0.0, 1e-9);
  // Asked for, but neither declared nor measurable: not applicable, with the reason.
  try {
    run({{"band_noise_multiple", 1.0}}, nullptr);
    ADD_FAILURE() << "a noise band without a noise was scored";
  } catch (const NotApplicable& e) {
    EXPECT_NE(std::string(e.what()).find("declare noise"), std::string::npos) << e.what();
  }
  const Json all =
      evaluate(gt, out, nullptr, {}, Json{{"edges.p2plane", {{"band_noise_multiple", 1.0}}}}, ctx);
  EXPECT_TRUE(all["skipped"].contains("edges.p2plane")) << all["skipped"].dump();
}

}  // namespace
}  // namespace scanbench::metrics
