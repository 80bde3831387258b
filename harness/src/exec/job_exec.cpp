// The child side of a job: dataset -> (cached) scan -> algorithm chain (repeated for timing) ->
// metrics -> outputs. Runs inside `scanbench job`; the parent turns the result into a record.
#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>

#include <algorithm>
#include <cstring>
#include <map>
#include <optional>

#include "exec/point_dataset.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/core/io.h"
#include "scanbench/core/json_text.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/config/plugins.h"
#include "scanbench/harness/config/test_algorithms.h"
#include "scanbench/harness/exec/chain.h"
#include "scanbench/harness/exec/runner.h"
#include "scanbench/harness/results/records.h"
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
             a.covariance_mesh->faces == b.covariance_mesh->faces;
    case DataKind::Mixture:
      return a.mixture && b.mixture && same_bytes(a.mixture->weights, b.mixture->weights) &&
             same_bytes(a.mixture->means, b.mixture->means) &&
             same_bytes(a.mixture->covariances, b.mixture->covariances);
    default:
      return same_bytes(a.points.positions, b.points.positions);
  }
}

/// A cache entry (a scan and its record, a distance field): files in one folder that a job
/// uses without building them when the entry's seal vouches for them. The seal, written
/// atomically after the files, lists each with its byte size and SHA-256 (OpenSSL, plugins.h):
/// a file truncated by a full disk, damaged or replaced later fails the check and is built
/// again, never used. Entries of earlier versions have no seal and are built again once.
struct CacheEntry {
  fs::path seal;                ///< "<folder>/<key>.check.json"
  std::vector<fs::path> files;  ///< in the seal's folder
};

/// Why the entry cannot be used ("" when it can): a file or the seal missing, not a regular
/// file (a link is not trusted), or a size or hash that is not the sealed one.
std::string cache_problem(const CacheEntry& e) try {
  std::error_code ec;
  if (!fs::is_regular_file(fs::symlink_status(e.seal, ec))) return "no seal";
  // A seal is a few hundred bytes; a larger one is damaged (and is not parsed).
  if (fs::file_size(e.seal, ec) > 16384 || ec) return "unreadable seal";
  const Json seal = parse_json_text(read_file(e.seal), e.seal.string());
  if (!seal.is_object() || !seal.contains("files") || !seal["files"].is_object()) {
    return "unreadable seal";
  }
  for (const fs::path& f : e.files) {
    const std::string name = f.filename().string();
    const Json& want = seal["files"].contains(name) ? seal["files"][name] : Json();
    if (!want.is_object() || !want.value("bytes", Json()).is_number_unsigned() ||
        !want.value("sha256", Json()).is_string()) {
      return name + " is not in the seal";
    }
    if (!fs::is_regular_file(fs::symlink_status(f, ec))) return name + " is missing";
    const std::uintmax_t bytes = fs::file_size(f, ec);
    if (ec) return name + ": " + ec.message();
    if (bytes != want["bytes"].get<std::uintmax_t>()) {
      return fmt::format("{} has {} bytes, sealed with {}", name, bytes,
                         want["bytes"].get<std::uintmax_t>());
    }
    if (file_sha256(f) != want["sha256"].get<std::string>()) {
      return name + "'s SHA-256 is not the sealed one";
    }
  }
  return "";
} catch (const Error& err) {
  return err.what();  // an unreadable file
}

/// Seals an entry whose files are written (write_file_atomic: each one whole).
void seal_cache(const CacheEntry& e) {
  Json files = Json::object();
  for (const fs::path& f : e.files) {
    std::error_code ec;
    const std::uintmax_t bytes = fs::file_size(f, ec);
    if (ec) throw IoError(fmt::format("{}: cannot read the size: {}", f.string(), ec.message()));
    files[f.filename().string()] = {{"bytes", bytes}, {"sha256", file_sha256(f)}};
  }
  write_file_atomic(e.seal, Json{{"files", files}}.dump(1) + "\n");
}

/// Whether the entry can be used; a present entry that fails its check is reported in the job's
/// log (the child's stderr) before it is built again.
bool cache_usable(const CacheEntry& e, const fs::path& key_file, std::string_view what) {
  const std::string why = cache_problem(e);
  if (why.empty()) return true;
  std::error_code ec;
  bool present = fs::exists(fs::symlink_status(e.seal, ec));
  for (const fs::path& f : e.files)
    present = present || fs::exists(fs::symlink_status(f, ec));
  if (present) {
    std::fprintf(stderr, "scanbench: %s: cache entry fails its check (%s); %s it again\n",
                 key_file.string().c_str(), why.c_str(), std::string(what).c_str());
    std::fflush(stderr);
  }
  return false;
}

