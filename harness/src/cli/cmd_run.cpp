// scanbench run [CONFIG] [-o DIR] [--jobs N] [--resume] [--filter REGEX]
//               [--executor local|slurm [--partition P] [--array-limit N] [--chunk N]
//                [--sbatch-arg ARG]... [--wait]]
// scanbench job SPEC RESULT            (hidden: the child process of one job)
// scanbench nightly [-o DIR] [--baseline DIR] [--update-baseline] [--no-claims]  (+ claims --quick)
#include <fmt/format.h>

#include <ctime>
#include <iostream>

#include "cli/commands.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/paths.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/config/protocol.h"
#include "scanbench/harness/exec/runner.h"
#include "scanbench/harness/exec/slurm.h"
#include "scanbench/harness/pipelines/claims_run.h"
#include "scanbench/harness/pipelines/run_local.h"
#include "scanbench/harness/results/claims_render.h"
#include "scanbench/harness/results/compare.h"
#include "scanbench/harness/results/finish.h"
#include "scanbench/harness/results/folder_lock.h"
#include "scanbench/harness/results/history.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/report.h"
#include "scanbench/harness/results/tuning.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

struct RunArgs {
  std::string config;
  std::string out;
  int jobs = 1;
  bool resume = false;
  bool retry_failed = false;
  std::string filter;
  bool quiet = false;
  bool allow_failures = false;  ///< exit 0 even when jobs failed (else kExitJobsFailed)
  std::string db;  ///< history database (history.h): the finished folder is added when set
  // --executor slurm (run only)
  std::string executor = "local";
  SlurmOptions slurm;
};

void add_run_options(CLI::App* sub, RunArgs& a) {
  sub->add_option("-o,--out", a.out, "Results folder (default results/<experiment name>)");
  sub->add_option("-j,--jobs", a.jobs, "Jobs run at the same time (child processes)")
      ->check(CLI::Range(1, 256));
  sub->add_flag("--resume", a.resume, "Skip jobs that already have a record in the folder");
  sub->add_flag("--retry-failed", a.retry_failed, "With --resume: run failed jobs again");
  sub->add_option("--filter", a.filter,
                  "Only jobs whose key (dataset|scanner|variant|point|seed) "
                  "matches this regex");
  sub->add_flag("-q,--quiet", a.quiet, "No progress output");
  sub->add_flag("--allow-failures", a.allow_failures,
                "Exit 0 even when jobs failed (default: exit 4, the failed jobs listed last)");
  add_db_option(sub, a.db, "Add the finished results folder to this database");
}

/// Adds the finished results folder to the history database when --db is given.
HistoryAddResult add_to_history(const std::string& db, const fs::path& out) {
  if (db.empty()) return {};
  const HistoryAddResult r = history_add(db, out);
  fmt::print("history: {} run {} ({} jobs) in {}\n", r.added ? "added" : "already had", r.identity,
             r.jobs, db);
  return r;
}

void add_slurm_options(CLI::App* sub, RunArgs& a) {
  sub->add_option("--executor", a.executor,
                  "local: child processes on this machine (default); slurm: one Slurm job array "
                  "and a dependent merge job (docs/cluster.md)")
      ->check(CLI::IsMember({"local", "slurm"}));
  sub->add_option("--partition", a.slurm.partition, "Slurm partition (default: the cluster's)");
  sub->add_option("--array-limit", a.slurm.array_limit,
                  "At most this many array tasks at once (sbatch --array=...%N)")
      ->check(CLI::Range(1, 1000000));
  sub->add_option("--chunk", a.slurm.chunk, "Jobs per array task (default 1)")
      ->check(CLI::Range(1, 1000000));
  sub->add_option("--sbatch-arg", a.slurm.sbatch_args,
                  "Extra sbatch argument, after scanbench's own (repeatable), e.g. "
                  "--sbatch-arg=--account=proj")
      ->allow_extra_args(false);
  sub->add_flag("--wait", a.slurm.wait,
                "Wait until the array and the merge job have ended, then print the summary");
}

