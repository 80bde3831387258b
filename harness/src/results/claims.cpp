#include "scanbench/harness/claims.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "config/json_checks.h"
#include "results/claims_tradeoff.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/experiment.h"
#include "scanbench/harness/records.h"
#include "scanbench/harness/table.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw ParamError(fmt::format("{}: {}", where, what));
}

std::string get_string(const Json& j, const std::string& key, const std::string& where,
                       bool required, const std::string& def = "") {
  if (!j.contains(key)) {
    if (required) fail(where + "/" + key, "missing");
    return def;
  }
  if (!j[key].is_string() || j[key].get<std::string>().empty()) {
    fail(where + "/" + key, "expected a non-empty string");
  }
  return j[key].get<std::string>();
}

double get_number(const Json& j, const std::string& key, const std::string& where, double def) {
  if (!j.contains(key)) return def;
  if (!j[key].is_number() || !std::isfinite(j[key].get<double>())) {
    fail(where + "/" + key, "expected a finite number, got " + j[key].dump());
  }
  return j[key].get<double>();
}

std::string get_choice(const Json& j, const std::string& key, const std::string& where,
                       const std::vector<std::string>& choices, const std::string& def) {
  const std::string v = get_string(j, key, where, false, def);
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) {
    std::string list;
    for (const auto& c : choices)
      list += (list.empty() ? "" : ", ") + c;
    fail(where + "/" + key, fmt::format("expected one of {}, got '{}'", list, v));
  }
  return v;
}

ClaimSelector parse_selector(const Json& j, const std::string& where) {
  check_keys(j, where, {"variant", "point", "dataset"});
  ClaimSelector s;
  s.variant = get_string(j, "variant", where, false);
  s.dataset = get_string(j, "dataset", where, false);
  if (j.contains("point")) {
    if (!j["point"].is_object()) fail(where + "/point", "expected an object of sweep values");
    s.point = j["point"];
  }
  return s;
}

ClaimRule parse_rule(const Json& j, const std::string& where) {
  if (j.is_object() && j.contains("kind") && (j["kind"] == "front" || j["kind"] == "matched")) {
    return parse_tradeoff_rule(j, where);
  }
  check_keys(j, where,
             {"what", "kind", "quantity", "per", "stat", "a", "b", "value", "factor", "op",
              "margin", "tolerance", "abs", "param", "range"});
  ClaimRule r;
  r.what = get_string(j, "what", where, true);
  r.kind = get_choice(j, "kind", where, {"compare", "argmin"}, "compare");
  r.quantity = get_string(j, "quantity", where, true);
  r.per = get_choice(j, "per", where, {"dataset", "all"}, "dataset");
  r.stat = get_choice(j, "stat", where, {"median", "mean", "min", "max"}, "median");
  if (!j.contains("a")) fail(where + "/a", "missing (the selector of the records to judge)");
  r.a = parse_selector(j["a"], where + "/a");
  if (r.kind == "argmin") {
    r.param = get_string(j, "param", where, true);
    const Json& rg = j.contains("range") ? j["range"] : Json();
    if (!rg.is_array() || rg.size() != 2 || !rg[0].is_number() || !rg[1].is_number() ||
        rg[0].get<double>() > rg[1].get<double>()) {
      fail(where + "/range", "expected [lo, hi] with lo <= hi");
    }
    r.lo = rg[0].get<double>();
    r.hi = rg[1].get<double>();
    for (const char* k : {"b", "value", "op", "factor", "margin", "tolerance", "abs"})
      if (j.contains(k)) fail(where + "/" + k, "not used by kind argmin");
    return r;
  }
  for (const char* k : {"param", "range"})
    if (j.contains(k)) fail(where + "/" + k, "only for kind argmin");
  if (j.contains("b") == j.contains("value")) {
    fail(where, "expected exactly one of \"b\" (a selector) and \"value\" (a number)");
  }
  if (j.contains("b")) {
    r.b = parse_selector(j["b"], where + "/b");
    r.has_b = true;
  } else {
    r.value = get_number(j, "value", where, 0.0);
  }
  r.op = get_choice(j, "op", where, {"<", "<=", ">", ">=", "=="}, "<=");
  r.factor = get_number(j, "factor", where, 1.0);
  r.margin = get_number(j, "margin", where, 0.0);
  r.tolerance = get_number(j, "tolerance", where, 1e-6);
  r.abs = get_number(j, "abs", where, 0.0);
  if (r.margin < 0 || r.tolerance < 0 || r.abs < 0) {
    fail(where, "margin, tolerance and abs must not be negative");
  }
  if (r.op == "==" && j.contains("margin")) fail(where + "/margin", "not used with op \"==\"");
  return r;
}

