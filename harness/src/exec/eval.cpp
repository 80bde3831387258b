#include "scanbench/harness/exec/eval.h"

#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <optional>

#include "config/json_checks.h"
#include "exec/point_dataset.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/table.h"
#include "scanbench/metrics/distance_field.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/heatmap.h"
#include "scanbench/metrics/mesh_volume.h"
#include "scanbench/metrics/p2plane.h"
#include "scanbench/metrics/point_truth.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/metrics/surface.h"
#include "scanbench/metrics/surface_sampling.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

// --gt-points: a point-cloud ground truth (metrics/point_truth.h): aligned by the transform,
// both clouds cropped to the box; only the point-capable metrics run. The job's code
// (point_dataset.h) reads and scores it, so eval and a job score alike.
EvalResult eval_point_truth(const EvalRequest& q) {
  if (q.points.empty() == q.output_mesh.empty())
    throw ParamError("eval: --gt-points needs one of --points FILE or --output-mesh FILE");
  RunContext ctx(q.seed, q.threads);
  Json truth_params = {{"gt_points", q.gt_points}};
  if (!q.gt_transform.empty()) truth_params["gt_transform"] = q.gt_transform;
  if (!q.gt_crop.empty()) truth_params["gt_crop"] = q.gt_crop;
  const PointTruth truth = read_point_truth(truth_params);
  const PointCloud out = q.points.empty() ? PointCloud() : read_point_cloud(q.points);
  const std::optional<TriangleMesh> mesh =
      q.output_mesh.empty() ? std::nullopt : std::optional<TriangleMesh>(read_mesh(q.output_mesh));
  EvalResult res;
  res.record =
      evaluate_on_point_truth(truth, out, mesh ? &*mesh : nullptr, q.metrics, q.metric_params, ctx);
  res.record["scoring"]["metrics"] = q.metrics;
  if (mesh) {
    res.record["scoring"]["output_mesh_samples"] = res.record["output_mesh_samples"];
    res.record["scoring"]["output_mesh_samples_seed"] = metrics::output_surface_samples_seed(ctx);
  }
  Json inputs = Json::object();
  inputs["ground_truth_points"] = q.gt_points;
  inputs["gt_transform"] = q.gt_transform.empty() ? Json(nullptr) : Json(q.gt_transform);
  inputs["gt_crop"] = q.gt_crop.empty() ? Json(nullptr) : Json(q.gt_crop);
  inputs["output"] = q.points.empty() ? q.output_mesh : q.points;
  inputs["output_kind"] = q.points.empty() ? "mesh" : "points";
  inputs["seed"] = ctx.seed();
  res.record["inputs"] = inputs;
  res.points = res.record.value("output_points", std::int64_t{0});
  res.gt_points = res.record.value("gt_points", std::int64_t{0});
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
  if (int(!q.points.empty()) + int(!q.output_mesh.empty()) +
          int(!q.output_covariance_mesh.empty()) !=
      1)
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
  gopt.band_voxels = q.field_band_voxels;
  // The stream a job draws from, so `eval --seed <job seed>` scores the job's samples.
  const metrics::GroundTruth gt(
      gt_mesh, q.sample_seed.value_or(ctx.stream_seed(metrics::kGroundTruthSamplesStream)), gopt);

  // Local origins (core stage_data.h): every input is re-expressed in the ground truth's
  // frame, so metrics compare like with like whatever origin each file was read with.
  std::unique_ptr<PointCloud> scan;
  if (!q.scan.empty()) {
    scan = std::make_unique<PointCloud>(read_point_cloud(q.scan));
    rebase(*scan, gt_mesh.origin);
  }
  StageData output;
  PointCloud points;  // what the point metrics saw (for the heatmap)
  DataKind kind = DataKind::Points;
  std::optional<TriangleMesh> scored_mesh;  // a mesh output, or a covariance mesh's mean mesh
  if (!q.points.empty()) {
    output.points = read_point_cloud(q.points);
    rebase(output.points, gt_mesh.origin);
  } else if (!q.output_mesh.empty()) {
    output.mesh = read_mesh(q.output_mesh);
    rebase(*output.mesh, gt_mesh.origin);
    kind = DataKind::Mesh;
    scored_mesh = output.mesh;
  } else {
    output.covariance_mesh = read_covariance_mesh(q.output_covariance_mesh);
    rebase(*output.covariance_mesh, gt_mesh.origin);
    kind = DataKind::CovarianceMesh;
    scored_mesh = output.covariance_mesh->mean_mesh();
  }
  // A mesh output's step input travels as a chain's does: as the points beside the mesh.
  if (!q.step_input.empty()) {
    if (kind == DataKind::Points)
      throw ParamError("eval: --step-input goes with --output-mesh (the points it was built from)");
    output.points = read_point_cloud(q.step_input);
    rebase(output.points, gt_mesh.origin);
  }
  EvalResult res;
  res.record = metrics::evaluate(gt, output, kind, scan.get(), q.metrics, metric_params, ctx,
                                 q.mesh_samples);
  points = scored_mesh ? metrics::output_surface_samples(*scored_mesh, q.mesh_samples, ctx)
                       : output.points;
  const Json images = q.heatmap.empty()
                          ? Json::array()
                          : write_eval_images(q.heatmap, gt, points, heat, res.record);
  const Json fields = q.vdb.empty()
                          ? Json::array()
                          : write_eval_fields(q.vdb, gt, scored_mesh ? &*scored_mesh : nullptr);
  Json inputs = Json::object();
  inputs["ground_truth"] = q.mesh.empty() ? q.dataset : q.mesh;
  inputs["ground_truth_params"] = q.dataset_params;
  inputs["gt_vertices"] = gt_mesh.num_vertices();
  inputs["gt_faces"] = gt_mesh.num_faces();
  if (!gt_mesh.origin.isZero(0.0)) {
    inputs["dataset_origin"] = {gt_mesh.origin.x(), gt_mesh.origin.y(), gt_mesh.origin.z()};
  }
  inputs["output"] = !q.points.empty()        ? q.points
                     : !q.output_mesh.empty() ? q.output_mesh
                                              : q.output_covariance_mesh;
  inputs["output_kind"] = kind_name(kind);
  inputs["scan"] = q.scan.empty() ? Json(nullptr) : Json(q.scan);
  inputs["step_input"] = q.step_input.empty() ? Json(nullptr) : Json(q.step_input);
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

/// The record `id` of a jobs/<id>.json file or a runs.jsonl file, and its results folder.
std::pair<Json, fs::path> read_record(const fs::path& source, const std::string& id) {
  const std::string where = "eval --from-record " + source.string();
  if (source.extension() == ".jsonl") {
    if (id.empty()) throw ParamError(where + ": a runs.jsonl file needs --id ID (a job id)");
    std::vector<std::string> ids;
    // The folder's records (runs.jsonl, checked, or jobs/ when newer: records.h).
    for (const Json& r : load_records(fs::absolute(source).parent_path())) {
      if (r.value("id", std::string()) == id) return {r, fs::absolute(source).parent_path()};
      ids.push_back(r.value("id", std::string()));
    }
    throw ParamError(where + ": no record with id " + id + did_you_mean(id, ids));
  }
  Json r = read_json_file(source);
  check_record(r, where);
  if (!id.empty() && r.value("id", std::string()) != id)
    throw ParamError(where + ": the record's id is not " + id);
  // jobs/<id>.json: artifacts are relative to the folder holding jobs/.
  const fs::path dir = fs::absolute(source).parent_path();
  if (dir.filename() != "jobs")
    throw ParamError(where + ": expected <results>/jobs/<id>.json or <results>/runs.jsonl");
  return {r, dir.parent_path()};
}

/// An artifact of the record as a path inside `dir` (rule: paths from the record stay inside
/// the results folder); "" when the record has none.
std::string artifact(const Json& rec, const fs::path& dir, const std::string& key) {
  const Json& a = rec.contains("artifacts") && rec["artifacts"].is_object()
                      ? rec["artifacts"].value(key, Json())
                      : Json();
  if (a.is_null()) return "";
  if (!a.is_string())
    throw ParamError("eval --from-record: artifacts." + key + ": expected a relative path");
  const fs::path rel = a.get<std::string>();
  bool inside = !rel.empty() && rel.is_relative();
  for (const auto& part : rel)
    inside = inside && part != "..";
  if (!inside)
    throw ParamError("eval --from-record: artifacts." + key + ": " + rel.string() +
                     " is not a path inside the results folder");
  return (dir / rel).string();
}

const Json& field(const Json& rec, const char* key, Json::value_t type) {
  if (!rec.contains(key) || rec[key].type() != type)
    throw ParamError(std::string("eval --from-record: the record's ") + key +
                     " is missing or of the wrong type");
  return rec[key];
}

/// The request that scores the record's output as its job did.
EvalRequest request_of(const Json& rec, const fs::path& dir) {
  if (rec.value("status", std::string()) != "ok")
    throw ParamError("eval --from-record: job " + rec.value("id", std::string()) + " has status " +
                     rec.value("status", Json("?")).dump() + "; only an ok job has metrics");
  if (!rec.contains("scoring") || !rec["scoring"].is_object())
    throw ParamError(
        "eval --from-record: the record has no \"scoring\" (written before scanbench recorded "
        "its sample seeds); run the job again");
  const Json& scoring = rec["scoring"];
  const Json& dataset = field(rec, "dataset", Json::value_t::object);
  const Json& scanner = field(rec, "scanner", Json::value_t::object);
  const Json params = dataset.value("params", Json::object());
  EvalRequest q;
  q.seed = scoring.value("seed", std::uint64_t{0});
  q.metrics = scoring.value("metrics", std::vector<std::string>());
  q.metric_params = field(rec, "metric_params", Json::value_t::object);
  const bool from_points = scanner.value("preset", std::string()) == kPointsInput;
  if (params.contains("gt_points")) {
    q.gt_points = params["gt_points"].get<std::string>();
    q.gt_transform = params.value("gt_transform", std::string());
    q.gt_crop = params.value("gt_crop", std::string());
  } else {
    q.dataset = dataset.value("name", std::string());
    q.dataset_params = from_points ? Json::object() : params;
    q.sample_seed = scoring.at("ground_truth_samples_seed").get<std::uint64_t>();
    q.field_voxel = scoring.value("field_voxel_rel", q.field_voxel);
    q.field_band_voxels = scoring.value("field_band_voxels", q.field_band_voxels);
  }
  q.mesh_samples = scoring.value("output_mesh_samples", q.mesh_samples);
  const std::string kind = rec.value("output_kind", std::string("points"));
  if (kind == "mesh" || kind == "covariance_mesh") {
    // The points the chain carried beside its mesh (the step input), when it held any.
    q.step_input = artifact(rec, dir, "output");
  }
  if (kind == "mesh") {
    q.output_mesh = artifact(rec, dir, "mesh");
  } else if (kind == "covariance_mesh") {
    q.output_covariance_mesh = artifact(rec, dir, "covariance_mesh");
  } else {
    q.points = artifact(rec, dir, "output");
  }
  if (q.points.empty() && q.output_mesh.empty() && q.output_covariance_mesh.empty())
    throw ParamError("eval --from-record: the record names no output file (save_outputs off?)");
  // The scan the metrics saw: the cached scan, or a point dataset's input file.
  q.scan = artifact(rec, dir, "scan");
  if (q.scan.empty() && from_points && q.gt_points.empty()) {
    const std::string input = params.value("points", std::string());
    if (!fs::is_directory(input)) q.scan = input;
  }
  return q;
}

RecordCheck::Row row(const std::string& key, const Json& recorded, const Json& rescored) {
  return {key, recorded, rescored, recorded == rescored};
}

}  // namespace