/// The end of a run, whichever executor ran it: finish_run (DIR/tables.md), then the summary:
/// statuses, the tables, and last the failed jobs with their one-line reasons. Returns how many
/// of the folder's jobs failed.
int finish_and_print(const std::string& name, const RunSummary& s, const fs::path& out) {
  const FinishedRun f = finish_run(out);
  std::string statuses;
  for (const auto& [k, v] : s.by_status)
    statuses += fmt::format("{}{} {}", statuses.empty() ? "" : ", ", v, k);
  fmt::print("\n{}: {} jobs selected, {} already done, {} ran ({})\n", name, s.planned, s.skipped,
             s.ran, statuses.empty() ? "none" : statuses);
  if (!f.records.empty()) fmt::print("\n{}\n", f.tables);
  fmt::print("records: {}/runs.jsonl, {}/runs.csv\n", out.string(), out.string());
  int failed = 0;
  for (const auto& r : f.records) {
    if (r.value("status", std::string()) != "ok") {
      if (failed++ == 0) fmt::print("\nfailed jobs (logs in {}/logs/<id>.log):\n", out.string());
      fmt::print("  {:<8} {} ({}): {}\n", r.value("status", std::string()),
                 r.value("key", std::string()), r.value("id", std::string()),
                 r.value("error", std::string()));
    }
  }
  if (failed > 0) {
    fmt::print("{} of {} jobs failed; after a fix, run them again with: {} --retry-failed\n",
               failed, f.records.size(), resume_command(out));
  }
  return failed;
}

/// --executor slurm: submits, and with --wait waits and prints the summary of the submitted jobs.
int do_slurm_run(const Experiment& e, const RunOptions& o, const SlurmOptions& so) {
  const SlurmSubmission sub = submit_slurm(e, o, so);
  RunSummary s = sub.prepared.summary;
  const fs::path dir = fs::absolute(o.out).lexically_normal();
  if (sub.id.empty()) {
    merge_and_finish(dir, "");
    fmt::print("{}: {} jobs selected, {} already done: nothing to submit (merged {}/runs.jsonl)\n",
               e.name, s.planned, s.skipped, o.out.string());
    return 0;
  }
  fmt::print(
      "{}: {} jobs selected, {} already done, {} submitted as submission {}: Slurm array job {} "
      "({} tasks{}), merge job {} (afterany)\n"
      "  logs: {}/slurm/{}/task-<i>.out, merge.out; per job {}/logs/<id>.log\n",
      e.name, s.planned, s.skipped, sub.prepared.todo.size(), sub.id, sub.array_job, sub.tasks,
      so.array_limit > 0 ? fmt::format(", at most {} at once", so.array_limit) : "", sub.merge_job,
      dir.string(), sub.id, dir.string());
  if (!so.wait) {
    fmt::print("  follow it with: scanbench status {}\n", dir.string());
    return 0;
  }
  std::fflush(stdout);
  wait_for_submission(dir, sub);
  for (std::size_t i : sub.prepared.todo) {
    const fs::path rec = dir / "jobs" / (sub.prepared.plan.jobs[i].id + ".json");
    if (!fs::exists(rec)) continue;
    ++s.ran;
    const Json r = read_record_file(rec);
    ++s.by_status[r.value("status", std::string("?"))];
  }
  const int failed = finish_and_print(e.name, s, dir);
  const FolderStatus st = folder_status(dir);
  if (!st.not_run.empty()) fmt::print("\n{}", render_status(st));
  return failed + static_cast<int>(st.not_run.size());
}

/// A finished `run`: its folder, the folder's lock (held on for what the command does next:
/// nightly's comparison and report, the history), and how many jobs failed or have no record.
struct RunDone {
  fs::path out;
  std::shared_ptr<FolderLock> lock;
  int failed = 0;
};

