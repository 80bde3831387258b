#pragma once
// Running a chain of registered steps once: the one way a job (job_exec.cpp) and a benchmark
// (`scanbench bench`) run and time methods, so both measure the same thing.
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

/// What one pass of a chain produced and took.
struct ChainRun {
  StageData output;
  double wall_s = 0.0;  ///< sum of the steps' wall seconds
  double cpu_s = 0.0;   ///< process CPU seconds over the whole chain (every thread)
  /// "<label>" -> the step's wall seconds; "<label>:<phase>" -> its RunContext phases' seconds.
  std::map<std::string, double> phases;
  /// Memory per step label, in MB, when `measure_memory` was asked and /proc allows it (see
  /// execute_job's record: step_peak_rss_mb, step_work_mb, step_program_peak_rss_mb).
  std::map<std::string, double> step_peak_mb, step_work_mb, step_program_mb;
  /// The control covariance mesh of the chain (the last step whose primary output is one):
  /// covmesh_vertices, covmesh_faces, covmesh_bytes (GPS Fig. 13c); empty when there is none.
  Json covmesh_sizes = Json::object();
};

/// Runs `chain` ([{"algorithm", "label", "params"}], params effective, as in Job::chain) on
/// `input` once, each step through the registry (harness algorithm_entry, so test algorithms too
/// when enabled). Throws whatever a step throws.
ChainRun run_chain(const Json& chain, StageData input, RunContext& ctx, bool measure_memory);

/// The one writer of a chain's output (a job's outputs/, `scanbench algo`): each kind of `kinds`
/// to path_of(kind) (write_stage_kind, core io.h), in the order points, mixture, mesh,
/// covariance mesh; returns (kind, file) as written. Throws InputError when `data` lacks one of
/// `kinds`, IoError when a file cannot be written.
std::vector<std::pair<DataKind, std::filesystem::path>> write_stage_data(
    const StageData& data, DataKinds kinds,
    const std::function<std::filesystem::path(DataKind)>& path_of);
/// The word a kind's file carries: its kind_name, covmesh for a covariance mesh (out.covmesh.ply).
std::string_view kind_suffix(DataKind kind);

}  // namespace scanbench::harness
