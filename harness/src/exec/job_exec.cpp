// The child side of a job: dataset -> (cached) scan -> algorithm chain (repeated for timing) ->
// metrics -> outputs. Runs inside `scanbench job`; the parent turns the result into a record.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <optional>

#include "point_dataset.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/chain.h"
#include "scanbench/harness/records.h"
#include "scanbench/harness/runner.h"
#include "scanbench/harness/test_algorithms.h"
#include "scanbench/metrics/distance_field.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/heatmap.h"
#include "scanbench/metrics/surface.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

std::string mesh_hash(const TriangleMesh& m) {
  std::string bytes;
  bytes.append(reinterpret_cast<const char*>(m.vertices.data()),
               sizeof(float) * static_cast<std::size_t>(m.vertices.size()));
  bytes.append(reinterpret_cast<const char*>(m.faces.data()),
               sizeof(int) * static_cast<std::size_t>(m.faces.size()));
  return content_hash(bytes);
}

/// "<host>.<pid>": a name private to this process even when tasks on several nodes share the
/// results folder (pids repeat across nodes).
std::string private_tag() {
  char host[256] = {0};
  if (gethostname(host, sizeof(host) - 1) != 0) host[0] = 0;
  return fmt::format("{}.{}", host, getpid());
}

template <class M>
bool same_bytes(const M& a, const M& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(),
                     sizeof(typename M::Scalar) * static_cast<std::size_t>(a.size())) == 0;
}

// Repeat identity of what the chain is scored on (its primary kind), bit for bit: the points'
// positions, the mesh's vertices and faces, or the covariance mesh's means, covariances and
// faces (not the points a mesh step carries through).
bool same_output(const StageData& a, const StageData& b, DataKind primary) {
  switch (primary) {
    case DataKind::Mesh:
      return a.mesh && b.mesh && same_bytes(a.mesh->vertices, b.mesh->vertices) &&
             same_bytes(a.mesh->faces, b.mesh->faces);
    case DataKind::CovarianceMesh:
      return a.covariance_mesh && b.covariance_mesh &&
             same_bytes(a.covariance_mesh->means, b.covariance_mesh->means) &&
             same_bytes(a.covariance_mesh->covariances, b.covariance_mesh->covariances) &&
             a.covariance_mesh->face_offsets == b.covariance_mesh->face_offsets &&
             a.covariance_mesh->face_vertices == b.covariance_mesh->face_vertices;
    case DataKind::Mixture:
      return a.mixture && b.mixture && same_bytes(a.mixture->weights, b.mixture->weights) &&
             same_bytes(a.mixture->means, b.mixture->means) &&
             same_bytes(a.mixture->covariances, b.mixture->covariances);
    default:
      return same_bytes(a.points.positions, b.points.positions);
  }
}

}  // namespace

