// scanbench history add DIR [--db FILE] [--machine NAME]
// scanbench history show [--db FILE] [--metric K] [--dataset D] [--variant V] [--job KEY]
//                        [--since REV] [--format md|csv|json]
// scanbench history bisect GOOD BAD --metric K --job KEY [--config F] [--repo DIR]
// scanbench history changes [--db FILE] [same filters] [--window N] [--alpha A] [--sigmas S]
//                           [--min-rel R] [--format md|csv|json]
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "cli/commands.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/paths.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/results/history.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/table.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

struct QueryArgs {
  std::string db;
  HistoryFilter filter;
  std::string format = "md";
};

fs::path db_path(const std::string& db) {
  return db.empty() ? default_history_db() : fs::path(db);
}

void add_query_options(CLI::App* sub, QueryArgs& a) {
  add_db_option(sub, a.db, "Database to read (default results/history.sqlite)");
  sub->add_option("--metric", a.filter.metric,
                  "Quantity: a metric key, time.total, time.<step>:<phase>, peak_rss_mb, "
                  "sizes.<key> (default: every metric key and time.total)");
  sub->add_option("--dataset", a.filter.dataset, "Only this dataset label");
  sub->add_option("--variant", a.filter.variant, "Only this variant label");
  sub->add_option("--job", a.filter.key, "Only this job key (dataset|scanner|variant|point|seed)");
  sub->add_option("--since", a.filter.since, "From this commit (prefix) on, by commit date");
  sub->add_option("--machine", a.filter.machine,
                  "Only runs of this machine (as `history add` recorded it)");
  sub->add_option("--format", a.format, "md, csv or json")
      ->check(CLI::IsMember({"md", "csv", "json"}));
}

std::string num(double v) {
  return std::isfinite(v) ? fmt::format("{:.6g}", v) : "";
}

std::string render_show(const std::vector<HistorySeries>& all, const std::string& format) {
  std::string out;
  if (format == "csv")
    out = "key,dataset,variant,quantity,commit,date,runs,samples,median,min,max\n";
  Json j = Json::array();
  for (const auto& s : all) {
    if (format == "md") {
      out += fmt::format(
          "### {} : {}\n\n| commit | date | runs | samples | median | min | max |\n"
          "|---|---|---:|---:|---:|---:|---:|\n",
          s.key, s.quantity);
    }
    Json pts = Json::array();
    for (const auto& p : s.points) {
      const auto [lo, hi] = std::minmax_element(p.samples.begin(), p.samples.end());
      const double mn = p.samples.empty() ? std::nan("") : *lo;
      const double mx = p.samples.empty() ? std::nan("") : *hi;
      const double med = median(p.samples);
      if (format == "md") {
        out += fmt::format("| {} | {} | {} | {} | {} | {} | {} |\n", p.commit, p.date, p.runs,
                           p.samples.size(), num(med), num(mn), num(mx));
      } else if (format == "csv") {
        out += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", csv_field(s.key),
                           csv_field(s.dataset), csv_field(s.variant), csv_field(s.quantity),
                           p.commit, p.date, p.runs, p.samples.size(), num(med), num(mn), num(mx));
      }
      pts.push_back(
          {{"commit", p.commit}, {"date", p.date}, {"runs", p.runs}, {"samples", p.samples}});
    }
    if (format == "md") out += "\n";
    j.push_back({{"key", s.key},
                 {"dataset", s.dataset},
                 {"variant", s.variant},
                 {"quantity", s.quantity},
                 {"direction", s.direction},
                 {"points", pts}});
  }
  if (format == "json") out = j.dump(1) + "\n";
  if (format == "md" && all.empty()) out = "(no matching history)\n";
  return out;
}

std::string render_changes(const std::vector<HistorySeries>& all, const ChangeOptions& o,
                           const std::string& format, int& found) {
  std::string out = format == "md" ? "| job | quantity | commits | before | after | step | noise | "
                                     "p | verdict |\n|---|---|---|---:|---:|---:|---:|---:|---|\n"
                                   : "key,quantity,last_before,first_after,before,after,step,"
                                     "rel_step,noise,p,verdict\n";
  Json j = Json::array();
  for (const auto& s : all) {
    std::vector<std::vector<double>> per_commit;
    for (const auto& p : s.points)
      per_commit.push_back(p.samples);
    for (const auto& c : find_change_points(per_commit, o)) {
      ++found;
      const std::string& a = s.points[c.index - 1].commit;
      const std::string& b = s.points[c.index].commit;
      const char* verdict = s.direction == 0           ? "changed"
                            : c.step * s.direction < 0 ? "regression"
                                                       : "improvement";
      if (format == "md") {
        out +=
            fmt::format("| {} | {} | {}..{} | {} | {} | {:+.3g} ({:+.1f}%) | {} | {:.2g} | {} |\n",
                        s.key, s.quantity, a, b, num(c.before), num(c.after), c.step,
                        100 * c.rel_step, num(c.noise), c.p, verdict);
      } else {
        out += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", csv_field(s.key),
                           csv_field(s.quantity), a, b, num(c.before), num(c.after), num(c.step),
                           num(c.rel_step), num(c.noise), num(c.p), verdict);
      }
      j.push_back({{"key", s.key},
                   {"quantity", s.quantity},
                   {"last_before", a},
                   {"first_after", b},
                   {"before", c.before},
                   {"after", c.after},
                   {"step", c.step},
                   {"rel_step", c.rel_step},
                   {"noise", c.noise},
                   {"p", c.p},
                   {"verdict", verdict}});
    }
  }
  if (format == "json") return j.dump(1) + "\n";
  if (format == "md" && found == 0) out += "| (no change points) | | | | | | | | |\n";
  return out;
}

