// scanbench scan --dataset NAME|--mesh FILE [--preset NAME|FILE] [--set key=value ...] --seed N
//                [--threads N] -o out.ply
#include <fmt/format.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_context.h"
#include "scanbench/scanner/registry.h"
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
      if (opts->dataset.empty() == opts->mesh.empty()) {
        throw ParamError("scan: give exactly one of --dataset NAME or --mesh FILE");
      }
      const auto t0 = std::chrono::steady_clock::now();
      const TriangleMesh mesh =
          opts->mesh.empty() ? load_dataset(opts->dataset) : read_mesh(opts->mesh);
      Json values = opts->preset.empty() ? schema_of<scanner::ScannerParams>().defaults()
                                         : scanner::preset_values(opts->preset);
      for (const auto& s : opts->sets)
        apply_assignment(values, s);
      const auto p = params_from_json<scanner::ScannerParams>(values, "scanner");
      RunContext ctx(opts->seed, opts->threads);
      scanner::Scan s = scanner::scan(mesh, p, ctx);
      Json input = Json::object();
      input["dataset"] = opts->dataset.empty() ? Json(nullptr) : Json(opts->dataset);
      input["mesh"] = opts->mesh.empty() ? Json(nullptr) : Json(opts->mesh);
      input["preset"] = opts->preset.empty() ? Json(nullptr) : Json(opts->preset);
      s.record["input"] = input;
      scanner::write_scan(s, opts->output);
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const Json& c = s.record["counts"];
      const std::string from = p.kind == "surface_samples" ? std::string("surface samples")
                                                           : fmt::format("{} views", p.views);
      fmt::print("scan: {} points ({} outliers) from {} of {} in {:.2f} s -> {}\n",
                 c["points"].get<std::int64_t>(), c["outliers"].get<std::int64_t>(), from,
                 opts->mesh.empty() ? opts->dataset : opts->mesh, seconds, opts->output);
      return 0;
    };
  });
}

}  // namespace scanbench::harness
