#pragma once
// One registered algorithm on files (`scanbench algo`): the inputs read (one file per kind the
// algorithm consumes), the parameters checked as declared, the step run at a local origin (the
// inputs in the frame of the first one; core/stage_data.h), and its primary output written with
// every other product beside it.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "scanbench/core/params.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::harness {

struct AlgoRunRequest {
  std::string name;                 ///< registered algorithm, e.g. "resample.wlop"
  std::vector<std::string> inputs;  ///< one file per kind it consumes
  std::string output;               ///< where the primary output goes (.ply, .obj for a mesh)
  std::vector<std::string> sets;    ///< "key=value" parameters
  std::uint64_t seed = 0;
  int threads = 0;
  /// Where a product that is not the primary output goes ("" = <output>.<kind>.ply).
  std::string mixture, mesh, covariance_mesh;
  /// Called before the step runs; what it returns lives while the step runs (a progress printer,
  /// for example). May be empty.
  std::function<std::shared_ptr<void>(const RunContext& ctx, const std::string& name)> watch;
};

struct AlgoRunResult {
  /// The run record (`algo --timings`): algorithm, effective parameters, seed, threads, inputs,
  /// sizes, phase wall and CPU seconds, total_s.
  Json record;
  /// One line: "resample.wlop: points -> points in 0.123 s -> out.ply, mixture -> ...".
  std::string summary;
  const Json& to_json() const { return record; }
};

/// One registered algorithm on data in memory (what `run_algo` runs between reading and writing
/// its files; the Python module's `run_algorithm`): the parameters checked as declared (`given`
/// over the defaults, errors named "algo <name>"), the step run with `seed` and `threads`.
struct StepRun {
  StageData output;
  Json params;              ///< the effective parameters
  Json phases, phases_cpu;  ///< phase -> wall and CPU seconds (RunContext)
  double total_s = 0;       ///< wall seconds of the step
};
StepRun run_step(
    const std::string& name, const StageData& input, const Json& given, std::uint64_t seed,
    int threads,
    const std::function<std::shared_ptr<void>(const RunContext&, const std::string&)>& watch = {});

/// Runs the request. Throws ParamError (an unknown name or parameter, a missing or a second input
/// of a kind), InputError naming the input files (data the algorithm rejects), IoError.
AlgoRunResult run_algo(const AlgoRunRequest& r);

}  // namespace scanbench::harness