/// rename(2) with the reason in the error.
void rename_or_throw(const fs::path& from, const fs::path& to) {
  if (::rename(from.c_str(), to.c_str()) != 0) throw io_error(to, "cannot write", errno);
}

/// The record a job returns, built in parts; execute_job appends timing, sizes and artifacts
/// last, in this order.
struct JobParts {
  Json res = Json::object();
  Json timing = Json::object();
  Json sizes = Json::object();
  Json artifacts = Json::object();
};

/// The job's input: the scan read back from the cache (scanned first when absent), a point
/// dataset's points, or none when the chain starts from the ground truth.
struct ScanInput {
  PointCloud cloud;
  std::string mesh_hash;  ///< of the dataset mesh (the distance-field cache key)
};

/// Pass 1, the scan, cached by content: the mesh bytes, the effective scanner parameters, the
/// seed and the scan model version. Fills timing.scan_s, scan_cached, the scan artifacts and
/// the input sizes.
ScanInput scan_pass(const Job& job, const TriangleMesh& mesh, const Eigen::Vector3d& origin,
                    PointCloud points, const fs::path& out, JobParts& r, RunContext& ctx) {
  const bool from_ground_truth = job.scanner_preset == kGroundTruthInput;
  const bool from_points = job.scanner_preset == kPointsInput;
  ScanInput in;
  in.mesh_hash = mesh_hash(mesh);
  Json scan_key = {{"mesh", in.mesh_hash},
                   {"scanner", job.scanner_params},
                   {"seed", job.seed},
                   {"scan_model", scanner::kScanModelVersion}};
  // The local vertices of a mesh and of its translate can be equal bit for bit; the scan file
  // (world coordinates) differs. Absent at origin zero, so earlier caches stay valid.
  if (r.res.contains("dataset_origin")) scan_key["origin"] = r.res["dataset_origin"];
  const std::string scan_hash = content_hash(scan_key.dump());
  const fs::path ply = out / "scans" / (scan_hash + ".ply");
  const CacheEntry entry{out / "scans" / (scan_hash + ".check.json"),
                         {ply, scanner::sidecar_path(ply)}};
  const double t_scan = wall_seconds();
  const bool cached = from_ground_truth || from_points || cache_usable(entry, ply, "scanning");
  if (!cached) {
    const auto p = params_from_json<scanner::ScannerParams>(job.scanner_params,
                                                            "scanner " + job.scanner_label);
    const scanner::Scan s = scanner::scan(mesh, p, ctx);
    // Written under a private name, renamed, then sealed (the seal marks a complete entry). Jobs
    // running at once (local children, Slurm tasks) may both scan: the bytes are the same (one
    // seed), each rename is atomic, so a reader sees no file or a whole one. On a failure (a
    // full disk) the private files are removed.
    const fs::path tmp = out / "scans" / fmt::format(".{}.{}.ply", scan_hash, private_tag());
    const fs::path ws_tmp = fs::path(tmp) += ".colmap";
    try {
      scanner::write_scan(s, tmp);
      // A photogrammetric scan's COLMAP workspace (write_scan: <ply>.colmap/) goes along.
      if (fs::exists(ws_tmp)) {
        const fs::path ws = fs::path(ply) += ".colmap";
        std::error_code ec;
        fs::remove_all(ws, ec);
        fs::rename(ws_tmp, ws, ec);
        if (ec) fs::remove_all(ws_tmp, ec);  // another job's rename won: the bytes are the same
      }
      rename_or_throw(scanner::sidecar_path(tmp), scanner::sidecar_path(ply));
      rename_or_throw(tmp, ply);
      seal_cache(entry);
    } catch (...) {
      std::error_code ec;
      fs::remove(tmp, ec);
      fs::remove(scanner::sidecar_path(tmp), ec);
      fs::remove_all(ws_tmp, ec);
      throw;
    }
  }
  // Every job reads the scan back from the cache, so a cached and a fresh scan give the same
  // input bit for bit.
  if (from_points) {
    in.cloud = std::move(points);
  } else if (!from_ground_truth) {
    in.cloud = read_point_cloud(ply);
  }
  if (!from_ground_truth && in.cloud.origin != origin) {
    throw IoError(fmt::format("{}: the scan's local origin ({} {} {}) is not its mesh's ({} {} {})",
                              ply.string(), in.cloud.origin.x(), in.cloud.origin.y(),
                              in.cloud.origin.z(), origin.x(), origin.y(), origin.z()));
  }
  r.timing["scan_s"] = wall_seconds() - t_scan;
  r.timing["scan_cached"] = cached;
  if (from_ground_truth) {
    r.sizes["input_mesh_vertices"] = mesh.num_vertices();
    r.sizes["input_mesh_faces"] = mesh.num_faces();
  } else if (from_points) {
    r.artifacts["input_points"] = job.dataset_params.at("points");
    r.sizes["scan_points"] = in.cloud.size();
  } else {
    r.artifacts["scan"] = "scans/" + scan_hash + ".ply";
    r.artifacts["scan_record"] = "scans/" + scan_hash + ".ply.json";
    r.sizes["scan_points"] = in.cloud.size();
  }
  if (in.cloud.has_property("outlier")) {
    r.sizes["scan_outliers"] = in.cloud.properties.at("outlier").sum();
  }
  return in;
}

