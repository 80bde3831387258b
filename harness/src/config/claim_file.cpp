// Claim files (claim_file.h): reading, validating against the experiment, selectors.
#include "scanbench/harness/config/claim_file.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <regex>
#include <set>

#include "config/json_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/json_text.h"
#include "scanbench/harness/config/experiment.h"

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

/// A finite number (with `positive`, a positive one); `def` when absent.
double get_number(const Json& j, const std::string& key, const std::string& where, double def,
                  bool positive = false) {
  if (!j.contains(key)) return def;
  if (!j[key].is_number() || !std::isfinite(j[key].get<double>()) ||
      (positive && j[key].get<double>() <= 0)) {
    fail(where + "/" + key, fmt::format("expected a {}finite number, got {}",
                                        positive ? "positive " : "", j[key].dump()));
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

/// The selector under `key` (ParamError "missing (a selector)" when absent).
ClaimSelector get_selector(const Json& j, const std::string& key, const std::string& where) {
  if (!j.contains(key)) fail(where + "/" + key, "missing (a selector)");
  return parse_selector(j[key], where + "/" + key);
}

/// A rule of kind "front" or "matched" (claims.h).
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
  r.what = get_string(j, "what", where, true);
  r.quantity = get_string(j, "quantity", where, true);
  r.per = get_choice(j, "per", where, {"dataset", "all"}, "dataset");
  r.a = get_selector(j, "a", where);
  r.b = get_selector(j, "b", where);
  r.has_b = true;
  r.factor = get_number(j, "factor", where, 1.0, true);
  r.op = get_string(j, "op", where, false, is_front ? "<" : "<=");
  const std::vector<std::string> ops = is_front
                                           ? std::vector<std::string>{"<", "<="}
                                           : std::vector<std::string>{"<", "<=", ">", ">=", "=="};
  if (std::find(ops.begin(), ops.end(), r.op) == ops.end()) {
    fail(where + "/op", fmt::format("not used by kind {}: '{}'", r.kind, r.op));
  }
  if (is_front) {
    r.cost = get_string(j, "cost", where, true);
    r.cost_b = get_string(j, "cost_b", where, false, r.cost);
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
  r.match_quantity = get_string(m, "quantity", w, true);
  r.match_ref = get_string(m, "ref", w, false, r.match_quantity);
  r.match_lo = get_selector(m, "lo", w);
  r.match_hi = get_selector(m, "hi", w);
  r.lo_factor = get_number(m, "lo_factor", w, 1.0, true);
  r.hi_factor = get_number(m, "hi_factor", w, 1.0, true);
  return r;
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

}  // namespace

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
              "rules", "chains"});
  if (!j.contains("scanbench_claim") || !j["scanbench_claim"].is_number_integer() ||
      j["scanbench_claim"].get<int>() != kClaimVersion) {
    fail(w0 + "/scanbench_claim", fmt::format("expected claim format version {}", kClaimVersion));
  }
  Claim c;
  c.id = get_string(j, "id", w0, false, default_id);
  check_label(c.id, w0 + (j.contains("id") ? "/id" : "/"));  // DIR/<id>/ in `scanbench claims`
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
  if (j.contains("chains")) c.chains = parse_chains(j["chains"], w0 + "/chains");
  std::vector<std::pair<std::string, std::string>> compared;
  for (const auto& r : c.rules)
    if (r.has_b) compared.emplace_back(r.a.variant, r.b.variant);
  // Both experiments must load, every selector name a variant/dataset of each, and the compared
  // chains differ only in their methods.
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
    check_fair_chains(c.experiment_config(q), c.chains, compared,
                      where + (q ? " (quick)" : "") + ": /chains");
  }
  return c;
}

Claim load_claim(const fs::path& file) {
  JsonTextOptions options;
  options.ignore_comments = true;
  options.reject_duplicate_keys = true;
  const Json j = parse_json_file(file, "claim file", options);
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

}  // namespace scanbench::harness
