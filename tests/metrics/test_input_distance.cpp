// surface.input_distance (surface.h) of the points a reconstruction consumed (of=step_input, GPS
// paper sec. 7.2, Fig. 13) against the analytic answer, and the scan-based option unchanged.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/metric_input.h"
#include "scanbench/metrics/surface_sampling.h"
#include "test_meshes.h"

namespace scanbench::metrics {
namespace {

using testing::icosphere;

const GroundTruthOptions kCoarseSurface{1.0 / 128.0, 3.0f};

// The output is an icosphere O of radius 1 (convex, its vertices on the unit sphere). A point
// v (1 + d) beyond a vertex v lies in the vertex's normal cone (the plane tangent to the sphere
// at v supports O), so its closest point on O is v and its distance exactly d. The step input
// holds one such point per vertex of O, d cycling through kOffsets, and two points marked as
// outliers far away: mean and RMS are those of the offsets, the outliers left out.
TEST(InputDistance, StepInputAtKnownOffsetsFromASphere) {
  const TriangleMesh sphere = icosphere(3, 1.0f);
  const GroundTruth gt(sphere, 1, kCoarseSurface);
  const std::vector<double> kOffsets = {0.01, 0.02, 0.05};
  const Eigen::Index n = sphere.num_vertices();
  PointCloud step;
  step.positions.resize(3, n + 2);
  step.properties["outlier"] = Eigen::VectorXf::Zero(n + 2);
  double sum = 0.0, sq = 0.0, max = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double d = kOffsets[static_cast<std::size_t>(i) % kOffsets.size()];
    step.positions.col(i) = sphere.vertices.col(i) * static_cast<float>(1.0 + d);
    sum += d;
    sq += d * d;
    max = std::max(max, d);
  }
  step.positions.col(n) << 5.0f, 0.0f, 0.0f;
  step.positions.col(n + 1) << 0.0f, -7.0f, 0.0f;
  step.properties["outlier"].tail(2).setOnes();
  PointCloud scan = sample_surface(icosphere(5, 1.0f), 3000, 4);
  scan.properties.clear();

  StageData data;
  data.mesh = sphere;
  data.points = step;
  RunContext ctx(2);
  const Json of_step = {{"surface.input_distance", {{"of", "step_input"}}}};
  const Json r =
      evaluate(gt, data, DataKind::Mesh, &scan, {"surface.input_distance"}, of_step, ctx, 1000);
  const double mean = sum / static_cast<double>(n), rms = std::sqrt(sq / static_cast<double>(n));
  EXPECT_EQ(r["input_distance_points"].get<Eigen::Index>(), n);
  EXPECT_NEAR(r["input_distance_mean"].get<double>(), mean, 1e-6);
  EXPECT_NEAR(r["input_distance_rms"].get<double>(), rms, 1e-6);
  EXPECT_NEAR(r["input_distance_max"].get<double>(), max, 1e-6);
  EXPECT_NEAR(r["input_distance_rms_rel"].get<double>(), rms / gt.diagonal(), 1e-6);
  EXPECT_GT(r["input_distance_rms"].get<double>(), r["input_distance_mean"].get<double>() + 1e-3);
  EXPECT_EQ(r["metric_params"]["surface.input_distance"]["of"], "step_input");
  // skip_outliers off: the two far points count (distances 4 and 6).
  const Json all =
      evaluate(gt, data, DataKind::Mesh, &scan, {"surface.input_distance"},
               Json{{"surface.input_distance", {{"of", "step_input"}, {"skip_outliers", false}}}},
               ctx, 1000);
  EXPECT_EQ(all["input_distance_points"].get<Eigen::Index>(), n + 2);
  EXPECT_NEAR(all["input_distance_max"].get<double>(), 6.0, 1e-5);
  EXPECT_NEAR(all["input_distance_mean"].get<double>(), (sum + 4.0 + 6.0) / double(n + 2), 1e-6);

