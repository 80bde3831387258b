// `scanbench bench resample`: the CLOP paper's Camel case (Fig. 9), from claim clop-fig9-speed.
// --scaling adds 1- vs 2-thread speedups, CLOP's time growth exponent over input sizes and its
// peak memory per input point (Linux: peak RSS reset through /proc/self/clear_refs). The growth
// run keeps the kernel's neighbourhood constant: h scales as 1/sqrt(N) from the case's scan (h
// N^1/2 fixed, as for a surface sampled N times), since at a fixed h every LOP-family operator
// does O(N) work per particle and grows as N^2 by definition.
#include <fmt/format.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "exec/proc_memory.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/simd.h"
#include "scanbench/harness/exec/chain.h"
#include "scanbench/harness/pipelines/bench.h"
#include "scanbench/metrics/evaluate.h"
#include "scanbench/metrics/ground_truth.h"

namespace scanbench::harness {

namespace {

double phase(const std::map<std::string, double>& phases, const std::string& suffix) {
  double s = 0.0;
  for (const auto& [k, v] : phases) {
    if (k.size() > suffix.size() && k.compare(k.size() - suffix.size(), suffix.size(), suffix) == 0)
      s += v;
  }
  return s;
}

/// The accuracy table: the input and each case's last output (p2plane_mean, nn_dist_cv) with the
/// medians of the rounds. Returns the JSON of the input and of the cases.
std::pair<Json, Json> accuracy_table(const std::vector<ChainCase>& cases, const Rounds& rounds,
                                     const PaperCase& pc, const ResampleBenchOptions& o) {
  const metrics::GroundTruth gt(pc.mesh, o.seed);
  auto measure = [&](const PointCloud& p) {
    RunContext mctx(o.seed, o.threads);
    return metrics::evaluate(gt, p, &pc.scan, {"accuracy.p2plane", "regularity.nn_dist"},
                             Json::object(), mctx);
  };
  const BenchTable table{{{"method", 19},
                          {"median_s", 10, 3},
                          {"cpu_s", 10, 3},
                          {"particles", 10},
                          {"p2plane_mean", 14, 6},
                          {"nn_dist_cv", 11, 4}}};
  const Json in_m = measure(pc.scan);
  table.print_header();
  table.print_row({"input", "-", "-", pc.scan.size(), in_m.value("p2plane_mean_rel", 0.0),
                   in_m.value("nn_dist_cv", 0.0)});
  Json cases_j = Json::array();
  for (const ChainCase& c : cases) {
    const Json m = measure(c.last.output.points);
    const Sample med = median_sample(rounds, c.name);
    Json j = {{"name", c.name},
              {"chain", c.chain},
              {"median_s", med.wall_s},
              {"cpu_s", med.cpu_s},
              {"p2plane_mean", m.value("p2plane_mean_rel", 0.0)},
              {"p2plane_mean_abs", m.value("p2plane_mean", 0.0)},
              {"p2plane_rms", m.value("p2plane_rms_rel", 0.0)},
              {"nn_dist_cv", m.value("nn_dist_cv", 0.0)},
              {"particles", c.last.output.points.size()},
              {"phases", c.last.phases}};
    if (c.last.output.mixture) j["mixture_components"] = c.last.output.mixture->size();
    table.print_row({c.name, med.wall_s, med.cpu_s, c.last.output.points.size(), j["p2plane_mean"],
                     j["nn_dist_cv"]});
    cases_j.push_back(std::move(j));
  }
  const Json input = {{"p2plane_mean", in_m.value("p2plane_mean_rel", 0.0)},
                      {"nn_dist_cv", in_m.value("nn_dist_cv", 0.0)}};
  return {input, cases_j};
}

/// Phase by phase, per kept round (wall seconds of the clop and wlop runs of one round), beside
/// the CLOP paper's Fig. 9 Camel speedups (GPU): WLOP's attraction includes its L2 first
/// iteration (phase init), as CLOP's includes its continuous first iteration; repulsion includes
/// the densities w_i. HEM's share is its phase over CLOP's wall time of the same run. Each figure:
/// the median of the rounds' values with its spread and bootstrap 95% interval (paired.h), and
/// the values.
Json phase_ratios(const ChainCase& cl, const ChainCase& wl, const Rounds& rounds,
                  std::uint64_t seed) {
  const std::vector<Sample>& clop_samples = rounds.samples.at(cl.name);
  std::map<std::string, std::vector<double>> values;
  for (std::size_t i = 0; i < clop_samples.size(); ++i) {
    const auto run = static_cast<std::size_t>(rounds.warmup) + i;
    const auto& c = cl.run_phases.at(run);
    const auto& w = wl.run_phases.at(run);
    values["attraction_wlop_over_clop"].push_back((phase(w, ":init") + phase(w, ":attraction")) /
                                                  phase(c, ":attraction"));
    values["repulsion_wlop_over_clop"].push_back(phase(w, ":repulsion") / phase(c, ":repulsion"));
    values["hem_share_of_clop"].push_back(phase(c, ":hem") / clop_samples[i].wall_s);
  }
  Json by_phase = Json::object();
  std::map<std::string, RatioSummary> summary;
  for (const auto& [name, v] : values) {
    summary[name] = summarize_ratios(v, derive_seed(seed, name));
    by_phase[name] = to_json(summary[name]);
    by_phase[name]["rounds"] = v;
  }
  const auto show = [&](const std::string& name, double scale) {
    const RatioSummary& s = summary.at(name);
    return fmt::format("{:.{}f} [{:.{}f}, {:.{}f}]", scale * s.median, scale > 1.0 ? 0 : 2,
                       scale * s.ci_low, scale > 1.0 ? 0 : 2, scale * s.ci_high,
                       scale > 1.0 ? 0 : 2);
  };
  fmt::print(
      "  by phase (median of {} rounds, 95% interval): attraction {} (paper Fig. 9 Camel F1: "
      "7.15), repulsion {} (F2: 7.80); HEM is {}% of CLOP (paper: 20%)\n",
      clop_samples.size(), show("attraction_wlop_over_clop", 1.0),
      show("repulsion_wlop_over_clop", 1.0), show("hem_share_of_clop", 100.0));
  return by_phase;
}

/// --scaling, growth: one CLOP run per size (medians of `rounds`), h scaled as 1/sqrt(N) to keep
/// the neighbourhoods; peak memory per point; the growth exponent of the time.
Json growth_run(const Json& clop_chain, const PaperCase& pc, const ResampleBenchOptions& o) {
  Json growth = Json::array();
  std::vector<double> ns, ts;
  double per_point = -1.0;
  for (long size : o.sizes) {
    const PaperCase big = load_paper_case("clop-fig9-speed", o.dataset, o.quick, size, o.seed);
    Json chain = clop_chain;
    const double h =
        chain[0]["params"]["h"].get<double>() *
        std::sqrt(static_cast<double>(pc.scan.size()) / static_cast<double>(big.scan.size()));
    chain[0]["params"]["h"] = h;
    ChainCase c{"clop", chain, &big.scan, o.threads, {}, {}};
    const bool mem_ok = reset_peak_rss();
    const long rss0 = status_kb("VmRSS");
    const Rounds g = run_rounds({timed_case(c, o.seed)}, o.quick ? 1 : 3, 0);
    const long hwm = status_kb("VmHWM");
    const Sample med = median_sample(g, "clop");
    per_point = mem_ok && rss0 >= 0 && hwm >= 0
                    ? 1024.0 * static_cast<double>(std::max(hwm - rss0, 0L)) /
                          static_cast<double>(big.scan.size())
                    : -1.0;
    ns.push_back(static_cast<double>(big.scan.size()));
    ts.push_back(med.wall_s);
    growth.push_back({{"points", big.scan.size()},
                      {"h", h},
                      {"median_s", med.wall_s},
                      {"cpu_s", med.cpu_s},
                      {"peak_bytes_per_point", per_point},
                      {"phases", c.last.phases}});
    fmt::print("clop at {:>9} points, h {:.4f}: {:8.3f} s ({:.3f} CPU s), peak {:.0f} B/point\n",
               big.scan.size(), h, med.wall_s, med.cpu_s, per_point);
  }
  Json sc = {{"growth", growth}};
  if (ns.size() >= 2) {
    sc["clop_growth_exponent"] =
        std::log(ts.back() / ts.front()) / std::log(ns.back() / ns.front());
    sc["clop_peak_bytes_per_point_largest"] = per_point;
    fmt::print("clop growth exponent {:.3f} (target <= 1.1), peak {:.0f} B/point at {}\n",
               sc["clop_growth_exponent"].get<double>(), per_point, static_cast<long>(ns.back()));
  }
  return sc;
}

}  // namespace

Json bench_resample(const ResampleBenchOptions& opts) {
  ResampleBenchOptions o = opts;
  if (o.quick) {
    o.points = o.points > 0 ? std::min(o.points, 20000L) : 20000L;
    o.rounds = std::min(o.rounds, 3);
    o.sizes = {5000, 20000, 80000};
  }
  const PaperCase pc = load_paper_case("clop-fig9-speed", o.dataset, o.quick, o.points, o.seed);
  const Json& clop_chain = pc.chains.at("clop");
  const Json& wlop_chain = pc.chains.at("wlop");
  const Json& wp = wlop_chain.at(0).at("params");
  fmt::print("simd: {}; CGAL peers compiled with {}\n", simd::describe(), simd::compile_flags());
  fmt::print("{} (claim {}): {} scan points; clop {}; wlop {}; {} rounds + {} warm-up\n",
             pc.dataset, pc.claim, pc.scan.size(), clop_chain.at(0).at("params").dump(), wp.dump(),
             o.rounds, o.warmup);

  std::vector<ChainCase> cases;
  cases.push_back({"clop", clop_chain, &pc.scan, o.threads, {}, {}});
  cases.push_back({"wlop", wlop_chain, &pc.scan, o.threads, {}, {}});
  if (!o.no_cgal)
    cases.push_back(
        {"cgal_wlop", single_step_chain("peer.cgal_wlop", wp), &pc.scan, o.threads, {}, {}});
  // The paper's other reading of eq. 26 (Algorithm 1: v_j summed in the kernel pass), for
  // comparison only.
  Json kernel = clop_chain;
  kernel[0]["params"]["density"] = "kernel";
  cases.push_back({"clop_kernel_density", kernel, &pc.scan, o.threads, {}, {}});
  std::vector<TimedCase> timed;
  for (ChainCase& c : cases)
    timed.push_back(timed_case(c, o.seed));
  const Rounds rounds = run_rounds(timed, o.rounds, o.warmup, print_round);
  const auto [input, cases_j] = accuracy_table(cases, rounds, pc, o);

  std::vector<PairedRatio> ratios;
  ratios.push_back(paired_ratio(rounds, "wlop_over_clop", "wlop", "clop", Target{6.0}, o.seed));
  ratios.push_back(paired_ratio(rounds, "wlop_over_clop_kernel_density", "wlop",
                                "clop_kernel_density", std::nullopt, o.seed));
  if (!o.no_cgal) {
    ratios.push_back(
        paired_ratio(rounds, "cgal_wlop_over_clop", "cgal_wlop", "clop", Target{25.0}, o.seed));
    ratios.push_back(
        paired_ratio(rounds, "cgal_wlop_over_wlop", "cgal_wlop", "wlop", Target{3.0}, o.seed));
  }
  for (const PairedRatio& r : ratios)
    fmt::print("{}\n", describe(r));
  const Json by_phase = phase_ratios(cases[0], cases[1], rounds, o.seed);

  Json out = paper_case_json("resample", pc, o);
  out["input"] = input;
  out["cases"] = cases_j;
  out["rounds"] = to_json(rounds);
  out["by_phase"] = by_phase;
  // Like for like: CGAL's WLOP (header-only, instantiated in algorithms/) is compiled with the
  // flags of the whole build, the same as our widest kernels.
  out["cgal_peers_compiled_with"] = {{"isa", std::string(simd::name(simd::compiled()))},
                                     {"flags", std::string(simd::compile_flags())}};
  if (o.scaling) {
    out["thread_rounds"] =
        thread_scaling({{"clop", clop_chain}, {"wlop", wlop_chain}}, pc.scan, o, ratios);
    out["scaling"] = growth_run(clop_chain, pc, o);
  }
  out["ratios"] = ratios_json(ratios);
  return out;
}

}  // namespace scanbench::harness
