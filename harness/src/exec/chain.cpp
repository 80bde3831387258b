#include "scanbench/harness/exec/chain.h"

#include <algorithm>

#include "exec/own_process.h"
#include "exec/proc_memory.h"
#include "scanbench/core/io.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/config/test_algorithms.h"
#include "scanbench/metrics/mesh_facts.h"

namespace scanbench::harness {

ChainRun run_chain(const Json& chain, StageData input, RunContext& ctx, bool measure_memory) {
  ChainRun r;
  StageData cur = std::move(input);
  const double cpu0 = process_cpu_seconds();
  for (const auto& step : chain) {
    const std::string algo = step.at("algorithm").get<std::string>();
    const std::string label = step.at("label").get<std::string>();
    const auto& entry = algorithm_entry(algo);
    ctx.clear_phases();
    const bool mem = measure_memory && reset_peak_rss();
    const long rss0 = mem ? status_kb("VmRSS") : -1;
    ctx.reset_program_peak_rss();
    const double t0 = wall_seconds();
    // A step whose output follows heap addresses runs in a fresh process (own_process.h).
    const std::optional<std::string> exe =
        entry.fn.own_process ? own_process_exe() : std::optional<std::string>();
    StageData next = exe ? run_in_own_process(*exe, entry, step.at("params"), cur, ctx)
                         : entry.fn(cur, step.at("params"), ctx);
    const double dt = wall_seconds() - t0;
    const long hwm = mem ? status_kb("VmHWM") : -1;
    if (rss0 >= 0 && hwm >= 0) {
      r.step_peak_mb[label] = static_cast<double>(hwm) / 1024.0;
      const long program = ctx.program_peak_rss_kb();
      r.step_work_mb[label] =
          static_cast<double>(std::max(hwm - rss0, 0L) + std::max(program, 0L)) / 1024.0;
      if (program >= 0) r.step_program_mb[label] = static_cast<double>(program) / 1024.0;
    }
    r.wall_s += dt;
    r.phases[label] += dt;
    for (const auto& [name, s] : ctx.phase_seconds())
      r.phases[label + ":" + name] += s;
    // The control covariance mesh of the chain (the last step whose primary output is one,
    // e.g. triangulate.bhattacharyya before subdivide.gp_loop): the representation whose size
    // the GPS paper's Fig. 13c counts (3 floats, 6 covariance floats per vertex, the faces).
    if (measure_memory && entry.fn.io.primary == DataKind::CovarianceMesh && next.covariance_mesh) {
      const metrics::MeshFacts f = metrics::mesh_facts(*next.covariance_mesh);
      r.covmesh_sizes["covmesh_vertices"] = f.vertices;
      r.covmesh_sizes["covmesh_faces"] = f.faces;
      r.covmesh_sizes["covmesh_bytes"] = f.bytes;
    }
    // The step's result already carries every kind it does not produce (StageData::carry).
    cur = std::move(next);
  }
  r.cpu_s = process_cpu_seconds() - cpu0;
  r.output = std::move(cur);
  return r;
}

std::vector<std::pair<DataKind, std::filesystem::path>> write_stage_data(
    const StageData& data, DataKinds kinds,
    const std::function<std::filesystem::path(DataKind)>& path_of) {
  std::vector<std::pair<DataKind, std::filesystem::path>> written;
  for (DataKind k :
       {DataKind::Points, DataKind::Mixture, DataKind::Mesh, DataKind::CovarianceMesh}) {
    if (!kinds.has(k)) continue;
    const std::filesystem::path path = path_of(k);
    write_stage_kind(data, k, path);
    written.emplace_back(k, path);
  }
  return written;
}

std::string_view kind_suffix(DataKind kind) {
  return kind == DataKind::CovarianceMesh ? std::string_view("covmesh") : kind_name(kind);
}

}  // namespace scanbench::harness
