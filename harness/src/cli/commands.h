#pragma once
// Private to the harness: each subcommand lives in its own cmd_*.cpp and is added to the CLI in
// cli.cpp by one explicit call.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <string>

#include "scanbench/core/params.h"

namespace scanbench::harness {

/// The parsed command line: the chosen subcommand stores what to run in `action`.
/// Exit codes (docs/cli.md): 0 success, 1 a regression, 2 bad input, usage or environment (one
/// line naming the file and field, or the path and the reason), 3 an internal error, 4 jobs
/// failed (`run`, `nightly`, `claims` without --allow-failures; the failed jobs are listed last).
inline constexpr int kExitJobsFailed = 4;

struct Cli {
  CLI::App app{
      "scanbench: evaluation and benchmark harness for point-set filtering and surface "
      "reconstruction"};
  std::function<int()> action;
};

void add_list_command(Cli& cli);

/// `scanbench scan`: virtual scan of a mesh (scanner-sim).
void add_scan_command(Cli& cli);

/// `scanbench import colmap DIR`: another tool's reconstruction as a scan PLY (core/colmap.h).
void add_import_command(Cli& cli);

/// `scanbench algo NAME`: one registered algorithm on a point cloud (algorithms module).
void add_algo_command(Cli& cli);

/// `scanbench bench <name>`: benchmarks that print ratios measured in one run. Each module's
/// benchmark adds itself in cmd_bench.cpp; the command is hidden while none exists.
void add_bench_command(Cli& cli);

/// `scanbench eval`: metrics of one output against a ground truth (metrics module).
void add_eval_command(Cli& cli);

/// Experiments (helper "harness"): run, the hidden job child, table, compare, report, nightly.
void add_run_command(Cli& cli);
void add_job_command(Cli& cli);
void add_table_command(Cli& cli);
void add_compare_command(Cli& cli);
void add_report_command(Cli& cli);
/// `scanbench figure DIR -o FILE` (figure.h): a static figure grid for print.
void add_figure_command(Cli& cli);
void add_nightly_command(Cli& cli);

/// Slurm (slurm.h): status of a results folder, merge, the hidden array task.
void add_status_command(Cli& cli);
void add_merge_command(Cli& cli);
void add_slurm_task_command(Cli& cli);
/// `scanbench merge DIR`: merge_folder (slurm.h), then finish_run with the report (finish.h);
/// prints what it wrote and the jobs without a record. Returns how many have none.
int merge_and_finish(const std::filesystem::path& dir, const std::string& submission);

/// `scanbench history` (cmd_history.cpp, history.h): the results database.
void add_history_command(Cli& cli);
/// `--db FILE`: the history database (history.h); on `history`, run, nightly, claims, report.
/// `what` says what the command does with it.
void add_db_option(CLI::App* sub, std::string& db, const std::string& what);

/// `scanbench claims` (cmd_claims.cpp, claims.h): the papers' claims with verdicts.
void add_claims_command(Cli& cli);
/// Prints the claims whose jobs failed (with where to read the reasons); returns how many jobs
/// failed over all claims of a `run_claims` summary.
int print_failed_claim_jobs(const Json& summary, const std::filesystem::path& out);

}  // namespace scanbench::harness