/// Labels and sweep keys of an expanded experiment, to check selectors against.
void check_selector(const ClaimSelector& s, const Experiment& e, const std::string& where) {
  if (!s.variant.empty()) {
    bool found = false;
    for (const auto& v : e.variants)
      found = found || v.label == s.variant;
    if (!found) fail(where + "/variant", "no variant labelled '" + s.variant + "'");
  }
  if (!s.dataset.empty()) {
    bool found = false;
    for (const auto& d : e.datasets)
      found = found || d.label == s.dataset;
    if (!found) fail(where + "/dataset", "no dataset labelled '" + s.dataset + "'");
  }
}

bool json_equal_value(const Json& a, const Json& b) {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    return std::abs(x - y) <= 1e-9 * std::max(1.0, std::abs(y));
  }
  return a == b;
}

double statistic(std::vector<double> v, const std::string& stat) {
  if (v.empty()) return std::nan("");
  if (stat == "mean") {
    double s = 0;
    for (double x : v)
      s += x;
    return s / static_cast<double>(v.size());
  }
  if (stat == "min") return *std::min_element(v.begin(), v.end());
  if (stat == "max") return *std::max_element(v.begin(), v.end());
  return median(v);
}

bool holds(double a, const std::string& op, double b) {
  if (op == "<") return a < b;
  if (op == "<=") return a <= b;
  if (op == ">") return a > b;
  if (op == ">=") return a >= b;
  return a == b;
}

std::string num(double v) {
  return std::isnan(v) ? "n/a" : fmt::format("{:.4g}", v);
}

/// Groups of records: per dataset (in order of first appearance) or one group "all".
std::vector<std::pair<std::string, std::vector<const Json*>>> group_records(
    const std::vector<Json>& records, const std::string& per) {
  std::vector<std::pair<std::string, std::vector<const Json*>>> groups;
  for (const auto& r : records) {
    const std::string g =
        per == "all" ? "all" : r.value("dataset", Json::object()).value("label", std::string("?"));
    auto it =
        std::find_if(groups.begin(), groups.end(), [&](const auto& x) { return x.first == g; });
    if (it == groups.end()) {
      groups.emplace_back(g, std::vector<const Json*>{});
      it = groups.end() - 1;
    }
    it->second.push_back(&r);
  }
  return groups;
}

struct Side {
  std::vector<const Json*> recs;
  std::string problem;  ///< non-empty: the reason the side cannot be judged
  double value = std::nan("");
};

Side select_side(const std::vector<const Json*>& group, const ClaimSelector& sel,
                 const ClaimRule& rule, const std::string& name) {
  Side s;
  for (const Json* r : group)
    if (sel.matches(*r)) s.recs.push_back(r);
  if (s.recs.empty()) {
    s.problem = fmt::format("no record matches {} ({})", name, sel.describe());
    return s;
  }
  std::vector<double> vals;
  for (const Json* r : s.recs) {
    const std::string status = r->value("status", std::string("?"));
    if (status != "ok") {
      s.problem = fmt::format("job {} {}: {}", r->value("key", std::string("?")), status,
                              r->value("error", std::string()));
      return s;
    }
    const double v = record_value(*r, rule.quantity);
    if (std::isnan(v)) {
      s.problem =
          fmt::format("job {} has no '{}'", r->value("key", std::string("?")), rule.quantity);
      return s;
    }
    vals.push_back(v);
  }
  s.value = statistic(vals, rule.stat);
  return s;
}

std::string combine(const std::vector<std::string>& verdicts) {
  if (std::find(verdicts.begin(), verdicts.end(), "failed") != verdicts.end()) return "failed";
  if (std::find(verdicts.begin(), verdicts.end(), "inconclusive") != verdicts.end()) {
    return "inconclusive";
  }
  return "held";
}

