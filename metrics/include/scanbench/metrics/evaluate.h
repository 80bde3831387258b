#pragma once
// evaluate(): runs metrics on one output and returns one flat JSON record:
//   every key of every metric run (see registry.h for names and the `_rel` convention),
//   "histograms": {name: histogram}, "metric_params": {metric: effective params},
//   "skipped": {metric: reason} (metrics that do not apply, only when running all of them),
//   "output_points", "gt_diagonal", "gt_closed".
// The exact closest points of the output are computed once and shared by the metrics that need
// them. Each metric's wall time goes to ctx phase "metric.<name>".
#include <string>
#include <vector>

#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"
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

/// For reconstructions: the same point metrics on `samples` uniform points sampled from the
/// output mesh (seeded from ctx stream "eval.mesh_samples", face normals as normals), plus
/// "mesh.volume". Adds "output_mesh_samples".
Json evaluate_mesh(const GroundTruth& gt, const TriangleMesh& output_mesh, const PointCloud* scan,
                   const std::vector<std::string>& metric_names, const Json& metric_params,
                   RunContext& ctx, Eigen::Index samples = 100000);

}  // namespace scanbench::metrics
