#pragma once
// The child side of a point dataset (experiment.h, DatasetSpec::points): its input points
// instead of a scan, and a point-cloud ground truth instead of a mesh (metrics/point_truth.h).
#include <optional>
#include <string>
#include <vector>

#include "scanbench/core/bbox.h"
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::harness {

/// The input of a point dataset: a folder is a COLMAP model or dense workspace
/// (colmap::import_dir), a file a point cloud (read_point_cloud). As read (local origin kept).
/// IoError / InputError naming the path.
PointCloud read_input_points(const std::string& path);

/// A point-cloud ground truth from a job's dataset_params ("gt_points", optional
/// "gt_transform", "gt_crop"): aligned, cropped, in world coordinates with origin zero.
struct PointTruth {
  PointCloud truth;
  std::optional<BoundingBox> crop;
};
PointTruth read_point_truth(const Json& dataset_params);

/// The chain's output scored against the points: output points as they are, an output mesh
/// through `output_mesh_samples` seeded samples of its surface (metrics::output_surface_samples,
/// as the mesh path samples it), both in world coordinates and cropped like the truth. The
/// metrics named (all when empty) that need a mesh go to "skipped" as not applicable.
Json evaluate_on_point_truth(const PointTruth& t, const PointCloud& output_points,
                             const TriangleMesh* output_mesh,
                             const std::vector<std::string>& metric_names,
                             const Json& metric_params, RunContext& ctx);

}  // namespace scanbench::harness
