#pragma once
// A declared parameter protocol: where each parameter of a variant comes from.
//
// An experiment config (experiment.h) may hold "protocol":
//   {"tuning":    {"datasets": [...], "scanners": [...], "seed": n | "seeds": [...]}
//                 the tuning data, in the experiment schema: another shape, or another seed and
//                 noise draw; it must share no (dataset, scanner, seed) with the experiment's own
//                 data, the data the results (a claim's verdict) are computed on,
//    "objective": {"quantity": "<record quantity>", "direction": "min" | "max",
//                  "stat": "median" (default) | "mean" | "min" | "max"}  the default objective,
//    "variants":  {"<variant label>": {"<step>.<param>": entry, ...}, ...},
//    "chains":    {...} optional: the variants' method steps (ChainDeclaration below); every pair
//                 of the protocol's variants is then checked to differ only in its method,
//    "scanner":   {"<scanner param>": entry, ...} optional: how the data are made, the same for
//                 every variant (see "Scanner entries" below)}
// with one entry per parameter:
//   {"source": "paper", "value": v, "cite": "GPF 2017, sec. 4.4"}
//   {"source": "rule",  "value": v, "rule": "h = 6 h0, h0 = d_bb / sqrt(N) (GPF sec. 5, principle
//   1)"}
//   {"source": "tuned", "range": [v1, v2, ...], "objective": {...} (default: the protocol's)}
//   {"source": "tuned", "rule": "h0_multiples", "multiples": [3, 4.5, 6, 9, 12],
//    "extend_limit": 2 (default), "objective": {...}}
//     an h-like parameter (a fraction of the bbox diagonal) as multiples of
//     h0 = d_bb / sqrt(N) (GPF 2017, sec. 4.3), N the median point count of the tuning scans:
//     h0 = 1 / sqrt(N) in the parameter's unit (d_bb is the diagonal h is a fraction of), so a
//     quick and a full scan each get their own range. Resolved when the tuning runs: a probe
//     (normals.pca on the tuning data, OUT/scan-sizes/) counts the points (sizes.scan_points).
// and, for paper and rule, an optional "sensitivity": [v1, ...] of values to re-judge at.
// <step> is a chain step's label (its algorithm name by default), as in sweep keys; the
// parameter must not also be set in the step's params or swept by the variant.
//
// Tuning: per variant, once, the variant (its swept parameters at their base values) runs on the
// tuning data over the Cartesian product of its tuned ranges; the point whose objective statistic
// over all tuning records is best (ties: the first in range order) is the chosen value, used on the
// experiment's own data. The experiment's data never enter the tuning, and no value is chosen per
// dataset or case. The chosen values are set in the steps' params, so every record carries them,
// and the resolved protocol (protocol_json) is written beside the records.
//
// Boundary optima (issue 50): a tuned numeric parameter whose chosen value is the lowest or highest
// of its range while the curve still falls there (its neighbour in the range is strictly worse, or
// has no value) is never silently accepted. With "h0_multiples" the range is extended on that side
// by the next multiples of the same ratio (upper: m_k * m_k / m_(k-1); lower: m_1 * m_1 / m_2),
// up to extend_limit times the declared top multiple (down to the declared bottom one divided by
// it), tuned again (OUT/tuning-<variant>.ext<k>/) and chosen over all records; an optimum still
// on a falling boundary past the limit makes the protocol inconclusive (`inconclusive`), and a
// claim on it is judged inconclusive (judge_claim_at_protocol). A fixed numeric "range" (all
// values positive) is extended the same way by its own ratio on that side (upper: v_n^2 / v_(n-1);
// lower: v_1^2 / v_2), integers staying integers, within "extend_limit" (default 2) times its
// declared top or bottom, and when the first step overshoots, to the limit itself; values the
// parameter's declaration rejects are not tried. An optimum still falling at a value that is the
// end of the parameter's own domain (the next value rounds back to it or is rejected: a stride
// of 1) is status "limit", the verdict unchanged (no range could be wider there); otherwise
// "inconclusive" as above. A range that is not all positive numbers is not checked.
//
// Scanner entries (issues 50 and 52): a paper's "3% noise" has several readings (a std along the
// ray or along the normal, a uniform amplitude; a Gaussian or another family). "scanner" declares
// the reading a verdict uses, with the others as its sensitivity:
//   "scanner": {"noise_family": {"source": "rule", "value": "gaussian", "rule": "...",
//                                "sensitivity": ["laplace", "uniform"]}}
// Only "paper" and "rule" (a reading is declared, never tuned). The value is set in the params of
// every scanner of the experiment and of the tuning data (a scanner that sets the parameter
// itself, or a sweep of "scanner.<param>", is refused: one source per parameter); each
// sensitivity value re-runs every variant on the experiment's data with that one scanner
// parameter changed (sweep key "scanner.<param>"), and the claim is re-judged there. The entries
// are recorded under "scanner" in protocol_json (so no variant may be labelled "scanner").
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