RuleOutcome judge_argmin(const ClaimRule& rule, const std::vector<Json>& records) {
  RuleOutcome out;
  std::vector<std::string> verdicts, reasons, measured;
  for (const auto& [g, recs] : group_records(records, rule.per)) {
    Side side = select_side(recs, rule.a, rule, "a");
    Json gj = {{"group", g}};
    if (!side.problem.empty()) {
      verdicts.push_back("inconclusive");
      reasons.push_back(g + ": " + side.problem);
      gj["verdict"] = "inconclusive";
      out.groups.push_back(gj);
      continue;
    }
    std::map<double, std::vector<double>> by_param;
    std::string problem;
    for (const Json* r : side.recs) {
      const Json pt = r->value("point", Json::object());
      if (!pt.contains(rule.param) || !pt[rule.param].is_number()) {
        problem = fmt::format("job {} has no numeric sweep value '{}'",
                              r->value("key", std::string("?")), rule.param);
        break;
      }
      by_param[pt[rule.param].get<double>()].push_back(record_value(*r, rule.quantity));
    }
    if (problem.empty() && by_param.size() < 2) {
      problem = fmt::format("fewer than two values of '{}'", rule.param);
    }
    if (!problem.empty()) {
      verdicts.push_back("inconclusive");
      reasons.push_back(g + ": " + problem);
      gj["verdict"] = "inconclusive";
      out.groups.push_back(gj);
      continue;
    }
    double best_x = 0, best = std::numeric_limits<double>::infinity();
    std::string curve;
    Json values = Json::object();
    for (const auto& [x, v] : by_param) {
      const double s = statistic(v, rule.stat);
      values[fmt::format("{:g}", x)] = s;
      curve += fmt::format("{}{:g}:{}", curve.empty() ? "" : " ", x, num(s));
      if (s < best) {
        best = s;
        best_x = x;
      }
    }
    const bool ok = best_x >= rule.lo && best_x <= rule.hi;
    verdicts.push_back(ok ? "held" : "failed");
    if (!ok) {
      reasons.push_back(fmt::format("{}: lowest at {}={:g}, outside [{:g}, {:g}]", g, rule.param,
                                    best_x, rule.lo, rule.hi));
    }
    measured.push_back(fmt::format("{}: argmin {:g} ({})", g, best_x, curve));
    gj["values"] = values;
    gj["argmin"] = best_x;
    gj["verdict"] = verdicts.back();
    out.groups.push_back(gj);
  }
  if (verdicts.empty()) {
    verdicts.push_back("inconclusive");
    reasons.push_back("no records");
  }
  out.verdict = combine(verdicts);
  for (const auto& m : measured)
    out.measured += (out.measured.empty() ? "" : "; ") + m;
  for (const auto& r : reasons)
    out.reason += (out.reason.empty() ? "" : "; ") + r;
  if (out.reason.empty()) {
    out.reason =
        fmt::format("lowest {} at {} in [{:g}, {:g}]", rule.quantity, rule.param, rule.lo, rule.hi);
  }
  return out;
}

}  // namespace

ClaimSelector parse_claim_selector(const Json& j, const std::string& where) {
  return parse_selector(j, where);
}

std::vector<std::pair<std::string, std::vector<const Json*>>> claim_groups(
    const std::vector<Json>& records, const std::string& per) {
  return group_records(records, per);
}

bool ClaimSelector::matches(const Json& r) const {
  if (!variant.empty() &&
      r.value("variant", Json::object()).value("label", std::string()) != variant) {
    return false;
  }
  if (!dataset.empty() &&
      r.value("dataset", Json::object()).value("label", std::string()) != dataset) {
    return false;
  }
  const Json pt = r.value("point", Json::object());
  for (const auto& [k, v] : point.items())
    if (!pt.contains(k) || !json_equal_value(pt[k], v)) return false;
  return true;
}

std::string ClaimSelector::describe() const {
  std::string s;
  if (!variant.empty()) s += "variant " + variant;
  if (!dataset.empty()) s += (s.empty() ? "" : ", ") + std::string("dataset ") + dataset;
  for (const auto& [k, v] : point.items())
    s += (s.empty() ? "" : ", ") + k + "=" + v.dump();
  return s.empty() ? "any record" : s;
}

Json Claim::experiment_config(bool use_quick) const {
  Json e = experiment;
  if (use_quick && !quick.is_null()) e.merge_patch(quick);
  if (!e.contains("name")) e["name"] = id;
  return e;
}

