// scanbench compare BASE NEW [--json FILE] [--all] [--metric Q ...] [tolerance options]
#include <fmt/format.h>

#include "cli/commands.h"
#include "scanbench/harness/results/compare.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

void add_compare_command(Cli& cli) {
  struct Args {
    std::string base, now, json;
    bool all = false, no_timing = false;
    std::optional<double> alpha, time_threshold, rel, abs, min_time;
    std::vector<std::string> metrics;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = cli.app.add_subcommand(
      "compare",
      "Compare two results folders: accuracy with declared tolerances, timings with a "
      "Mann-Whitney U test (\"not decidable\" with too few repeats); exit 1 on any regression");
  sub->add_option("base", a->base, "Baseline results folder")->required();
  sub->add_option("new", a->now, "New results folder")->required();
  sub->add_option("--json", a->json, "Write every comparison and the verdict to this file");
  sub->add_flag("--all", a->all, "List unchanged quantities too");
  sub->add_option("--metric", a->metrics,
                  "Compare only this quantity (a metric key, time.total, time.<phase>; "
                  "repeatable) and the status; one the records hold");
  sub->add_option("--alpha", a->alpha, "U-test significance level (default 0.05)")
      ->check(CLI::Range(0.0, 1.0));
  sub->add_option("--time-threshold", a->time_threshold,
                  "Relative timing change that counts (default 0.10)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--min-time", a->min_time, "Absolute timing change that counts, s (0.001)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--rel", a->rel, "Default relative accuracy tolerance (0.05)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--abs", a->abs, "Default absolute accuracy tolerance (1e-9)")
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--no-timing", a->no_timing, "Compare accuracy and status only");
  sub->callback([&cli, a] {
    cli.action = [a] {
      // Tolerances declared in NEW's config ("compare"), then the command line.
      Json declared = Json::object();
      const fs::path cfg = fs::path(a->now) / "config.json";
      if (fs::exists(cfg))
        declared = read_json_file(cfg)["config"].value("compare", Json::object());
      CompareOptions o = CompareOptions::from_json(declared, cfg.string() + ": /compare");
      if (a->alpha) o.alpha = *a->alpha;
      if (a->time_threshold) o.time_threshold = *a->time_threshold;
      if (a->min_time) o.min_time_s = *a->min_time;
      if (a->rel) o.default_tolerance.rel = *a->rel;
      if (a->abs) o.default_tolerance.abs = *a->abs;
      if (a->no_timing) o.timing = false;
      o.only = a->metrics;
      const CompareResult res = compare_records(load_records(a->base), load_records(a->now), o);
      fmt::print("{}", res.table(a->all));
      if (!a->json.empty()) write_json_file(a->json, res.to_json());
      return res.regressed() ? 1 : 0;
    };
  });
}

}  // namespace scanbench::harness
