// scanbench claims [--quick] [-o DIR] [--filter REGEX] [--jobs N] [--baseline FILE]
//                  [--update-baseline] [--claims DIR] [--resume] [--allow-failures] [--db FILE]
// Parses the flags, runs the claims pipeline (pipelines/claims_run.h) and prints its summary.
#include <fmt/format.h>

#include "cli/commands.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/core/paths.h"
#include "scanbench/harness/pipelines/claims_run.h"
#include "scanbench/harness/results/claims_render.h"
#include "scanbench/harness/results/folder_lock.h"
#include "scanbench/harness/results/history.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

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
