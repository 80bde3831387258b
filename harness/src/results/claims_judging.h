#pragma once
// Private to the harness: what the judges of claims.cpp (compare, argmin) and claims_tradeoff.cpp
// (front, matched) share. The rules themselves are documented in claims.h.
#include <string>
#include <utility>
#include <vector>

#include "scanbench/harness/results/claims.h"

namespace scanbench::harness {

/// The records grouped per dataset (in order of first appearance) or in one group "all" (the
/// rule's "per"). A dataset group that one of the rule's selectors cannot match (it names another
/// dataset) is left out: the rule says nothing about that dataset.
std::vector<std::pair<std::string, std::vector<const Json*>>> claim_groups(
    const std::vector<Json>& records, const ClaimRule& rule);

/// Verdicts combined: failed if any failed, else inconclusive if any was (or there is none),
/// else held.
std::string combine_verdicts(const std::vector<std::string>& verdicts);

/// `a op b` for a rule's op ("<", "<=", ">", ">=", "==").
bool op_holds(double a, const std::string& op, double b);

/// A measured value as reasons and the measured line show it: 4 significant digits, "n/a" for NaN.
std::string claim_number(double v);

/// Judges a rule of kind "front" or "matched" (claims_tradeoff.cpp).
RuleOutcome judge_tradeoff(const ClaimRule& rule, const std::vector<Json>& records);

}  // namespace scanbench::harness