struct ProtocolObjective {
  std::string quantity;  ///< a record quantity (records.h, record_value)
  std::string direction = "min";
  std::string stat = "median";
  Json to_json() const;
};

struct ProtocolParam {
  std::string variant;      ///< variant label
  std::string key;          ///< "<step>.<param>" (a sweep key)
  std::string step, param;  ///< key split at its last dot
  std::string source;       ///< paper | rule | tuned
  std::string cite;         ///< paper: the citation; rule: the rule as stated
  Json value;               ///< paper/rule: the value; tuned: the chosen value once tuned
  std::vector<Json> range;  ///< tuned: the candidates; paper/rule: sensitivity values (optional)
  ProtocolObjective objective;         ///< tuned
  Json tuning_curve = Json::object();  ///< tuned: "<point>" -> objective statistic
  std::string range_rule;              ///< tuned: "" (the fixed `range`) or "h0_multiples"
  std::vector<double> multiples;       ///< h0_multiples: ascending, extended ones included
  double extend_limit = 2.0;           ///< tuned: how far the range may be extended
  std::vector<Json> declared_range;    ///< tuned: the range before any extension (resolved)
  double scan_points = 0;              ///< h0_multiples: N, the tuning scans' median point count
  double h0 = 0;                       ///< h0_multiples: 1 / sqrt(N), fraction of the diagonal
  /// tuned, after resolve_protocol: {"status": "interior" | "flat" (on the boundary, the curve
  /// flat there) | "extended" | "limit" (still falling at the end of the parameter's own domain)
  /// | "inconclusive",
  /// "side": "lower" | "upper", "text": one line for the sensitivity line ("" when interior)}.
  Json boundary = Json::object();
};

/// Fair chains (issue 50): variants that are compared may differ only in their method. A chain
/// variant is split into its upstream steps, its method steps (a contiguous run of step labels,
/// declared), and its downstream steps; a one-step variant is its own method. The upstream and
/// downstream steps of two compared variants must be the same step for step: the same label and
/// algorithm, the same params, the same sweep values and the same protocol entries (source, value
/// or range, rule; a tuned value is chosen per variant by the same declared range and objective).
/// A difference is allowed only when declared for one of the two variants with its reason.
/// So a method whose own normals go downstream (GPF's particles keep their source points'
/// normals) differs from one whose output gets new normals, unless declared.
///
/// JSON (a claim file's "chains", claim_file.h, or a protocol's "chains"):
///   {"methods": {"<variant>": ["<step label>", ...], ...},
///    "downstream_differs": {"<variant>": {"reason": "why its chain differs outside its method"}}}
struct ChainDeclaration {
  std::map<std::string, std::vector<std::string>> methods;  ///< variant -> its method steps
  std::map<std::string, std::string> differs;               ///< variant -> the declared reason
  bool empty() const { return methods.empty() && differs.empty(); }
  Json to_json() const;
};

struct Protocol {
  std::string where;             ///< "<file>: /protocol", for messages
  Json tuning = Json::object();  ///< the tuning data (datasets, scanners, seed/seeds)
  std::vector<ProtocolParam> params;
  ChainDeclaration chains;  ///< "chains": every pair of the protocol's variants is compared
  /// "scanner": one entry per scanner parameter, variant "" (every variant), key
  /// "scanner.<param>", step "scanner"; source paper or rule, `range` its sensitivity values.
  std::vector<ProtocolParam> scanner;
  bool empty() const { return params.empty() && scanner.empty(); }
  /// The boundary texts of tuned parameters whose status is "inconclusive" ("" when none).
  std::string inconclusive() const;
  /// The params of one variant whose source is "tuned".
  std::vector<const ProtocolParam*> tuned(const std::string& variant) const;
};