/// Runs the config and prints the summary.
RunDone do_run(const RunArgs& a, const fs::path& default_config, const std::string& default_out,
               const std::string& command) {
  const fs::path config = a.config.empty() ? default_config : fs::path(a.config);
  Experiment e = load_experiment(config);
  RunOptions o;
  o.out = a.out.empty() ? fs::path(default_out.empty() ? "results/" + e.name : default_out)
                        : fs::path(a.out);
  o.jobs = a.jobs;
  o.resume = a.resume;
  o.retry_failed = a.retry_failed;
  o.filter = a.filter;
  o.quiet = a.quiet;
  o.command = command;
  RunDone done;
  done.out = o.out;
  if (a.executor == "slurm") {
    if (e.raw.contains("protocol")) {
      throw ParamError(config.string() +
                       ": /protocol: not supported with --executor slurm (run "
                       "it locally, or set the values in the steps' params)");
    }
    // The submission takes the folder's lock while it prepares the folder, the merge job after.
    done.failed = do_slurm_run(e, o, a.slurm);
    return done;
  }
  // Held on after the run for what the command does next (nightly's comparison, the history).
  done.lock = std::make_shared<FolderLock>(FolderLock::acquire(o.out, command, 0, true));
  const RunSummary s = run_local(e, o);
  done.failed = finish_and_print(e.name, s, o.out);
  return done;
}

/// The exit code of a command that ran jobs: 0, or kExitJobsFailed when some failed (or have no
/// record) unless the user allowed it.
int jobs_exit_code(const RunDone& d, int more_failed, bool allow_failures) {
  return d.failed + more_failed > 0 && !allow_failures ? kExitJobsFailed : 0;
}

}  // namespace

void add_run_command(Cli& cli) {
  auto a = std::make_shared<RunArgs>();
  CLI::App* sub = cli.app.add_subcommand(
      "run",
      "Run an experiment config: expand jobs, scan (cached), run algorithm variants and metrics "
      "in isolated child processes, write records, runs.jsonl and runs.csv");
  sub->add_option("config", a->config, "Experiment JSON (default configs/default.json)");
  add_run_options(sub, *a);
  add_slurm_options(sub, *a);
  sub->callback([&cli, a, sub] {
    std::string misuse;  // reported as one line (ParamError) when the action runs
    if (a->executor == "local") {
      for (const char* opt : {"--partition", "--array-limit", "--chunk", "--sbatch-arg", "--wait"})
        if (misuse.empty() && sub->get_option(opt)->count() > 0) {
          misuse = fmt::format("{}: needs --executor slurm", opt);
        }
    } else if (sub->get_option("--jobs")->count() > 0) {
      misuse = "--jobs: is for the local executor (with --executor slurm: --array-limit)";
    }
    cli.action = [a, misuse] {
      if (!misuse.empty()) throw ParamError(misuse);
      const RunDone done = do_run(*a, config_root() / "default.json", "", "scanbench run");
      if (a->executor == "local") add_to_history(a->db, done.out);
      return jobs_exit_code(done, 0, a->allow_failures);
    };
  });
}

