#pragma once
// `scanbench eval`: the metrics (metrics/evaluate.h) of one output file against a ground truth,
// as one flat JSON object: every metric key, "histograms", "metric_params", "skipped", and
// "inputs" (what was compared, the seed, the field voxel, written images and fields).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct EvalRequest {
  /// The ground truth: a mesh file, a dataset name (with dataset_params), or a point cloud
  /// (gt_points, aligned by gt_transform, both clouds cropped to gt_crop: metrics/point_truth.h).
  std::string mesh, dataset, gt_points, gt_transform, gt_crop;
  Json dataset_params = Json::object();
  std::string points, output_mesh;     ///< the output: one of the two
  std::string output_covariance_mesh;  ///< or a covariance mesh (--from-record only)
  std::string scan;                    ///< the algorithm's input scan (for outliers.residue)
  /// For a mesh output: the points its reconstruction consumed (surface.input_distance
  /// of=step_input); --from-record takes the job's saved points (artifacts.output).
  std::string step_input;
  std::string heatmap, vdb;             ///< folders for the images and the distance fields
  std::vector<std::string> metrics;     ///< empty = every registered metric
  Json metric_params = Json::object();  ///< metric -> params; "heatmap" -> HeatmapParams
  std::uint64_t seed = 0;
  /// The ground truth's surface-sample seed; unset: stream "ground_truth" of `seed`, as in a job.
  std::optional<std::uint64_t> sample_seed;
  int threads = 0;
  double field_voxel = 1.0 / 512.0;
  float field_band_voxels = 5.0f;
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

/// `eval --from-record`: one job's record scored again from its results folder, with the
/// record's "scoring" (seeds of the ground truth's and the output mesh's surface samples, the
/// field voxel, the metric list) and effective metric_params, and compared key by key.
struct RecordCheck {
  struct Row {
    std::string key;  ///< a metrics key, or "histograms", "skipped", "metric_params", "scoring"
    Json recorded, rescored;  ///< null when absent on that side
    bool same = false;        ///< equal bit for bit (JSON numbers round-trip exactly)
  };
  std::string id;         ///< the record's job id
  std::string folder;     ///< the results folder its artifacts are relative to
  EvalRequest request;    ///< what was scored
  EvalResult result;      ///< the new scores
  std::vector<Row> rows;  ///< every compared key, metrics keys first
  std::size_t differences = 0;
};

/// `source` is a jobs/<id>.json file of a results folder, or a runs.jsonl file with `id` naming
/// the line. ParamError for a missing or unknown id, a record that is not "ok" or has no
/// "scoring" (written before scanbench recorded it); IoError for a missing output file; the
/// artifact paths of the record must stay inside the folder (no "..", not absolute).
RecordCheck rescore_record(const std::string& source, const std::string& id, int threads);

}  // namespace scanbench::harness
