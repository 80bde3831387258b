// scanbench bench <scanner|distance|resample|filter> [--json FILE]: benchmarks measured in one run,
// printing ratios (never absolute targets checked by a timed test).
#include "commands.h"

namespace scanbench::harness {

void add_bench_scanner(CLI::App* bench, Cli& cli);    // cmd_bench_scanner.cpp
void add_bench_distance(CLI::App* bench, Cli& cli);   // cmd_bench_distance.cpp
void add_bench_resample(CLI::App* bench, Cli& cli);   // cmd_bench_resample.cpp
void add_bench_filter(CLI::App* bench, Cli& cli);     // cmd_bench_filter.cpp
void add_bench_subdivide(CLI::App* bench, Cli& cli);  // cmd_bench_subdivide.cpp

void add_bench_command(Cli& cli) {
  CLI::App* bench = cli.app.add_subcommand(
      "bench", "Benchmarks that print speed ratios measured in one run (--json FILE to save)");
  bench->require_subcommand(1);
  // One explicit list of benchmarks (each defined in its own cmd_bench_*.cpp).
  add_bench_scanner(bench, cli);
  add_bench_distance(bench, cli);
  add_bench_resample(bench, cli);
  add_bench_filter(bench, cli);
  add_bench_subdivide(bench, cli);

  if (bench->get_subcommands({}).empty()) cli.app.remove_subcommand(bench);
}

}  // namespace scanbench::harness
