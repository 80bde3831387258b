// claims.json entries, the Markdown table and the report's section of the claims (claims_render.h).
#include "scanbench/harness/results/claims_render.h"

#include <fmt/format.h>

#include <map>

#include "scanbench/harness/config/protocol.h"
#include "scanbench/harness/results/table.h"

namespace scanbench::harness {

Json RuleOutcome::to_json(const ClaimRule& r) const {
  return {{"what", r.what},   {"quantity", r.quantity}, {"verdict", verdict},
          {"reason", reason}, {"measured", measured},   {"groups", groups}};
}

Json claim_result_json(const Claim& claim, const ClaimOutcome& outcome) {
  Json j = {{"id", claim.id},       {"claim", claim.claim},       {"source", claim.source},
            {"paper", claim.paper}, {"verdict", outcome.verdict}, {"reason", outcome.reason}};
  if (!claim.notes.empty()) j["notes"] = claim.notes;
  if (!claim.chains.empty()) j["chains"] = claim.chains.to_json();
  std::string measured;
  Json rules = Json::array();
  for (std::size_t i = 0; i < outcome.rules.size(); ++i) {
    rules.push_back(outcome.rules[i].to_json(claim.rules[i]));
    if (!outcome.rules[i].measured.empty()) {
      measured += (measured.empty() ? "" : " | ") + claim.rules[i].quantity + " " +
                  outcome.rules[i].measured;
    }
  }
  j["measured"] = measured;
  j["rules"] = rules;
  return j;
}

namespace {

/// The parameters cell: the protocol's summary and any declared chain difference.
std::string parameters_cell(const Json& c) {
  std::string s = protocol_summary(c.value("protocol", Json::object()));
  const std::string d = chains_summary(c.value("chains", Json::object()));
  if (!d.empty()) s += (s.empty() ? "" : "; ") + std::string("declared: ") + d;
  return s;
}

std::string md_cell(std::string s) {
  for (auto& c : s)
    if (c == '|' || c == '\n') c = c == '|' ? '/' : ' ';
  return s;
}

}  // namespace

std::string claims_markdown(const Json& summary) {
  std::string s =
      "| claim | source | paper | parameters | measured | verdict | sensitivity |\n"
      "|---|---|---|---|---|---|---|\n";
  for (const auto& c : summary.value("claims", Json::array())) {
    s += fmt::format("| {} | {} | {} | {} | {} | **{}**: {} | {} |\n", md_cell(c.value("id", "")),
                     md_cell(c.value("source", "")), md_cell(c.value("paper", "")),
                     md_cell(parameters_cell(c)), md_cell(c.value("measured", "")),
                     md_cell(c.value("verdict", "")), md_cell(c.value("reason", "")),
                     md_cell(c.value("sensitivity", Json::object()).value("text", "")));
  }
  return s;
}

std::string claims_html_section(const Json& summary) {
  std::map<std::string, int> counts;
  for (const auto& c : summary.value("claims", Json::array()))
    ++counts[c.value("verdict", std::string("?"))];
  std::string tally;
  for (const auto& [v, n] : counts)
    tally += fmt::format("{}{} {}", tally.empty() ? "" : ", ", n, v);
  std::string h = fmt::format(
      "<h2>Claims of the source papers</h2>\n<p id=\"claims-summary\">{}{}. "
      "<code>scanbench claims{}</code>; rules in <code>configs/claims/</code>.</p>\n",
      html_escape(tally),
      summary.value("regressions", Json::array()).empty()
          ? ""
          : ", <span class=\"regression\">regressed: " +
                html_escape(summary["regressions"].dump()) + "</span>",
      summary.value("quick", false) ? " --quick" : "");
  h += "<table id=\"claims\"><tr><th>claim</th><th>source</th><th>paper</th>"
       "<th>parameters</th><th>measured</th><th>verdict</th><th>reason</th>"
       "<th>sensitivity</th></tr>\n";
  for (const auto& c : summary.value("claims", Json::array())) {
    const std::string v = c.value("verdict", std::string("?"));
    const std::string folder = c.value("folder", std::string());
    const std::string id = html_escape(c.value("id", ""));
    h += fmt::format(
        "<tr><td style=\"text-align:left\">{}<br><small>{}</small></td><td>{}</td>"
        "<td style=\"text-align:left\">{}</td><td style=\"text-align:left\">{}</td>"
        "<td style=\"text-align:left\">{}</td><td class=\"{}\">{}</td>"
        "<td style=\"text-align:left\">{}</td><td style=\"text-align:left\">{}</td></tr>\n",
        folder.empty() ? id
                       : fmt::format("<a href=\"{}/index.html\">{}</a>", html_escape(folder), id),
        html_escape(c.value("claim", "")), html_escape(c.value("source", "")),
        html_escape(c.value("paper", "")), html_escape(parameters_cell(c)),
        html_escape(c.value("measured", "")), v == "failed" ? "fail" : (v == "held" ? "best" : ""),
        html_escape(v), html_escape(c.value("reason", "")),
        html_escape(c.value("sensitivity", Json::object()).value("text", "")));
  }
  h += "</table>\n";
  return h;
}

}  // namespace scanbench::harness
