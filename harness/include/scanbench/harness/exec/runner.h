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
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/results/folder_lock.h"
#include "scanbench/harness/results/tuning.h"

namespace scanbench::harness {

/// A run stopped by SIGINT or SIGTERM (Ctrl-C): its finished jobs are recorded and merged, the
/// jobs it stopped are recorded "interrupted" (`--resume` runs them again). Message: "DIR:
/// interrupted after N of M jobs; resume with: scanbench run CONFIG -o DIR --resume". The CLI
/// exits 130.
class Interrupted : public Error {
 public:
  using Error::Error;
};

struct RunOptions {
  std::filesystem::path out;              ///< results folder
  int jobs = 1;                           ///< concurrent child processes
  bool resume = false;                    ///< skip jobs with a record in out/jobs
  bool retry_failed = false;              ///< with resume: run failed jobs again
  std::string filter;                     ///< ECMAScript regex on the job key; empty = all
  std::filesystem::path exe;              ///< the scanbench binary (default /proc/self/exe)
  bool quiet = false;                     ///< no progress output
  std::string command = "scanbench run";  ///< named in the folder's lock (folder_lock.h)
};

struct RunSummary {
  int planned = 0;  ///< jobs in the plan after the filter
  int skipped = 0;  ///< already finished (resume)
  int ran = 0;
  std::map<std::string, int> by_status;  ///< of the jobs that ran
};

/// Expands and runs `e` into opts.out: prepare_run, run_jobs, merge_records. Throws ParamError
/// when out already holds records and resume is off, or when the filter is not a valid regex.
RunSummary run_experiment(const Experiment& e, const RunOptions& opts);

/// The protocol tuning's runner (results/tuning.h) as `scanbench run` runs: child processes,
/// `jobs` at a time; `resume` keeps records; `exe` the scanbench binary whose children run the
/// jobs (empty: this process's own binary).
RecordsRunner local_records_runner(int jobs, bool resume, bool quiet,
                                   const std::filesystem::path& exe = {});

/// A run prepared in its results folder: the plan and the jobs still to run.
struct PreparedRun {
  Plan plan;
  std::vector<std::size_t> todo;     ///< indices into plan.jobs, in plan order
  RunSummary summary;                ///< planned and skipped (ran is left 0)
  std::shared_ptr<FolderLock> lock;  ///< the folder's lock, held while this value lives
};

/// The first half of every run, whatever executes the jobs: takes the folder's lock
/// (folder_lock.h), expands `e`, creates the folder's sub-folders (refusing any that is a
/// symbolic link or a file), refuses a folder that holds another experiment (DIR/config.json
/// differs from `e`'s config) or records of this plan unless opts.resume, removes the leftovers of
/// killed runs (DIR/tmp/*, temp files named ".*" in jobs/, scans/, outputs/, logs/, fields/),
/// writes DIR/config.json and DIR/plan.json, and selects the jobs: those matching opts.filter,
/// less (with resume) those with a record, except records with status "interrupted" (the
/// scheduler stopped the job) and, with retry_failed, every status but "ok". Throws ParamError
/// when the filter selects no job of the plan.
PreparedRun prepare_run(const Experiment& e, const RunOptions& opts);

/// Hooks of an executor around run_jobs (the Slurm array task uses them; see slurm.h).
struct RunHooks {
  std::function<void(const Job&)> started;  ///< just before the child of a job is started
  std::function<bool()> stop;  ///< polled: true kills the running children, starts no more
  std::function<void(const Job&, Json& record)> amend;  ///< may rewrite a record before writing
};

/// Runs `jobs` in child processes, opts.jobs at a time, each under its limits, and writes
/// DIR/jobs/<id>.json per finished job; adds the outcomes to `summary`.
void run_jobs(const std::vector<const Job*>& jobs, const RunOptions& opts, RunSummary& summary,
              const RunHooks& hooks = {});

/// Writes DIR/runs.jsonl and DIR/runs.csv from the records of DIR/plan.json's jobs, in plan
/// order (a job has one record file, so nothing is duplicated); returns those records.
std::vector<Json> merge_records(const std::filesystem::path& out);

/// The record of a job that ended without a result of its own (e.g. its Slurm task was
/// cancelled): the job's description, `status` and `error`, no metrics.
Json failure_record(const Job& job, const std::string& status, const std::string& error,
                    const std::filesystem::path& out);

/// The child side: runs one job in this process and returns the partial record (status "ok",
/// metrics, histograms, timing, sizes, artifacts). Typed errors propagate to the caller.
Json execute_job(const Job& job, const std::filesystem::path& out);

/// `scanbench job SPEC RESULT`: reads {"job","out"} from SPEC, runs it, writes the result JSON
/// atomically to RESULT ({"status": "error"|"memory", "error"} on failure). Returns 0.
int run_job_file(const std::filesystem::path& spec, const std::filesystem::path& result);

}  // namespace scanbench::harness
