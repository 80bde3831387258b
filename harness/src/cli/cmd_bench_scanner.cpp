// scanbench bench scanner [--json FILE] [--sizes N,...] [--repeats N] [--threads N]: rays per
// second of the full scanner (every artifact on) against a bare rtcIntersect1M loop over the same
// scene and the same rays (same order, same coherent-context flag, same per-tile streams; see
// scanbench/scanner/throughput.h), measured in one run, for procedural spheres of increasing size.
// Wall-clock ratios are the result; process-CPU ratios are printed next to them because the
// build machine is shared (other processes disturb wall clocks more than CPU seconds).
#include <fmt/format.h>

#include <algorithm>
#include <memory>
#include <vector>

#include "cli/commands.h"
#include "scanbench/core/allocator.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/core/run_context.h"
#include "scanbench/harness/records.h"
#include "scanbench/scanner/throughput.h"

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
      // The allocator policy is the program's own, set in main for every command
      // (scanbench/core/allocator.h): the bench measures what `scan` and `run` do.
      RunContext ctx(1, opts->threads);
      const scanner::ScannerParams p = scanner::all_artifacts_params();
      Json cases = Json::array();
      std::vector<double> ratios;
      std::vector<double> cpu_ratios;
      fmt::print("{:>10} {:>10} {:>14} {:>16} {:>7} {:>9}\n", "triangles", "rays", "bare Mrays/s",
                 "scanner Mrays/s", "ratio", "CPU ratio");
      for (int size : opts->sizes) {
        const TriangleMesh mesh = scanner::uv_sphere(size);
        const scanner::ThroughputResult r =
            scanner::measure_throughput(mesh, p, opts->repeats, ctx);
        fmt::print("{:>10} {:>10} {:>14.2f} {:>16.2f} {:>7.3f} {:>9.3f}\n", r.triangles,
                   r.rays_per_run, r.bare_rays_per_second * 1e-6, r.scanner_rays_per_second * 1e-6,
                   r.ratio, r.cpu_ratio);
        Json c = Json::object();
        c["triangles"] = r.triangles;
        c["rays_per_run"] = r.rays_per_run;
        c["points"] = r.points;
        c["bare_rays_per_second"] = r.bare_rays_per_second;
        c["scanner_rays_per_second"] = r.scanner_rays_per_second;
        c["ratio"] = r.ratio;
        c["cpu_ratio"] = r.cpu_ratio;
        // Same rays on both sides: the bare hits give the scanner's returned beams.
        c["beams_returned_bare"] = r.bare_beams_returned;
        c["beams_returned_scanner"] = r.scanner_beams_returned;
        if (r.bare_beams_returned != r.scanner_beams_returned) {
          throw Error(
              fmt::format("bench scanner: {} triangles: the bare loop returned {} beams, "
                          "the scanner {}: not the same rays",
                          r.triangles, r.bare_beams_returned, r.scanner_beams_returned));
        }
        c["bare_seconds"] = r.bare_seconds;
        c["scanner_seconds"] = r.scanner_seconds;
        c["bare_cpu_seconds"] = r.bare_cpu_seconds;
        c["scanner_cpu_seconds"] = r.scanner_cpu_seconds;
        cases.push_back(std::move(c));
        ratios.push_back(r.ratio);
        cpu_ratios.push_back(r.cpu_ratio);
      }
      const double med = median(ratios);
      fmt::print(
          "scanner_over_bare_embree (median over sizes): {:.3f}, smallest {:.3f} (target >= 0.8 "
          "at every size); CPU-time median {:.3f}\n",
          med, *std::min_element(ratios.begin(), ratios.end()), median(cpu_ratios));
      if (!opts->json.empty()) {
        Json out = Json::object();
        out["benchmark"] = "scanner";
        // Version, compiler, SIMD path (isa, isa_flags) and allocator policy of this run.
        out["context"] = run_context_json();
        out["params"] = params_to_json(p);
        out["repeats"] = opts->repeats;
        out["threads"] = opts->threads;
        out["cases"] = std::move(cases);
        Json rat = Json::object();
        rat["scanner_over_bare_embree"] = med;
        rat["scanner_over_bare_embree_min"] = *std::min_element(ratios.begin(), ratios.end());
        rat["scanner_over_bare_embree_largest"] = ratios.back();
        rat["scanner_over_bare_embree_cpu"] = median(cpu_ratios);
        rat["scanner_over_bare_embree_cpu_min"] =
            *std::min_element(cpu_ratios.begin(), cpu_ratios.end());
        out["ratios"] = rat;
        out["comparison"] =
            "both sides cast the same rays (bit-identical; view, 8x8 tile, pixel, sub-ray order) "
            "on one BVH (robust, high quality) as one rtcIntersect1M AoS stream per (view, tile) "
            "with RTC_INTERSECT_CONTEXT_FLAG_COHERENT; bare = precomputed rays (untimed reset), "
            "scanner = ray generation + every artifact + output; BVH build excluded; ratio = "
            "scanner rays/s over bare rays/s (wall medians); cpu_ratio = bare over scanner "
            "process-CPU medians";
        out["target"] = 0.8;
        out["allocator"] = std::string(allocator_policy());
        write_json_file(opts->json, out, 2);
      }
      return 0;
    };
  });
}

}  // namespace scanbench::harness
