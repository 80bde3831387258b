#pragma once
// The results history: every run in one SQLite database (`scanbench history`, docs/history.md).
//
// Schema (version kHistorySchema, kept in PRAGMA user_version; older databases are migrated one
// step at a time inside one transaction, a newer one is refused):
//   runs(id, identity UNIQUE, folder, experiment, commit_id, commit_date, branch, dirty, host,
//        machine, cpu, cores, isa, compiler, build, config_hash, config_name, started, ended,
//        added)                          one row per imported results folder
//   jobs(id, run_id, job_id, key, dataset, scanner, variant, point, seed, repeats, status, error)
//   samples(job, quantity, idx, value, direction)   every sample: metric keys (one sample),
//        time.total / time.cpu / time.<step>:<phase> (one per repeat), peak_rss_mb, sizes.<key>;
//        direction -1 lower is better, +1 higher, 0 informational (compare.h quantity_direction)
//   claims(run_id, claim, verdict, reason)           the claims verdicts of DIR/claims.json
// A run's identity is a hash of its commit and of every job's id, start date and measured times
// (or of the claims summary's date for a claims-only folder): importing the same folder twice
// adds nothing.
//
// Safety: WAL journal, a busy timeout of 60 s, one IMMEDIATE transaction per import (a process
// killed mid-import leaves the previous state). A file that is not a SQLite database, or whose
// schema is newer than this binary's, is refused with an IoError and never written.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "scanbench/core/params.h"
#include "scanbench/harness/results/compare.h"

