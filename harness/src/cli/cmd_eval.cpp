// scanbench eval --mesh GT | --dataset NAME | --gt-points FILE [--gt-transform M] [--gt-crop C]
//                --points OUT.ply | --output-mesh MESH
//                [--scan SCAN.ply] [--metrics a,b] [--set metric.key=value ...]
//                [--heatmap DIR] [--vdb DIR] [--seed N] [--threads N] -o metrics.json
// Evaluates one output against a ground truth with the registered metrics (metrics/evaluate.h)
// and writes one flat JSON object: every metric key, "histograms", "metric_params", "skipped",
// and "inputs" (what was compared, the seed, the field voxel, written images and fields).
#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_context.h"
#include "scanbench/harness/records.h"
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

namespace {

namespace fs = std::filesystem;

// "accuracy.chamfer.tau=0.01" -> params["accuracy.chamfer"]["tau"] = 0.01 (value as JSON when
// it parses, else a string). Metric names hold dots, so the key is split at the last one.
void apply_metric_set(Json& params, const std::string& s) {
  const auto eq = s.find('=');
  if (eq == std::string::npos || eq == 0)
    throw ParamError("eval --set " + s + ": expected metric.key=value");
  const std::string lhs = s.substr(0, eq);
  const auto dot = lhs.rfind('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == lhs.size())
    throw ParamError("eval --set " + s + ": expected <metric name>.<key>=value");
  const std::string text = s.substr(eq + 1);
  Json value = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (value.is_discarded()) value = text;
  params[lhs.substr(0, dot)][lhs.substr(dot + 1)] = value;
}

// --gt-points: a point-cloud ground truth (metrics/point_truth.h): aligned by the transform,
// both clouds cropped to the box; only the point-capable metrics run.
Json eval_point_truth(const std::string& gt_file, const std::string& transform,
                      const std::string& crop, const std::string& points,
                      const std::vector<std::string>& names, const Json& metric_params,
                      RunContext& ctx) {
  PointCloud truth = read_point_cloud(gt_file);
  PointCloud out = metrics::transformed(read_point_cloud(points), Eigen::Matrix4d::Identity());
  truth = metrics::transformed(
      truth, transform.empty() ? Eigen::Matrix4d::Identity()
                               : metrics::parse_transform(transform, "eval --gt-transform"));
  if (!crop.empty()) {
    const BoundingBox box = metrics::parse_crop(crop, "eval --gt-crop");
    truth = metrics::cropped(truth, box);
    out = metrics::cropped(out, box);
  }
  Json record = metrics::evaluate_point_truth(truth, out, names, metric_params, ctx);
  Json inputs = Json::object();
  inputs["ground_truth_points"] = gt_file;
  inputs["gt_transform"] = transform.empty() ? Json(nullptr) : Json(transform);
  inputs["gt_crop"] = crop.empty() ? Json(nullptr) : Json(crop);
  inputs["output"] = points;
  inputs["output_kind"] = "points";
  inputs["seed"] = ctx.seed();
  record["inputs"] = inputs;
  return record;
}

std::string fmt_value(const Json& v) {
  if (v.is_number_float()) return fmt::format("{:.6g}", v.get<double>());
  return v.dump();
}

}  // namespace

void add_eval_command(Cli& cli) {
  struct Opts {
    std::string mesh, dataset, points, output_mesh, scan, heatmap, vdb, output;
    std::string gt_points, gt_transform, gt_crop;
    std::vector<std::string> metrics, sets, dataset_sets;
    std::uint64_t seed = 0;
    int threads = 0;
    double field_voxel = 1.0 / 512.0;
    std::int64_t mesh_samples = 100000;
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = cli.app.add_subcommand(
      "eval",
      "Evaluate output points (or a reconstructed mesh) against a ground-truth mesh: every "
      "registered metric (scanbench list metrics), histograms, optional heatmaps and .vdb fields");
  auto* mf = sub->add_option("--mesh", opts->mesh, "Ground-truth mesh file (.off .ply .obj .stl)");
  auto* ds = sub->add_option("--dataset", opts->dataset,
                             "Ground-truth dataset name (scanbench list datasets)");
  auto* gp = sub->add_option(
      "--gt-points", opts->gt_points,
      "Ground-truth point cloud (.ply, .xyz, .pwn; normals used when present) instead of a mesh: "
      "only accuracy.chamfer (precision/recall/F-score at tau, Tanks and Temples) and "
      "accuracy.p2plane run, the others are reported not applicable");
  sub->add_option("--gt-transform", opts->gt_transform,
                  "4x4 alignment of the ground-truth points: a file of 16 numbers (row-major, "
                  "e.g. Tanks and Temples' _trans.txt) or the numbers themselves")
      ->needs(gp);
  sub->add_option("--gt-crop", opts->gt_crop,
                  "Crop box xmin,ymin,zmin,xmax,ymax,zmax (aligned frame) applied to the "
                  "ground truth and the output")
      ->needs(gp);
  mf->excludes(ds);
  ds->excludes(mf);
  gp->excludes(mf);
  gp->excludes(ds);
  sub->add_option("--dataset-set", opts->dataset_sets,
                  "Dataset parameter key=value (repeatable), e.g. for procedural shapes");
  auto* pf = sub->add_option("--points", opts->points, "Output point cloud (.ply)");
  auto* om = sub->add_option("--output-mesh", opts->output_mesh,
                             "Reconstructed mesh: metrics on points sampled from it + mesh.volume");
  pf->excludes(om);
  om->excludes(pf);
  sub->add_option("--scan", opts->scan,
                  "The algorithm's input scan (.ply with clean_x/y/z, outlier): for "
                  "outliers.residue");
  sub->add_option("--metrics", opts->metrics, "Only these metrics (comma separated)")
      ->delimiter(',');
  sub->add_option("--set", opts->sets,
                  "Metric parameter <metric>.<key>=value, e.g. accuracy.chamfer.tau=0.01; "
                  "heatmap.<key>=value for the heatmap (repeatable)");
  sub->add_option("--heatmap", opts->heatmap,
                  "Write heatmap_p2plane.png and histogram_<name>.png into this folder");
  sub->add_option("--vdb", opts->vdb,
                  "Write ground_truth.vdb (and output_mesh.vdb) distance fields into this folder");
  sub->add_option("--seed", opts->seed,
                  "Seed of the fixed surface samples and of the output-mesh samples");
  sub->add_option("--threads", opts->threads, "Worker threads (0 = all); never changes results")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--field-voxel", opts->field_voxel,
                  "Distance-field voxel, fraction of the GT bbox diagonal")
      ->check(CLI::Range(1e-5, 0.1));
  sub->add_option("--mesh-samples", opts->mesh_samples,
                  "Points sampled from --output-mesh for the point metrics")
      ->check(CLI::Range(std::int64_t{10}, std::int64_t{100000000}));
  sub->add_option("-o,--output", opts->output, "Metrics JSON file")->required();
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      if (!opts->gt_points.empty()) {
        if (opts->points.empty()) throw ParamError("eval: --gt-points needs --points FILE");
        Json metric_params = Json::object();
        for (const auto& s : opts->sets)
          apply_metric_set(metric_params, s);
        RunContext ctx(opts->seed, opts->threads);
        const Json record = eval_point_truth(opts->gt_points, opts->gt_transform, opts->gt_crop,
                                             opts->points, opts->metrics, metric_params, ctx);
        const fs::path out_json(opts->output);
        if (out_json.has_parent_path()) fs::create_directories(out_json.parent_path());
        write_file_atomic(out_json, record.dump(2) + "\n");
        fmt::print("eval: {} points vs {} ground-truth points -> {}\n",
                   record["output_points"].get<std::int64_t>(),
                   record["gt_points"].get<std::int64_t>(), opts->output);
        return 0;
      }
      if (opts->dataset.empty() == opts->mesh.empty())
        throw ParamError(
            "eval: give exactly one of --mesh FILE, --dataset NAME or --gt-points FILE");
      if (opts->points.empty() == opts->output_mesh.empty())
        throw ParamError("eval: give exactly one of --points FILE or --output-mesh FILE");
      const auto t0 = std::chrono::steady_clock::now();
      Json dataset_params = Json::object();
      for (const auto& s : opts->dataset_sets)
        apply_assignment(dataset_params, s);
      const TriangleMesh gt_mesh =
          opts->mesh.empty() ? load_dataset(opts->dataset, dataset_params) : read_mesh(opts->mesh);
      Json metric_params = Json::object();
      for (const auto& s : opts->sets)
        apply_metric_set(metric_params, s);
      Json heat_json = Json::object();
      if (metric_params.contains("heatmap")) {
        heat_json = metric_params["heatmap"];
        metric_params.erase("heatmap");
      }
      const auto heat = params_from_json<metrics::HeatmapParams>(heat_json, "eval --set heatmap");
      // Reject bad metric names and parameters before any file is read.
      for (const auto& [name, obj] : metric_params.items())
        metrics::registry().at(name).params.validate(obj, "eval --set " + name);

      RunContext ctx(opts->seed, opts->threads);
      metrics::GroundTruthOptions gopt;
      gopt.field_voxel = opts->field_voxel;
      const metrics::GroundTruth gt(gt_mesh, ctx.stream_seed("metrics.surface_samples"), gopt);

      // Local origins (core stage_data.h): every input is re-expressed in the ground truth's
      // frame, so metrics compare like with like whatever origin each file was read with.
      std::unique_ptr<PointCloud> scan;
      if (!opts->scan.empty()) {
        scan = std::make_unique<PointCloud>(read_point_cloud(opts->scan));
        rebase(*scan, gt_mesh.origin);
      }

      Json record;
      PointCloud points;  // what the point metrics saw (for the heatmap)
      std::unique_ptr<TriangleMesh> out_mesh;
      if (!opts->points.empty()) {
        points = read_point_cloud(opts->points);
        rebase(points, gt_mesh.origin);
        record = metrics::evaluate(gt, points, scan.get(), opts->metrics, metric_params, ctx);
      } else {
        out_mesh = std::make_unique<TriangleMesh>(read_mesh(opts->output_mesh));
        rebase(*out_mesh, gt_mesh.origin);
        record = metrics::evaluate_mesh(gt, *out_mesh, scan.get(), opts->metrics, metric_params,
                                        ctx, opts->mesh_samples);
        points = metrics::sample_surface(*out_mesh, opts->mesh_samples,
                                         ctx.stream_seed("eval.mesh_samples"));
      }

      Json images = Json::array();
      if (!opts->heatmap.empty()) {
        const fs::path dir(opts->heatmap);
        fs::create_directories(dir);
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
      }
      Json fields = Json::array();
      if (!opts->vdb.empty()) {
        const fs::path dir(opts->vdb);
        fs::create_directories(dir);
        gt.field().write_vdb(dir / "ground_truth.vdb", "ground_truth");
        fields.push_back((dir / "ground_truth.vdb").string());
        if (out_mesh) {
          metrics::output_field(gt, *out_mesh).write_vdb(dir / "output_mesh.vdb", "output_mesh");
          fields.push_back((dir / "output_mesh.vdb").string());
        }
      }

      Json inputs = Json::object();
      inputs["ground_truth"] = opts->mesh.empty() ? opts->dataset : opts->mesh;
      inputs["ground_truth_params"] = dataset_params;
      inputs["gt_vertices"] = gt_mesh.num_vertices();
      inputs["gt_faces"] = gt_mesh.num_faces();
      if (!gt_mesh.origin.isZero(0.0)) {
        inputs["dataset_origin"] = {gt_mesh.origin.x(), gt_mesh.origin.y(), gt_mesh.origin.z()};
      }
      inputs["output"] = opts->points.empty() ? opts->output_mesh : opts->points;
      inputs["output_kind"] = opts->points.empty() ? "mesh" : "points";
      inputs["scan"] = opts->scan.empty() ? Json(nullptr) : Json(opts->scan);
      inputs["seed"] = opts->seed;
      inputs["field_voxel_rel"] = opts->field_voxel;
      inputs["heatmap_params"] = params_to_json(heat);
      inputs["images"] = images;
      inputs["fields"] = fields;
      Json phases = Json::object();
      for (const auto& [k, v] : ctx.phase_seconds())
        phases[k] = v;
      inputs["phase_seconds"] = phases;
      record["inputs"] = inputs;
      const fs::path out_json(opts->output);
      if (out_json.has_parent_path()) fs::create_directories(out_json.parent_path());
      write_file_atomic(out_json, record.dump(2) + "\n");

      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      fmt::print("eval: {} points vs {} ({} faces) in {:.2f} s -> {}\n", points.size(),
                 inputs["ground_truth"].get<std::string>(), gt_mesh.num_faces(), seconds,
                 opts->output);
      for (const auto& [k, v] : record.items()) {
        if (v.is_object() || v.is_array() || k.ends_with("_rel")) continue;
        const std::string rel = record.contains(k + "_rel") && !record[k + "_rel"].is_null()
                                    ? fmt::format("  ({} {})", fmt_value(record[k + "_rel"]),
                                                  k.ends_with("_var") ? "diag^2" : "diag")
                                    : "";
        fmt::print("  {:<28} {}{}\n", k, fmt_value(v), rel);
      }
      for (const auto& [k, v] : record["skipped"].items())
        fmt::print("  skipped {}: {}\n", k, v.get<std::string>());
      return 0;
    };
  });
}

}  // namespace scanbench::harness
