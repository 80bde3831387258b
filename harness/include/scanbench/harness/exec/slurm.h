#pragma once
// Running an experiment on a Slurm cluster (`scanbench run CONFIG -o DIR --executor slurm`), its
// array tasks, the merge job and `scanbench status DIR`.
//
// The data flow is the local one (runner.h): the same plan, the same `scanbench job` child per
// job under the same limits (RLIMIT_AS, timeout), the same atomic DIR/jobs/<id>.json records,
// the same merge in plan order. Only who starts the children changes:
//
//   submit (scanbench run --executor slurm)
//     checks that sbatch, squeue, scontrol and sinfo are on PATH, that the controller answers
//     (`scontrol ping`), that the partition exists (`sinfo`), and that no earlier submission
//     into DIR is still in the queue; then prepare_run (plan, resume selection) and two sbatch
//     calls: one job array (task i runs jobs [i*chunk, (i+1)*chunk) of the submission) and a
//     merge job with --dependency=afterany on it. Any failure: SchedulerError, nothing left
//     submitted (a merge job that sbatch refuses cancels the array just submitted).
//   array task (scanbench slurm-task DIR SUB, hidden)
//     runs its jobs one at a time through run_jobs (runner.h). On SIGTERM (scancel, time limit,
//     preemption: Slurm sends SIGTERM, then SIGKILL after KillWait) it kills its child and
//     records the job with Slurm's reason, read from the "*** JOB ... CANCELLED AT ... [DUE TO
//     TIME LIMIT] ***" line that slurmstepd writes to the task's output: status "timeout" for a
//     time limit, else "interrupted". The jobs of the chunk not yet started get no record.
//   merge job (scanbench merge DIR --submission SUB)
//     a job whose task started it but wrote no record (the task was SIGKILLed, its node failed)
//     is recorded from `scontrol show job` (JobState NODE_FAIL, CANCELLED, TIMEOUT,
//     OUT_OF_MEMORY, ...); then runs.jsonl and runs.csv are merged, and the command presents the
//     folder as every run ends (finish.h: tables.md and index.html). Jobs
//     of the submission that still have no record are listed with the command that resubmits
//     them; the merge then exits 1.
//   status (scanbench status DIR)
//     done and failed from the records, running and pending from `squeue`; no accounting
//     database (sacct) is needed.
//
// Files of a submission: DIR/slurm/<NNN>/submission.json (job ids, chunk, Slurm job ids, the
// sbatch command lines), task.sh and merge.sh (the batch scripts), task-<i>.out (output of array
// task i, appended across requeues), merge.out, started/<job id> (written as a job starts).
// Every Slurm job of DIR is named sb-<8 hex digits of DIR's absolute path> (the merge job with
// "-merge"), so squeue finds them by name, and job ids reused after a controller reset are not
// mistaken for ours.
//
// The folder's lock (folder_lock.h) is held by the submission while it prepares DIR and by the
// merge job; the array tasks take none: each writes only its own jobs' files. A local run into a
// folder whose submission is still queued is refused (refuse_if_submission_queued).
//
// Written against Slurm 22.05; it uses only sbatch --parsable/--array/--dependency=afterany,
// squeue -r -n -o, scontrol ping / show job -o and sinfo -o, all present since Slurm 20.11.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/harness/exec/runner.h"

