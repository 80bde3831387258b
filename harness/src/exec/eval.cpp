#include "scanbench/harness/eval.h"

#include <fmt/format.h>

#include <filesystem>
#include <memory>

#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/metrics/distance_field.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/heatmap.h"
#include "scanbench/metrics/mesh_volume.h"
#include "scanbench/metrics/p2plane.h"
#include "scanbench/metrics/point_truth.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/metrics/surface_sampling.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

// --gt-points: a point-cloud ground truth (metrics/point_truth.h): aligned by the transform,
// both clouds cropped to the box; only the point-capable metrics run.
EvalResult eval_point_truth(const EvalRequest& q) {
  if (q.points.empty()) throw ParamError("eval: --gt-points needs --points FILE");
  RunContext ctx(q.seed, q.threads);
  PointCloud truth = read_point_cloud(q.gt_points);
  PointCloud out = metrics::transformed(read_point_cloud(q.points), Eigen::Matrix4d::Identity());
  truth = metrics::transformed(
      truth, q.gt_transform.empty()
                 ? Eigen::Matrix4d::Identity()
                 : metrics::parse_transform(q.gt_transform, "eval --gt-transform"));
  if (!q.gt_crop.empty()) {
    const BoundingBox box = metrics::parse_crop(q.gt_crop, "eval --gt-crop");
    truth = metrics::cropped(truth, box);
    out = metrics::cropped(out, box);
  }
  EvalResult res;
  res.record = metrics::evaluate_point_truth(truth, out, q.metrics, q.metric_params, ctx);
  Json inputs = Json::object();
  inputs["ground_truth_points"] = q.gt_points;
  inputs["gt_transform"] = q.gt_transform.empty() ? Json(nullptr) : Json(q.gt_transform);
  inputs["gt_crop"] = q.gt_crop.empty() ? Json(nullptr) : Json(q.gt_crop);
  inputs["output"] = q.points;
  inputs["output_kind"] = "points";
  inputs["seed"] = ctx.seed();
  res.record["inputs"] = inputs;
  res.points = res.record["output_points"].get<std::int64_t>();
  res.gt_points = res.record["gt_points"].get<std::int64_t>();
  return res;
}

/// The folder of --heatmap or --vdb; IoError with the reason (a file in the way, read-only).
void make_folder(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    throw IoError(fmt::format("{}: cannot create the folder: {}", dir.string(), ec.message()));
  }
}

/// --heatmap DIR: the point-to-plane error of what the point metrics saw on four views, and
/// one image per histogram of the record. Returns the files written.
Json write_eval_images(const fs::path& dir, const metrics::GroundTruth& gt,
                       const PointCloud& points, const metrics::HeatmapParams& heat,
                       const Json& record) {
  Json images = Json::array();
  make_folder(dir);
  const auto closest = gt.closest_points(points.positions);
  const Eigen::VectorXf e = metrics::point_to_plane_errors(points.positions, closest);
  const fs::path png = dir / "heatmap_p2plane.png";
  metrics::write_heatmap(points, e, gt.bbox(), gt.diagonal(), heat, png,
                         fmt::format("point-to-plane |E|, {} points", points.size()));
  images.push_back(png.string());
  for (const auto& [name, h] : record["histograms"].items()) {
    const fs::path hp = dir / ("histogram_" + name + ".png");
    metrics::write_histogram_image(h, hp, name + " (" + h.value("unit", "") + ")");
    images.push_back(hp.string());
  }
  return images;
}

/// --vdb DIR: the ground truth's distance field and, for a mesh output, the output's. Returns
/// the files written.
Json write_eval_fields(const fs::path& dir, const metrics::GroundTruth& gt,
                       const TriangleMesh* out_mesh) {
  Json fields = Json::array();
  make_folder(dir);
  gt.field().write_vdb(dir / "ground_truth.vdb", "ground_truth");
  fields.push_back((dir / "ground_truth.vdb").string());
  if (out_mesh) {
    metrics::output_field(gt, *out_mesh).write_vdb(dir / "output_mesh.vdb", "output_mesh");
    fields.push_back((dir / "output_mesh.vdb").string());
  }
  return fields;
}

