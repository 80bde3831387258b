#pragma once
// A claim of the source papers as a file (`scanbench claims`: the rules are judged in claims.h).
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
//   "rules"       the verdict rules, all of which must hold (claims.h)
//   "chains"      optional: the method steps of the compared variants and any declared
//                 difference outside them (ChainDeclaration, protocol.h). The variants a rule
//                 compares (its a and b) must differ only in their methods: checked at load.
// The experiment may declare a parameter protocol ("protocol", protocol.h): the claim is then
// judged at the protocol's values (tuned ones chosen on the tuning data first), and its
// sensitivity (claim_sensitivity) over the protocol's ranges is reported beside the verdict.
//
// The rules' fields and the verdicts they give are described in claims.h.
#include <filesystem>
#include <string>
#include <vector>

#include "scanbench/core/params.h"
#include "scanbench/harness/config/protocol.h"

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
  // Kinds "front" and "matched" (trade-offs over two sweeps; claims.h).
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
  ChainDeclaration chains;
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

}  // namespace scanbench::harness
