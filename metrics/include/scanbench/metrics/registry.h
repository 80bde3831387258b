#pragma once
// The metric registry: every metric by dotted name with its declared parameters. A metric maps
// (ground truth, output) to a JSON object of named values (the keys listed below) and may add
// histograms under "histograms".
//
// Registered metrics (metrics/src/registry.cpp), their keys, and the reporting convention:
// every length is reported twice, `key` in the units of the ground-truth mesh and `key_rel` as a
// fraction of the ground-truth bounding-box diagonal (variances: `_rel` divides by diagonal^2).
//   accuracy.p2plane   p2plane_mean|rms|max|p50|p90|p99   (p2plane.h)
//   accuracy.chamfer   accuracy completeness chamfer hausdorff precision recall fscore (chamfer.h)
//   regularity.nn_dist nn_dist_mean nn_dist_var nn_dist_cv                       (regularity.h)
//   normals.angle      normal_angle_mean_deg normal_angle_rms_deg normal_pgp5 normal_pgp10
//   outliers.residue   outlier_residue (+ outlier_threshold, scan_noise)    (outlier_residue.h)
//   mesh.volume        volume_mean_abs_diff volume_iou (reconstructions only)   (mesh_volume.h)
#include <functional>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/registry.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::metrics {

class GroundTruth;    // metrics/ground_truth.h: the mesh with its distance oracles
struct ClosestPoint;  // metrics/ground_truth.h

struct MetricInput {
  const GroundTruth& truth;
  const PointCloud& output;                   ///< the algorithm's output points
  const PointCloud* scan = nullptr;           ///< the algorithm's input (for outlier residue)
  const TriangleMesh* output_mesh = nullptr;  ///< set for reconstructions
  /// Exact closest points of every output point on the ground truth, when already computed
  /// (evaluate() computes them once for all metrics); metrics compute them when null.
  const std::vector<ClosestPoint>* closest = nullptr;
};

/// Thrown by a metric that cannot be computed for this input (no normals, no scan, no mesh).
/// evaluate() records it under "skipped" when running all metrics and rethrows it when the
/// metric was asked for by name.
class NotApplicable : public InputError {
 public:
  using InputError::InputError;
};

using MetricFn = std::function<Json(const MetricInput& in, const Json& params, RunContext& ctx)>;
using MetricRegistry = Registry<MetricFn>;

/// Every registered metric, in one explicit list (metrics/src/registry.cpp).
const MetricRegistry& registry();

/// The exact closest points of in.output (in.closest, or computed now).
std::vector<ClosestPoint> closest_points_of(const MetricInput& in);

}  // namespace scanbench::metrics
