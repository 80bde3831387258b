#pragma once
// The source papers' claims as a reproduction suite (`scanbench claims`).
//
// A claim file (configs/claims/<id>.json, "scanbench_claim": 1) holds:
//   "id"          the claim's name (default: the file stem)
//   "claim"       what the paper claims, in one sentence
//   "source"      paper and figure/table/equation ("CLOP 2014, Fig. 9")
//   "paper"       the paper's own number(s) where it gives them, as text (e.g. "speedup 4.0-7.1")
//   "notes"       optional: how the claim is measured here, where the paper is silent
//   "experiment"  an experiment config (experiment.h, the same schema as `scanbench run`)
//   "quick"       optional: a JSON merge patch (RFC 7386) applied to "experiment" by --quick
//                 (smaller scans, fewer repeats; objects merge, arrays are replaced whole)
//   "rules"       the verdict rules, all of which must hold (below)
// The experiment may declare a parameter protocol ("protocol", protocol.h): the claim is then
// judged at the protocol's values (tuned ones chosen on the tuning data first), and its
// sensitivity (claim_sensitivity) over the protocol's ranges is reported beside the verdict.
//
// A rule compares statistics of one record quantity (records.h, record_value: a metric key such
// as "p2plane_mean_rel", "time.total" = median of the repeat samples, "time.<step>:<phase>",
// "sizes.<key>"):
//   {"what": "text", "quantity": "p2plane_mean_rel",
//    "kind": "compare" (default) | "argmin",
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
#include <filesystem>
#include <string>
#include <vector>

#include "scanbench/core/params.h"
#include "scanbench/harness/protocol.h"

namespace scanbench::harness {

/// Current claim file format version (key "scanbench_claim").
inline constexpr int kClaimVersion = 1;

struct ClaimSelector {
  std::string variant;          ///< variant label; empty = any
  Json point = Json::object();  ///< sweep assignments that must match
  std::string dataset;          ///< dataset label; empty = any
  bool matches(const Json& record) const;
  std::string describe() const;
};

struct ClaimRule {
  std::string what;
  std::string kind = "compare";  ///< compare | argmin | front | matched
  std::string quantity;
  std::string per = "dataset";  ///< dataset | all
  std::string stat = "median";  ///< median | mean | min | max
  ClaimSelector a, b;
  bool has_b = false;  ///< else `value`
  double value = 0.0;
  double factor = 1.0;
  std::string op = "<=";
  double margin = 0.0;
  double tolerance = 1e-6;
  double abs = 0.0;
  std::string param;  ///< argmin
  double lo = 0.0, hi = 0.0;
  // Kinds "front" and "matched" (trade-offs over two sweeps; results/claims_tradeoff.h).
  std::string cost, cost_b;                ///< front: cost quantities of a and b
  std::vector<std::string> exclude_steps;  ///< front: chain steps left out of a time.* cost
  std::string match_quantity, match_ref;   ///< matched: the size of a, and of the band's records
  ClaimSelector match_lo, match_hi;        ///< matched: the records bounding the band
  double lo_factor = 1.0, hi_factor = 1.0;
};

struct Claim {
  std::filesystem::path file;
  std::string id, claim, source, paper, notes;
  Json experiment = Json::object();
  Json quick;  ///< null when absent
  std::vector<ClaimRule> rules;
  /// The experiment config to run (the quick patch applied when `quick`), named after the claim.
  Json experiment_config(bool quick) const;
};

/// Reads and validates a claim file: the rules, and the experiment (full and quick) through
/// parse_experiment. Throws IoError (unreadable, not JSON) or ParamError naming the file and JSON
/// path.
Claim load_claim(const std::filesystem::path& file);
Claim parse_claim(const Json& j, const std::string& where, const std::string& default_id);
/// Every *.json of `dir` (sorted by name) whose id matches the ECMAScript regex `filter` (empty:
/// all). Throws ParamError for a bad regex or duplicate ids.
std::vector<Claim> load_claims(const std::filesystem::path& dir, const std::string& filter);

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

/// The entry of one claim in claims.json: id, claim, source, paper, notes, verdict, reason,
/// measured (one line), rules (with groups), plus what the caller adds (jobs, wall_s, folder).
Json claim_result_json(const Claim& claim, const ClaimOutcome& outcome);

/// Markdown table of a claims.json summary: claim, source, paper, measured, verdict (reason).
std::string claims_markdown(const Json& summary);
/// The HTML section of the report (`<h2>Claims</h2>` and a table), links relative to the folder
/// holding the summary.
std::string claims_html_section(const Json& summary);

/// Ids of the claims that held in `baseline` and failed in `current` (claims.json summaries).
std::vector<std::string> claim_regressions(const Json& baseline, const Json& current);

}  // namespace scanbench::harness
