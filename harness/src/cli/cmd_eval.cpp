// scanbench eval --mesh GT | --dataset NAME | --gt-points FILE [--gt-transform M] [--gt-crop C]
//                --points OUT.ply | --output-mesh MESH
//                [--scan SCAN.ply] [--step-input PTS.ply] [--metrics a,b]
//                [--set metric.key=value ...]
//                [--heatmap DIR] [--vdb DIR] [--seed N] [--threads N] -o metrics.json
// scanbench eval --from-record DIR/jobs/ID.json | DIR/runs.jsonl --id ID [-o metrics.json]
// Evaluates one output against a ground truth with the registered metrics (metrics/evaluate.h)
// and writes one flat JSON object: every metric key, "histograms", "metric_params", "skipped",
// "scoring" (the seeds of the surface samples) and "inputs" (what was compared, the seed, the
// field voxel, written images and fields). --from-record scores a job's output again with its
// record's scoring and prints the comparison, key by key (exit 1 on any difference).
#include <fmt/format.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/json_text.h"
#include "scanbench/harness/exec/eval.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

namespace {

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
  const Json value = parse_assigned_value(text, "eval --set " + lhs);
  params[lhs.substr(0, dot)][lhs.substr(dot + 1)] = value;
}

std::string fmt_value(const Json& v) {
  if (v.is_number_float()) return fmt::format("{:.6g}", v.get<double>());
  return v.dump();
}

/// The summary line and one line per metric key (with its `_rel` value), then the skipped.
void print_eval(const EvalResult& res, double seconds, const std::string& output) {
  const Json& record = res.record;
  fmt::print("eval: {} points vs {} ({} faces) in {:.2f} s -> {}\n", res.points,
             record["inputs"]["ground_truth"].get<std::string>(), res.gt_faces, seconds, output);
  for (const auto& [k, v] : record.items()) {
    if (v.is_object() || v.is_array() || k.ends_with("_rel")) continue;
    const std::string rel = record.contains(k + "_rel") && !record[k + "_rel"].is_null()
                                ? fmt::format("  ({} {})", fmt_value(record[k + "_rel"]),
                                              k.ends_with("_var") ? "diag^2" : "diag")
                                : "";
    fmt::print("  {:<28} {}{}\n", k, fmt_value(v), rel);
  }
  const Json skipped = record.value("skipped", Json::object());
  for (const auto& [k, v] : skipped.items())
    fmt::print("  skipped {}: {}\n", k, v.get<std::string>());
}

std::string cell(const Json& v) {
  if (v.is_null()) return "(absent)";
  if (v.is_number_float()) return fmt::format("{:.17g}", v.get<double>());
  if (v.is_object() || v.is_array()) return fmt::format("{} entries", v.size());
  return v.dump();
}

/// One line per compared key, then the verdict; returns the exit code (1 on any difference).
int print_record_check(const RecordCheck& c) {
  fmt::print("eval --from-record: job {} of {}, scored again (seed {})\n", c.id, c.folder,
             c.request.seed);
  fmt::print("  {:<28} {:>24} {:>24}\n", "key", "record", "eval");
  for (const auto& r : c.rows)
    fmt::print("  {:<28} {:>24} {:>24}  {}\n", r.key, cell(r.recorded), cell(r.rescored),
               r.same ? "same" : "DIFFERENT");
  if (c.differences == 0) {
    fmt::print("all {} keys equal bit for bit\n", c.rows.size());
    return 0;
  }
  fmt::print("{} of {} keys differ\n", c.differences, c.rows.size());
  return 1;
}

}  // namespace

void add_eval_command(Cli& cli) {
  struct Opts : EvalRequest {
    std::vector<std::string> sets, dataset_sets;
    std::string output, from_record, record_id;
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
      "only accuracy.chamfer (precision/recall/F-score at tau, Tanks and Temples), "
      "accuracy.p2plane and regularity.nn_dist run, the others are reported not applicable");
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
  sub->add_option("--step-input", opts->step_input,
                  "With --output-mesh: the points the reconstruction consumed (.ply), for "
                  "surface.input_distance.of=step_input");
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
  auto* fr = sub->add_option(
      "--from-record", opts->from_record,
      "Score a job's output again as its record says (DIR/jobs/ID.json, or DIR/runs.jsonl with "
      "--id): same seeds, metrics and parameters; prints record vs eval per key, exit 1 on any "
      "difference");
  sub->add_option("--id", opts->record_id, "The job id of the runs.jsonl line for --from-record")
      ->needs(fr);
  for (auto* o : {mf, ds, gp, pf, om})
    fr->excludes(o);
  sub->add_option("-o,--output", opts->output, "Metrics JSON file (required unless --from-record)");
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      if (!opts->from_record.empty()) {
        const RecordCheck c = rescore_record(opts->from_record, opts->record_id, opts->threads);
        if (!opts->output.empty()) write_json_file(opts->output, c.result.record, 2);
        return print_record_check(c);
      }
      if (opts->output.empty()) throw ParamError("eval: -o FILE is required");
      const auto t0 = std::chrono::steady_clock::now();
      EvalRequest q = *opts;
      for (const auto& s : opts->dataset_sets)
        apply_assignment(q.dataset_params, s);
      for (const auto& s : opts->sets)
        apply_metric_set(q.metric_params, s);
      const EvalResult res = evaluate_files(q);
      write_json_file(opts->output, res.record, 2);
      if (!q.gt_points.empty()) {
        fmt::print("eval: {} points vs {} ground-truth points -> {}\n", res.points, res.gt_points,
                   opts->output);
        return 0;
      }
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      print_eval(res, seconds, opts->output);
      return 0;
    };
  });
}

}  // namespace scanbench::harness