/// Pass 2, the chain, `repeats` times; every sample of every phase is kept (timing.total_s,
/// cpu_s, phases). Memory of each step (first repeat; Linux /proc, else absent):
/// step_peak_rss_mb = the job's peak RSS while the step ran (the peak is reset before it),
/// step_work_mb = that peak minus the RSS before the step, plus the peak RSS of a program the
/// step ran (reconstruct.poisson's colmap, measured alone: RunContext::program_peak_rss_kb, also
/// recorded as step_program_peak_rss_mb): the working memory the step needed on top of its input
/// (the GPS paper's "build MB" of Fig. 13c and 14). Returns the first repeat's output; sets
/// repeat_outputs_identical (what the chain is scored on, bit for bit, in every repeat).
StageData chain_pass(const Job& job, const TriangleMesh& mesh, const ScanInput& in,
                     DataKind primary, JobParts& r, RunContext& ctx) {
  std::map<std::string, std::vector<double>> phases;
  std::vector<double> total, cpu;
  Json step_peak = Json::object(), step_work = Json::object(), step_program = Json::object();
  StageData final_out;
  bool identical = true;
  for (int rep = 0; rep < job.repeats; ++rep) {
    StageData cur;
    if (job.scanner_preset == kGroundTruthInput) {
      cur.mesh = mesh;
    } else {
      cur.points = in.cloud;
    }
    // Every step sees its input in the local frame with origin zero, as data at the world origin
    // (an external program is handed float32 local coordinates); the origin goes back on the
    // chain's result (execute_job), whatever each step did with it.
    cur.set_origin(Eigen::Vector3d::Zero());
    ChainRun run = run_chain(job.chain, std::move(cur), ctx, rep == 0);
    for (const auto& [k, v] : run.step_peak_mb)
      step_peak[k] = v;
    for (const auto& [k, v] : run.step_work_mb)
      step_work[k] = v;
    for (const auto& [k, v] : run.step_program_mb)
      step_program[k] = v;
    for (const auto& [k, v] : run.covmesh_sizes.items())
      r.sizes[k] = v;
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
  Json& timing = r.timing;
  timing["total_s"] = total;
  timing["cpu_s"] = cpu;
  Json ph = Json::object();
  for (const auto& [k, v] : phases)
    ph[k] = v;
  timing["phases"] = ph;
  timing["step_peak_rss_mb"] = step_peak;
  timing["step_work_mb"] = step_work;
  timing["step_program_peak_rss_mb"] = step_program;
  r.res["repeat_outputs_identical"] = identical;
  return final_out;
}

/// The sizes of the scored output: a mesh output's vertices and faces (a covariance mesh's own
/// polygons), else the output points (a mesh output's points are the input carried through, not
/// an output); the mixture's components.
void output_sizes(const StageData& out, DataKind primary, const TriangleMesh* scored_mesh,
                  Json& sizes) {
  if (scored_mesh) {
    sizes["mesh_vertices"] = primary == DataKind::CovarianceMesh
                                 ? out.covariance_mesh->num_vertices()
                                 : scored_mesh->num_vertices();
    sizes["mesh_faces"] = primary == DataKind::CovarianceMesh ? out.covariance_mesh->num_faces()
                                                              : scored_mesh->num_faces();
  } else {
    sizes["output_points"] = out.points.size();
  }
  if (out.mixture) sizes["mixture_components"] = out.mixture->size();
}

/// Pass 3, the metrics (metrics::evaluate on the primary kind against a mesh ground truth, or
/// evaluate_on_point_truth against a point one): res.metrics (the flat numbers), histograms,
/// metric_params, skipped, timing.metrics_s (since `t_metrics`, when the pass began with the
/// ground truth's oracles) and metric_phases. Returns what evaluate returned less the moved keys.
Json metrics_pass(const Job& job, const metrics::GroundTruth* gt, const PointTruth* point_truth,
                  const StageData& out, DataKind primary, const TriangleMesh* scored_mesh,
                  const PointCloud* scan, double t_metrics, JobParts& r, RunContext& ctx) {
  Json m = point_truth
               ? evaluate_on_point_truth(*point_truth, out.points, scored_mesh, job.metrics,
                                         job.metric_params, ctx)
               : metrics::evaluate(*gt, out, primary, scan, job.metrics, job.metric_params, ctx);
  r.timing["metrics_s"] = wall_seconds() - t_metrics;
  Json metric_phases = Json::object();
  for (const auto& [k, v] : ctx.phase_seconds())
    metric_phases[k] = v;
  r.timing["metric_phases"] = metric_phases;
  if (point_truth) {
    // evaluate_on_point_truth names only the point-capable metrics; the record keeps the job's
    // list, and the seed of a mesh output's samples.
    m["scoring"]["metrics"] = job.metrics;
    if (scored_mesh) {
      m["scoring"]["output_mesh_samples"] = m.value("output_mesh_samples", Eigen::Index{100000});
      m["scoring"]["output_mesh_samples_seed"] = metrics::output_surface_samples_seed(ctx);
    }
  }
  for (const char* k : {"histograms", "metric_params", "skipped", "scoring"}) {
    if (m.contains(k)) {
      r.res[k] = m[k];
      m.erase(k);
    }
  }
  Json flat = Json::object();
  for (const auto& [k, v] : m.items()) {
    if (v.is_number() || v.is_boolean()) flat[k] = v;
  }
  r.res["metrics"] = flat;
  return m;
}

/// Heatmap on four views. Points: the point-to-plane error E(q) = <q - p, N_p> (CLOP paper
/// sec. 10.2) of every output point. Mesh outputs: the distance to the ground truth of the same
/// seeded samples of the output surface the metrics scored (metrics::output_surface_samples).
/// Returns the file written (relative to the results folder); empty when there is nothing to draw.
std::string write_job_heatmap(const Job& job, const metrics::GroundTruth& gt, const StageData& out,
                              const TriangleMesh* scored_mesh, Eigen::Index mesh_samples,
                              const fs::path& base, RunContext& ctx) {
  metrics::HeatmapParams hp;
  hp.width = hp.height = 256;
  const std::string title = fmt::format("{} / {} / {} {}", job.dataset_label, job.scanner_label,
                                        job.variant, job.point_label);
  const std::string png = base.string() + ".heatmap.png";
  if (scored_mesh) {
    const PointCloud samples = metrics::output_surface_samples(*scored_mesh, mesh_samples, ctx);
    const Eigen::VectorXf d = gt.distances(samples.positions, metrics::DistancePath::Exact);
    metrics::write_heatmap(samples, d, gt.bbox(), gt.diagonal(), hp, png, title + ": surface |d|");
  } else if (out.points.size() > 0) {
    const auto cps = gt.closest_points(out.points.positions);
    Eigen::VectorXf err(out.points.size());
    for (Eigen::Index i = 0; i < err.size(); ++i) {
      const auto& c = cps[static_cast<std::size_t>(i)];
      err[i] = (out.points.positions.col(i) - c.point).dot(c.normal);
    }
    metrics::write_heatmap(out.points, err, gt.bbox(), gt.diagonal(), hp, png, title + ": |E|");
  } else {
    return "";
  }
  return "outputs/" + job.id + ".heatmap.png";
}

/// Pass 4 (save_outputs): the output's files (write_stage_data: outputs/<id>.ply,
/// .mixture.ply, .mesh.ply, .covmesh.ply) and, with a mesh ground truth, the heatmap and its
/// distance field, once per mesh (fields/<mesh hash>.vdb).
void outputs_pass(const Job& job, const metrics::GroundTruth* gt, const StageData& out,
                  const TriangleMesh* scored_mesh, Eigen::Index mesh_samples,
                  const std::string& mesh_key, const fs::path& dir, Json& artifacts,
                  RunContext& ctx) {
  const fs::path base = dir / "outputs" / job.id;
  const auto file_of = [&](DataKind k) {
    return fs::path(base.string() +
                    (k == DataKind::Points ? ".ply" : "." + std::string(kind_suffix(k)) + ".ply"));
  };
  // The record's names: output (the points; none when the chain started from the ground truth
  // and holds no points), mixture, mesh, covariance_mesh.
  for (const auto& [kind, path] : write_stage_data(out, out.kinds(), file_of)) {
    const std::string key = kind == DataKind::Points ? "output" : std::string(kind_name(kind));
    artifacts[key] = "outputs/" + path.filename().string();
  }
  if (!gt) return;  // a point ground truth: no heatmap or distance field
  const std::string heatmap =
      write_job_heatmap(job, *gt, out, scored_mesh, mesh_samples, base, ctx);
  if (!heatmap.empty()) artifacts["heatmap"] = heatmap;
  // The distance field, once per mesh: written whole (write_vdb) and sealed.
  const fs::path vdb = dir / "fields" / (mesh_key + ".vdb");
  const CacheEntry entry{dir / "fields" / (mesh_key + ".check.json"), {vdb}};
  if (!cache_usable(entry, vdb, "writing")) {
    std::error_code ec;
    fs::create_directories(vdb.parent_path(), ec);
    if (ec) {
      throw IoError(fmt::format("{}: cannot create the folder: {}", vdb.parent_path().string(),
                                ec.message()));
    }
    gt->field().write_vdb(vdb, "distance");
    seal_cache(entry);
  }
  artifacts["field"] = "fields/" + vdb.filename().string();
}

}  // namespace

