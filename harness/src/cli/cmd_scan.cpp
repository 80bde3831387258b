// scanbench scan --dataset NAME|--mesh FILE [--preset NAME|FILE] [--set key=value ...] --seed N
//                [--threads N] -o out.ply
#include <fmt/format.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "scanbench/harness/pipelines/scan_run.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::harness {

void add_scan_command(Cli& cli) {
  struct Opts {
    std::string dataset;
    std::string mesh;
    std::string preset;
    std::vector<std::string> sets;
    std::uint64_t seed = 0;
    int threads = 0;
    std::string output;
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = cli.app.add_subcommand(
      "scan",
      "Virtual scan of a mesh: binary PLY (positions, scan_id, outlier, clean_x/y/z, sensors) "
      "plus <out>.json with parameters, seed, poses and applied misalignments");
  auto* ds =
      sub->add_option("--dataset", opts->dataset, "Registered dataset (scanbench list datasets)");
  auto* mf = sub->add_option("--mesh", opts->mesh, "Mesh file (.off, .ply, .obj, .stl)");
  ds->excludes(mf);
  mf->excludes(ds);
  sub->add_option("--preset", opts->preset,
                  "Scanner preset name (scanbench list scanners) or preset JSON file; default: "
                  "the scanner's defaults");
  sub->add_option("--set", opts->sets, "Override a scanner parameter: key=value (repeatable)");
  sub->add_option("--seed", opts->seed, "Seed of every random stream")->required();
  sub->add_option("--threads", opts->threads, "Worker threads (0 = all); never changes results")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("-o,--output", opts->output, "Output PLY (the record goes to <output>.json)")
      ->required();
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      const auto t0 = std::chrono::steady_clock::now();
      ScanRequest r;
      r.dataset = opts->dataset;
      r.mesh = opts->mesh;
      r.preset = opts->preset;
      r.sets = opts->sets;
      r.seed = opts->seed;
      r.threads = opts->threads;
      const scanner::Scan s = run_scan(r);
      const auto& p = s.record["params"];
      scanner::write_scan(s, opts->output);
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const Json& c = s.record["counts"];
      const std::string from = p.value("kind", std::string()) == "surface_samples"
                                   ? std::string("surface samples")
                                   : fmt::format("{} views", p.value("views", 0));
      fmt::print("scan: {} points ({} outliers) from {} of {} in {:.2f} s -> {}\n",
                 c["points"].get<std::int64_t>(), c["outliers"].get<std::int64_t>(), from,
                 opts->mesh.empty() ? opts->dataset : opts->mesh, seconds, opts->output);
      return 0;
    };
  });
}

}  // namespace scanbench::harness
