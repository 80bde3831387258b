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
//   and two trade-off kinds, each over a sweep of each method's own accuracy parameter:
//   {"kind": "front", "quantity": <error, lower is better>, "cost": <cost of a, lower is better>,
//    "cost_b": <cost of b> (default: cost), "exclude_steps": [<chain step label>, ...],
//    "factor": f (default 1), "op": "<" | "<=" (default "<"), "a": selector, "b": selector}
//     Pareto fronts (cost, error) of the a and b records of a group (one point per record: a
//     sweep point, its time the median of its repeats). For each point of b's front, the cheapest
//     a point whose error is at most f x b's must cost `op` b's cost. Held when every such b point
//     is beaten and there is one; failed when one is not; inconclusive when no a point reaches
//     any b point's error, or (time.* costs) when the deciding points' repeat samples overlap.
//     exclude_steps: the seconds of these chain steps (timing.phases, per repeat) are left out of
//     a time.* cost, e.g. a consolidation step both methods share.
//   {"kind": "matched", "quantity": q, "op": ... (default "<="), "factor": f, "a": selector,
//    "b": selector, "match": {"quantity": <size of a>, "ref": <size of the band's records>
//    (default: quantity), "lo": selector, "lo_factor": x (default 1), "hi": selector,
//    "hi_factor": y (default 1)}}
//     The a records whose match quantity lies in [x lo, y hi] (a budget band, e.g. bytes between
//     Poisson depth 7's and a third of depth 8's) must each satisfy a.q op f b.q. Inconclusive
//     when no a record lies in the band (the sizes are the reason), so an operating point outside
//     the budget is never judged; no a record is chosen, every one in the band is judged.
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
#include "scanbench/harness/config/claim_file.h"
#include "scanbench/harness/config/protocol.h"

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
/// judge_claim on the records at the protocol's values, made inconclusive when a tuned parameter's
/// optimum sits on a boundary of its range with the curve still falling past its rule's limit
/// (Protocol::inconclusive; protocol.h, "Boundary optima"); the reason names it and keeps the rules'
/// own verdict.
ClaimOutcome judge_claim_at_protocol(const Claim& claim, const std::vector<Json>& records,
                                     const Protocol& protocol);

/// How the verdict moves over the protocol's ranges (protocol.h): for each parameter with a range
/// (tuned, or a paper/rule value with "sensitivity"), the claim judged on the records with that
/// parameter at each value of its range and every other at its protocol value. Returns
/// {"text": one line (each tuned parameter's boundary text in brackets), "params": [{"variant",
/// "key", "source", "value", "boundary", "verdicts": {v: verdict},
/// "rule_verdicts": {v: [verdict per rule]}}]};
/// `records` are those of the run swept over the ranges (protocol_config with sweep_ranges).
Json claim_sensitivity(const Claim& claim, const Protocol& protocol,
                       const std::vector<Json>& records);

/// Ids of the claims that held in `baseline` and failed in `current` (claims.json summaries).
std::vector<std::string> claim_regressions(const Json& baseline, const Json& current);

}  // namespace scanbench::harness
