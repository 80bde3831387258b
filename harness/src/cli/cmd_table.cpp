// scanbench table DIR [--format md|csv|tex|html] [--rows F] [--cols F] [--metric Q] [--pool-sweeps]
//                 [-o FILE]
#include <fmt/format.h>

#include "cli/commands.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/table.h"

namespace scanbench::harness {

void add_table_command(Cli& cli) {
  struct Args {
    std::string dir, format = "md", out;
    TableSpec spec;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = cli.app.add_subcommand(
      "table",
      "Comparison table of a results folder: best value per row marked, spread over "
      "repeats; sweep points separate unless --pool-sweeps");
  sub->add_option("dir", a->dir, "Results folder")->required();
  sub->add_option("--format", a->format, "md, csv, tex or html")
      ->check(CLI::IsMember({"md", "csv", "tex", "html"}));
  sub->add_option("--rows", a->spec.rows,
                  "Row fields joined by '+': dataset, scanner, variant, point, seed, status, "
                  "param:<key>")
      ->capture_default_str();
  sub->add_option("--cols", a->spec.cols, "Column fields (as --rows)")->capture_default_str();
  sub->add_option("--metric", a->spec.metric,
                  "Metric key, time.total, time.cpu, time.<phase>, peak_rss_mb or sizes.<key> "
                  "(default p2plane_mean_rel); one the records hold");
  sub->add_flag("--pool-sweeps", a->spec.pool_sweeps,
                "Pool the sweep points of a variant into one cell (the header says so); by "
                "default a variant's sweep points are separate columns");
  sub->add_option("-o,--out", a->out, "Write to this file instead of stdout");
  sub->callback([&cli, a] {
    cli.action = [a] {
      const std::string text = render_table(build_table(load_records(a->dir), a->spec), a->format);
      if (a->out.empty()) {
        fmt::print("{}", text);
      } else {
        write_file_atomic(a->out, text);
      }
      return 0;
    };
  });
}

}  // namespace scanbench::harness