Json execute_job(const Job& job, const fs::path& out) {
  Json res = Json::object();
  Json timing = Json::object();
  Json artifacts = Json::object();
  Json sizes = Json::object();
  RunContext ctx(job.seed, job.threads);

  // A point dataset (experiment.h): its points instead of a scan, and a mesh or a point cloud
  // (point_truth) as ground truth.
  const bool from_points = job.scanner_preset == kPointsInput;
  std::optional<PointTruth> point_truth;
  if (job.dataset_params.contains("gt_points")) point_truth = read_point_truth(job.dataset_params);
  PointCloud input = from_points
                         ? read_input_points(job.dataset_params.at("points").get<std::string>())
                         : PointCloud();
  const TriangleMesh mesh =
      point_truth ? TriangleMesh()
                  : load_dataset(job.dataset, from_points ? Json::object() : job.dataset_params);
  // The dataset's local origin (core stage_data.h): zero, except for a mesh file whose coordinates
  // float32 cannot hold (survey / UTM data). Scan, chain and metrics run in the local frame; the
  // origin is recorded and restored on every file written.
  const Eigen::Vector3d origin = point_truth ? input.origin : mesh.origin;
  if (from_points) rebase(input, origin);
  const bool has_origin = !origin.isZero(0.0);
  if (has_origin) res["dataset_origin"] = {origin.x(), origin.y(), origin.z()};
  // The ground_truth input (experiment.h): no scan, the chain starts from the mesh itself.
  const bool from_ground_truth = job.scanner_preset == kGroundTruthInput;

  // Scan, cached by content: the mesh bytes, the effective scanner parameters, the seed and the
  // scan model version.
  Json scan_key = {{"mesh", mesh_hash(mesh)},
                   {"scanner", job.scanner_params},
                   {"seed", job.seed},
                   {"scan_model", scanner::kScanModelVersion}};
  // The local vertices of a mesh and of its translate can be equal bit for bit; the scan file
  // (world coordinates) differs. Absent at origin zero, so earlier caches stay valid.
  if (has_origin) scan_key["origin"] = res["dataset_origin"];
  const std::string scan_hash = content_hash(scan_key.dump());
  const fs::path ply = out / "scans" / (scan_hash + ".ply");
  const double t_scan = wall_seconds();
  const bool cached = from_ground_truth || from_points ||
                      (fs::exists(ply) && fs::exists(scanner::sidecar_path(ply)));
  if (!cached) {
    const auto p = params_from_json<scanner::ScannerParams>(job.scanner_params,
                                                            "scanner " + job.scanner_label);
    const scanner::Scan s = scanner::scan(mesh, p, ctx);
    // Write under a private name, then rename (sidecar first: the PLY marks completion). Jobs
    // running at once (local children, Slurm tasks) may both scan: the bytes are the same (one
    // seed), each rename is atomic, so a reader sees no file or a whole one.
    const fs::path tmp = out / "scans" / fmt::format(".{}.{}.ply", scan_hash, private_tag());
    scanner::write_scan(s, tmp);
    fs::rename(scanner::sidecar_path(tmp), scanner::sidecar_path(ply));
    // A photogrammetric scan's COLMAP workspace (write_scan: <ply>.colmap/) goes along.
    if (fs::path ws_tmp = fs::path(tmp) += ".colmap"; fs::exists(ws_tmp)) {
      const fs::path ws = fs::path(ply) += ".colmap";
      std::error_code ec;
      fs::remove_all(ws, ec);
      fs::rename(ws_tmp, ws, ec);
      if (ec) fs::remove_all(ws_tmp, ec);  // another job's rename won: the bytes are the same
    }
    fs::rename(tmp, ply);
  }
  // Every job reads the scan back from the cache, so a cached and a fresh scan give the same
  // input bit for bit.
  PointCloud cloud = from_ground_truth ? PointCloud()
                     : from_points     ? std::move(input)
                                       : read_point_cloud(ply);
  if (!from_ground_truth && cloud.origin != origin) {
    throw IoError(fmt::format("{}: the scan's local origin ({} {} {}) is not its mesh's ({} {} {})",
                              ply.string(), cloud.origin.x(), cloud.origin.y(), cloud.origin.z(),
                              origin.x(), origin.y(), origin.z()));
  }
  timing["scan_s"] = wall_seconds() - t_scan;
  timing["scan_cached"] = cached;
  if (from_ground_truth) {
    sizes["input_mesh_vertices"] = mesh.num_vertices();
    sizes["input_mesh_faces"] = mesh.num_faces();
  } else if (from_points) {
    artifacts["input_points"] = job.dataset_params.at("points");
    sizes["scan_points"] = cloud.size();
  } else {
    artifacts["scan"] = "scans/" + scan_hash + ".ply";
    artifacts["scan_record"] = "scans/" + scan_hash + ".ply.json";
    sizes["scan_points"] = cloud.size();
  }
  if (cloud.has_property("outlier")) {
    sizes["scan_outliers"] = cloud.properties.at("outlier").sum();
  }

  // The chain, `repeats` times; every sample of every phase is kept.
  std::map<std::string, std::vector<double>> phases;
  std::vector<double> total, cpu;
  // Memory of each step (first repeat; Linux /proc, else absent): step_peak_rss_mb = the job's
  // peak RSS while the step ran (the peak is reset before it), step_work_mb = that peak minus the
  // RSS before the step, plus the peak RSS of a program the step ran (reconstruct.poisson's
  // colmap, measured alone: RunContext::program_peak_rss_kb, also recorded as
  // step_program_peak_rss_mb): the working memory the step needed on top of its input (the GPS
  // paper's "build MB" of Fig. 13c and 14).
  Json step_peak = Json::object(), step_work = Json::object(), step_program = Json::object();
  StageData final_out;
  bool identical = true;
  // What the chain is scored on: the primary kind of its last step (a mesh for a reconstruction,
  // the mean mesh of a covariance mesh, else the points).
  const DataKind primary =
      algorithm_entry(job.chain.back().at("algorithm").get<std::string>()).fn.io.primary;
  for (int rep = 0; rep < job.repeats; ++rep) {
    StageData cur;
    if (from_ground_truth) {
      cur.mesh = mesh;
    } else {
      cur.points = cloud;
    }
    // Every step sees its input in the local frame with origin zero, as data at the world origin
    // (an external program is handed float32 local coordinates); the origin goes back on the
    // chain's result below, whatever each step did with it.
    cur.set_origin(Eigen::Vector3d::Zero());
    ChainRun run = run_chain(job.chain, std::move(cur), ctx, rep == 0);
    for (const auto& [k, v] : run.step_peak_mb)
      step_peak[k] = v;
    for (const auto& [k, v] : run.step_work_mb)
      step_work[k] = v;
    for (const auto& [k, v] : run.step_program_mb)
      step_program[k] = v;
    for (const auto& [k, v] : run.covmesh_sizes.items())
      sizes[k] = v;
    cur = std::move(run.output);
    cpu.push_back(run.cpu_s);
    total.push_back(run.wall_s);
    for (const auto& [k, v] : run.phases)
      phases[k].push_back(v);
    if (rep == 0) {
      final_out = std::move(cur);
    } else {
      identical = identical && same_output(final_out, cur, primary);
    }
  }
  timing["total_s"] = total;
  timing["cpu_s"] = cpu;
  Json ph = Json::object();
  for (const auto& [k, v] : phases)
    ph[k] = v;
  timing["phases"] = ph;
  timing["step_peak_rss_mb"] = step_peak;
  timing["step_work_mb"] = step_work;
  timing["step_program_peak_rss_mb"] = step_program;
  res["repeat_outputs_identical"] = identical;
  final_out.set_origin(origin);  // written outputs restore world coordinates
  // The scored mesh (mean mesh of a covariance mesh); sizes describe the scored output (a mesh
  // output's points are the input carried through, not an output).
  // A chain ending in a mixture is scored on its components as points.
  if (primary == DataKind::Mixture) final_out.points = final_out.mixture->component_points();
  std::optional<TriangleMesh> scored_mesh;
  if (primary == DataKind::Mesh) scored_mesh = final_out.mesh;
  if (primary == DataKind::CovarianceMesh) scored_mesh = final_out.covariance_mesh->mean_mesh();
  res["output_kind"] = kind_name(primary);
  if (scored_mesh) {
    sizes["mesh_vertices"] = primary == DataKind::CovarianceMesh
                                 ? final_out.covariance_mesh->num_vertices()
                                 : scored_mesh->num_vertices();
    sizes["mesh_faces"] = primary == DataKind::CovarianceMesh
                              ? final_out.covariance_mesh->num_faces()
                              : scored_mesh->num_faces();
  } else {
    sizes["output_points"] = final_out.points.size();
  }
  if (final_out.mixture) sizes["mixture_components"] = final_out.mixture->size();

  // Metrics.
  ctx.clear_phases();
  const double t_metrics = wall_seconds();
  std::optional<metrics::GroundTruth> gt_mesh;
  if (!point_truth) gt_mesh.emplace(mesh, ctx.stream_seed("ground_truth"));
  const PointCloud* scan = from_ground_truth ? nullptr : &cloud;
  Json m = point_truth ? evaluate_on_point_truth(*point_truth, final_out.points,
                                                 scored_mesh ? &*scored_mesh : nullptr, job.metrics,
                                                 job.metric_params, ctx)
           : primary == DataKind::CovarianceMesh
               ? metrics::evaluate_covariance_mesh(*gt_mesh, *final_out.covariance_mesh, scan,
                                                   job.metrics, job.metric_params, ctx)
           : scored_mesh ? metrics::evaluate_mesh(*gt_mesh, *scored_mesh, scan, job.metrics,
                                                  job.metric_params, ctx)
                         : metrics::evaluate(*gt_mesh, final_out.points, scan, job.metrics,
                                             job.metric_params, ctx);
  timing["metrics_s"] = wall_seconds() - t_metrics;
  Json metric_phases = Json::object();
  for (const auto& [k, v] : ctx.phase_seconds())
    metric_phases[k] = v;
  timing["metric_phases"] = metric_phases;
  for (const char* k : {"histograms", "metric_params", "skipped"}) {
    if (m.contains(k)) {
      res[k] = m[k];
      m.erase(k);
    }
  }
  Json flat = Json::object();
  for (const auto& [k, v] : m.items()) {
    if (v.is_number() || v.is_boolean()) flat[k] = v;
  }
  res["metrics"] = flat;

  if (job.save_outputs) {
    const fs::path base = out / "outputs" / job.id;
    if (final_out.points.size() > 0) {  // none when the chain started from the ground truth
      write_point_cloud(final_out.points, base.string() + ".ply");
      artifacts["output"] = "outputs/" + job.id + ".ply";
    }
    if (final_out.mixture) {
      write_mixture(*final_out.mixture, base.string() + ".mixture.ply");
      artifacts["mixture"] = "outputs/" + job.id + ".mixture.ply";
    }
    if (final_out.mesh) {
      write_mesh(*final_out.mesh, base.string() + ".mesh.ply");
      artifacts["mesh"] = "outputs/" + job.id + ".mesh.ply";
    }
    if (final_out.covariance_mesh) {
      write_covariance_mesh(*final_out.covariance_mesh, base.string() + ".covmesh.ply");
      artifacts["covariance_mesh"] = "outputs/" + job.id + ".covmesh.ply";
    }
    if (!gt_mesh) {  // a point ground truth: no heatmap or distance field
      res["timing"] = timing;
      res["sizes"] = sizes;
      res["artifacts"] = artifacts;
      return res;
    }
    const metrics::GroundTruth& gt = *gt_mesh;
    // Heatmap on four views. Points: the point-to-plane error E(q) = <q - p, N_p> (CLOP paper
    // sec. 10.2) of every output point. Mesh outputs: the distance to the ground truth of the same
    // seeded samples of the output surface the metrics scored (metrics::output_surface_samples).
    metrics::HeatmapParams hp;
    hp.width = hp.height = 256;
    const std::string title = fmt::format("{} / {} / {} {}", job.dataset_label, job.scanner_label,
                                          job.variant, job.point_label);
    if (scored_mesh) {
      const PointCloud samples = metrics::output_surface_samples(
          *scored_mesh, m.value("output_mesh_samples", Eigen::Index{100000}), ctx);
      const Eigen::VectorXf d = gt.distances(samples.positions, metrics::DistancePath::Exact);
      metrics::write_heatmap(samples, d, gt.bbox(), gt.diagonal(), hp,
                             base.string() + ".heatmap.png", title + ": surface |d|");
      artifacts["heatmap"] = "outputs/" + job.id + ".heatmap.png";
    } else if (final_out.points.size() > 0) {
      const auto cps = gt.closest_points(final_out.points.positions);
      Eigen::VectorXf err(final_out.points.size());
      for (Eigen::Index i = 0; i < err.size(); ++i) {
        const auto& c = cps[static_cast<std::size_t>(i)];
        err[i] = (final_out.points.positions.col(i) - c.point).dot(c.normal);
      }
      metrics::write_heatmap(final_out.points, err, gt.bbox(), gt.diagonal(), hp,
                             base.string() + ".heatmap.png", title + ": |E|");
      artifacts["heatmap"] = "outputs/" + job.id + ".heatmap.png";
    }
    // The ground truth's distance field, once per mesh.
    const fs::path vdb = out / "fields" / (scan_key["mesh"].get<std::string>() + ".vdb");
    if (!fs::exists(vdb)) {
      fs::create_directories(vdb.parent_path());
      const fs::path tmp =
          vdb.parent_path() / fmt::format(".{}.{}", private_tag(), vdb.filename().string());
      gt.field().write_vdb(tmp, "distance");
      fs::rename(tmp, vdb);
    }
    artifacts["field"] = "fields/" + vdb.filename().string();
  }
  res["timing"] = timing;
  res["sizes"] = sizes;
  res["artifacts"] = artifacts;
  return res;
}

}  // namespace scanbench::harness
