#pragma once
// The source papers' claims as a reproduction suite (`scanbench claims`): the verdict rules of a
// claim (claim_file.h: the file and its parsing) judged on the records of its experiment;
// claims_render.h writes the results.
//
// A rule compares statistics of one record quantity (records.h, record_value: a metric key such
// as "p2plane_mean_rel", "time.total" = median of the repeat samples, "time.<step>:<phase>",
// "sizes.<key>"):
//   {"what": "text", "quantity": "p2plane_mean_rel",
//    "kind": "compare" (default) | "argmin" | "front" | "matched",
//    "per": "dataset" (default: the rule must hold on every dataset) | "all" (once, over all),
//    "stat": "median" (default) | "mean" | "min" | "max"  over the records a selector matches
//            within the group (seeds, sweep points, datasets with per "all"),
//    "a": selector, "b": selector | "value": number, "factor": number (default 1),
//    "op": "<" | "<=" | ">" | ">=" | "==",
//    "margin": relative band (default 0): |A - factor B| <= margin |factor B| is inconclusive,
//    "tolerance": for "==", relative (default 1e-6), "abs": absolute (default 0),
//    "param", "range": [lo, hi]  for "argmin": the value of the sweep parameter `param` at which
//            the statistic of the `a` records is lowest must lie in [lo, hi]}
//   and two trade-off kinds, "front" (Pareto fronts of cost against error) and "matched" (judged
//   within a budget band), documented in harness/src/results/claims_tradeoff.h.
//   selector: {"variant": label, "point": {"<sweep key>": value, ...}, "dataset": label}
//            (every given field must match; "point" values compare numerically).
// Verdicts: "held", "failed" or "inconclusive" with a reason. A rule is inconclusive when a
// selected job did not finish ok (its status and error are the reason), when no record matches a
// selector, when the quantity is missing, when the difference lies within `margin`, or, for a
// time.* quantity with one record on each side, when the repeat samples of the two sides overlap
// (the medians alone would then decide on noise). A claim is failed if any rule failed, else
// inconclusive if any rule was, else held.
#include <string>
#include <vector>

#include "scanbench/core/params.h"
#include "scanbench/harness/claim_file.h"
#include "scanbench/harness/protocol.h"

namespace scanbench::harness {

struct RuleOutcome {
  std::string verdict;  ///< held | failed | inconclusive
  std::string reason;
  std::string measured;  ///< one line: the values per group
  Json groups = Json::array();
  Json to_json(const ClaimRule& r) const;
};

struct ClaimOutcome {
  std::string verdict;
  std::string reason;
  std::vector<RuleOutcome> rules;
};

RuleOutcome judge_rule(const ClaimRule& rule, const std::vector<Json>& records);
ClaimOutcome judge_claim(const Claim& claim, const std::vector<Json>& records);

/// How the verdict moves over the protocol's ranges (protocol.h): for each parameter with a range
/// (tuned, or a paper/rule value with "sensitivity"), the claim judged on the records with that
/// parameter at each value of its range and every other at its protocol value. Returns
/// {"text": one line, "params": [{"variant", "key", "source", "value", "verdicts": {v: verdict},
/// "rule_verdicts": {v: [verdict per rule]}}]};
/// `records` are those of the run swept over the ranges (protocol_config with sweep_ranges).
Json claim_sensitivity(const Claim& claim, const Protocol& protocol,
                       const std::vector<Json>& records);

/// Ids of the claims that held in `baseline` and failed in `current` (claims.json summaries).
std::vector<std::string> claim_regressions(const Json& baseline, const Json& current);

}  // namespace scanbench::harness
