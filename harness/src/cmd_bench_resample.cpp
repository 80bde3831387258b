// scanbench bench resample [--json FILE] [--quick] [--scaling] ...: the CLOP paper's Camel case
// (Fig. 9): the camel mesh scanned to about 87K points (18 views, range noise 0.5% of the
// diagonal, half the scans misregistered by 0.5 deg and 0.2% of the diagonal), about 72K
// particles, 10 iterations and one kernel width h for every method. Weighted CLOP (alpha 2,
// interleaved repulsion, HEM included in its time), our WLOP and CGAL's WLOP run in one process;
// each reports the median wall time of its repeats, p2plane_mean and nn_dist_cv, and the ratios of
// the medians. --scaling adds 1- vs 2-thread speedups, CLOP's time growth exponent over input
// sizes and its peak memory per input point (Linux: peak RSS reset through /proc/self/clear_refs).
// The growth run keeps the kernel's neighbourhood constant: h scales as 1/sqrt(N) from the Camel
// case (h N^1/2 fixed, as for a surface sampled N times), since at a fixed h every LOP-family
// operator does O(N) work per particle and grows as N^2 by definition.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "proc_memory.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/simd.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/records.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::harness {

namespace {

// The camel scan of the paper's case, its resolution calibrated so that it holds about
// target_points points (one scan at resolution 128, then the resolution scaled by the square
// root of the ratio). Deterministic for a seed.
PointCloud camel_scan(const TriangleMesh& mesh, long target_points, std::uint64_t seed,
                      Json* record) {
  scanner::ScannerParams p;
  p.views = 18;
  p.resolution = 128;
  p.noise_sigma = 0.005;
  p.max_incidence_deg = 80.0;
  p.misalign_fraction = 0.5;
  p.misalign_deg = 0.5;
  p.misalign_shift = 0.002;
  RunContext ctx(seed);
  const scanner::Scan probe = scanner::scan(mesh, p, ctx);
  if (probe.cloud.empty()) throw InputError("bench resample: the probe scan hit nothing");
  const double scale =
      std::sqrt(static_cast<double>(target_points) / static_cast<double>(probe.cloud.size()));
  p.resolution = std::max(8, static_cast<int>(std::lround(128.0 * scale)));
  RunContext ctx2(seed);
  scanner::Scan s = scanner::scan(mesh, p, ctx2);
  if (record) *record = s.record;
  return std::move(s.cloud);
}

struct CaseResult {
  std::string name;
  std::string algorithm;
  Json params;
  std::vector<double> seconds;
  std::vector<double> cpu;  // process CPU seconds per repeat (robust on a shared machine)
  std::map<std::string, double> phases;      // wall seconds, of the last repeat
  std::map<std::string, double> phases_cpu;  // process CPU seconds, of the last repeat
  algorithms::AlgorithmOutput output;
};

CaseResult run_case(const std::string& name, const std::string& algorithm, const Json& given,
                    const PointCloud& input, int repeats, int threads, std::uint64_t seed) {
  const auto& entry = algorithms::registry().at(algorithm);
  CaseResult r;
  r.name = name;
  r.algorithm = algorithm;
  r.params = entry.params.validate(given, "bench resample " + name);
  for (int i = 0; i < repeats; ++i) {
    RunContext ctx(seed, threads);
    const double t0 = wall_seconds();
    const double c0 = process_cpu_seconds();
    r.output = entry.fn(input, r.params, ctx);
    r.seconds.push_back(wall_seconds() - t0);
    r.cpu.push_back(process_cpu_seconds() - c0);
    r.phases = ctx.phase_seconds();
    r.phases_cpu = ctx.phase_cpu_seconds();
  }
  return r;
}

}  // namespace

