#pragma once
// `scanbench run` on this machine (the local executor; the Python module's `run`): the results
// folder's lock, a folder whose Slurm submission is still queued refused, a declared parameter
// protocol (config/protocol.h) resolved first (tuning into OUT/tuning-<variant>/, the resolved
// values in OUT/protocol.json, results/tuning.h), then the experiment run at the protocol's
// values (exec/runner.h).
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/exec/runner.h"

namespace scanbench::harness {

/// Runs `e` into o.out as above and returns the run's summary. The tuning runs use o.jobs,
/// o.resume, o.quiet and o.exe. Throws as run_experiment and resolve_protocol do.
RunSummary run_local(Experiment e, const RunOptions& o);

}  // namespace scanbench::harness
