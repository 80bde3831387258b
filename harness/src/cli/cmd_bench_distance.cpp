// scanbench bench distance [--json FILE] [--points N] [--dataset NAME | --mesh FILE]
//                          [--repeats N] [--threads N] [--far-share F] [--field-voxel F]
// Parses the flags, runs the distance benchmark (pipelines/bench_distance.h) and prints it.
#include <fmt/format.h>

#include <memory>

#include "cli/commands.h"
#include "scanbench/core/files.h"
#include "scanbench/harness/pipelines/bench_distance.h"

namespace scanbench::harness {

void add_bench_distance(CLI::App* bench, Cli& cli) {
  struct Opts {
    std::string json, dataset, mesh;
    std::int64_t points = 1000000;
    int repeats = 5;
    int threads = 0;
    double far_share = 0.02;
    double near_sigma = 0.002;
    double field_voxel = 1.0 / 512.0;
    std::uint64_t seed = 1;
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = bench->add_subcommand(
      "distance",
      "Exact closest-point oracle vs OpenVDB distance-field path on the same query points "
      "(medians; ratio exact/field; mean deviation in voxels)");
  sub->add_option("--json", opts->json, "Write the results as JSON to this file");
  sub->add_option("--points", opts->points, "Query points")
      ->check(CLI::Range(std::int64_t{1}, std::int64_t{100000000}));
  auto* ds = sub->add_option("--dataset", opts->dataset,
                             "Ground-truth dataset (default: bunny when extracted, else sphere)");
  auto* mf = sub->add_option("--mesh", opts->mesh, "Ground-truth mesh file");
  ds->excludes(mf);
  mf->excludes(ds);
  sub->add_option("--repeats", opts->repeats, "Timed repeats per path (medians are reported)")
      ->check(CLI::Range(1, 1000));
  sub->add_option("--threads", opts->threads, "Worker threads (0 = all)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--far-share", opts->far_share,
                  "Share of queries uniform in 1.2 x bbox (the rest near the surface)")
      ->check(CLI::Range(0.0, 1.0));
  sub->add_option("--near-sigma", opts->near_sigma,
                  "Normal offset sigma of the near queries, fraction of the diagonal")
      ->check(CLI::Range(0.0, 0.1));
  sub->add_option("--field-voxel", opts->field_voxel, "Field voxel, fraction of the diagonal")
      ->check(CLI::Range(1e-5, 0.1));
  sub->add_option("--seed", opts->seed, "Seed of the query points");
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      DistanceBenchOptions o;
      o.dataset = opts->dataset;
      o.mesh = opts->mesh;
      o.points = opts->points;
      o.repeats = opts->repeats;
      o.threads = opts->threads;
      o.far_share = opts->far_share;
      o.near_sigma = opts->near_sigma;
      o.field_voxel = opts->field_voxel;
      o.seed = opts->seed;
      const DistanceBenchResult r = run_distance_bench(o);
      fmt::print("{}", r.text);
      if (!opts->json.empty()) write_json_file(opts->json, r.to_json(), 2);
      return 0;
    };
  });
}

}  // namespace scanbench::harness
