#pragma once
// `scanbench eval`: the metrics (metrics/evaluate.h) of one output file against a ground truth,
// as one flat JSON object: every metric key, "histograms", "metric_params", "skipped", and
// "inputs" (what was compared, the seed, the field voxel, written images and fields).
#include <cstdint>
#include <string>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct EvalRequest {
  /// The ground truth: a mesh file, a dataset name (with dataset_params), or a point cloud
  /// (gt_points, aligned by gt_transform, both clouds cropped to gt_crop: metrics/point_truth.h).
  std::string mesh, dataset, gt_points, gt_transform, gt_crop;
  Json dataset_params = Json::object();
  std::string points, output_mesh;      ///< the output: one of the two
  std::string scan;                     ///< the algorithm's input scan (for outliers.residue)
  std::string heatmap, vdb;             ///< folders for the images and the distance fields
  std::vector<std::string> metrics;     ///< empty = every registered metric
  Json metric_params = Json::object();  ///< metric -> params; "heatmap" -> HeatmapParams
  std::uint64_t seed = 0;
  int threads = 0;
  double field_voxel = 1.0 / 512.0;
  std::int64_t mesh_samples = 100000;
};

struct EvalResult {
  Json record;                 ///< the JSON object described above
  std::int64_t points = 0;     ///< the output points the point metrics saw
  std::int64_t gt_points = 0;  ///< with gt_points: the ground-truth points after the crop
  std::int64_t gt_faces = 0;   ///< with a mesh ground truth: its faces
};

/// Runs the request; throws ParamError for a bad request (names the `eval` option), IoError and
/// InputError for bad files.
EvalResult evaluate_files(const EvalRequest& r);

}  // namespace scanbench::harness
