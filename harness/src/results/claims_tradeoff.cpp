// Judging the trade-off rules, kinds "front" and "matched" (claims.h).
#include "results/claims_judging.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "scanbench/core/timing.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

namespace {

/// One record as a point of a trade-off: its error, its cost (median of its samples) and, for a
/// time.* cost, the samples of its repeats.
struct Point {
  const Json* rec = nullptr;
  double error = std::nan(""), cost = std::nan("");
  std::vector<double> samples;
  std::string label() const {
    const Json pt = rec->value("point", Json::object());
    std::string s;
    for (const auto& [k, v] : pt.items())
      s += (s.empty() ? "" : ",") + k.substr(k.rfind('.') + 1) + "=" + v.dump();
    return s.empty() ? rec->value("variant", Json::object()).value("label", std::string("?")) : s;
  }
};

/// The cost samples of a record: a time.* quantity per repeat less the excluded steps' seconds of
/// that repeat (timing.phases.<step>), any other quantity as its one value.
std::vector<double> cost_samples(const Json& r, const std::string& q,
                                 const std::vector<std::string>& exclude) {
  std::vector<double> s = record_samples(r, q);
  if (q.rfind("time.", 0) != 0 || exclude.empty()) return s;
  const Json phases = r.value("timing", Json::object()).value("phases", Json::object());
  for (const auto& step : exclude) {
    if (!phases.contains(step) || !phases[step].is_array() || phases[step].size() != s.size()) {
      return {};  // the step's seconds are missing: no cost rather than a wrong one
    }
    for (std::size_t i = 0; i < s.size(); ++i)
      s[i] -= phases[step][i].get<double>();
  }
  return s;
}

/// The points of the records a selector matches in a group; `problem` names the first record
/// that cannot be a point.
std::vector<Point> points(const std::vector<const Json*>& group, const ClaimSelector& sel,
                          const std::string& error_q, const std::string& cost_q,
                          const std::vector<std::string>& exclude, std::string& problem) {
  std::vector<Point> out;
  for (const Json* r : group) {
    if (!sel.matches(*r)) continue;
    const std::string key = r->value("key", std::string("?"));
    if (r->value("status", std::string("?")) != "ok") {
      problem = fmt::format("job {} {}: {}", key, r->value("status", std::string("?")),
                            r->value("error", std::string()));
      return {};
    }
    Point p;
    p.rec = r;
    p.error = record_value(*r, error_q);
    p.samples = cost_samples(*r, cost_q, exclude);
    if (!p.samples.empty()) p.cost = median(p.samples);
    if (std::isnan(p.error) || std::isnan(p.cost)) {
      problem = fmt::format("job {} has no '{}'", key, std::isnan(p.error) ? error_q : cost_q);
      return {};
    }
    out.push_back(std::move(p));
  }
  if (out.empty() && problem.empty()) problem = "no record matches " + sel.describe();
  return out;
}

/// The Pareto front: the points no other point beats in both cost and error, by rising cost.
std::vector<const Point*> front(const std::vector<Point>& pts) {
  std::vector<const Point*> sorted;
  for (const auto& p : pts)
    sorted.push_back(&p);
  std::stable_sort(sorted.begin(), sorted.end(), [](const Point* x, const Point* y) {
    return x->cost < y->cost || (x->cost == y->cost && x->error < y->error);
  });
  std::vector<const Point*> f;
  double best = std::numeric_limits<double>::infinity();
  for (const Point* p : sorted) {
    if (p->error < best) {
      f.push_back(p);
      best = p->error;
    }
  }
  return f;
}

std::string front_text(const std::vector<const Point*>& f) {
  std::string s;
  for (const Point* p : f)
    s += fmt::format("{}{} ({}, {})", s.empty() ? "" : " ", p->label(), claim_number(p->cost),
                     claim_number(p->error));
  return s;
}

/// One group of a "front" rule: the verdict, with what was measured and why.
std::string judge_front_group(const ClaimRule& rule, const std::vector<const Json*>& group,
                              Json& gj, std::string& measured, std::string& why) {
  std::string problem;
  const auto pa = points(group, rule.a, rule.quantity, rule.cost, rule.exclude_steps, problem);
  const auto pb = problem.empty() ? points(group, rule.b, rule.quantity, rule.cost_b,
                                           rule.exclude_steps, problem)
                                  : std::vector<Point>{};
  if (!problem.empty()) {
    why = problem;
    return "inconclusive";
  }
  const auto fa = front(pa), fb = front(pb);
  const bool timing = rule.cost.rfind("time.", 0) == 0;
  std::vector<std::string> verdicts, reasons;
  Json pairs = Json::array();
  for (const Point* b : fb) {
    const Point* a = nullptr;  // the cheapest a point at least as accurate (within factor)
    for (const Point* p : fa)
      if (p->error <= rule.factor * b->error && (!a || p->cost < a->cost)) a = p;
    if (!a) continue;
    std::string v = op_holds(a->cost, rule.op, b->cost) ? "held" : "failed";
    if (timing && (a->samples.size() > 1 || b->samples.size() > 1)) {
      const auto [amin, amax] = std::minmax_element(a->samples.begin(), a->samples.end());
      const auto [bmin, bmax] = std::minmax_element(b->samples.begin(), b->samples.end());
      if (*amin <= *bmax && *bmin <= *amax) {
        v = "inconclusive";
        reasons.push_back(fmt::format("at b {} the cost samples overlap ([{}, {}] vs [{}, {}])",
                                      b->label(), claim_number(*amin), claim_number(*amax),
                                      claim_number(*bmin), claim_number(*bmax)));
      }
    }
    if (v == "failed") {
      reasons.push_back(
          fmt::format("at b {} (cost {}, error {}) the cheapest a as accurate, {}, "
                      "costs {}",
                      b->label(), claim_number(b->cost), claim_number(b->error), a->label(),
                      claim_number(a->cost)));
    }
    verdicts.push_back(v);
    pairs.push_back({{"b", b->label()},
                     {"b_cost", b->cost},
                     {"b_error", b->error},
                     {"a", a->label()},
                     {"a_cost", a->cost},
                     {"a_error", a->error},
                     {"verdict", v}});
  }
  measured = fmt::format("a front {}; b front {}", front_text(fa), front_text(fb));
  gj["a_front"] = front_text(fa);
  gj["b_front"] = front_text(fb);
  gj["pairs"] = pairs;
  if (verdicts.empty()) {
    why = fmt::format("no a point reaches {} x the error of a point of b's front", rule.factor);
    return "inconclusive";
  }
  for (const auto& r : reasons)
    why += (why.empty() ? "" : ", ") + r;
  return combine_verdicts(verdicts);
}

/// One group of a "matched" rule.
std::string judge_matched_group(const ClaimRule& rule, const std::vector<const Json*>& group,
                                Json& gj, std::string& measured, std::string& why) {
  std::string problem;
  const auto pa = points(group, rule.a, rule.quantity, rule.match_quantity, {}, problem);
  std::vector<Point> pb, lo, hi;
  if (problem.empty()) pb = points(group, rule.b, rule.quantity, rule.match_ref, {}, problem);
  if (problem.empty())
    lo = points(group, rule.match_lo, rule.quantity, rule.match_ref, {}, problem);
  if (problem.empty())
    hi = points(group, rule.match_hi, rule.quantity, rule.match_ref, {}, problem);
  if (problem.empty() && (pb.size() != 1 || lo.size() != 1 || hi.size() != 1)) {
    problem = "b, match/lo and match/hi must each select one record";
  }
  if (!problem.empty()) {
    why = problem;
    return "inconclusive";
  }
  const double band_lo = rule.lo_factor * lo[0].cost, band_hi = rule.hi_factor * hi[0].cost;
  const double ref = rule.factor * pb[0].error;
  std::vector<std::string> verdicts;
  std::string sizes;
  for (const auto& p : pa) {
    sizes += fmt::format("{}{} {}", sizes.empty() ? "" : ", ", p.label(), claim_number(p.cost));
    if (p.cost < band_lo || p.cost > band_hi) continue;
    const bool ok = op_holds(p.error, rule.op, ref);
    verdicts.push_back(ok ? "held" : "failed");
    measured += fmt::format("{}{} ({} {}): {} vs {} (ratio {:.3g})", measured.empty() ? "" : ", ",
                            p.label(), rule.match_quantity, claim_number(p.cost),
                            claim_number(p.error), claim_number(ref), p.error / ref);
    if (!ok) {
      why += fmt::format("{}{}: {} {} {} does not hold", why.empty() ? "" : ", ", p.label(),
                         claim_number(p.error), rule.op, claim_number(ref));
    }
  }
  gj["band"] = {band_lo, band_hi};
  gj["reference"] = ref;
  if (verdicts.empty()) {
    why = fmt::format("no a record in the band [{}, {}] of {}{} (a: {})", claim_number(band_lo),
                      claim_number(band_hi), rule.match_quantity,
                      band_lo > band_hi ? " (empty: its lower end lies above its upper end)" : "",
                      sizes);
    measured = "no a record in the band";
    return "inconclusive";
  }
  return combine_verdicts(verdicts);
}

}  // namespace

