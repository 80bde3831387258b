// scanbench claims [--quick] [-o DIR] [--filter REGEX] [--jobs N] [--baseline FILE]
//                  [--update-baseline] [--claims DIR] [--resume]
//
// Runs every claim of configs/claims/ (claims.h) through the experiment runner: each claim's
// experiment goes to DIR/<id>/ (records, report) with one scan cache for all claims (DIR/scans,
// linked as DIR/<id>/scans), then its rules judge the records. Writes DIR/claims.json,
// DIR/claims.md and DIR/index.html, prints the table, and exits 1 when a claim that held in the
// baseline (results/baseline/claims.json) failed. A claim whose experiment declares a parameter
// protocol (protocol.h) is tuned first (DIR/<id>/tuning-<variant>/), then run at the protocol's
// values and over its ranges; the verdict uses the records at the values, the sensitivity all.
#include <fmt/format.h>

#include <chrono>
#include <ctime>
#include <iostream>

#include "cli/commands.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/paths.h"
#include "scanbench/harness/claims.h"
#include "scanbench/harness/claims_render.h"
#include "scanbench/harness/experiment.h"
#include "scanbench/harness/finish.h"
#include "scanbench/harness/folder_lock.h"
#include "scanbench/harness/history.h"
#include "scanbench/harness/protocol.h"
#include "scanbench/harness/records.h"
#include "scanbench/harness/runner.h"
#include "scanbench/harness/table.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

void write_claims_page(const fs::path& dir, const Json& summary) {
  std::string h =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>scanbench: "
      "claims</title>\n<style>body{font-family:sans-serif;margin:1.5em;max-width:1400px;"
      "color:#222}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;"
      "font-size:13px;vertical-align:top}td.best{background:#e6f4e6}td.fail{background:#fbe3e3;"
      "color:#900}.regression{color:#b00;font-weight:bold}</style></head><body>\n"
      "<h1>scanbench claims</h1>\n";
  const Json ctx = summary.value("context", Json::object());
  h += fmt::format("<p>commit <code>{}</code>, host {} ({} hardware threads), {}; {} s wall.</p>\n",
                   html_escape(ctx.value("commit", "")), html_escape(ctx.value("host", "")),
                   ctx.value("hardware_threads", 0), html_escape(ctx.value("date", "")),
                   format_number(summary.value("wall_s", 0.0)));
  h += claims_html_section(summary);
  h += "<p>Records: <a href=\"claims.json\">claims.json</a>, <a href=\"claims.md\">claims.md"
       "</a>; one results folder (records and report) per claim.</p>\n</body></html>\n";
  write_file_atomic(dir / "index.html", h);
}

}  // namespace

