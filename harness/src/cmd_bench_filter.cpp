// scanbench bench filter [--json FILE] [--quick] ...: the GPF paper's timing case (Lu et al.
// 2017, Table 1, Fig. 8: the Block model, about 33K points with 1.5% noise, about half of them as
// particles): our fandisk_block scanned to about --points points with range noise --noise (fraction
// of the diagonal), one kernel width h for every method (scanbench's convention; GPF's own h is
// h/2, CGAL's neighbor_radius h/2).
//
// Cases (one process, median wall and CPU seconds over --repeats):
//  - normals: normals.pca -> normals.bilateral on the scan (timed once per repeat);
//  - gpf: filter.gpf on the scan with those normals; its total adds the normals' time, as the
//    paper's Table 1 counts PCA and bilateral filtering in GPF's time (`gpf_only` without);
//  - gpf_s2_fixed: the same with s2_update = fixed (see filter.gpf), for its accuracy;
//  - wlop, clop: resample.wlop and resample.clop on the bare scan (no normals needed);
//  - cgal_ear: CGAL's EAR upsampling (peer.cgal_ear) on the scan with the same normals, inserting
//    as many new points as GPF outputs (factor 1 + particles); its total adds the normals' time
//    too. CGAL has only EAR's upsampling, not its WLOP/ALOP resampling, so this is the peer's
//    part of the paper's EAR column.
// FilterAccuracy (against the procedural ground truth): p2plane_mean over every output point and
// p2plane_edge: the mean |<q - p, N_p>| / diag over the output points whose closest ground-truth
// point lies within 0.02 diag of a mesh edge with a dihedral angle above 30 degrees.
// Ratios: wlop_over_gpf, cgal_ear_over_gpf (totals), and the same over gpf_only; the paper's
// Table 1: CLOP fastest, GPF faster than WLOP and EAR (targets: both ratios >= 1).
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "scanbench/algorithms/bilateral_normals.h"
#include "scanbench/algorithms/cgal_peers.h"
#include "scanbench/algorithms/clop.h"
#include "scanbench/algorithms/gpf.h"
#include "scanbench/algorithms/lop.h"
#include "scanbench/algorithms/pca_normals.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/records.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/sharp_edges.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::harness {

namespace {

struct FilterAccuracy {
  double p2plane = 0.0, p2plane_edge = 0.0;
  long edge_points = 0;
};

// The edge set is edges.p2plane's (metrics/sharp_edges.h, at its defaults 30 degrees, 0.02 diag).
FilterAccuracy filter_accuracy(const metrics::GroundTruth& gt, const PointCloud& out) {
  const auto cps = gt.closest_points(out.positions);
  const std::vector<bool> near = metrics::near_sharp_edges(gt, cps, metrics::SharpEdgeParams{});
  const float diag = gt.diagonal();
  FilterAccuracy a;
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    const auto& cp = cps[static_cast<std::size_t>(i)];
    const double e = std::abs((out.positions.col(i) - cp.point).dot(cp.normal)) / diag;
    a.p2plane += e;
    if (near[static_cast<std::size_t>(i)]) {
      a.p2plane_edge += e;
      ++a.edge_points;
    }
  }
  a.p2plane /= std::max<double>(1.0, static_cast<double>(out.size()));
  a.p2plane_edge /= std::max<double>(1.0, static_cast<double>(a.edge_points));
  return a;
}

struct Timed {
  std::vector<double> seconds, cpu;
  std::map<std::string, double> phases_cpu;
  PointCloud output;
};

Timed time_it(int repeats, int threads, std::uint64_t seed,
              const std::function<PointCloud(RunContext&)>& f) {
  Timed t;
  for (int i = 0; i < repeats; ++i) {
    RunContext ctx(seed, threads);
    const double t0 = wall_seconds();
    const double c0 = process_cpu_seconds();
    t.output = f(ctx);
    t.seconds.push_back(wall_seconds() - t0);
    t.cpu.push_back(process_cpu_seconds() - c0);
    t.phases_cpu = ctx.phase_cpu_seconds();
  }
  return t;
}

}  // namespace

