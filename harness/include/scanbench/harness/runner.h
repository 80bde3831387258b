#pragma once
// Running an experiment: every job in a child process (`scanbench job`, hidden), so a crash, a
// hang or a memory blow-up fails only that job.
//
// Per job the parent forks, sets RLIMIT_AS to memory_limit_mb in the child, execs the scanbench
// binary, and kills the child with SIGKILL after timeout_s. The child dies with the parent
// (PR_SET_PDEATHSIG). The parent turns the outcome into a record (records.h: status ok | error
// | crash | timeout | memory, error text, peak RSS from wait4's ru_maxrss) and writes it
// atomically to DIR/jobs/<id>.json. A run killed at any moment leaves only complete records;
// `--resume` skips every job that has one, so the next run completes the sweep with nothing lost
// or duplicated. DIR/runs.jsonl and DIR/runs.csv are rewritten from the records at the end.
#include <filesystem>
#include <map>
#include <string>

#include "scanbench/harness/experiment.h"

namespace scanbench::harness {

struct RunOptions {
  std::filesystem::path out;  ///< results folder
  int jobs = 1;               ///< concurrent child processes
  bool resume = false;        ///< skip jobs with a record in out/jobs
  bool retry_failed = false;  ///< with resume: run failed jobs again
  std::string filter;         ///< ECMAScript regex on the job key; empty = all
  std::filesystem::path exe;  ///< the scanbench binary (default /proc/self/exe)
  bool quiet = false;         ///< no progress output
};

struct RunSummary {
  int planned = 0;  ///< jobs in the plan after the filter
  int skipped = 0;  ///< already finished (resume)
  int ran = 0;
  std::map<std::string, int> by_status;  ///< of the jobs that ran
};

/// Expands and runs `e` into opts.out. Throws ParamError when out already holds records and
/// resume is off, or when the filter is not a valid regex.
RunSummary run_experiment(const Experiment& e, const RunOptions& opts);

/// The child side: runs one job in this process and returns the partial record (status "ok",
/// metrics, histograms, timing, sizes, artifacts). Typed errors propagate to the caller.
Json execute_job(const Job& job, const std::filesystem::path& out);

/// `scanbench job SPEC RESULT`: reads {"job","out"} from SPEC, runs it, writes the result JSON
/// atomically to RESULT ({"status": "error"|"memory", "error"} on failure). Returns 0.
int run_job_file(const std::filesystem::path& spec, const std::filesystem::path& result);

}  // namespace scanbench::harness
