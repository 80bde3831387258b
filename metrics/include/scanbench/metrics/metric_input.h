#pragma once
// What every metric function is given (registry.h registers them; evaluate.h fills it): the ground
// truth, the output points or surface samples, and what evaluate() shares between metrics. The
// metric headers include this, not the registry.
#include <vector>

#include "scanbench/core/covariance_mesh.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/params.h"  // Json, the metrics' parameter declarations
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::metrics {

class GroundTruth;    // metrics/ground_truth.h: the mesh with its distance oracles
struct ClosestPoint;  // metrics/ground_truth.h

struct MetricInput {
  const GroundTruth& truth;
  /// The algorithm's output points; for a mesh output, the seeded area-uniform samples of the
  /// output surface (evaluate_mesh), with the sampled face's unit normal as normal.
  const PointCloud& output;
  const PointCloud* scan = nullptr;  ///< the chain's input scan (outliers, noise, input distance)
  /// For a mesh output: the points the chain held when it ended, i.e. the points its
  /// reconstruction consumed (the last point set a step produced, or the scan when none did;
  /// core/stage_data.h carries them through the mesh steps and evaluate(StageData) passes them).
  /// Null for point outputs and for chains that hold no points (started from the ground truth).
  const PointCloud* step_input = nullptr;
  const TriangleMesh* output_mesh = nullptr;  ///< set for mesh outputs
  /// Set when the output is a covariance mesh (output_mesh is then its mean mesh).
  const CovarianceMesh* output_covariance_mesh = nullptr;
  /// The exact closest-point oracle of the output mesh (a GroundTruth built on it), when the
  /// output is a mesh and a metric declared needs_output_oracle.
  const GroundTruth* output_oracle = nullptr;
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

/// The exact closest points of in.output (in.closest, or computed now).
std::vector<ClosestPoint> closest_points_of(const MetricInput& in);

}  // namespace scanbench::metrics