Json execute_job(const Job& job, const fs::path& out) {
  JobParts r;
  RunContext ctx(job.seed, job.threads);

  // A point dataset (experiment.h): its points instead of a scan, and a mesh or a point cloud
  // (point_dataset.h) as ground truth.
  const bool from_points = job.scanner_preset == kPointsInput;
  std::optional<PointTruth> point_truth;
  if (job.dataset_params.contains("gt_points")) point_truth = read_point_truth(job.dataset_params);
  PointCloud points = from_points
                          ? read_input_points(job.dataset_params.at("points").get<std::string>())
                          : PointCloud();
  const TriangleMesh mesh =
      point_truth ? TriangleMesh()
                  : load_dataset(job.dataset, from_points ? Json::object() : job.dataset_params);
  // The dataset's local origin (core stage_data.h): zero, except for a mesh file whose coordinates
  // float32 cannot hold (survey / UTM data). Scan, chain and metrics run in the local frame; the
  // origin is recorded and restored on every file written.
  const Eigen::Vector3d origin = point_truth ? points.origin : mesh.origin;
  if (from_points) rebase(points, origin);
  if (!origin.isZero(0.0)) r.res["dataset_origin"] = {origin.x(), origin.y(), origin.z()};
  const ScanInput in = scan_pass(job, mesh, origin, std::move(points), out, r, ctx);

  // What the chain is scored on: the primary kind of its last step (a mesh for a reconstruction,
  // the mean mesh of a covariance mesh, a mixture's components as points, else the points).
  const DataKind primary =
      algorithm_entry(job.chain.back().at("algorithm").get<std::string>()).fn.io.primary;
  StageData final_out = chain_pass(job, mesh, in, primary, r, ctx);
  final_out.set_origin(origin);  // written outputs restore world coordinates
  if (primary == DataKind::Mixture) final_out.points = final_out.mixture->component_points();
  std::optional<TriangleMesh> scored_mesh;
  if (primary == DataKind::Mesh) scored_mesh = final_out.mesh;
  if (primary == DataKind::CovarianceMesh) scored_mesh = final_out.covariance_mesh->mean_mesh();
  const TriangleMesh* scored = scored_mesh ? &*scored_mesh : nullptr;
  r.res["output_kind"] = kind_name(primary);
  output_sizes(final_out, primary, scored, r.sizes);

  ctx.clear_phases();
  const double t_metrics = wall_seconds();
  std::optional<metrics::GroundTruth> gt;
  if (!point_truth) gt.emplace(mesh, ctx.stream_seed(metrics::kGroundTruthSamplesStream));
  const PointCloud* scan = job.scanner_preset == kGroundTruthInput ? nullptr : &in.cloud;
  const metrics::GroundTruth* gt_mesh = gt ? &*gt : nullptr;
  const PointTruth* gt_points = point_truth ? &*point_truth : nullptr;
  const Json m =
      metrics_pass(job, gt_mesh, gt_points, final_out, primary, scored, scan, t_metrics, r, ctx);
  if (job.save_outputs) {
    outputs_pass(job, gt_mesh, final_out, scored,
                 m.value("output_mesh_samples", Eigen::Index{100000}), in.mesh_hash, out,
                 r.artifacts, ctx);
  }
  r.res["timing"] = r.timing;
  r.res["sizes"] = r.sizes;
  r.res["artifacts"] = r.artifacts;
  return r.res;
}

}  // namespace scanbench::harness
