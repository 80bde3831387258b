#pragma once
// The results of `scanbench claims` (claims.h) as claims.json entries, a Markdown table and the
// report's section.
#include <string>

#include "scanbench/core/params.h"
#include "scanbench/harness/results/claims.h"

namespace scanbench::harness {

/// The entry of one claim in claims.json: id, claim, source, paper, notes, verdict, reason,
/// measured (one line), rules (with groups), plus what the caller adds (jobs, wall_s, folder).
Json claim_result_json(const Claim& claim, const ClaimOutcome& outcome);

/// Markdown table of a claims.json summary: claim, source, paper, measured, verdict (reason).
std::string claims_markdown(const Json& summary);
/// The HTML section of the report (`<h2>Claims</h2>` and a table), links relative to the folder
/// holding the summary.
std::string claims_html_section(const Json& summary);

}  // namespace scanbench::harness