Claim parse_claim(const Json& j, const std::string& where, const std::string& default_id) {
  const std::string w0 = where + ": ";  // + "/key": "file: /key"
  check_keys(j, w0,
             {"scanbench_claim", "id", "claim", "source", "paper", "notes", "experiment", "quick",
              "rules"});
  if (!j.contains("scanbench_claim") || !j["scanbench_claim"].is_number_integer() ||
      j["scanbench_claim"].get<int>() != kClaimVersion) {
    fail(w0 + "/scanbench_claim", fmt::format("expected claim format version {}", kClaimVersion));
  }
  Claim c;
  c.id = get_string(j, "id", w0, false, default_id);
  c.claim = get_string(j, "claim", w0, true);
  c.source = get_string(j, "source", w0, true);
  c.paper = get_string(j, "paper", w0, false, "");
  c.notes = get_string(j, "notes", w0, false, "");
  if (!j.contains("experiment") || !j["experiment"].is_object()) {
    fail(w0 + "/experiment", "expected an experiment config (object)");
  }
  c.experiment = j["experiment"];
  if (j.contains("quick")) {
    if (!j["quick"].is_object()) fail(w0 + "/quick", "expected a JSON merge patch (object)");
    c.quick = j["quick"];
  }
  if (!j.contains("rules") || !j["rules"].is_array() || j["rules"].empty()) {
    fail(w0 + "/rules", "expected a non-empty list of verdict rules");
  }
  for (std::size_t i = 0; i < j["rules"].size(); ++i)
    c.rules.push_back(parse_rule(j["rules"][i], fmt::format("{}/rules/{}", w0, i)));
  // Both experiments must load, and every selector name a variant/dataset of each.
  for (bool q : {false, true}) {
    if (q && c.quick.is_null()) continue;
    const std::string w = where + (q ? " (quick)" : "") + ": /experiment";
    const Experiment e = parse_experiment(c.experiment_config(q), w);
    for (std::size_t i = 0; i < c.rules.size(); ++i) {
      const std::string rw = fmt::format("{}{}: /rules/{}", where, q ? " (quick)" : "", i);
      check_selector(c.rules[i].a, e, rw + "/a");
      if (c.rules[i].has_b) check_selector(c.rules[i].b, e, rw + "/b");
      if (c.rules[i].kind == "matched") {
        check_selector(c.rules[i].match_lo, e, rw + "/match/lo");
        check_selector(c.rules[i].match_hi, e, rw + "/match/hi");
      }
    }
  }
  return c;
}

Claim load_claim(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw IoError(fmt::format("{}: cannot open claim file", file.string()));
  std::stringstream ss;
  ss << in.rdbuf();
  Json j;
  try {
    j = Json::parse(ss.str(), nullptr, true, /*ignore_comments=*/true);
  } catch (const std::exception& e) {
    throw IoError(fmt::format("{}: not valid JSON: {}", file.string(), e.what()));
  }
  Claim c = parse_claim(j, file.string(), file.stem().string());
  c.file = file;
  return c;
}

std::vector<Claim> load_claims(const fs::path& dir, const std::string& filter) {
  if (!fs::is_directory(dir)) throw IoError(dir.string() + ": no claims folder");
  std::regex re;
  try {
    re = std::regex(filter.empty() ? ".*" : filter, std::regex::ECMAScript);
  } catch (const std::regex_error& e) {
    throw ParamError(fmt::format("--filter: not a valid regex '{}': {}", filter, e.what()));
  }
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".json") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::vector<Claim> out;
  std::set<std::string> ids;
  for (const auto& f : files) {
    Claim c = load_claim(f);
    if (!ids.insert(c.id).second) fail(f.string() + ": /id", "claim id '" + c.id + "' used twice");
    if (std::regex_search(c.id, re)) out.push_back(std::move(c));
  }
  return out;
}

