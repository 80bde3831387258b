// The paper case of a claim, for the benches (harness/bench.h).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/paths.h"
#include "scanbench/core/run_context.h"
#include "scanbench/harness/config/claim_file.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/config/protocol.h"
#include "scanbench/harness/pipelines/bench.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::harness {

namespace {

PointCloud scan_of(const TriangleMesh& mesh, const Json& params, std::uint64_t seed,
                   const std::string& where) {
  const auto p = params_from_json<scanner::ScannerParams>(params, where);
  RunContext ctx(seed);
  return scanner::scan(mesh, p, ctx).cloud;
}

// The claim's experiment at its protocol's values: paper and rule values from the claim file,
// tuned values as the committed baseline run chose them (results/baseline/claims.json, a real
// `scanbench claims --quick --update-baseline`), so a bench does not re-tune on every run.
Json with_baseline_protocol(const Json& config, const std::string& claim_id,
                            const std::filesystem::path& file) {
  Protocol p = parse_protocol(config.at("protocol"), file.string() + ": /protocol");
  const auto baseline = project_root() / "results" / "baseline" / "claims.json";
  Json chosen = Json::object();
  if (std::filesystem::exists(baseline)) {
    for (const Json& c : read_json_file(baseline).value("claims", Json::array()))
      if (c.value("id", std::string()) == claim_id) chosen = c.value("protocol", Json::object());
  }
  for (ProtocolParam& pp : p.params) {
    if (pp.source != "tuned") continue;
    const Json* v = nullptr;
    if (chosen.contains(pp.variant) && chosen[pp.variant].contains(pp.key))
      v = &chosen[pp.variant][pp.key];
    if (!v || !v->contains("value") || v->at("value").is_null()) {
      throw IoError(
          fmt::format("{}: no tuned value of {} {} for claim {} (run `scanbench claims --quick "
                      "--update-baseline`)",
                      baseline.string(), pp.variant, pp.key, claim_id));
    }
    pp.value = v->at("value");
  }
  return protocol_config(config, p, false);
}

}  // namespace

PaperCase load_paper_case(const std::string& claim_id, const std::string& dataset, bool quick,
                          long target_points, std::uint64_t seed) {
  const auto file = config_root() / "claims" / (claim_id + ".json");
  const Claim claim = load_claim(file);
  Json config = claim.experiment_config(quick);
  if (config.contains("protocol")) config = with_baseline_protocol(config, claim_id, file);
  Experiment e = parse_experiment(config, file.string());
  if (e.datasets.empty())
    throw ParamError(fmt::format("{}: the claim has no dataset", file.string()));
  // A dataset the claim does not name is scanned like the claim's first one.
  const auto named = std::find_if(e.datasets.begin(), e.datasets.end(), [&](const DatasetSpec& d) {
    return d.name == dataset || d.label == dataset;
  });
  DatasetSpec chosen = named != e.datasets.end() ? *named : e.datasets.front();
  if (!dataset.empty() && named == e.datasets.end()) {
    chosen.name = chosen.label = dataset;
    chosen.params = Json::object();
  }
  chosen.optional = false;
  e.datasets = {chosen};
  e.seeds = {seed};
  e.sweeps.clear();
  const Plan plan = expand(e);
  if (plan.jobs.empty()) throw ParamError(fmt::format("{}: the claim has no job", file.string()));

  PaperCase c;
  c.claim = claim_id;
  c.dataset = chosen.name;
  const Job& first = plan.jobs.front();
  c.mesh = load_dataset(first.dataset, first.dataset_params);
  c.scanner_params = first.scanner_params;
  c.metrics = first.metrics;
  c.metric_params = first.metric_params;
  for (const Job& j : plan.jobs) {
    if (j.scanner_label != first.scanner_label || !j.point.empty()) continue;
    c.chains.emplace(j.variant, j.chain);
  }
  const std::string where = fmt::format("{} scanner {}", file.string(), first.scanner_label);
  if (target_points > 0) {
    // The resolution scaled by the square root of the point ratio of a probe scan.
    const PointCloud probe = scan_of(c.mesh, c.scanner_params, seed, where);
    if (probe.empty()) throw InputError(fmt::format("{}: the probe scan hit nothing", where));
    const int res = c.scanner_params.at("resolution").get<int>();
    c.scanner_params["resolution"] = std::max(
        8, static_cast<int>(std::lround(res * std::sqrt(static_cast<double>(target_points) /
                                                        static_cast<double>(probe.size())))));
  }
  c.scan = scan_of(c.mesh, c.scanner_params, seed, where);
  if (c.scan.empty()) throw InputError(fmt::format("{}: the scan hit nothing", where));
  return c;
}

