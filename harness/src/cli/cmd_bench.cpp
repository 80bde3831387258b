// scanbench bench <scanner|distance|resample|filter|subdivide> [--json FILE]: benchmarks measured
// in one run, printing ratios (never absolute targets checked by a timed test). The paper-case
// benches (resample, filter, subdivide) are library code (harness/bench.h); these commands parse
// flags and call it.
#include <functional>
#include <memory>

#include "cli/commands.h"
#include "scanbench/harness/pipelines/bench.h"

namespace scanbench::harness {

void add_bench_scanner(CLI::App* bench, Cli& cli);   // cmd_bench_scanner.cpp
void add_bench_distance(CLI::App* bench, Cli& cli);  // cmd_bench_distance.cpp

namespace {

// The flags of every paper-case bench, and its JSON file.
void add_common(CLI::App* sub, BenchOptions& o, std::string& json, const char* quick_doc) {
  sub->add_option("--json", json, "Write the results as JSON to this file");
  sub->add_flag("--quick", o.quick, quick_doc);
  sub->add_option("--rounds,--repeats", o.rounds,
                  "Interleaved rounds kept (each runs every case once; ratios per round)")
      ->check(CLI::Range(1, 1000));
  sub->add_option("--warmup", o.warmup, "Rounds run first and discarded")
      ->check(CLI::Range(0, 100));
  sub->add_option("--threads", o.threads, "Worker threads (0 = all)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--seed", o.seed, "Seed of the scan, the methods and the bootstrap");
}

// The paper case's scan: its size and dataset.
void add_case_options(CLI::App* sub, long& points, std::string& dataset, long max_points) {
  sub->add_option("--points", points, "Rescale the claim's scan to about this many points")
      ->check(CLI::Range(1000L, max_points));
  sub->add_option("--dataset", dataset, "Dataset name or mesh file (default: the claim's)");
}

// One paper-case bench: its subcommand with the common flags, then its own (`own_flags`), and
// the action that runs it and writes --json.
template <class Opts>
void add_case_bench(CLI::App* bench, Cli& cli, const char* name, const char* doc,
                    const char* quick_doc, Json (*run)(const Opts&),
                    const std::function<void(CLI::App*, Opts&)>& own_flags) {
  auto o = std::make_shared<Opts>();
  auto json = std::make_shared<std::string>();
  CLI::App* sub = bench->add_subcommand(name, doc);
  add_common(sub, *o, *json, quick_doc);
  own_flags(sub, *o);
  sub->callback([&cli, o, json, run] {
    cli.action = [o, json, run] {
      const Json out = run(*o);
      if (!json->empty()) write_json_file(*json, out, 2);
      return 0;
    };
  });
}

void add_bench_resample(CLI::App* bench, Cli& cli) {
  add_case_bench<ResampleBenchOptions>(
      bench, cli, "resample",
      "CLOP paper Camel case (claim clop-fig9-speed): CLOP vs WLOP vs CGAL's WLOP in interleaved "
      "rounds (median ratios with 95% intervals, p2plane_mean, nn_dist_cv; --scaling: threads, "
      "growth, memory)",
      "About 20K points and 3 rounds (a smoke run)", &bench_resample,
      [](CLI::App* sub, ResampleBenchOptions& o) {
        sub->add_flag("--scaling", o.scaling,
                      "Also 1 vs 2 threads, CLOP time over --sizes and peak memory per point");
        sub->add_flag("--no-cgal", o.no_cgal, "Skip CGAL's WLOP (slow)");
        add_case_options(sub, o.points, o.dataset, 50000000L);
        sub->add_option("--sizes", o.sizes, "Scan sizes of the --scaling growth run")
            ->delimiter(',')
            ->check(CLI::Range(1000L, 50000000L));
      });
}

void add_bench_filter(CLI::App* bench, Cli& cli) {
  add_case_bench<FilterBenchOptions>(
      bench, cli, "filter",
      "GPF paper Table 1 case (claim gpf-table1-timing): GPF (normals counted) vs WLOP, CLOP and "
      "the EAR chain in interleaved rounds (median ratios with 95% intervals, p2plane near sharp "
      "edges; --scaling: GPF on 1 vs 2 threads)",
      "About 10K points and 3 rounds (a smoke run)", &bench_filter,
      [](CLI::App* sub, FilterBenchOptions& o) {
        sub->add_flag("--scaling", o.scaling,
                      "Also GPF's chain (normals included) on 1 vs 2 threads, interleaved");
        add_case_options(sub, o.points, o.dataset, 10000000L);
      });
}

void add_bench_subdivide(CLI::App* bench, Cli& cli) {
  add_case_bench<SubdivideBenchOptions>(
      bench, cli, "subdivide",
      "GP-Loop vs linear Loop on the same control mesh, levels 1-4, in interleaved rounds "
      "(ratio gp_loop/loop per level), and both limit surfaces' distance to the smooth original "
      "of coarse sphere and torus control meshes",
      "Fewer rounds (a smoke run)", &bench_subdivide, [](CLI::App* sub, SubdivideBenchOptions& o) {
        sub->add_option("--resolution", o.resolution,
                        "Cube-sphere resolution of the timed control mesh (12 n^2 triangles)")
            ->check(CLI::Range(1, 256));
        sub->add_option("--sigma0", o.sigma_0,
                        "sigma_0 of the face-based covariance inference (eq. 17), fraction of "
                        "the bbox diagonal")
            ->check(CLI::Range(1e-6, 1.0));
      });
}

}  // namespace

void add_bench_command(Cli& cli) {
  CLI::App* bench = cli.app.add_subcommand(
      "bench", "Benchmarks that print speed ratios measured in one run (--json FILE to save)");
  bench->require_subcommand(1);
  // One explicit list of benchmarks.
  add_bench_scanner(bench, cli);
  add_bench_distance(bench, cli);
  add_bench_resample(bench, cli);
  add_bench_filter(bench, cli);
  add_bench_subdivide(bench, cli);

  if (bench->get_subcommands({}).empty()) cli.app.remove_subcommand(bench);
}

}  // namespace scanbench::harness