RuleOutcome judge_rule(const ClaimRule& rule, const std::vector<Json>& records) {
  if (rule.kind == "argmin") return judge_argmin(rule, records);
  if (rule.kind == "front" || rule.kind == "matched") return judge_tradeoff(rule, records);
  RuleOutcome out;
  std::vector<std::string> verdicts, reasons, measured;
  const bool timing = rule.quantity.rfind("time.", 0) == 0;
  for (const auto& [g, recs] : group_records(records, rule.per)) {
    Json gj = {{"group", g}};
    Side a = select_side(recs, rule.a, rule, "a");
    Side b;
    if (rule.has_b) b = select_side(recs, rule.b, rule, "b");
    const std::string problem = !a.problem.empty() ? a.problem : b.problem;
    if (!problem.empty()) {
      verdicts.push_back("inconclusive");
      reasons.push_back(g + ": " + problem);
      gj["verdict"] = "inconclusive";
      out.groups.push_back(gj);
      continue;
    }
    const double ref = rule.factor * (rule.has_b ? b.value : rule.value);
    std::string verdict, why;
    if (rule.op == "==") {
      const bool eq = std::abs(a.value - ref) <= rule.abs + rule.tolerance * std::abs(ref);
      verdict = eq ? "held" : "failed";
      if (!eq)
        why =
            fmt::format("{}: {} != {} (tolerance {:g})", g, num(a.value), num(ref), rule.tolerance);
    } else {
      verdict = holds(a.value, rule.op, ref) ? "held" : "failed";
      if (rule.margin > 0 && std::abs(a.value - ref) <= rule.margin * std::abs(ref)) {
        verdict = "inconclusive";
        why = fmt::format("{}: {} vs {} differ by less than the margin {:g}", g, num(a.value),
                          num(ref), rule.margin);
      } else if (timing && a.recs.size() == 1 && (!rule.has_b || b.recs.size() == 1)) {
        // Repeat samples: the claim is decided only when the two sides' ranges do not overlap.
        const std::vector<double> sa = record_samples(*a.recs[0], rule.quantity);
        std::vector<double> sb = {ref};
        if (rule.has_b) {
          sb = record_samples(*b.recs[0], rule.quantity);
          for (double& x : sb)
            x *= rule.factor;
        }
        const auto [amin, amax] = std::minmax_element(sa.begin(), sa.end());
        const auto [bmin, bmax] = std::minmax_element(sb.begin(), sb.end());
        if (!sa.empty() && !sb.empty() && *amin <= *bmax && *bmin <= *amax &&
            (sa.size() > 1 || sb.size() > 1)) {
          verdict = "inconclusive";
          why = fmt::format("{}: timing samples overlap ([{}, {}] vs [{}, {}] s)", g, num(*amin),
                            num(*amax), num(*bmin), num(*bmax));
        }
      }
      if (verdict == "failed") {
        why = fmt::format("{}: {} {} {} does not hold", g, num(a.value), rule.op, num(ref));
      }
    }
    std::string m = fmt::format("{}: {}", g, num(a.value));
    if (rule.has_b) {
      m += fmt::format(" vs {}", num(b.value));
      if (b.value != 0.0) m += fmt::format(" (ratio {:.3g})", a.value / b.value);
      gj["b"] = b.value;
      if (b.value != 0.0) gj["ratio"] = a.value / b.value;
    } else {
      m += fmt::format(" vs {}", num(ref));
    }
    gj["a"] = a.value;
    gj["reference"] = ref;
    gj["verdict"] = verdict;
    out.groups.push_back(gj);
    measured.push_back(m);
    verdicts.push_back(verdict);
    if (!why.empty()) reasons.push_back(why);
  }
  if (verdicts.empty()) {
    verdicts.push_back("inconclusive");
    reasons.push_back("no records");
  }
  out.verdict = combine(verdicts);
  for (const auto& m : measured)
    out.measured += (out.measured.empty() ? "" : "; ") + m;
  for (const auto& r : reasons)
    out.reason += (out.reason.empty() ? "" : "; ") + r;
  if (out.reason.empty()) {
    out.reason = fmt::format("{} {} {}{} {}", rule.quantity, rule.op,
                             rule.factor != 1.0 ? fmt::format("{:g} x ", rule.factor) : "",
                             rule.has_b ? rule.b.describe() : num(rule.value),
                             rule.per == "dataset" ? "on every dataset" : "over all datasets");
  }
  return out;
}

ClaimOutcome judge_claim(const Claim& claim, const std::vector<Json>& records) {
  ClaimOutcome out;
  std::vector<std::string> verdicts;
  for (const auto& r : claim.rules) {
    out.rules.push_back(judge_rule(r, records));
    verdicts.push_back(out.rules.back().verdict);
  }
  out.verdict = combine(verdicts);
  if (out.verdict == "held") {
    out.reason =
        fmt::format("all {} rule{} held", claim.rules.size(), claim.rules.size() == 1 ? "" : "s");
  } else {
    for (std::size_t i = 0; i < out.rules.size(); ++i) {
      if (out.rules[i].verdict == out.verdict) {
        out.reason = claim.rules[i].what + ": " + out.rules[i].reason;
        break;
      }
    }
  }
  return out;
}

