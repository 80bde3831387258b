#include "results/claims_tradeoff.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "config/json_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/records.h"

namespace scanbench::harness {

namespace {

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw ParamError(fmt::format("{}: {}", where, what));
}

std::string text(const Json& j, const std::string& key, const std::string& where, bool required,
                 const std::string& def = "") {
  if (!j.contains(key)) {
    if (required) fail(where + "/" + key, "missing");
    return def;
  }
  if (!j[key].is_string() || j[key].get<std::string>().empty()) {
    fail(where + "/" + key, "expected a non-empty string");
  }
  return j[key].get<std::string>();
}

double positive(const Json& j, const std::string& key, const std::string& where, double def) {
  if (!j.contains(key)) return def;
  if (!j[key].is_number() || !std::isfinite(j[key].get<double>()) || j[key].get<double>() <= 0) {
    fail(where + "/" + key, "expected a positive finite number, got " + j[key].dump());
  }
  return j[key].get<double>();
}

ClaimSelector selector(const Json& j, const std::string& key, const std::string& where) {
  if (!j.contains(key)) fail(where + "/" + key, "missing (a selector)");
  return parse_claim_selector(j[key], where + "/" + key);
}

std::string num(double v) {
  return std::isnan(v) ? "n/a" : fmt::format("{:.4g}", v);
}

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
    s +=
        fmt::format("{}{} ({}, {})", s.empty() ? "" : " ", p->label(), num(p->cost), num(p->error));
  return s;
}

bool beats(double a, const std::string& op, double b) {
  return op == "<=" ? a <= b : a < b;
}

std::string combine(const std::vector<std::string>& v) {
  if (std::find(v.begin(), v.end(), "failed") != v.end()) return "failed";
  if (v.empty() || std::find(v.begin(), v.end(), "inconclusive") != v.end()) {
    return "inconclusive";
  }
  return "held";
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
    std::string v = beats(a->cost, rule.op, b->cost) ? "held" : "failed";
    if (timing && (a->samples.size() > 1 || b->samples.size() > 1)) {
      const auto [amin, amax] = std::minmax_element(a->samples.begin(), a->samples.end());
      const auto [bmin, bmax] = std::minmax_element(b->samples.begin(), b->samples.end());
      if (*amin <= *bmax && *bmin <= *amax) {
        v = "inconclusive";
        reasons.push_back(fmt::format("at b {} the cost samples overlap ([{}, {}] vs [{}, {}])",
                                      b->label(), num(*amin), num(*amax), num(*bmin), num(*bmax)));
      }
    }
    if (v == "failed") {
      reasons.push_back(
          fmt::format("at b {} (cost {}, error {}) the cheapest a as accurate, {}, "
                      "costs {}",
                      b->label(), num(b->cost), num(b->error), a->label(), num(a->cost)));
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
  return combine(verdicts);
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
    sizes += fmt::format("{}{} {}", sizes.empty() ? "" : ", ", p.label(), num(p.cost));
    if (p.cost < band_lo || p.cost > band_hi) continue;
    const bool ok = rule.op == "<"    ? p.error < ref
                    : rule.op == "<=" ? p.error <= ref
                    : rule.op == ">"  ? p.error > ref
                    : rule.op == ">=" ? p.error >= ref
                                      : p.error == ref;
    verdicts.push_back(ok ? "held" : "failed");
    measured += fmt::format("{}{} ({} {}): {} vs {} (ratio {:.3g})", measured.empty() ? "" : ", ",
                            p.label(), rule.match_quantity, num(p.cost), num(p.error), num(ref),
                            p.error / ref);
    if (!ok) {
      why += fmt::format("{}{}: {} {} {} does not hold", why.empty() ? "" : ", ", p.label(),
                         num(p.error), rule.op, num(ref));
    }
  }
  gj["band"] = {band_lo, band_hi};
  gj["reference"] = ref;
  if (verdicts.empty()) {
    why = fmt::format("no a record in the band [{}, {}] of {}{} (a: {})", num(band_lo),
                      num(band_hi), rule.match_quantity,
                      band_lo > band_hi ? " (empty: its lower end lies above its upper end)" : "",
                      sizes);
    measured = "no a record in the band";
    return "inconclusive";
  }
  return combine(verdicts);
}

}  // namespace

ClaimRule parse_tradeoff_rule(const Json& j, const std::string& where) {
  ClaimRule r;
  r.kind = j["kind"].get<std::string>();
  const bool is_front = r.kind == "front";
  if (is_front) {
    check_keys(j, where,
               {"what", "kind", "quantity", "per", "a", "b", "cost", "cost_b", "exclude_steps",
                "factor", "op"});
  } else {
    check_keys(j, where, {"what", "kind", "quantity", "per", "a", "b", "factor", "op", "match"});
  }
  r.what = text(j, "what", where, true);
  r.quantity = text(j, "quantity", where, true);
  r.per = text(j, "per", where, false, "dataset");
  if (r.per != "dataset" && r.per != "all") {
    fail(where + "/per", "expected one of dataset, all, got '" + r.per + "'");
  }
  r.a = selector(j, "a", where);
  r.b = selector(j, "b", where);
  r.has_b = true;
  r.factor = positive(j, "factor", where, 1.0);
  r.op = text(j, "op", where, false, is_front ? "<" : "<=");
  const std::vector<std::string> ops = is_front
                                           ? std::vector<std::string>{"<", "<="}
                                           : std::vector<std::string>{"<", "<=", ">", ">=", "=="};
  if (std::find(ops.begin(), ops.end(), r.op) == ops.end()) {
    fail(where + "/op", fmt::format("not used by kind {}: '{}'", r.kind, r.op));
  }
  if (is_front) {
    r.cost = text(j, "cost", where, true);
    r.cost_b = text(j, "cost_b", where, false, r.cost);
    if (j.contains("exclude_steps")) {
      const Json& e = j["exclude_steps"];
      if (!e.is_array()) fail(where + "/exclude_steps", "expected a list of chain step labels");
      for (const auto& s : e) {
        if (!s.is_string() || s.get<std::string>().empty()) {
          fail(where + "/exclude_steps", "expected a list of chain step labels");
        }
        r.exclude_steps.push_back(s.get<std::string>());
      }
      if (r.cost.rfind("time.", 0) != 0 || r.cost_b.rfind("time.", 0) != 0) {
        fail(where + "/exclude_steps", "only for time.* costs");
      }
    }
    return r;
  }
  if (!j.contains("match") || !j["match"].is_object()) {
    fail(where + "/match", "expected {\"quantity\", \"lo\", \"hi\", ...}");
  }
  const Json& m = j["match"];
  const std::string w = where + "/match";
  check_keys(m, w, {"quantity", "ref", "lo", "lo_factor", "hi", "hi_factor"});
  r.match_quantity = text(m, "quantity", w, true);
  r.match_ref = text(m, "ref", w, false, r.match_quantity);
  r.match_lo = selector(m, "lo", w);
  r.match_hi = selector(m, "hi", w);
  r.lo_factor = positive(m, "lo_factor", w, 1.0);
  r.hi_factor = positive(m, "hi_factor", w, 1.0);
  return r;
}

RuleOutcome judge_tradeoff(const ClaimRule& rule, const std::vector<Json>& records) {
  RuleOutcome out;
  std::vector<std::string> verdicts;
  for (const auto& [g, recs] : claim_groups(records, rule.per)) {
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
  out.verdict = combine(verdicts);
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