Json run_claims(const ClaimsOptions& o) {
  const fs::path dir = o.claims_dir.empty() ? config_root() / "claims" : o.claims_dir;
  const std::vector<Claim> claims = load_claims(dir, o.filter);  // all validated before any run
  if (claims.empty()) throw ParamError(fmt::format("--filter '{}': no claim matches", o.filter));
  const FolderLock lock = FolderLock::acquire(o.out, "scanbench claims", 0, true);
  fs::create_directories(o.out / "scans");
  const auto t0 = std::chrono::steady_clock::now();
  Json summary = {{"scanbench_claims", 1},
                  {"quick", o.quick},
                  {"context", run_context_json()},
                  {"claims", Json::array()}};
  for (const Claim& c : claims) {
    const auto tc = std::chrono::steady_clock::now();
    const Json config = c.experiment_config(o.quick);
    RunOptions ro;
    ro.out = o.out / c.id;
    ro.jobs = o.jobs;
    ro.resume = o.resume;
    ro.quiet = true;
    ro.command = "scanbench claims";
    // One scan cache for every claim: DIR/<id>/scans is a link to DIR/scans.
    fs::create_directories(ro.out);
    if (!fs::exists(fs::symlink_status(ro.out / "scans"))) {
      fs::create_directory_symlink(fs::path("..") / "scans", ro.out / "scans");
    }
    if (!o.quiet) {
      fmt::print("claim {} ({}): running {} ...\n", c.id, c.source, ro.out.string());
      std::fflush(stdout);
    }
    // The parameter protocol: tuned values chosen on the tuning data first, then the claim's
    // experiment at those values and swept over the ranges for the sensitivity.
    Protocol protocol;
    if (config.contains("protocol")) {
      const RecordsRunner local = local_records_runner(o.jobs, o.resume, true);
      const RecordsRunner tune = [&](const Json& tc, const fs::path& out) {
        fs::create_directories(out);
        if (!fs::exists(fs::symlink_status(out / "scans"))) {
          fs::create_directory_symlink(fs::path("..") / "scans", out / "scans");
        }
        return local(tc, out);
      };
      protocol = resolve_protocol(
          config, parse_protocol(config["protocol"], c.file.string() + ": /experiment/protocol"),
          ro.out, tune);
      write_json_file(ro.out / "protocol.json", protocol_json(protocol));
    }
    const Experiment e = parse_experiment(protocol_config(config, protocol, true), c.file.string());
    const RunSummary rs = run_experiment(e, ro);
    const std::vector<Json> all_records = load_records(ro.out);
    const std::vector<Json> records = records_at_protocol(all_records, protocol);
    const ClaimOutcome outcome = judge_claim_at_protocol(c, records, protocol);
    Json j = claim_result_json(c, outcome);
    j["protocol"] = protocol_json(protocol);
    j["sensitivity"] = claim_sensitivity(c, protocol, all_records);
    j["folder"] = c.id;
    j["jobs"] = rs.planned;
    int not_ok = 0;
    for (const auto& r : all_records)
      not_ok += r.value("status", std::string()) == "ok" ? 0 : 1;
    j["jobs_failed"] = not_ok;
    j["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - tc).count();
    FinishOptions fo;
    fo.report = true;
    finish_run(ro.out, fo);
    if (!o.quiet) {
      fmt::print("  {}: {} ({:.0f} s)\n  measured: {}\n  sensitivity: {}\n", outcome.verdict,
                 outcome.reason, j["wall_s"].get<double>(), j["measured"].get<std::string>(),
                 j["sensitivity"]["text"].get<std::string>());
      if (!protocol.empty()) fmt::print("  parameters: {}\n", protocol_summary(j["protocol"]));
      std::fflush(stdout);
    }
    summary["claims"].push_back(j);
  }
  summary["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  summary["regressions"] = Json::array();
  if (!o.baseline.empty() && fs::exists(o.baseline)) {
    const Json base = read_json_file(o.baseline);
    summary["baseline"] = o.baseline.string();
    for (const auto& id : claim_regressions(base, summary))
      summary["regressions"].push_back(id);
  }
  write_json_file(o.out / "claims.json", summary);
  write_file_atomic(o.out / "claims.md", claims_markdown(summary));
  write_claims_page(o.out, summary);
  return summary;
}

int print_failed_claim_jobs(const Json& summary, const fs::path& out) {
  int failed = 0;
  for (const auto& c : summary.value("claims", Json::array())) {
    const int n = c.value("jobs_failed", 0);
    if (n == 0) continue;
    if (failed == 0) fmt::print("\nclaims with failed jobs:\n");
    failed += n;
    fmt::print("  {}: {} of {} jobs failed (their reasons: scanbench status {})\n",
               c.value("id", std::string()), n, c.value("jobs", 0),
               (out / c.value("folder", std::string())).string());
  }
  return failed;
}

void add_claims_command(Cli& cli) {
  struct Args {
    ClaimsOptions o;
    std::string out, baseline, claims_dir, db;
    bool update_baseline = false;
    bool allow_failures = false;
  };
  auto a = std::make_shared<Args>();
  a->o.jobs = 2;
  CLI::App* sub = cli.app.add_subcommand(
      "claims",
      "Run the source papers' claims (configs/claims/*.json: an experiment and verdict rules "
      "each), print and write held/failed/inconclusive with the measured values; exit 1 when a "
      "claim that held in results/baseline/claims.json failed");
  sub->add_flag("--quick", a->o.quick, "Run each claim's quick variant (smaller scans)");
  sub->add_option("-o,--out", a->out, "Results folder (default results/claims-<UTC time>)");
  sub->add_option("--filter", a->o.filter, "Only claims whose id matches this regex");
  sub->add_option("-j,--jobs", a->o.jobs, "Jobs run at the same time (default 2)")
      ->check(CLI::Range(1, 256));
  sub->add_option("--baseline", a->baseline,
                  "Verdicts to compare with (default results/baseline/claims.json)");
  sub->add_flag("--update-baseline", a->update_baseline,
                "Write this run's verdicts to the baseline file instead of comparing");
  sub->add_option("--claims", a->claims_dir, "Folder of claim files (default configs/claims)");
  sub->add_flag("--resume", a->o.resume, "Keep the records already in the results folder");
  sub->add_flag("--allow-failures", a->allow_failures,
                "Exit 0 even when jobs of the claims failed (default: exit 4, listed last)");
  add_db_option(sub, a->db, "Add the claims folder (its verdicts) to this database");
  sub->callback([&cli, a] {
    cli.action = [a] {
      ClaimsOptions o = a->o;
      o.out = a->out.empty() ? fs::path("results/claims-" + utc_now("%Y%m%d-%H%M%S"))
                             : fs::path(a->out);
      const fs::path baseline = a->baseline.empty()
                                    ? project_root() / "results" / "baseline" / "claims.json"
                                    : fs::path(a->baseline);
      if (!a->claims_dir.empty()) o.claims_dir = a->claims_dir;
      if (!a->update_baseline) o.baseline = baseline;
      const Json s = run_claims(o);
      fmt::print("\n{}\n", claims_markdown(s));
      fmt::print("claims: {}/claims.json, {}/claims.md, {}/index.html ({:.0f} s)\n", o.out.string(),
                 o.out.string(), o.out.string(), s["wall_s"].get<double>());
      if (!a->db.empty()) {
        const HistoryAddResult h = history_add(a->db, o.out);
        fmt::print("history: {} claims run {} in {}\n", h.added ? "added" : "already had",
                   h.identity, a->db);
      }
      const int failed_jobs = print_failed_claim_jobs(s, o.out);
      const int ok = failed_jobs > 0 && !a->allow_failures ? kExitJobsFailed : 0;
      if (a->update_baseline) {
        const FolderLock lock = FolderLock::acquire(baseline.parent_path(),
                                                    "scanbench claims --update-baseline", 0, true);
        Json b = s;
        b.erase("regressions");
        write_json_file(baseline, b);
        fmt::print("baseline updated: {}\n", baseline.string());
        return ok;
      }
      if (!s.contains("baseline")) {
        fmt::print("no baseline at {}: nothing to compare\n", baseline.string());
        return ok;
      }
      if (s["regressions"].empty()) {
        fmt::print("no claim that held in {} failed\n", baseline.string());
        return ok;
      }
      fmt::print("REGRESSION: held in {} and failed now: {}\n", baseline.string(),
                 s["regressions"].dump());
      return 1;
    };
  });
}

}  // namespace scanbench::harness