Json claim_sensitivity(const Claim& claim, const Protocol& protocol,
                       const std::vector<Json>& records) {
  Json params = Json::array();
  std::string text;
  for (const auto& q : protocol.params) {
    if (q.range.empty()) continue;
    std::vector<Json> values = q.range;
    if (std::none_of(values.begin(), values.end(), [&](const Json& x) { return x == q.value; })) {
      values.insert(values.begin(), q.value);
    }
    Json verdicts = Json::object(), rule_verdicts = Json::object();
    std::vector<std::pair<std::string, std::string>> runs;  // verdict, values (consecutive)
    for (const Json& x : values) {
      const ClaimOutcome o = judge_claim(claim, records_at_protocol(records, protocol, &q, x));
      // With several rules, how many held: a claim failed by one rule of three reads apart from
      // one failed by all.
      int held = 0;
      Json rules = Json::array();
      for (const auto& r : o.rules) {
        held += r.verdict == "held" ? 1 : 0;
        rules.push_back(r.verdict);
      }
      const std::string shown = x.dump() + (x == q.value ? "*" : "") +
                                (o.rules.size() > 1 && o.verdict != "held"
                                     ? fmt::format(" ({}/{} rules held)", held, o.rules.size())
                                     : "");
      verdicts[x.dump()] = o.verdict;
      rule_verdicts[x.dump()] = rules;
      if (!runs.empty() && runs.back().first == o.verdict) {
        runs.back().second += ", " + shown;
      } else {
        runs.emplace_back(o.verdict, shown);
      }
    }
    std::string line;
    for (const auto& [v, xs] : runs)
      line += fmt::format("{}{} at {}", line.empty() ? "" : "; ", v, xs);
    text += fmt::format("{}{} {} ({}): {}", text.empty() ? "" : " | ", q.variant, q.key, q.source,
                        line);
    params.push_back({{"variant", q.variant},
                      {"key", q.key},
                      {"source", q.source},
                      {"value", q.value},
                      {"verdicts", verdicts},
                      {"rule_verdicts", rule_verdicts}});
  }
  if (params.empty()) text = "no parameter ranges declared";
  return {{"text", text + (params.empty() ? ""
                                          : " (* the protocol's value; one parameter "
                                            "varied at a time)")},
          {"params", params}};
}

Json RuleOutcome::to_json(const ClaimRule& r) const {
  return {{"what", r.what},   {"quantity", r.quantity}, {"verdict", verdict},
          {"reason", reason}, {"measured", measured},   {"groups", groups}};
}

Json claim_result_json(const Claim& claim, const ClaimOutcome& outcome) {
  Json j = {{"id", claim.id},       {"claim", claim.claim},       {"source", claim.source},
            {"paper", claim.paper}, {"verdict", outcome.verdict}, {"reason", outcome.reason}};
  if (!claim.notes.empty()) j["notes"] = claim.notes;
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
                     md_cell(protocol_summary(c.value("protocol", Json::object()))),
                     md_cell(c.value("measured", "")), md_cell(c.value("verdict", "")),
                     md_cell(c.value("reason", "")),
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
        html_escape(c.value("paper", "")),
        html_escape(protocol_summary(c.value("protocol", Json::object()))),
        html_escape(c.value("measured", "")), v == "failed" ? "fail" : (v == "held" ? "best" : ""),
        html_escape(v), html_escape(c.value("reason", "")),
        html_escape(c.value("sensitivity", Json::object()).value("text", "")));
  }
  h += "</table>\n";
  return h;
}

std::vector<std::string> claim_regressions(const Json& baseline, const Json& current) {
  std::map<std::string, std::string> base;
  for (const auto& c : baseline.value("claims", Json::array()))
    base[c.value("id", std::string())] = c.value("verdict", std::string());
  std::vector<std::string> out;
  for (const auto& c : current.value("claims", Json::array())) {
    const std::string id = c.value("id", std::string());
    const auto it = base.find(id);
    if (it != base.end() && it->second == "held" && c.value("verdict", std::string()) == "failed") {
      out.push_back(id);
    }
  }
  return out;
}

}  // namespace scanbench::harness