RuleOutcome judge_tradeoff(const ClaimRule& rule, const std::vector<Json>& records) {
  RuleOutcome out;
  std::vector<std::string> verdicts;
  for (const auto& [g, recs] : claim_groups(records, rule)) {
    Json gj = {{"group", g}};
    std::string measured, why;
    const std::string v = rule.kind == "front" ? judge_front_group(rule, recs, gj, measured, why)
                                               : judge_matched_group(rule, recs, gj, measured, why);
    gj["verdict"] = v;
    out.groups.push_back(gj);
    verdicts.push_back(v);
    if (!measured.empty())
      out.measured += fmt::format("{}{}: {}", out.measured.empty() ? "" : "; ", g, measured);
    if (!why.empty()) out.reason += fmt::format("{}{}: {}", out.reason.empty() ? "" : "; ", g, why);
  }
  if (verdicts.empty()) out.reason = "no records";
  out.verdict = combine_verdicts(verdicts);
  if (out.reason.empty()) {
    out.reason = rule.kind == "front"
                     ? fmt::format("on b's {} vs {} front, a is as accurate for less {}",
                                   rule.cost_b, rule.quantity, rule.cost)
                     : fmt::format("every a in the {} band: {} {} {}", rule.match_quantity,
                                   rule.quantity, rule.op, rule.b.describe());
  }
  return out;
}

}  // namespace scanbench::harness