/// Reads a "protocol" object; `where` is the JSON location prefix ("file: /protocol"). Throws
/// ParamError naming the file and field.
Protocol parse_protocol(const Json& j, const std::string& where);

/// Checks `p` against the experiment config holding it: variants and steps exist, no parameter set
/// twice, every value accepted by the parameter's declaration, the tuning data disjoint from the
/// experiment's; with "chains", the protocol's variants differ only in their methods
/// (check_fair_chains). Throws ParamError.
void check_protocol(const Protocol& p, const Json& config);

/// The experiment config that tunes `variant`: the tuning data, that variant alone, swept over the
/// product of its tuned ranges, one repeat, no "protocol".
Json tuning_config(const Json& config, const Protocol& p, const std::string& variant);

/// Reads a "chains" object; `where` is its JSON location ("file: /chains"). Throws ParamError.
ChainDeclaration parse_chains(const Json& j, const std::string& where);

/// Checks that every pair of `compared` variants of the experiment `config` (labels; pairs with an
/// empty or equal label are skipped) differs only in its method steps, or declares the difference.
/// Throws ParamError "<where>: variants 'a' and 'b' differ outside their methods: downstream step
/// 2 ('peer.cgal_ear' vs 'normals.pca') ..." naming the file, the variants and the step; also for
/// a method step that is not a step of the variant, or a chain variant with no declared method.
void check_fair_chains(const Json& config, const ChainDeclaration& d,
                       const std::vector<std::pair<std::string, std::string>>& compared,
                       const std::string& where);

/// One line for reports: "ear: downstream differs (its own upsampling)", or "" when none.
std::string chains_summary(const Json& chains);

/// "The same radius" across methods (issue 50). Every scanbench radius parameter is a kernel
/// width h in one convention, theta(r) = exp(-16 r^2/h^2) (kernel std h / (4 sqrt 2)), but the
/// methods read their data differently within it: WLOP/LOP/CLOP attract to the points within h
/// (Huang et al. 2009, eq. 1-3; Preiner et al. 2014, eq. 24), GPF's data term and E-step use
/// the points within h/4 (its theta = exp(-4 r^2/h_GPF^2) with h_GPF = h/2, data term within
/// h_GPF/2; Lu et al. 2017, sec. 4), CGAL's WLOP its neighbor_radius h/2. The table of
/// docs/claims.md ("Radii in each method's convention") lists them.
struct KernelConvention {
  std::string algorithm;  ///< the step's algorithm
  std::string param;      ///< its radius parameter
  double support;         ///< data-term support radius per unit of the parameter
  double kernel_std;      ///< kernel std per unit of the parameter
};
/// The methods with a radius parameter, in the docs table's order.
const std::vector<KernelConvention>& kernel_conventions();
/// The value of `algorithm`'s radius parameter that gives `radius` (a fraction of the bbox
/// diagonal) as its data-term support (`same` = "support": equal support, the protocol's meaning
/// of "the same radius") or as its kernel std (`same` = "std"). Throws ParamError for an
/// algorithm with no radius parameter or another `same`.
double radius_param(const std::string& algorithm, double radius, const std::string& same);

/// The config to run: every protocol value set in its step's params, no "protocol"; with
/// `sweep_ranges`, each variant also swept over each parameter's range (one at a time, the others
/// at their value) for the sensitivity of the results.
Json protocol_config(const Json& config, const Protocol& resolved, bool sweep_ranges);

/// The resolved protocol as recorded: per variant, per parameter its source, cite or rule,
/// value, and when tuned the range, tuning data, objective and tuning curve.
Json protocol_json(const Protocol& p);
/// One line: "gpf: filter.gpf.h tuned 0.04 (min p2plane_mean_rel on ...), omega paper 0.02; ...".
std::string protocol_summary(const Json& protocol);

}  // namespace scanbench::harness