void add_changes_options(CLI::App* sub, ChangeOptions& o) {
  sub->add_option("--window", o.window, "Commits on each side of a split (default 5)")
      ->check(CLI::Range(1, 1000));
  sub->add_option("--alpha", o.alpha, "U-test significance level (default 0.01)")
      ->check(CLI::Range(1e-12, 1.0));
  sub->add_option("--sigmas", o.sigmas, "Step must exceed this many noise SDs (default 3)")
      ->check(CLI::Range(0.0, 1e6));
  sub->add_option("--min-rel", o.min_rel,
                  "Step must exceed this fraction of the level (default 0.01)")
      ->check(CLI::Range(0.0, 1e6));
}

void add_bisect_command(Cli& cli, CLI::App* hist) {
  auto o = std::make_shared<BisectOptions>();
  auto scratch = std::make_shared<std::string>();
  CLI::App* sub = hist->add_subcommand(
      "bisect",
      "Name the first bad commit between GOOD and BAD for one job's quantity: build each probed "
      "commit in a scratch worktree (scripts/build.sh), rerun the job, binary search");
  sub->add_option("good", o->good, "A commit where the quantity is good")->required();
  sub->add_option("bad", o->bad, "A later commit where it is bad")->required();
  sub->add_option("--metric", o->metric, "Quantity (a metric key or time.total)")->required();
  sub->add_option("--job", o->job, "Job key (dataset|scanner|variant|point|seed)")->required();
  sub->add_option("--config", o->config,
                  "Experiment holding the job, relative to the repository (default "
                  "configs/nightly.json)");
  sub->add_option("--rel", o->rel,
                  "Bad: worse than at GOOD by more than this fraction (default 0.05)")
      ->check(CLI::Range(0.0, 1e6));
  sub->add_option("--repo", o->repo, "Git repository (default the scanbench source folder)");
  sub->add_option("--scratch", *scratch, "Scratch folder (default results/bisect-<UTC time>)");
  sub->callback([&cli, o, scratch] {
    cli.action = [o, scratch] {
      BisectOptions b = *o;
      if (b.repo.empty()) b.repo = project_root();
      b.scratch = scratch->empty() ? fs::path("results/bisect-" + utc_now("%Y%m%d-%H%M%S"))
                                   : fs::path(*scratch);
      const BisectResult r = history_bisect(b);
      if (!r.first_bad.empty()) {
        fmt::print("first bad commit: {}\n", r.first_bad);
        return 0;
      }
      fmt::print("bisect stopped: {}\n", r.stopped);
      return 1;
    };
  });
}

}  // namespace

void add_db_option(CLI::App* sub, std::string& db, const std::string& what) {
  sub->add_option("--db", db, what + " (SQLite results history, docs/history.md)");
}

void add_history_command(Cli& cli) {
  CLI::App* hist = cli.app.add_subcommand(
      "history",
      "Results history in a SQLite database: add results folders, show a quantity per commit, "
      "find change points, bisect (docs/history.md)");
  hist->require_subcommand(1);

  struct AddArgs {
    std::string db, dir, machine;
  };
  auto add = std::make_shared<AddArgs>();
  CLI::App* sub = hist->add_subcommand(
      "add", "Import a finished results folder (idempotent: a run already there changes nothing)");
  sub->add_option("dir", add->dir, "Results folder (runs.jsonl or jobs/, and/or claims.json)")
      ->required();
  add_db_option(sub, add->db,
                "Database to add to, made when missing (default "
                "results/history.sqlite)");
  sub->add_option("--machine", add->machine,
                  "Machine name for timing history (default host / CPU / threads / ISA)");
  sub->callback([&cli, add] {
    cli.action = [add] {
      const HistoryAddResult r = history_add(db_path(add->db), add->dir, add->machine);
      if (r.added) {
        fmt::print("{}: added run {} ({} jobs, {} samples, {} claims) to {}\n", add->dir,
                   r.identity, r.jobs, r.samples, r.claims, db_path(add->db).string());
      } else {
        fmt::print("{}: run {} already in {}: nothing changed\n", add->dir, r.identity,
                   db_path(add->db).string());
      }
      return 0;
    };
  });

  auto show = std::make_shared<QueryArgs>();
  sub = hist->add_subcommand("show", "A table per job and quantity: one row per commit");
  add_query_options(sub, *show);
  sub->callback([&cli, show] {
    cli.action = [show] {
      fmt::print("{}", render_show(history_series(db_path(show->db), show->filter), show->format));
      return 0;
    };
  });

  struct ChangesArgs {
    QueryArgs q;
    ChangeOptions o;
  };
  auto ch = std::make_shared<ChangesArgs>();
  sub = hist->add_subcommand(
      "changes",
      "Change points: commits where a quantity's level stepped by more than its noise (U test on "
      "a window of commits before and after, the repeats as samples; docs/history.md)");
  add_query_options(sub, ch->q);
  add_changes_options(sub, ch->o);
  sub->callback([&cli, ch] {
    cli.action = [ch] {
      int found = 0;
      fmt::print("{}", render_changes(history_series(db_path(ch->q.db), ch->q.filter), ch->o,
                                      ch->q.format, found));
      return 0;
    };
  });
  add_bisect_command(cli, hist);
}

}  // namespace scanbench::harness
