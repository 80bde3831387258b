#pragma once
// Private to the harness: the claim rules that judge a trade-off between two methods, each run
// over a sweep of its own accuracy parameter (claims.h documents the claim file; this file the
// two kinds "front" and "matched", kept apart from the compare and argmin rules of claims.cpp).
//
//   {"kind": "front", "quantity": <error, lower is better>, "cost": <cost of a, lower is better>,
//    "cost_b": <cost of b> (default: cost), "exclude_steps": [<chain step label>, ...],
//    "factor": f (default 1), "op": "<" | "<=" (default "<"), "a": selector, "b": selector}
//   Pareto fronts (cost, error) of the a and b records of a group (one point per record: a sweep
//   point, its time the median of its repeats). For each point of b's front, the cheapest a point
//   whose error is at most f x b's must cost `op` b's cost. Held when every such b point is beaten
//   and there is one; failed when one is not; inconclusive when no a point reaches any b point's
//   error, or (time.* costs) when the deciding points' repeat samples overlap. exclude_steps:
//   the seconds of these chain steps (timing.phases, per repeat) are left out of a time.* cost,
//   e.g. a consolidation step both methods share.
//
//   {"kind": "matched", "quantity": q, "op": ..., "factor": f, "a": selector, "b": selector,
//    "match": {"quantity": <size of a>, "ref": <size of the band's records> (default: quantity),
//              "lo": selector, "lo_factor": x (default 1), "hi": selector, "hi_factor": y}}
//   The a records whose match quantity lies in [x lo, y hi] (a budget band, e.g. bytes between
//   Poisson depth 7's and a third of depth 8's) must each satisfy a.q op f b.q. Inconclusive when
//   no a record lies in the band (the sizes are the reason), so an operating point outside the
//   budget is never judged; no a record is chosen, every one in the band is judged.
#include <string>
#include <utility>
#include <vector>

#include "scanbench/harness/claims.h"

namespace scanbench::harness {

/// From claims.cpp: a selector ({"variant", "point", "dataset"}), and the records grouped per
/// dataset (in order of first appearance) or in one group "all".
ClaimSelector parse_claim_selector(const Json& j, const std::string& where);
std::vector<std::pair<std::string, std::vector<const Json*>>> claim_groups(
    const std::vector<Json>& records, const std::string& per);

/// Reads a rule of kind "front" or "matched" (`where`: the JSON location). Throws ParamError.
ClaimRule parse_tradeoff_rule(const Json& j, const std::string& where);

/// Judges a rule of kind "front" or "matched" on the records of one claim.
RuleOutcome judge_tradeoff(const ClaimRule& rule, const std::vector<Json>& records);

}  // namespace scanbench::harness