  // A consolidation's output has no outlier marks: max_truth_distance leaves the far points out
  // by their distance to the ground truth (here 4 and 6, above 0.5 diag = 1.73).
  StageData unmarked = data;
  unmarked.points.properties.clear();
  const Json far = evaluate(
      gt, unmarked, DataKind::Mesh, &scan, {"surface.input_distance"},
      Json{{"surface.input_distance", {{"of", "step_input"}, {"max_truth_distance", 0.5}}}}, ctx,
      1000);
  EXPECT_EQ(far["input_distance_points"].get<Eigen::Index>(), n);
  EXPECT_NEAR(far["input_distance_mean"].get<double>(), mean, 1e-6);
  EXPECT_NEAR(far["input_distance_rms"].get<double>(), rms, 1e-6);

  // The covariance-mesh path hands the carried points over the same way.
  StageData cov;
  cov.covariance_mesh.emplace();
  cov.covariance_mesh->resize(n);
  cov.covariance_mesh->means = sphere.vertices.cast<double>();
  for (Eigen::Index i = 0; i < n; ++i)
    cov.covariance_mesh->set_covariance(i, 1e-6 * Eigen::Matrix3d::Identity());
  for (Eigen::Index f = 0; f < sphere.num_faces(); ++f) {
    const int t[3] = {sphere.faces(0, f), sphere.faces(1, f), sphere.faces(2, f)};
    cov.covariance_mesh->faces.add(t);
  }
  cov.points = step;
  const Json rc = evaluate(gt, cov, DataKind::CovarianceMesh, &scan, {"surface.input_distance"},
                           of_step, ctx, 1000);
  EXPECT_NEAR(rc["input_distance_mean"].get<double>(), mean, 1e-6);
  EXPECT_NEAR(rc["input_distance_rms"].get<double>(), rms, 1e-6);
}

// of=scan (the default) measures the scan whether or not the chain carried points: the record is
// the one evaluate_mesh gives without them, bit for bit; of=step_input without carried points is
// not applicable (an error when named, skipped when all metrics run).
TEST(InputDistance, ScanOptionUnchangedAndStepInputRequired) {
  const TriangleMesh unit = icosphere(4, 1.0f);
  const TriangleMesh outer = icosphere(4, 1.01f);
  const GroundTruth gt(unit, 3, kCoarseSurface);
  PointCloud scan = sample_surface(unit, 2000, 17);
  scan.properties.clear();
  StageData data;
  data.mesh = outer;
  data.points = sample_surface(outer, 500, 9);  // what a reconstruction might have consumed
  RunContext ctx(5);
  const Json plain =
      evaluate_mesh(gt, outer, &scan, {"surface.input_distance"}, Json::object(), ctx, 2000);
  const Json carried = evaluate(gt, data, DataKind::Mesh, &scan, {"surface.input_distance"},
                                Json::object(), ctx, 2000);
  EXPECT_EQ(plain.dump(), carried.dump());
  EXPECT_EQ(carried["metric_params"]["surface.input_distance"]["of"], "scan");
  EXPECT_EQ(carried["input_distance_points"].get<int>(), 2000);
  EXPECT_NEAR(carried["input_distance_mean"].get<double>(), 0.01, 2e-4);

  const Json of_step = {{"surface.input_distance", {{"of", "step_input"}}}};
  EXPECT_THROW(evaluate_mesh(gt, outer, &scan, {"surface.input_distance"}, of_step, ctx, 2000),
               NotApplicable);
  data.points = PointCloud();  // a chain that started from the ground truth holds no points
  try {
    evaluate(gt, data, DataKind::Mesh, &scan, {"surface.input_distance"}, of_step, ctx, 2000);
    ADD_FAILURE() << "of=step_input scored without a step input";
  } catch (const NotApplicable& e) {
    EXPECT_NE(std::string(e.what()).find("of=step_input"), std::string::npos) << e.what();
  }
  const Json skipped = evaluate(gt, data, DataKind::Mesh, &scan, {}, of_step, ctx, 2000);
  EXPECT_TRUE(skipped["skipped"].contains("surface.input_distance")) << skipped["skipped"].dump();
  EXPECT_THROW(evaluate(gt, data, DataKind::Mesh, &scan, {"surface.input_distance"},
                        Json{{"surface.input_distance", {{"of", "points"}}}}, ctx, 2000),
               ParamError);
}

}  // namespace
}  // namespace scanbench::metrics