void add_bench_filter(CLI::App* bench, Cli& cli) {
  struct Opts {
    std::string json;
    bool quick = false;
    int repeats = 3;
    int threads = 0;
    long points = 33000;
    double noise = 0.015;
    double particles = 0.5;
    double h = 0.08;
    int iterations = 10;
    std::uint64_t seed = 1;
    std::string dataset = "fandisk_block";
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = bench->add_subcommand(
      "filter",
      "GPF paper Table 1 case: filter.gpf (with PCA + bilateral normals) vs WLOP, CLOP and CGAL's "
      "EAR upsampling at one kernel width (median times, p2plane near sharp edges, ratios)");
  sub->add_option("--json", opts->json, "Write the results as JSON to this file");
  sub->add_flag("--quick", opts->quick, "About 10K points and one repeat (a smoke run)");
  sub->add_option("--repeats", opts->repeats, "Timed repeats per method (medians are reported)")
      ->check(CLI::Range(1, 100));
  sub->add_option("--threads", opts->threads, "Worker threads (0 = all)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--points", opts->points, "Target scan size")
      ->check(CLI::Range(1000L, 10000000L));
  sub->add_option("--noise", opts->noise, "Range noise sigma, fraction of the diagonal")
      ->check(CLI::Range(0.0, 0.2));
  sub->add_option("--particles", opts->particles, "Particles as a share of the scan")
      ->check(CLI::Range(0.01, 1.0));
  sub->add_option("--h", opts->h, "Kernel width h (fraction of the diagonal, LOP kernel)")
      ->check(CLI::Range(0.001, 0.5));
  sub->add_option("--iterations", opts->iterations, "Iterations of GPF, WLOP and CLOP")
      ->check(CLI::Range(1, 1000));
  sub->add_option("--seed", opts->seed, "Seed of the scan and the methods");
  sub->add_option("--dataset", opts->dataset, "Dataset name or mesh file (default fandisk_block)");
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      Opts o = *opts;
      if (o.quick) {
        o.points = std::min(o.points, 10000L);
        o.repeats = 1;
      }
      const TriangleMesh mesh = load_dataset(o.dataset);
      // Scan: 10 views; the resolution calibrated from a probe to about o.points points.
      scanner::ScannerParams sp;
      sp.views = 10;
      sp.resolution = 128;
      sp.noise_sigma = o.noise;
      sp.max_incidence_deg = 80.0;
      PointCloud input;
      {
        RunContext c1(o.seed);
        const auto probe = scanner::scan(mesh, sp, c1);
        if (probe.cloud.empty()) throw InputError("bench filter: the probe scan hit nothing");
        sp.resolution = std::max(
            8, static_cast<int>(
                   std::lround(128.0 * std::sqrt(static_cast<double>(o.points) /
                                                 static_cast<double>(probe.cloud.size())))));
        RunContext c2(o.seed);
        input = scanner::scan(mesh, sp, c2).cloud;
      }
      const metrics::GroundTruth gt(mesh, o.seed);
      fmt::print(
          "{}: {} scan points (noise {} diag), particles {}, h = {} diag, {} iterations, "
          "{} repeats\n",
          o.dataset, input.size(), o.noise, o.particles, o.h, o.iterations, o.repeats);

      using namespace algorithms;
      const int th = o.threads;
      const Timed normals = time_it(o.repeats, th, o.seed, [&](RunContext& ctx) {
        return bilateral_normals(pca_normals(input, {}, ctx), {}, ctx);
      });
      const PointCloud& with_normals = normals.output;
      GpfParams gp;
      gp.h = o.h;
      gp.iterations = o.iterations;
      gp.particles = o.particles;
      const Timed g = time_it(o.repeats, th, o.seed,
                              [&](RunContext& ctx) { return gpf(with_normals, gp, ctx); });
      GpfParams gpf_fixed = gp;
      gpf_fixed.s2_update = "fixed";
      const Timed gf = time_it(o.repeats, th, o.seed,
                               [&](RunContext& ctx) { return gpf(with_normals, gpf_fixed, ctx); });
      LopParams wp;
      wp.h = o.h;
      wp.iterations = o.iterations;
      wp.particles = o.particles;
      wp.mu = 0.4;
      const Timed w =
          time_it(o.repeats, th, o.seed, [&](RunContext& ctx) { return wlop(input, wp, ctx); });
      ClopParams cp;
      cp.h = o.h;
      cp.iterations = o.iterations;
      cp.particles = o.particles;
      const Timed c = time_it(o.repeats, th, o.seed,
                              [&](RunContext& ctx) { return clop(input, cp, ctx).points; });
      CgalEarParams ep;
      ep.h = o.h;
      ep.factor = 1.0 + o.particles;
      const Timed e = time_it(o.repeats, th, o.seed,
                              [&](RunContext& ctx) { return cgal_ear(with_normals, ep, ctx); });

      const double t_normals = median(normals.seconds), c_normals = median(normals.cpu);
      struct Row {
        std::string name;
        double s, cpu;
        const PointCloud* out;
        const std::map<std::string, double>* phases;
      };
      const std::vector<Row> rows = {
          {"normals", t_normals, c_normals, &with_normals, &normals.phases_cpu},
          {"gpf_only", median(g.seconds), median(g.cpu), &g.output, &g.phases_cpu},
          {"gpf", t_normals + median(g.seconds), c_normals + median(g.cpu), &g.output,
           &g.phases_cpu},
          {"gpf_s2_fixed", t_normals + median(gf.seconds), c_normals + median(gf.cpu), &gf.output,
           &gf.phases_cpu},
          {"wlop", median(w.seconds), median(w.cpu), &w.output, &w.phases_cpu},
          {"clop", median(c.seconds), median(c.cpu), &c.output, &c.phases_cpu},
          {"cgal_ear", t_normals + median(e.seconds), c_normals + median(e.cpu), &e.output,
           &e.phases_cpu},
      };
      const FilterAccuracy in_acc = filter_accuracy(gt, input);
      fmt::print("{:>12} {:>9} {:>9} {:>9} {:>13} {:>13}  phases (CPU s)\n", "method", "median_s",
                 "cpu_s", "points", "p2plane_mean", "p2plane_edge");
      fmt::print("{:>12} {:>9} {:>9} {:>9} {:>13.6f} {:>13.6f}\n", "input", "-", "-", input.size(),
                 in_acc.p2plane, in_acc.p2plane_edge);
      Json cases = Json::array();
      std::map<std::string, double> med, med_cpu;
      for (const Row& r : rows) {
        const FilterAccuracy a = filter_accuracy(gt, *r.out);
        med[r.name] = r.s;
        med_cpu[r.name] = r.cpu;
        std::string ph;
        Json phj = Json::object();
        for (const auto& [k, v] : *r.phases) {
          ph += fmt::format("{}={:.3f} ", k, v);
          phj[k] = v;
        }
        fmt::print("{:>12} {:>9.3f} {:>9.3f} {:>9} {:>13.6f} {:>13.6f}  {}\n", r.name, r.s, r.cpu,
                   r.out->size(), a.p2plane, a.p2plane_edge, ph);
        cases.push_back({{"name", r.name},
                         {"median_s", r.s},
                         {"cpu_s", r.cpu},
                         {"points", r.out->size()},
                         {"p2plane_mean", a.p2plane},
                         {"p2plane_edge", a.p2plane_edge},
                         {"edge_points", a.edge_points},
                         {"phases_cpu", phj}});
      }
      Json ratios = Json::object();
      ratios["wlop_over_gpf"] = med["wlop"] / med["gpf"];
      ratios["cgal_ear_over_gpf"] = med["cgal_ear"] / med["gpf"];
      ratios["wlop_over_gpf_cpu"] = med_cpu["wlop"] / med_cpu["gpf"];
      ratios["cgal_ear_over_gpf_cpu"] = med_cpu["cgal_ear"] / med_cpu["gpf"];
      ratios["wlop_over_gpf_only"] = med["wlop"] / med["gpf_only"];
      ratios["cgal_ear_over_gpf_only"] = (med["cgal_ear"] - t_normals) / med["gpf_only"];
      ratios["gpf_over_clop"] = med["gpf"] / med["clop"];
      fmt::print(
          "wlop_over_gpf     {:6.2f}  (target >= 1; CPU {:.2f}; GPF without normals {:.2f})\n",
          ratios["wlop_over_gpf"].get<double>(), ratios["wlop_over_gpf_cpu"].get<double>(),
          ratios["wlop_over_gpf_only"].get<double>());
      fmt::print(
          "cgal_ear_over_gpf {:6.2f}  (target >= 1; CPU {:.2f}; both without normals {:.2f})\n",
          ratios["cgal_ear_over_gpf"].get<double>(), ratios["cgal_ear_over_gpf_cpu"].get<double>(),
          ratios["cgal_ear_over_gpf_only"].get<double>());
      fmt::print("gpf_over_clop     {:6.2f}  (paper Table 1: CLOP fastest, so > 1)\n",
                 ratios["gpf_over_clop"].get<double>());
      if (!o.json.empty()) {
        Json out = Json::object();
        out["benchmark"] = "filter";
        // Version, compiler, SIMD path (isa, isa_flags) and allocator policy of this run.
        out["context"] = run_context_json();
        out["dataset"] = o.dataset;
        out["scan_points"] = input.size();
        out["noise"] = o.noise;
        out["h"] = o.h;
        out["iterations"] = o.iterations;
        out["particles_share"] = o.particles;
        out["repeats"] = o.repeats;
        out["threads"] = o.threads;
        out["seed"] = o.seed;
        out["input"] = {{"p2plane_mean", in_acc.p2plane}, {"p2plane_edge", in_acc.p2plane_edge}};
        out["cases"] = std::move(cases);
        out["ratios"] = std::move(ratios);
        out["targets"] = {{"wlop_over_gpf", 1.0}, {"cgal_ear_over_gpf", 1.0}};
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
