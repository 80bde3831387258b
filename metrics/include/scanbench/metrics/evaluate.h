#pragma once
// evaluate(): runs metrics on one output and returns one flat JSON record:
//   every key of every metric run (see registry.h for names and the `_rel` convention),
//   "histograms": {name: histogram}, "metric_params": {metric: effective params},
//   "skipped": {metric: reason}: metrics of the other output kind (points and normals metrics
//     for a mesh, mesh metrics for points; also when asked for by name, see registry.h) and,
//     when running all metrics, those that do not apply (no normals, no scan),
//   "output_points" (points only), "gt_diagonal", "gt_closed".
// Every key a metric emits must be declared in its registry entry (Error otherwise).
// The exact closest points of the output are computed once and shared by the metrics that need
// them. Each metric's wall time goes to ctx phase "metric.<name>".
#include <string>
#include <vector>

#include "scanbench/core/covariance_mesh.h"
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/core/triangle_mesh.h"
#include "scanbench/metrics/ground_truth.h"

namespace scanbench::metrics {

/// metric_names empty = every registered metric (skipping those that do not apply); otherwise
/// exactly those (UnknownNameError for an unknown one; NotApplicable if one cannot run).
/// metric_params: object metric name -> params object (ParamError for unknown metric names,
/// unknown keys, wrong types or out-of-range values). InputError for an empty or invalid output.
Json evaluate(const GroundTruth& gt, const PointCloud& output, const PointCloud* scan,
              const std::vector<std::string>& metric_names, const Json& metric_params,
              RunContext& ctx);

/// For a mesh output: the metrics that score a mesh (surface.h, mesh_volume.h, mesh_facts.h) on
/// the mesh and on `samples` area-uniform samples of it (output_surface_samples: ctx stream
/// "eval.mesh_samples", face normals as normals); their closest points on the ground truth are
/// computed once, and the output mesh's exact oracle once. Adds "output_mesh_samples".
/// InputError for an invalid mesh or one without area.
Json evaluate_mesh(const GroundTruth& gt, const TriangleMesh& output_mesh, const PointCloud* scan,
                   const std::vector<std::string>& metric_names, const Json& metric_params,
                   RunContext& ctx, Eigen::Index samples = 100000);

/// For a covariance mesh output: evaluate_mesh on its mean mesh (fan-triangulated), with
/// mesh.facts describing the covariance mesh itself (its polygons and bytes).
Json evaluate_covariance_mesh(const GroundTruth& gt, const CovarianceMesh& output,
                              const PointCloud* scan, const std::vector<std::string>& metric_names,
                              const Json& metric_params, RunContext& ctx,
                              Eigen::Index samples = 100000);

/// The one entry for a stage's output (a job's chain, `scanbench eval`), scored as its `primary`
/// kind: a covariance mesh by evaluate_covariance_mesh, a mesh by evaluate_mesh, a mixture by
/// evaluate on its components as points, points by evaluate. For a mesh or covariance mesh,
/// `output.points` (when not empty) are the points the chain carried to its reconstruction
/// (StageData::carry) and become MetricInput::step_input (surface.input_distance of=step_input);
/// this is the only way the step input reaches the metrics. InputError when `output` lacks the
/// primary kind.
Json evaluate(const GroundTruth& gt, const StageData& output, DataKind primary,
              const PointCloud* scan, const std::vector<std::string>& metric_names,
              const Json& metric_params, RunContext& ctx, Eigen::Index samples = 100000);

}  // namespace scanbench::metrics