void add_job_command(Cli& cli) {
  struct Args {
    std::string spec, result;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = cli.app.add_subcommand("job", "Run one job (internal: the child of `run`)");
  sub->group("");  // hidden
  sub->add_option("spec", a->spec, "Job spec JSON")->required();
  sub->add_option("result", a->result, "Where to write the result JSON")->required();
  sub->callback([&cli, a] { cli.action = [a] { return run_job_file(a->spec, a->result); }; });
}

void add_nightly_command(Cli& cli) {
  struct Args {
    RunArgs run;
    std::string baseline;
    bool update_baseline = false;
    bool no_claims = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = cli.app.add_subcommand(
      "nightly",
      "Run configs/nightly.json, compare with results/baseline/, write the report; exit 1 on any "
      "regression");
  sub->add_option("--config", a->run.config, "Experiment JSON (default configs/nightly.json)");
  add_run_options(sub, a->run);
  sub->add_option("--baseline", a->baseline, "Baseline results (default results/baseline/)");
  sub->add_flag("--update-baseline", a->update_baseline,
                "Copy this run's records into the baseline folder instead of comparing");
  sub->add_flag("--no-claims", a->no_claims,
                "Skip the quick claims (`scanbench claims --quick` into DIR/claims, compared with "
                "the baseline's claims.json)");
  sub->callback([&cli, a] {
    cli.action = [a] {
      const fs::path baseline =
          a->baseline.empty() ? project_root() / "results" / "baseline" : fs::path(a->baseline);
      const RunDone done =
          do_run(a->run, config_root() / "nightly.json",
                 "results/nightly-" + utc_now("%Y%m%d-%H%M%S"), "scanbench nightly");
      const fs::path& out = done.out;
      // The papers' claims, quick set: DIR/claims/<id>/, summary also in DIR/claims.json (shown
      // by the report). A claim that held in the baseline and failed now is a regression.
      std::vector<std::string> claim_regressed;
      int claims_failed = 0;
      if (!a->no_claims) {
        ClaimsOptions co;
        co.out = out / "claims";
        co.quick = true;
        co.jobs = a->run.jobs;
        co.resume = a->run.resume;
        if (!a->update_baseline) co.baseline = baseline / "claims.json";
        Json cs = run_claims(co);
        claims_failed = print_failed_claim_jobs(cs, co.out);
        for (const auto& id : cs["regressions"])
          claim_regressed.push_back(id.get<std::string>());
        fmt::print("\n{}", claims_markdown(cs));
        if (a->update_baseline) {
          const FolderLock baseline_lock =
              FolderLock::acquire(baseline, "scanbench nightly --update-baseline", 0, true);
          Json b = cs;
          b.erase("regressions");
          fs::create_directories(baseline);
          write_json_file(baseline / "claims.json", b);
        }
        for (auto& c : cs["claims"])
          c["folder"] = "claims/" + c.value("folder", std::string());
        write_json_file(out / "claims.json", cs);
      }
      const HistoryAddResult added = add_to_history(a->run.db, out);
      if (a->update_baseline) {
        // Only the merged records (without histograms) and the config: small enough to commit.
        const FolderLock baseline_lock =
            FolderLock::acquire(baseline, "scanbench nightly --update-baseline", 0, true);
        for (const char* f : {"runs.csv", "config.json"})
          write_file_atomic(baseline / f, read_file(out / f));  // never through a link
        std::string jsonl;
        for (Json r : load_records(out)) {
          r.erase("histograms");
          jsonl += r.dump() + "\n";
        }
        write_file_atomic(baseline / "runs.jsonl", jsonl);
        fmt::print("baseline updated: {}\n", baseline.string());
        write_report(out, {}, a->run.db);
        return jobs_exit_code(done, claims_failed, a->run.allow_failures);
      }
      if (!fs::exists(baseline / "runs.jsonl")) {
        throw IoError(fmt::format("{}: no baseline (run `scanbench nightly --update-baseline`)",
                                  baseline.string()));
      }
      const Json cfg = read_json_file(out / "config.json");
      CompareOptions opts = CompareOptions::from_json(
          cfg["config"].value("compare", Json::object()), "config.json: /compare");
      // With a history database timings are judged against this machine's history only; without
      // one, against the baseline only when the baseline ran on this machine (machine_identity:
      // host, CPU model, hardware threads, ISA), else timings are reported and not judged.
      const std::vector<Json> base_records = load_records(baseline);
      const std::vector<Json> new_records = load_records(out);
      if (!a->run.db.empty()) opts.timing = false;
      if (a->run.db.empty() && !base_records.empty() && !new_records.empty()) {
        const std::string bm =
            machine_identity(base_records.front().value("context", Json::object()));
        const std::string nm =
            machine_identity(new_records.front().value("context", Json::object()));
        if (bm != nm) {
          opts.timing = false;
          fmt::print(
              "timings not judged: the baseline ran on {}, this run on {} (accuracy is judged; "
              "give --db for timings judged against this machine's own history)\n",
              bm, nm);
        }
      }
      CompareResult res = compare_records(base_records, new_records, opts);
      if (!a->run.db.empty()) {
        judge_timings_by_history(res, a->run.db, load_records(out), added.identity);
      }
      write_json_file(out / "compare.json", res.to_json());
      write_file_atomic(out / "compare.md", res.table());
      const fs::path page = write_report(out, {}, a->run.db);
      fmt::print("\n{}\nreport: {}\n", res.table(), page.string());
      if (!claim_regressed.empty()) {
        std::string ids;
        for (const auto& id : claim_regressed)
          ids += (ids.empty() ? "" : ", ") + id;
        fmt::print("claims that held in the baseline and failed now: {}\n", ids);
      }
      if (res.regressed() || !claim_regressed.empty()) return 1;
      return jobs_exit_code(done, claims_failed, a->run.allow_failures);
    };
  });
}

}  // namespace scanbench::harness