namespace scanbench::harness {

inline constexpr int kHistorySchema = 1;

/// The default database: results/history.sqlite (relative to the working directory).
std::filesystem::path default_history_db();

struct HistoryAddResult {
  bool added = false;  ///< false: the run was already in the database (nothing changed)
  std::int64_t run_id = 0;
  std::string identity;
  int jobs = 0, samples = 0, claims = 0;
};

/// Imports the finished results folder `dir` (runs.jsonl or jobs/, and DIR/claims.json when
/// present; a claims-only folder holds just claims.json) into `db` (created when missing).
/// `machine` names the machine (empty: host / CPU / hardware threads / ISA of the records'
/// context). Throws IoError (unreadable folder, database refused) or ParamError.
HistoryAddResult history_add(const std::filesystem::path& db, const std::filesystem::path& dir,
                             const std::string& machine = {});

/// The machine identity of a record context: host / CPU model / hardware threads / ISA.
std::string machine_identity(const Json& context);

/// Which series to read. Empty fields match everything; `since` is a commit (prefix) present in
/// the database, from which on (by commit date) points are kept.
struct HistoryFilter {
  std::string metric, dataset, variant, key, since, machine;
  bool timing = true;  ///< include time.* quantities when `metric` is empty
};

/// One commit of a series: the samples of every run of that commit pooled.
struct HistoryPoint {
  std::string commit, date;  ///< date: commit date, else the first run's start
  int runs = 0;
  std::vector<double> samples;
};

/// The history of one quantity of one job key, ordered by commit date.
struct HistorySeries {
  std::string key, dataset, variant, quantity;
  int direction = 0;
  std::vector<HistoryPoint> points;
};

/// Reads the series matching `f` from an existing database. Throws IoError.
std::vector<HistorySeries> history_series(const std::filesystem::path& db, const HistoryFilter& f);

/// Change-point detection on a series of commits (docs/history.md, "Change points"): for every
/// split between commit i-1 and i, the samples of up to `window` commits before and after are
/// pooled; the split is a change when a two-sided Mann-Whitney U test (stats.h) gives p < alpha
/// AND the step of the medians exceeds `sigmas` times the noise (1.4826 x the median absolute
/// deviation of each side's samples from its own median, pooled) AND `min_rel` of the level
/// before AND `min_abs`. Among changes closer than `window` commits only the one that separates
/// the windows best stays (smallest p, then largest step).
struct ChangeOptions {
  int window = 5;
  double alpha = 0.01;
  double sigmas = 3.0;
  double min_rel = 0.01;
  double min_abs = 0.0;
  int min_samples = 3;  ///< per side
};

struct ChangePoint {
  std::size_t index = 0;         ///< first commit after the step
  double before = 0, after = 0;  ///< medians of the pooled windows
  double step = 0, rel_step = 0, noise = 0, p = 1;
};

std::vector<ChangePoint> find_change_points(const std::vector<std::vector<double>>& commits,
                                            const ChangeOptions& o);

/// Timing verdicts of a run judged against the same machine's history only (nightly --db):
/// per job key and time quantity, the history of that machine (runs other than `exclude_identity`)
/// gives the level (median of per-run medians) and its noise (1.4826 x MAD of the per-run
/// medians); the run's own repeats give theirs. Slower by more than
/// max(sigmas x sqrt(noise_h^2 + noise_r^2), threshold x level) with a U-test p < alpha against
/// the last `window` runs' samples = regression (faster = improvement). Levels below
/// `min_time_s` are "n/a" (too short to judge); fewer than `min_runs` runs on the machine: none
/// judged (the returned vector is empty and `machine_known` false).
struct TimingHistoryOptions {
  double alpha = 0.01;
  double sigmas = 3.0;
  double threshold = 0.10;
  double min_time_s = 0.1;
  int min_runs = 3;
  int window = 10;
};
struct TimingHistoryResult {
  bool machine_known = false;
  std::string machine;
  int history_runs = 0;
  std::vector<Verdict> verdicts;
};
TimingHistoryResult history_timing_verdicts(const std::filesystem::path& db,
                                            const std::vector<Json>& records,
                                            const std::string& exclude_identity,
                                            const std::string& machine,
                                            const TimingHistoryOptions& o);

/// Nightly with a database: adds the timing verdicts of history_timing_verdicts to `res` (which
/// holds the accuracy and status verdicts only) and a note naming the machine and how many of
/// its runs the timings were judged against, or that there is no history on it (timings
/// reported, not judged).
void judge_timings_by_history(CompareResult& res, const std::filesystem::path& db,
                              const std::vector<Json>& records, const std::string& exclude_identity,
                              const TimingHistoryOptions& o = {});

/// A plot of the report's History section: one series over commits (x = commit index), with the
/// baseline's commit (index or -1) and the change points (first commit after each) marked.
struct HistoryPlot {
  std::string title, ylabel;
  std::vector<std::string> commits;
  std::vector<std::vector<double>> samples;  ///< per commit
  long baseline = -1;
  std::vector<std::size_t> changes;
};

/// The plots of the History section for the records of a results folder: per (dataset, variant)
/// its headline metrics and time.total, over the commits in `db` (all machines for accuracy,
/// the records' machine for timing). `baseline_commit` (may be empty) is marked.
std::vector<HistoryPlot> history_plots(const std::filesystem::path& db,
                                       const std::vector<Json>& records,
                                       const std::vector<std::string>& metrics,
                                       const std::string& baseline_commit);

/// `scanbench history bisect` (like `asv find`): the commits on the ancestry path GOOD..BAD of
/// `repo` are checked out one at a time in a scratch worktree (scratch/worktree, removed at the
/// end), built by that commit's scripts/build.sh (SCANBENCH_BUILD_DIR=scratch/build, target
/// scanbench, ccache) and that build's `scanbench run CONFIG --filter ^JOB$` measures `metric`.
/// A commit is bad when the quantity is worse than at GOOD (its direction, compare.h; any change
/// for an informational one) by more than rel x |value at GOOD|. Binary search; a commit that
/// does not build stops the search with the range left. Logs: scratch/bisect.log.
struct BisectOptions {
  std::filesystem::path repo, scratch;
  std::string good, bad, metric, job;
  std::filesystem::path config = "configs/nightly.json";  ///< relative to the worktree
  double rel = 0.05;
};
struct BisectResult {
  std::string first_bad;                               ///< full hash; empty when stopped
  std::string stopped;                                 ///< why the search stopped early
  std::vector<std::pair<std::string, double>> values;  ///< probed commits in probe order
};
/// Throws ParamError (bad range), IoError (GOOD does not build, the job fails).
BisectResult history_bisect(const BisectOptions& o);

}  // namespace scanbench::harness