namespace scanbench::harness {

/// A Slurm command is missing from PATH, the controller does not answer, a request is refused,
/// or the results folder is still being written by another submission. The CLI exits 2.
class SchedulerError : public Error {
 public:
  using Error::Error;
};

struct SlurmOptions {
  std::string partition;                 ///< --partition; empty: the cluster's default
  int array_limit = 0;                   ///< > 0: at most this many tasks at once (%N)
  int chunk = 1;                         ///< jobs per array task (>= 1)
  std::vector<std::string> sbatch_args;  ///< extra sbatch arguments, after scanbench's own
  bool wait = false;                     ///< return only once both Slurm jobs have ended
};

struct SlurmSubmission {
  std::string id;         ///< "001": the folder DIR/slurm/<id>; empty when nothing was submitted
  std::string array_job;  ///< Slurm job id of the array
  std::string merge_job;  ///< Slurm job id of the merge job
  int tasks = 0;          ///< array tasks
  PreparedRun prepared;   ///< the plan and the submitted jobs (prepared.todo)
};

/// The command that continues DIR's run with the executor that wrote it ("scanbench run CONFIG
/// -o DIR --resume", with "--executor slurm" when DIR holds a Slurm submission).
std::string resume_command(const std::filesystem::path& dir);

/// Throws SchedulerError when Slurm jobs of an earlier submission into `dir` are still queued or
/// running (their tasks write the folder); nothing when `dir` has no submission or there is no
/// squeue on PATH.
void refuse_if_submission_queued(const std::filesystem::path& dir);

/// Submits the jobs selected by prepare_run (see the top of this file). sbatch gets
/// --time = the largest sum of timeout_s over a task's jobs plus 60 s, in whole minutes;
/// --mem = the largest memory_limit_mb; --cpus-per-task = the largest positive `threads`.
/// When no job is left to run, nothing is submitted (the id stays empty; the caller merges).
/// Throws SchedulerError, ParamError (records without resume, bad filter), IoError.
SlurmSubmission submit_slurm(const Experiment& e, const RunOptions& opts, const SlurmOptions& so);

/// Waits until no Slurm job of `s` is in the queue (polls squeue every 2 s).
void wait_for_submission(const std::filesystem::path& dir, const SlurmSubmission& s);

/// `scanbench slurm-task DIR SUB`: runs array task $SLURM_ARRAY_TASK_ID of submission SUB.
/// Returns 0, or 1 when Slurm stopped it.
int run_slurm_task(const std::filesystem::path& dir, const std::string& submission);

/// The jobs left without a record after a merge, and how to resubmit them.
struct MergedFolder {
  std::vector<std::pair<std::string, std::string>> missing;  ///< (job id, key), in plan order
  std::string resume_hint;  ///< the command that resubmits them; empty when none is missing
};

/// `scanbench merge DIR [--submission SUB]`, the executor's half: records the jobs of SUB that
/// started but left no record, writes runs.jsonl and runs.csv (merge_records) and returns the
/// jobs without a record (of SUB, or of the whole plan without SUB). The command then presents
/// the folder (finish.h) and prints render_missing.
MergedFolder merge_folder(const std::filesystem::path& dir, const std::string& submission);
/// "N jobs without a record:", one line a job, the command that resubmits them; empty when none.
std::string render_missing(const MergedFolder& m);

/// The state of every job of DIR's plan.
struct FolderStatus {
  struct Item {
    std::string id, key;
    std::string status;  ///< record status (done/failed), or the Slurm state (running/pending)
    std::string detail;  ///< error text, or "Slurm job 12_3 on node01, 0:42", or the pending reason
  };
  std::string experiment;
  std::vector<Item> done, failed, running, pending, not_run;
  std::vector<std::string> other_jobs;  ///< e.g. "merge job 13 PENDING (Dependency)"
  std::string queue_error;  ///< why squeue could not be asked (running/pending then unknown)
  std::string resume_hint;  ///< the command that submits what has no record
};

/// Reads DIR's plan, records and submissions and asks squeue about the submissions' jobs (when
/// DIR has any). Throws IoError when DIR holds no plan.json.
FolderStatus folder_status(const std::filesystem::path& dir);
/// Text for the terminal: one summary line, then the failed, running, pending and not-run jobs
/// (at most `max_lines` each).
std::string render_status(const FolderStatus& s, std::size_t max_lines = 50);
/// {"experiment", "counts": {...}, "done": [...], "failed": [...], ...}.
Json status_json(const FolderStatus& s);

}  // namespace scanbench::harness