void add_bench_resample(CLI::App* bench, Cli& cli) {
  struct Opts {
    std::string json;
    bool quick = false;
    bool scaling = false;
    bool no_cgal = false;
    int repeats = 3;
    int threads = 0;
    long points = 87000;
    double particles = 72.0 / 87.0;
    double h = 0.04;
    int iterations = 10;
    std::uint64_t seed = 1;
    std::string dataset = "camel";
    std::vector<long> sizes{10000, 100000, 1000000};
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = bench->add_subcommand(
      "resample",
      "CLOP paper Camel case: weighted CLOP vs our WLOP vs CGAL's WLOP at one kernel width "
      "(median times, p2plane_mean, nn_dist_cv, ratios; --scaling: threads, growth, memory)");
  sub->add_option("--json", opts->json, "Write the results as JSON to this file");
  sub->add_flag("--quick", opts->quick, "About 20K points and one repeat (a smoke run)");
  sub->add_flag("--scaling", opts->scaling,
                "Also 1 vs 2 threads, CLOP time over --sizes and peak memory per point");
  sub->add_flag("--no-cgal", opts->no_cgal, "Skip CGAL's WLOP (slow)");
  sub->add_option("--repeats", opts->repeats, "Timed repeats per method (medians are reported)")
      ->check(CLI::Range(1, 100));
  sub->add_option("--threads", opts->threads, "Worker threads (0 = all)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--points", opts->points, "Target scan size")
      ->check(CLI::Range(1000L, 50000000L));
  sub->add_option("--particles", opts->particles, "Particles as a share of the scan")
      ->check(CLI::Range(0.001, 1.0));
  sub->add_option("--h", opts->h, "Kernel width h (fraction of the bbox diagonal, LOP kernel)")
      ->check(CLI::Range(0.001, 0.5));
  sub->add_option("--iterations", opts->iterations, "Iterations of every method")
      ->check(CLI::Range(1, 1000));
  sub->add_option("--seed", opts->seed, "Seed of the scan and the methods");
  sub->add_option("--dataset", opts->dataset, "Dataset name or mesh file (default camel)");
  sub->add_option("--sizes", opts->sizes, "Scan sizes of the --scaling growth run")
      ->delimiter(',')
      ->check(CLI::Range(1000L, 50000000L));
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      Opts o = *opts;
      if (o.quick) {
        o.points = std::min(o.points, 20000L);
        o.repeats = 1;
        o.sizes = {5000, 20000, 80000};
      }
      const TriangleMesh mesh = load_dataset(o.dataset);
      Json scan_record;
      const PointCloud input = camel_scan(mesh, o.points, o.seed, &scan_record);
      const metrics::GroundTruth gt(mesh, o.seed);
      fmt::print("simd: {}; CGAL peers compiled with {}\n", simd::describe(),
                 simd::compile_flags());
      fmt::print("{}: {} scan points, {} particles, h = {} diag, {} iterations, {} repeats\n",
                 o.dataset, input.size(), std::lround(o.particles * input.size()), o.h,
                 o.iterations, o.repeats);

      const Json common = {{"h", o.h}, {"iterations", o.iterations}, {"particles", o.particles}};
      Json clop_p = common;
      clop_p["mu"] = 0.4;
      clop_p["alpha"] = 2.0;
      clop_p["interleave"] = true;
      clop_p["weighted"] = true;
      Json wlop_p = common;
      wlop_p["mu"] = 0.4;
      std::vector<CaseResult> results;
      results.push_back(
          run_case("clop", "resample.clop", clop_p, input, o.repeats, o.threads, o.seed));
      results.push_back(
          run_case("wlop", "resample.wlop", wlop_p, input, o.repeats, o.threads, o.seed));
      if (!o.no_cgal) {
        results.push_back(
            run_case("cgal_wlop", "peer.cgal_wlop", common, input, o.repeats, o.threads, o.seed));
      }
      // The paper's other reading of eq. 26 (Algorithm 1: v_j summed in the kernel pass), for
      // comparison only: the ratios above use the default.
      Json kernel_p = clop_p;
      kernel_p["density"] = "kernel";
      results.push_back(run_case("clop_kernel_density", "resample.clop", kernel_p, input, o.repeats,
                                 o.threads, o.seed));

      const std::vector<std::string> metric_names = {"accuracy.p2plane", "regularity.nn_dist"};
      auto measure = [&](const PointCloud& pc) {
        RunContext mctx(o.seed, o.threads);
        return metrics::evaluate(gt, pc, &input, metric_names, Json::object(), mctx);
      };
      const Json input_metrics = measure(input);
      Json cases = Json::array();
      std::map<std::string, double> med, med_cpu;
      fmt::print("{:>19} {:>10} {:>10} {:>10} {:>14} {:>11}  phases\n", "method", "median_s",
                 "cpu_s", "particles", "p2plane_mean", "nn_dist_cv");
      fmt::print("{:>19} {:>10} {:>10} {:>10} {:>14.6f} {:>11.4f}\n", "input", "-", "-",
                 input.size(), input_metrics.value("p2plane_mean_rel", 0.0),
                 input_metrics.value("nn_dist_cv", 0.0));
      for (const CaseResult& r : results) {
        const Json m = measure(r.output.points);
        Json c = Json::object();
        c["name"] = r.name;
        c["algorithm"] = r.algorithm;
        c["median_s"] = med[r.name] = median(r.seconds);
        c["seconds"] = r.seconds;
        c["cpu_s"] = med_cpu[r.name] = median(r.cpu);
        c["cpu_seconds"] = r.cpu;
        c["p2plane_mean"] = m.value("p2plane_mean_rel", 0.0);
        c["p2plane_mean_abs"] = m.value("p2plane_mean", 0.0);
        c["p2plane_rms"] = m.value("p2plane_rms_rel", 0.0);
        c["nn_dist_cv"] = m.value("nn_dist_cv", 0.0);
        c["particles"] = r.output.points.size();
        if (r.output.mixture) c["mixture_components"] = r.output.mixture->size();
        Json ph = Json::object();
        std::string phase_text;
        for (const auto& [k, v] : r.phases) {
          ph[k] = v;
          phase_text += fmt::format("{}={:.3f} ", k, v);
        }
        c["phases"] = ph;
        Json ph_cpu = Json::object();
        for (const auto& [k, v] : r.phases_cpu)
          ph_cpu[k] = v;
        c["phases_cpu"] = ph_cpu;
        c["params"] = r.params;
        fmt::print("{:>19} {:>10.3f} {:>10.3f} {:>10} {:>14.6f} {:>11.4f}  {}\n", r.name,
                   med[r.name], med_cpu[r.name], r.output.points.size(),
                   c["p2plane_mean"].get<double>(), c["nn_dist_cv"].get<double>(), phase_text);
        cases.push_back(std::move(c));
      }
      Json ratios = Json::object();
      ratios["wlop_over_clop"] = med["wlop"] / med["clop"];
      ratios["wlop_over_clop_cpu"] = med_cpu["wlop"] / med_cpu["clop"];
      ratios["wlop_over_clop_kernel_density"] = med["wlop"] / med["clop_kernel_density"];
      fmt::print("wlop_over_clop      {:8.2f}  (target >= 6; CPU time ratio {:.2f})\n",
                 med["wlop"] / med["clop"], med_cpu["wlop"] / med_cpu["clop"]);
      fmt::print("  (with density=kernel, Algorithm 1's reading of eq. 26: {:.2f})\n",
                 med["wlop"] / med["clop_kernel_density"]);
      // Phase by phase (CPU seconds of the last repeat), beside the CLOP paper's Fig. 9 Camel
      // speedups (GPU): WLOP's attraction includes its L2 first iteration (phase init), as
      // CLOP's includes its continuous first iteration; repulsion includes the densities w_i.
      {
        auto phases_of = [&](const std::string& name) -> const std::map<std::string, double>& {
          return std::find_if(results.begin(), results.end(),
                              [&](const CaseResult& r) { return r.name == name; })
              ->phases_cpu;
        };
        const auto& wc = phases_of("wlop");
        const auto& cc = phases_of("clop");
        auto get = [](const std::map<std::string, double>& m, const char* k) {
          const auto it = m.find(k);
          return it == m.end() ? 0.0 : it->second;
        };
        const double att = (get(wc, "init") + get(wc, "attraction")) / get(cc, "attraction");
        const double rep = get(wc, "repulsion") / get(cc, "repulsion");
        ratios["attraction_wlop_over_clop_cpu"] = att;
        ratios["repulsion_wlop_over_clop_cpu"] = rep;
        double clop_total = 0.0;
        for (const auto& [k, v] : cc)
          clop_total += v;
        const double hem_share = get(cc, "hem") / clop_total;
        ratios["hem_share_of_clop_cpu"] = hem_share;
        fmt::print(
            "  by phase (CPU): attraction {:.2f} (paper Fig. 9 Camel F1: 7.15), repulsion {:.2f} "
            "(F2: 7.80); HEM is {:.0f}% of CLOP (paper: 20%)\n",
            att, rep, 100.0 * hem_share);
      }
      if (!o.no_cgal) {
        ratios["cgal_wlop_over_clop"] = med["cgal_wlop"] / med["clop"];
        ratios["cgal_wlop_over_wlop"] = med["cgal_wlop"] / med["wlop"];
        ratios["cgal_wlop_over_clop_cpu"] = med_cpu["cgal_wlop"] / med_cpu["clop"];
        ratios["cgal_wlop_over_wlop_cpu"] = med_cpu["cgal_wlop"] / med_cpu["wlop"];
        fmt::print("cgal_wlop_over_clop {:8.2f}  (target >= 25; CPU time ratio {:.2f})\n",
                   med["cgal_wlop"] / med["clop"], med_cpu["cgal_wlop"] / med_cpu["clop"]);
        fmt::print("cgal_wlop_over_wlop {:8.2f}  (target >= 3; CPU time ratio {:.2f})\n",
                   med["cgal_wlop"] / med["wlop"], med_cpu["cgal_wlop"] / med_cpu["wlop"]);
      }

      Json scaling = Json::object();
      if (o.scaling) {
        for (const char* name : {"clop", "wlop"}) {
          const bool is_clop = std::string(name) == "clop";
          const Json& p = is_clop ? clop_p : wlop_p;
          const std::string algo = is_clop ? "resample.clop" : "resample.wlop";
          const CaseResult r1 = run_case(name, algo, p, input, o.repeats, 1, o.seed);
          const CaseResult r2 = run_case(name, algo, p, input, o.repeats, 2, o.seed);
          const double t1 = median(r1.seconds);
          const double t2 = median(r2.seconds);
          // Wall-time speedup; the CPU-time ratio shows the parallel overhead (1 = none).
          ratios[fmt::format("{}_threads_cpu_2_over_1", name)] = median(r2.cpu) / median(r1.cpu);
          ratios[fmt::format("{}_threads_2_over_1", name)] = t1 / t2;
          fmt::print("{} 1 thread {:.3f} s, 2 threads {:.3f} s: speedup {:.2f} (target >= 1.8)\n",
                     name, t1, t2, t1 / t2);
        }
        Json growth = Json::array();
        std::vector<double> ns, ts, tcs;
        double mem_per_point = -1.0;
        for (long size : o.sizes) {
          const PointCloud big = camel_scan(mesh, size, o.seed, nullptr);
          const bool mem_ok = reset_peak_rss();
          const long rss0 = status_kb("VmRSS");
          Json scaled = clop_p;
          const double h_scaled =
              o.h * std::sqrt(static_cast<double>(input.size()) / static_cast<double>(big.size()));
          scaled["h"] = h_scaled;
          const CaseResult r =
              run_case("clop", "resample.clop", scaled, big, o.repeats, o.threads, o.seed);
          const long hwm = status_kb("VmHWM");
          const double t = median(r.seconds);
          const double tc = median(r.cpu);
          // Peak growth over the RSS before the run; -1 when /proc cannot reset the peak.
          const double per_point = mem_ok && rss0 >= 0 && hwm >= 0
                                       ? 1024.0 * static_cast<double>(std::max(hwm - rss0, 0L)) /
                                             static_cast<double>(big.size())
                                       : -1.0;
          mem_per_point = per_point;
          ns.push_back(static_cast<double>(big.size()));
          ts.push_back(t);
          tcs.push_back(tc);
          growth.push_back({{"points", big.size()},
                            {"h", h_scaled},
                            {"median_s", t},
                            {"cpu_s", tc},
                            {"mixture_components", r.output.mixture ? r.output.mixture->size() : 0},
                            {"peak_bytes_per_point", per_point}});
          fmt::print(
              "clop at {:>9} points, h {:.4f}: {:8.3f} s ({:.3f} CPU s), peak memory {:.0f} "
              "B/point\n",
              big.size(), h_scaled, t, tc, per_point);
        }
        if (ns.size() >= 2) {
          const double exponent =
              std::log(ts.back() / ts.front()) / std::log(ns.back() / ns.front());
          ratios["clop_growth_exponent"] = exponent;
          ratios["clop_growth_exponent_cpu"] =
              std::log(tcs.back() / tcs.front()) / std::log(ns.back() / ns.front());
          ratios["clop_peak_bytes_per_point_largest"] = mem_per_point;
          fmt::print(
              "clop growth exponent {:.3f} (target <= 1.1), peak {:.0f} B/point at {} "
              "(target < 1024)\n",
              exponent, mem_per_point, static_cast<long>(ns.back()));
        }
        scaling["growth"] = std::move(growth);
      }

      if (!o.json.empty()) {
        Json out = Json::object();
        out["benchmark"] = "resample";
        // Version, compiler, SIMD path (isa, isa_flags) and allocator policy of this run.
        out["context"] = run_context_json();
        // Like for like: CGAL's WLOP (header-only, instantiated in algorithms/src/cgal_peers.cpp)
        // is compiled with the flags of the whole build, the same as our widest kernels.
        out["cgal_peers_compiled_with"] = {
            {"isa", std::string(simd::name(simd::compiled()))},
            {"flags", std::string(simd::compile_flags())},
            {"note",
             "every translation unit, CGAL's templates included, is compiled with these flags "
             "(CMake SCANBENCH_SIMD); our kernels run the packet of 'context.isa'"}};
        out["dataset"] = o.dataset;
        out["scan_points"] = input.size();
        out["h"] = o.h;
        out["iterations"] = o.iterations;
        out["particles_share"] = o.particles;
        out["repeats"] = o.repeats;
        out["threads"] = o.threads;
        out["seed"] = o.seed;
        out["scan_params"] = scan_record.contains("params") ? scan_record["params"] : Json();
        out["input"] = {{"p2plane_mean", input_metrics.value("p2plane_mean_rel", 0.0)},
                        {"nn_dist_cv", input_metrics.value("nn_dist_cv", 0.0)}};
        out["cases"] = std::move(cases);
        out["ratios"] = std::move(ratios);
        if (o.scaling) out["scaling"] = std::move(scaling);
        out["targets"] = {{"wlop_over_clop", 6.0},       {"cgal_wlop_over_clop", 25.0},
                          {"cgal_wlop_over_wlop", 3.0},  {"threads_2_over_1", 1.8},
                          {"clop_growth_exponent", 1.1}, {"clop_peak_bytes_per_point", 1024.0}};
        std::ofstream f(o.json, std::ios::binary | std::ios::trunc);
        f << out.dump(2) << "\n";
        f.flush();
        if (!f) throw IoError(fmt::format("{}: cannot write", o.json));
      }
      return 0;
    };
  });
}

}  // namespace scanbench::harness