EvalResult evaluate_files(const EvalRequest& r) {
  return r.gt_points.empty() ? eval_mesh_truth(r) : eval_point_truth(r);
}

RecordCheck rescore_record(const std::string& source, const std::string& id, int threads) {
  RecordCheck c;
  const auto [rec, dir] = read_record(source, id);
  c.id = rec.value("id", std::string());
  c.folder = dir.string();
  c.request = request_of(rec, dir);
  c.request.threads = threads;
  c.result = evaluate_files(c.request);
  const Json& now = c.result.record;
  // A job's "metrics" are the numbers and booleans evaluate returned (job_exec.cpp).
  const Json recorded = field(rec, "metrics", Json::value_t::object);
  Json rescored = Json::object();
  for (const auto& [k, v] : now.items())
    if (v.is_number() || v.is_boolean()) rescored[k] = v;
  for (const auto& [k, v] : recorded.items())
    c.rows.push_back(row(k, v, rescored.value(k, Json())));
  for (const auto& [k, v] : rescored.items())
    if (!recorded.contains(k)) c.rows.push_back(row(k, Json(), v));
  Json scoring = now.value("scoring", Json());
  for (const char* k : {"histograms", "skipped", "metric_params"})
    c.rows.push_back(row(k, rec.value(k, Json()), now.value(k, Json())));
  c.rows.push_back(row("scoring", rec["scoring"], scoring));
  for (const auto& r : c.rows)
    c.differences += r.same ? 0 : 1;
  return c;
}

}  // namespace scanbench::harness
