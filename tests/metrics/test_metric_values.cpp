// Metrics on inputs whose answers are known analytically, the registry, bad input, determinism.
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/procedural.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/metrics/regularity.h"
#include "scanbench/metrics/surface_sampling.h"
#include "test_meshes.h"

namespace scanbench::metrics {
namespace {

using testing::grid;
using testing::icosphere;

const GroundTruthOptions kCoarse{1.0 / 128.0, 3.0f};

// Outward offsets of samples along their face normals on a convex polyhedron: the sample stays
// the closest point, so E = delta exactly for every point.
TEST(Metrics, KnownOffsetsFromASphere) {
  const TriangleMesh m = icosphere(3);
  GroundTruth gt(m, 11, kCoarse);
  const double diag = gt.diagonal();
  const float delta = 0.01f;
  PointCloud out = sample_surface(m, 3000, 99);
  out.positions += delta * out.normals;
  out.properties.clear();
  RunContext ctx(1);
  const Json r = evaluate(gt, out, nullptr, {"accuracy.p2plane", "accuracy.chamfer"},
                          Json{{"accuracy.chamfer", {{"tau", 0.02}, {"samples", 5000}}}}, ctx);
  for (const char* k : {"p2plane_mean", "p2plane_rms", "p2plane_max", "p2plane_p50", "p2plane_p90",
                        "p2plane_p99", "accuracy"}) {
    EXPECT_NEAR(r[k].get<double>(), delta, 2e-6) << k;
    EXPECT_NEAR(r[std::string(k) + "_rel"].get<double>(), delta / diag, 1e-6) << k;
  }
  EXPECT_DOUBLE_EQ(r["precision"].get<double>(), 1.0);  // 0.01 < 0.02 * diag
  EXPECT_GT(r["completeness"].get<double>(), delta);
  EXPECT_NEAR(r["chamfer"].get<double>(),
              r["accuracy"].get<double>() + r["completeness"].get<double>(), 1e-12);
  EXPECT_EQ(r["histograms"]["p2plane"]["count"].get<int>(), 3000);
}

// Plane z = 0: points at z = +-delta inside the square have E = +-delta, |E| = delta; samples
// of the plane itself at lattice spacing give a known completeness bound and a zero-variance
// regularity.
TEST(Metrics, KnownOffsetsFromAPlaneAndLatticeRegularity) {
  const TriangleMesh m = grid(10);
  GroundTruth gt(m, 5, kCoarse);
  const int n = 40;
  const float h = 1.0f / n;
  PointCloud out;
  out.positions.resize(3, n * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      out.positions.col(j * n + i) =
          Eigen::Vector3f((i + 0.5f) * h, (j + 0.5f) * h, ((i + j) % 2 ? 1.0f : -1.0f) * 0.003f);
  RunContext ctx(1);
  const Json r =
      evaluate(gt, out, nullptr, {"accuracy.p2plane", "regularity.nn_dist"}, Json::object(), ctx);
  EXPECT_NEAR(r["p2plane_mean"].get<double>(), 0.003, 1e-7);
  EXPECT_NEAR(r["p2plane_max"].get<double>(), 0.003, 1e-7);
  // Checkerboard z: the 4 lattice neighbours sit at height difference 0.006 (diagonal ones are
  // farther), so every nearest-neighbour distance is sqrt(h^2 + 0.006^2).
  const double nn = std::sqrt(double(h) * h + 0.006 * 0.006);
  EXPECT_NEAR(r["nn_dist_mean"].get<double>(), nn, 1e-6);
  EXPECT_NEAR(r["nn_dist_var"].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(r["nn_dist_cv"].get<double>(), 0.0, 1e-4);
}

// Uniform random points on a sphere: nearest-neighbour distances of a planar Poisson process are
// Rayleigh distributed, cv = sqrt(4/pi - 1) = 0.5227; a Fibonacci sphere is far more regular.
TEST(Metrics, SampledSphereRegularity) {
  const TriangleMesh m = icosphere(5);
  const PointCloud s = sample_surface(m, 40000, 3);
  const Eigen::VectorXf d = nearest_neighbour_distances(s.positions);
  const double mean = d.cast<double>().mean();
  const double cv = std::sqrt((d.cast<double>().array() - mean).square().mean()) / mean;
  EXPECT_NEAR(cv, std::sqrt(4.0 / M_PI - 1.0), 0.015);
  // Poisson process of intensity n / area: mean nn distance 1 / (2 sqrt(lambda)).
  EXPECT_NEAR(mean, 0.5 / std::sqrt(40000.0 / m.area()), 0.01 * mean);

  const int n = 20000;
  Eigen::Matrix3Xf fib(3, n);
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (i + 0.5) * 2.0 / n;
    const double r = std::sqrt(1.0 - z * z);
    fib.col(i) = Eigen::Vector3f(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  const Eigen::VectorXf df = nearest_neighbour_distances(fib);
  const double mf = df.cast<double>().mean();
  EXPECT_LT(std::sqrt((df.cast<double>().array() - mf).square().mean()) / mf, 0.1);
}

// The cloud against itself: the ground truth's own surface samples as the output.
TEST(Metrics, CloudAgainstItself) {
  const TriangleMesh m = icosphere(3);
  GroundTruth gt(m, 21, kCoarse);
  PointCloud out = gt.surface_samples(5000);
  out.properties.clear();
  RunContext ctx(1);
  const Json r =
      evaluate(gt, out, nullptr, {}, Json{{"accuracy.chamfer", {{"samples", 5000}}}}, ctx);
  EXPECT_EQ(r["completeness"].get<double>(), 0.0);
  EXPECT_EQ(r["recall"].get<double>(), 1.0);
  EXPECT_EQ(r["precision"].get<double>(), 1.0);
  EXPECT_EQ(r["fscore"].get<double>(), 1.0);
  EXPECT_LT(r["accuracy_rel"].get<double>(), 1e-6);
  EXPECT_LT(r["hausdorff_rel"].get<double>(), 1e-6);
  EXPECT_LT(r["p2plane_max_rel"].get<double>(), 1e-6);
  // Face normals as output normals: angle 0 everywhere (up to float rounding).
  EXPECT_LT(r["normal_angle_mean_deg"].get<double>(), 0.01);
  EXPECT_EQ(r["normal_pgp5"].get<double>(), 1.0);
  // No scan and no declared noise: outliers.residue does not apply; no mesh: mesh.volume either.
  EXPECT_TRUE(r["skipped"].contains("outliers.residue"));
  EXPECT_TRUE(r["skipped"].contains("mesh.volume"));
  EXPECT_TRUE(r["histograms"].contains("completeness"));
}

TEST(Metrics, OutlierResidueFromScanNoise) {
  const TriangleMesh m = icosphere(3);
  GroundTruth gt(m, 1, kCoarse);
  const float sigma = 0.004f;
  PointCloud scan = sample_surface(m, 20000, 8);
  scan.properties.clear();
  Eigen::VectorXf cx = scan.positions.row(0), cy = scan.positions.row(1),
                  cz = scan.positions.row(2), outl = Eigen::VectorXf::Zero(scan.size());
  Rng rng(4);
  for (Eigen::Index i = 0; i < scan.size(); ++i) {
    if (i % 50 == 0) {  // 2% far outliers, marked
      scan.positions.col(i) *= 1.5f;
      outl[i] = 1.0f;
    } else {
      scan.positions.col(i) += static_cast<float>(rng.normal(0.0, sigma)) * scan.normals.col(i);
    }
  }
  scan.properties = {{"clean_x", cx}, {"clean_y", cy}, {"clean_z", cz}, {"outlier", outl}};
  // Output: the scan's inliers, with 10% moved 10 sigma out.
  PointCloud out;
  out.positions = gt.surface_samples(1000).positions;
  for (Eigen::Index i = 0; i < 1000; i += 10)
    out.positions.col(i) += 10 * sigma * gt.surface_samples(1000).normals.col(i);
  RunContext ctx(1);
  const Json r = evaluate(gt, out, &scan, {"outliers.residue"}, Json::object(), ctx);
  EXPECT_NEAR(r["scan_noise"].get<double>(), sigma, 0.05 * sigma);
  EXPECT_DOUBLE_EQ(r["outlier_residue"].get<double>(), 0.1);
  // Scan: 2% outliers plus the Gaussian tail beyond 3 sigma (0.27%).
  EXPECT_NEAR(r["scan_outlier_share"].get<double>(), 0.02 + 0.98 * 0.0027, 0.002);
  // Declared noise overrides the estimate.
  const Json d = evaluate(gt, out, nullptr, {"outliers.residue"},
                          Json{{"outliers.residue", {{"noise", 0.1}}}}, ctx);
  EXPECT_EQ(d["outlier_residue"].get<double>(), 0.0);
  EXPECT_EQ(d["scan_noise_source"].get<std::string>(), "declared");
  // Asked for by name but not applicable: an error.
  EXPECT_THROW(evaluate(gt, out, nullptr, {"outliers.residue"}, Json::object(), ctx),
               NotApplicable);
}

TEST(Metrics, ReconstructedMeshVolume) {
  GroundTruth gt(icosphere(4, 1.0f), 2, GroundTruthOptions{1.0 / 100.0, 3.0f});
  RunContext ctx(1);
  const Json same =
      evaluate_mesh(gt, icosphere(4, 1.0f), nullptr, {"mesh.volume"}, Json::object(), ctx, 1000);
  EXPECT_EQ(same["volume_mean_abs_diff"].get<double>(), 0.0);
  EXPECT_EQ(same["volume_iou"].get<double>(), 1.0);
  const Json bigger =
      evaluate_mesh(gt, icosphere(4, 1.03f), nullptr, {}, Json::object(), ctx, 20000);
  EXPECT_NEAR(bigger["volume_iou"].get<double>(), 1.0 / (1.03 * 1.03 * 1.03), 0.02);
  EXPECT_GT(bigger["volume_mean_abs_diff"].get<double>(), 0.0);
  // Surface metrics on the mesh samples: a sphere scaled by 1.03 lies about 0.03 outside.
  EXPECT_NEAR(bigger["accuracy"].get<double>(), 0.03, 0.002);
  EXPECT_EQ(bigger["output_mesh_samples"].get<int>(), 20000);
  // Open output mesh: no IoU.
  const Json open = evaluate_mesh(gt, grid(4), nullptr, {"mesh.volume"}, Json::object(), ctx, 100);
  EXPECT_TRUE(open["volume_iou"].is_null());
}

TEST(Metrics, EveryRegisteredMetricRunsByName) {
  const TriangleMesh m = icosphere(2);
  GroundTruth gt(m, 1, kCoarse);
  PointCloud out = sample_surface(m, 500, 5);
  out.properties.clear();
  RunContext ctx(1);
  const Json params = {{"outliers.residue", {{"noise", 0.001}}},
                       {"accuracy.chamfer", {{"samples", 1000}}},
                       {"surface.chamfer", {{"samples", 1000}}}};
  // Each metric's own keys (metrics/registry.h), as numbers: the bookkeeping keys every record
  // carries (output_points, gt_diagonal, metric_params, ...) do not count.
  const std::map<std::string, std::vector<std::string>> keys = {
      {"accuracy.p2plane",
       {"p2plane_mean", "p2plane_mean_rel", "p2plane_rms", "p2plane_max", "p2plane_p50",
        "p2plane_p90", "p2plane_p99"}},
      {"accuracy.chamfer",
       {"accuracy", "completeness", "chamfer", "hausdorff", "precision", "recall", "fscore"}},
      {"regularity.nn_dist", {"nn_dist_mean", "nn_dist_var", "nn_dist_cv"}},
      {"normals.angle",
       {"normal_angle_mean_deg", "normal_angle_rms_deg", "normal_pgp5", "normal_pgp10"}},
      {"outliers.residue", {"outlier_residue", "outlier_threshold", "scan_noise"}},
      {"mesh.volume", {"volume_mean_abs_diff", "volume_iou"}},
      {"convention.scoredenoise", {"sd_cd_sph_x1e4", "sd_p2f_x1e4", "sd_hd_sph"}}};
  for (const auto& e : registry().entries()) {
    Json r;
    if (e.name.rfind("edges.", 0) == 0) {
      // The sharp-edge metrics need a truth with sharp edges (a sphere has none: NotApplicable).
      const TriangleMesh cube = make_cube({});
      GroundTruth cgt(cube, 1, kCoarse);
      PointCloud cpts = sample_surface(cube, 500, 5);
      cpts.properties.clear();
      r = evaluate(cgt, cpts, nullptr, {e.name}, params, ctx);
    } else if (e.name == "convention.eth3d") {
      // ETH3D's ground truth is a scan's noise-free hits with their scanner origins.
      PointCloud scan = out;
      scan.properties["clean_x"] = scan.positions.row(0).transpose();
      scan.properties["clean_y"] = scan.positions.row(1).transpose();
      scan.properties["clean_z"] = scan.positions.row(2).transpose();
      scan.scan_ids = Eigen::VectorXi::Zero(scan.size());
      scan.sensor_origins = Eigen::Matrix3Xf::Zero(3, 1);
      scan.sensor_origins(0, 0) = 3.0f;
      r = evaluate(gt, out, &scan, {e.name}, params, ctx);
    } else if (e.fn.scores == Scores::Mesh) {
      r = evaluate_mesh(gt, m, &out, {e.name}, params, ctx, 200);
    } else {
      r = evaluate(gt, out, nullptr, {e.name}, params, ctx);
    }
    EXPECT_TRUE(r["metric_params"].contains(e.name)) << e.name;
    // Metrics not listed here (surface.*, mesh.facts) are checked key by key against their
    // declared directions in test_surface_metrics.cpp.
    if (keys.count(e.name) != 0) {
      for (const std::string& k : keys.at(e.name)) {
        ASSERT_TRUE(r.contains(k)) << e.name << " lacks " << k;
        EXPECT_TRUE(r[k].is_number()) << e.name << "." << k << " = " << r[k].dump();
      }
    }
    EXPECT_TRUE(r["skipped"].empty()) << e.name << r["skipped"].dump();
  }
  EXPECT_EQ(registry().entries().size(), 18u);
}

TEST(Metrics, BadInputThrowsTypedErrors) {
  GroundTruth gt(icosphere(2), 1, kCoarse);
  PointCloud out = sample_surface(icosphere(2), 100, 5);
  RunContext ctx(1);
  EXPECT_THROW(evaluate(gt, out, nullptr, {"nope"}, Json::object(), ctx), UnknownNameError);
  EXPECT_THROW(evaluate(gt, out, nullptr, {}, Json{{"nope", Json::object()}}, ctx), ParamError);
  EXPECT_THROW(evaluate(gt, out, nullptr, {}, Json::array(), ctx), ParamError);
  EXPECT_THROW(evaluate(gt, out, nullptr, {}, Json{{"accuracy.chamfer", {{"tau", "big"}}}}, ctx),
               ParamError);
  EXPECT_THROW(evaluate(gt, out, nullptr, {}, Json{{"accuracy.chamfer", {{"tau", -1}}}}, ctx),
               ParamError);
  EXPECT_THROW(evaluate(gt, out, nullptr, {}, Json{{"accuracy.p2plane", {{"bogus", 1}}}}, ctx),
               ParamError);
  PointCloud empty;
  EXPECT_THROW(evaluate(gt, empty, nullptr, {}, Json::object(), ctx), InputError);
  out.positions(1, 7) = std::nanf("");
  EXPECT_THROW(evaluate(gt, out, nullptr, {}, Json::object(), ctx), InputError);
  PointCloud no_normals;
  no_normals.positions = Eigen::Matrix3Xf::Random(3, 10);
  EXPECT_THROW(evaluate(gt, no_normals, nullptr, {"normals.angle"}, Json::object(), ctx),
               NotApplicable);
}

TEST(Metrics, IndependentOfThreadCount) {
  const TriangleMesh m = icosphere(3);
  PointCloud out = sample_surface(m, 20000, 77);
  out.properties.clear();
  Rng rng(3);
  for (Eigen::Index i = 0; i < out.size(); ++i)
    out.positions.col(i) += static_cast<float>(rng.normal(0.0, 0.01)) * out.normals.col(i);
  const Json params = {{"outliers.residue", {{"noise", 0.002}}},
                       {"accuracy.chamfer", {{"path", "field"}, {"samples", 20000}}}};
  std::string dumps[2];
  for (int t : {1, 2}) {
    GroundTruth gt(m, 1, kCoarse);
    RunContext ctx(7, t);
    dumps[t - 1] = evaluate(gt, out, nullptr, {}, params, ctx).dump();
  }
  EXPECT_EQ(dumps[0], dumps[1]);
}

}  // namespace
}  // namespace scanbench::metrics
