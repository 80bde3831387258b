// scanbench run [CONFIG] [-o DIR] [--jobs N] [--resume] [--filter REGEX]
// scanbench job SPEC RESULT            (hidden: the child process of one job)
// scanbench nightly [-o DIR] [--baseline DIR] [--update-baseline]
#include <fmt/format.h>

#include <ctime>
#include <iostream>

#include "commands.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/paths.h"
#include "scanbench/harness/compare.h"
#include "scanbench/harness/experiment.h"
#include "scanbench/harness/records.h"
#include "scanbench/harness/report.h"
#include "scanbench/harness/runner.h"
#include "scanbench/harness/table.h"

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
}

std::string stamp() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char s[32];
  std::strftime(s, sizeof(s), "%Y%m%d-%H%M%S", &tm);
  return s;
}

/// Runs the config and prints the summary; returns the results folder.
fs::path do_run(const RunArgs& a, const fs::path& default_config, const std::string& default_out) {
  const fs::path config = a.config.empty() ? default_config : fs::path(a.config);
  const Experiment e = load_experiment(config);
  RunOptions o;
  o.out = a.out.empty() ? fs::path(default_out.empty() ? "results/" + e.name : default_out)
                        : fs::path(a.out);
  o.jobs = a.jobs;
  o.resume = a.resume;
  o.retry_failed = a.retry_failed;
  o.filter = a.filter;
  o.quiet = a.quiet;
  const RunSummary s = run_experiment(e, o);
  const std::vector<Json> records = load_job_records(o.out);
  std::vector<Json> ok;
  for (const auto& r : records)
    if (r.value("status", std::string()) == "ok") ok.push_back(r);
  std::string statuses;
  for (const auto& [k, v] : s.by_status)
    statuses += fmt::format("{}{} {}", statuses.empty() ? "" : ", ", v, k);
  fmt::print("\n{}: {} jobs selected, {} already done, {} ran ({})\n", e.name, s.planned, s.skipped,
             s.ran, statuses.empty() ? "none" : statuses);
  if (!records.empty()) {
    fmt::print("\n{}\n", render_table(build_table(records, TableSpec{}), "md"));
    TableSpec ts;
    ts.metric = "time.total";
    fmt::print("{}\n", render_table(build_table(records, ts), "md"));
  }
  int failed = 0;
  for (const auto& r : records) {
    if (r.value("status", std::string()) != "ok") {
      if (failed++ == 0) fmt::print("failed jobs:\n");
      fmt::print("  {:<8} {}: {}\n", r.value("status", std::string()),
                 r.value("key", std::string()), r.value("error", std::string()));
    }
  }
  fmt::print("records: {}/runs.jsonl, {}/runs.csv\n", o.out.string(), o.out.string());
  return o.out;
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
  sub->callback([&cli, a] {
    cli.action = [a] {
      do_run(*a, config_root() / "default.json", "");
      return 0;
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
  sub->callback([&cli, a] {
    cli.action = [a] {
      const fs::path baseline =
          a->baseline.empty() ? project_root() / "results" / "baseline" : fs::path(a->baseline);
      const fs::path out =
          do_run(a->run, config_root() / "nightly.json", "results/nightly-" + stamp());
      if (a->update_baseline) {
        // Only the merged records (without histograms) and the config: small enough to commit.
        fs::create_directories(baseline);
        for (const char* f : {"runs.csv", "config.json"})
          fs::copy_file(out / f, baseline / f, fs::copy_options::overwrite_existing);
        std::string jsonl;
        for (Json r : load_records(out)) {
          r.erase("histograms");
          jsonl += r.dump() + "\n";
        }
        write_file_atomic(baseline / "runs.jsonl", jsonl);
        fmt::print("baseline updated: {}\n", baseline.string());
        write_report(out);
        return 0;
      }
      if (!fs::exists(baseline / "runs.jsonl")) {
        throw IoError(fmt::format("{}: no baseline (run `scanbench nightly --update-baseline`)",
                                  baseline.string()));
      }
      const Json cfg = read_json_file(out / "config.json");
      const CompareOptions opts = CompareOptions::from_json(
          cfg["config"].value("compare", Json::object()), "config.json: /compare");
      const CompareResult res = compare_records(load_records(baseline), load_records(out), opts);
      write_file_atomic(out / "compare.json", res.to_json().dump(1) + "\n");
      write_file_atomic(out / "compare.md", res.table());
      const fs::path page = write_report(out);
      fmt::print("\n{}\nreport: {}\n", res.table(), page.string());
      return res.regressed() ? 1 : 0;
    };
  });
}

}  // namespace scanbench::harness
