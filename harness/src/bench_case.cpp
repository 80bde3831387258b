// The paper case of a claim, for the benches (harness/bench.h).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/paths.h"
#include "scanbench/core/run_context.h"
#include "scanbench/harness/bench.h"
#include "scanbench/harness/claims.h"
#include "scanbench/harness/experiment.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::harness {

namespace {

PointCloud scan_of(const TriangleMesh& mesh, const Json& params, std::uint64_t seed,
                   const std::string& where) {
  const auto p = params_from_json<scanner::ScannerParams>(params, where);
  RunContext ctx(seed);
  return scanner::scan(mesh, p, ctx).cloud;
}

}  // namespace

PaperCase load_paper_case(const std::string& claim_id, const std::string& dataset, bool quick,
                          long target_points, std::uint64_t seed) {
  const auto file = config_root() / "claims" / (claim_id + ".json");
  const Claim claim = load_claim(file);
  Experiment e = parse_experiment(claim.experiment_config(quick), file.string());
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

}  // namespace scanbench::harness
