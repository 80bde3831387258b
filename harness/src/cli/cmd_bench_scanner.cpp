// scanbench bench scanner [--json FILE] [--sizes N,...] [--repeats N] [--threads N]: parses the
// flags, runs the scanner benchmark (pipelines/bench_scanner.h) and prints it.
#include <fmt/format.h>

#include <memory>
#include <vector>

#include "cli/commands.h"
#include "scanbench/core/files.h"
#include "scanbench/harness/pipelines/bench_scanner.h"

namespace scanbench::harness {

void add_bench_scanner(CLI::App* bench, Cli& cli) {
  struct Opts {
    std::string json;
    std::vector<int> sizes{1000, 10000, 100000, 1000000};
    int repeats = 5;
    int threads = 0;
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = bench->add_subcommand(
      "scanner",
      "Rays/s of the scanner with every artifact on vs bare rtcIntersect1M on the same rays "
      "(medians; ratio = median over sizes)");
  sub->add_option("--json", opts->json, "Write the results as JSON to this file");
  sub->add_option("--sizes", opts->sizes, "Triangle counts of the procedural spheres")
      ->delimiter(',')
      ->check(CLI::Range(8, 50000000));
  sub->add_option("--repeats", opts->repeats, "Timed repeats per size (medians are reported)")
      ->check(CLI::Range(1, 1000));
  sub->add_option("--threads", opts->threads, "Worker threads (0 = all)")
      ->check(CLI::NonNegativeNumber);
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      ScannerBenchOptions o;
      o.sizes = opts->sizes;
      o.repeats = opts->repeats;
      o.threads = opts->threads;
      o.progress = [](const std::string& line) { fmt::print("{}", line); };
      const ScannerBenchResult r = run_scanner_bench(o);
      fmt::print("{}", r.text);
      if (!opts->json.empty()) write_json_file(opts->json, r.to_json(), 2);
      return 0;
    };
  });
}

}  // namespace scanbench::harness