/// A mesh ground truth (--mesh, --dataset): the output points or mesh scored by
/// metrics::evaluate, then the images and fields asked for.
EvalResult eval_mesh_truth(const EvalRequest& q) {
  if (q.dataset.empty() == q.mesh.empty())
    throw ParamError("eval: give exactly one of --mesh FILE, --dataset NAME or --gt-points FILE");
  if (q.points.empty() == q.output_mesh.empty())
    throw ParamError("eval: give exactly one of --points FILE or --output-mesh FILE");
  const TriangleMesh gt_mesh =
      q.mesh.empty() ? load_dataset(q.dataset, q.dataset_params) : read_mesh(q.mesh);
  Json metric_params = q.metric_params;
  Json heat_json = Json::object();
  if (metric_params.contains("heatmap")) {
    heat_json = metric_params["heatmap"];
    metric_params.erase("heatmap");
  }
  const auto heat = params_from_json<metrics::HeatmapParams>(heat_json, "eval --set heatmap");
  // Reject bad metric names and parameters before any file is read.
  for (const auto& [name, obj] : metric_params.items())
    metrics::registry().at(name).params.validate(obj, "eval --set " + name);

  RunContext ctx(q.seed, q.threads);
  metrics::GroundTruthOptions gopt;
  gopt.field_voxel = q.field_voxel;
  const metrics::GroundTruth gt(gt_mesh, ctx.stream_seed("metrics.surface_samples"), gopt);

  // Local origins (core stage_data.h): every input is re-expressed in the ground truth's
  // frame, so metrics compare like with like whatever origin each file was read with.
  std::unique_ptr<PointCloud> scan;
  if (!q.scan.empty()) {
    scan = std::make_unique<PointCloud>(read_point_cloud(q.scan));
    rebase(*scan, gt_mesh.origin);
  }
  StageData output;
  PointCloud points;  // what the point metrics saw (for the heatmap)
  if (!q.points.empty()) {
    output.points = read_point_cloud(q.points);
    rebase(output.points, gt_mesh.origin);
  } else {
    output.mesh = read_mesh(q.output_mesh);
    rebase(*output.mesh, gt_mesh.origin);
  }
  const DataKind kind = output.mesh ? DataKind::Mesh : DataKind::Points;
  EvalResult res;
  res.record = metrics::evaluate(gt, output, kind, scan.get(), q.metrics, metric_params, ctx,
                                 q.mesh_samples);
  points = output.mesh ? metrics::sample_surface(*output.mesh, q.mesh_samples,
                                                 ctx.stream_seed("eval.mesh_samples"))
                       : output.points;
  const Json images = q.heatmap.empty()
                          ? Json::array()
                          : write_eval_images(q.heatmap, gt, points, heat, res.record);
  const Json fields = q.vdb.empty()
                          ? Json::array()
                          : write_eval_fields(q.vdb, gt, output.mesh ? &*output.mesh : nullptr);
  Json inputs = Json::object();
  inputs["ground_truth"] = q.mesh.empty() ? q.dataset : q.mesh;
  inputs["ground_truth_params"] = q.dataset_params;
  inputs["gt_vertices"] = gt_mesh.num_vertices();
  inputs["gt_faces"] = gt_mesh.num_faces();
  if (!gt_mesh.origin.isZero(0.0)) {
    inputs["dataset_origin"] = {gt_mesh.origin.x(), gt_mesh.origin.y(), gt_mesh.origin.z()};
  }
  inputs["output"] = q.points.empty() ? q.output_mesh : q.points;
  inputs["output_kind"] = q.points.empty() ? "mesh" : "points";
  inputs["scan"] = q.scan.empty() ? Json(nullptr) : Json(q.scan);
  inputs["seed"] = q.seed;
  inputs["field_voxel_rel"] = q.field_voxel;
  inputs["heatmap_params"] = params_to_json(heat);
  inputs["images"] = images;
  inputs["fields"] = fields;
  Json phases = Json::object();
  for (const auto& [k, v] : ctx.phase_seconds())
    phases[k] = v;
  inputs["phase_seconds"] = phases;
  res.record["inputs"] = inputs;
  res.points = points.size();
  res.gt_faces = gt_mesh.num_faces();
  return res;
}

}  // namespace

EvalResult evaluate_files(const EvalRequest& r) {
  return r.gt_points.empty() ? eval_mesh_truth(r) : eval_point_truth(r);
}

}  // namespace scanbench::harness
