#include "scanbench/harness/pipelines/claims_run.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>

#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/core/paths.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/config/protocol.h"
#include "scanbench/harness/exec/runner.h"
#include "scanbench/harness/results/claims.h"
#include "scanbench/harness/results/claims_render.h"
#include "scanbench/harness/results/finish.h"
#include "scanbench/harness/results/folder_lock.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/table.h"
#include "scanbench/harness/results/tuning.h"

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

}  // namespace scanbench::harness
