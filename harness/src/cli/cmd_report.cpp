// scanbench report DIR [-o FILE] [--db FILE]
#include <fmt/format.h>

#include "cli/commands.h"
#include "scanbench/harness/results/folder_lock.h"
#include "scanbench/harness/results/report.h"

namespace scanbench::harness {

void add_report_command(Cli& cli) {
  struct Args {
    std::string dir, out, db;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = cli.app.add_subcommand(
      "report",
      "Write one static offline HTML page (DIR/index.html): tables, SVG plots, "
      "heatmaps, links to scans and outputs");
  sub->add_option("dir", a->dir, "Results folder")->required();
  sub->add_option("-o,--out", a->out, "HTML file (default DIR/index.html)");
  add_db_option(sub, a->db, "Add a History section: plots over the commits of this database");
  sub->callback([&cli, a] {
    cli.action = [a] {
      const FolderLock lock = FolderLock::acquire(a->dir, "scanbench report");
      fmt::print("{}\n", write_report(a->dir, a->out, a->db).string());
      return 0;
    };
  });
}

}  // namespace scanbench::harness