Json single_step_chain(const std::string& algorithm, const Json& given) {
  const auto& entry = algorithms::registry().at(algorithm);
  Json declared = Json::object();
  for (const auto& [k, v] : given.items()) {
    if (entry.params.find(k)) declared[k] = v;
  }
  return Json::array({{{"algorithm", algorithm},
                       {"label", algorithm},
                       {"params", entry.params.validate(declared, "bench " + algorithm)}}});
}

TimedCase timed_case(ChainCase& c, std::uint64_t seed) {
  return {c.name, [&c, seed] {
            RunContext ctx(seed, c.threads);
            StageData in;
            in.points = *c.input;
            c.last = run_chain(c.chain, std::move(in), ctx, false);
            c.run_phases.push_back(c.last.phases);
            return Sample{c.last.wall_s, c.last.cpu_s};
          }};
}

Json thread_scaling(const std::vector<std::pair<std::string, Json>>& methods,
                    const PointCloud& scan, const BenchOptions& o,
                    std::vector<PairedRatio>& ratios) {
  std::vector<ChainCase> cases;
  for (const auto& [name, chain] : methods)
    for (int threads : {1, 2})
      cases.push_back({fmt::format("{}_{}t", name, threads), chain, &scan, threads, {}, {}});
  std::vector<TimedCase> timed;
  for (ChainCase& c : cases)
    timed.push_back(timed_case(c, o.seed));
  const Rounds r = run_rounds(timed, o.rounds, o.warmup, print_round);
  for (const auto& [name, chain] : methods) {
    ratios.push_back(paired_ratio(r, fmt::format("{}_threads_2_over_1", name),
                                  fmt::format("{}_1t", name), fmt::format("{}_2t", name),
                                  Target{1.8}, o.seed));
    fmt::print("{}\n", describe(ratios.back()));
  }
  return to_json(r);
}

void print_round(int round) {
  fmt::print("  round {}{}\n", round < 0 ? "warm-up " : "", round < 0 ? -round : round + 1);
  std::fflush(stdout);
}

Json paper_case_json(const std::string& benchmark, const PaperCase& pc, const BenchOptions& o) {
  return {{"benchmark", benchmark},        {"claim", pc.claim},
          {"context", run_context_json()}, {"dataset", pc.dataset},
          {"scan_points", pc.scan.size()}, {"scanner_params", pc.scanner_params},
          {"threads", o.threads},          {"seed", o.seed}};
}

void BenchTable::print_header() const {
  std::string line;
  for (const Column& c : columns)
    line += fmt::format("{}{:>{}}", line.empty() ? "" : " ", c.header, c.width);
  fmt::print("{}\n", line);
}

void BenchTable::print_row(const std::vector<Json>& cells) const {
  std::string line;
  for (std::size_t i = 0; i < columns.size() && i < cells.size(); ++i) {
    const Column& c = columns[i];
    const Json& v = cells[i];
    std::string text;
    if (v.is_string()) {
      text = fmt::format("{:>{}}", v.get<std::string>(), c.width);
    } else if (c.decimals >= 0) {
      text = fmt::format("{:>{}.{}f}", v.get<double>(), c.width, c.decimals);
    } else {
      text = fmt::format("{:>{}}", v.dump(), c.width);
    }
    line += (i == 0 ? "" : " ") + text;
  }
  fmt::print("{}\n", line);
}

}  // namespace scanbench::harness
