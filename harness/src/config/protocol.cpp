#include "scanbench/harness/config/protocol.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "config/json_checks.h"
#include "config/protocol_values.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/config/experiment.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

using detail::protocol_same_value;
using detail::ranged_params;

[[noreturn]] void protocol_fail(const std::string& where, const std::string& what) {
  throw ParamError(fmt::format("{}: {}", where, what));
}

std::string protocol_text(const Json& j, const std::string& key, const std::string& where) {
  if (!j.contains(key) || !j[key].is_string() || j[key].get<std::string>().empty()) {
    protocol_fail(where + "/" + key, "expected a non-empty string");
  }
  return j[key].get<std::string>();
}

std::string protocol_choice(const Json& j, const std::string& key, const std::string& where,
                            const std::vector<std::string>& choices, const std::string& def) {
  if (!j.contains(key)) return def;
  const std::string v = j[key].is_string() ? j[key].get<std::string>() : j[key].dump();
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) {
    std::string list;
    for (const auto& c : choices)
      list += (list.empty() ? "" : ", ") + c;
    protocol_fail(where + "/" + key, fmt::format("expected one of {}, got '{}'", list, v));
  }
  return v;
}

ProtocolObjective parse_protocol_objective(const Json& j, const std::string& where) {
  harness::check_keys(j, where, {"quantity", "direction", "stat"});
  ProtocolObjective o;
  o.quantity = protocol_text(j, "quantity", where);
  o.direction = protocol_choice(j, "direction", where, {"min", "max"}, "min");
  o.stat = protocol_choice(j, "stat", where, {"median", "mean", "min", "max"}, "median");
  return o;
}

std::vector<Json> protocol_values(const Json& j, const std::string& where) {
  if (!j.is_array() || j.empty()) protocol_fail(where, "expected a non-empty list of values");
  std::vector<Json> out(j.begin(), j.end());
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t k = 0; k < i; ++k)
      if (out[i] == out[k]) protocol_fail(fmt::format("{}/{}", where, i), "value listed twice");
  return out;
}

ProtocolParam parse_protocol_param(const Json& j, const std::string& variant,
                                   const std::string& key, const std::string& where,
                                   const Protocol& p, bool has_objective,
                                   const ProtocolObjective& objective) {
  harness::check_keys(j, where,
                      {"source", "value", "cite", "rule", "range", "sensitivity", "objective",
                       "multiples", "extend_limit"});
  ProtocolParam q;
  q.variant = variant;
  q.key = key;
  const auto dot = key.rfind('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == key.size()) {
    protocol_fail(where, "expected a key \"<step>.<param>\" (a sweep key of the variant)");
  }
  q.step = key.substr(0, dot);
  q.param = key.substr(dot + 1);
  if (!j.contains("source")) protocol_fail(where + "/source", "missing (paper, rule or tuned)");
  q.source = protocol_choice(j, "source", where, {"paper", "rule", "tuned"}, "");
  auto only = [&](const char* field, bool allowed) {
    if (j.contains(field) && !allowed) {
      protocol_fail(where + "/" + field, fmt::format("not used with source \"{}\"", q.source));
    }
  };
  only("cite", q.source == "paper");
  only("rule", q.source != "paper");
  only("value", q.source != "tuned");
  only("sensitivity", q.source != "tuned");
  only("range", q.source == "tuned");
  only("objective", q.source == "tuned");
  if (q.source == "tuned") {
    if (j.contains("rule")) {
      q.range_rule = protocol_choice(j, "rule", where, {"h0_multiples"}, "");
      if (j.contains("range"))
        protocol_fail(where + "/range", "not used with \"rule\" (the rule gives the range)");
      if (!j.contains("multiples"))
        protocol_fail(where + "/multiples", "missing (the multiples of h0 to tune over)");
      const Json& m = j["multiples"];
      if (!m.is_array() || m.size() < 2)
        protocol_fail(where + "/multiples", "expected at least two multiples of h0");
      for (std::size_t i = 0; i < m.size(); ++i) {
        if (!m[i].is_number() || !(m[i].get<double>() > 0) || !std::isfinite(m[i].get<double>()) ||
            (i > 0 && !(m[i].get<double>() > m[i - 1].get<double>()))) {
          protocol_fail(fmt::format("{}/multiples/{}", where, i),
                        "expected positive multiples in ascending order");
        }
        q.multiples.push_back(m[i].get<double>());
      }
      if (j.contains("extend_limit")) {
        const Json& l = j["extend_limit"];
        if (!l.is_number() || !(l.get<double>() >= 1.0) || !std::isfinite(l.get<double>()))
          protocol_fail(where + "/extend_limit", "expected a number >= 1");
        q.extend_limit = l.get<double>();
      }
    } else {
      if (j.contains("multiples"))
        protocol_fail(where + "/multiples", "used only with \"rule\": \"h0_multiples\"");
      if (j.contains("extend_limit")) {
        const Json& l = j["extend_limit"];
        if (!l.is_number() || !(l.get<double>() >= 1.0) || !std::isfinite(l.get<double>()))
          protocol_fail(where + "/extend_limit", "expected a number >= 1");
        q.extend_limit = l.get<double>();
      }
      if (!j.contains("range")) {
        protocol_fail(where + "/range", "missing (the values to tune over, or a \"rule\")");
      }
      q.range = protocol_values(j["range"], where + "/range");
      if (q.range.size() < 2)
        protocol_fail(where + "/range", "expected at least two values to tune over");
    }
    if (j.contains("objective")) {
      q.objective = parse_protocol_objective(j["objective"], where + "/objective");
    } else if (has_objective) {
      q.objective = objective;
    } else {
      protocol_fail(where + "/objective",
                    "missing (and the protocol has no default \"objective\")");
    }
    if (p.tuning.empty())
      protocol_fail(p.where + "/tuning", "missing (the data tuned parameters use)");
    return q;
  }
  for (const char* f : {"multiples", "extend_limit"})
    if (j.contains(f)) protocol_fail(where + "/" + f, "not used with source \"" + q.source + "\"");
  q.cite = protocol_text(j, q.source == "paper" ? "cite" : "rule", where);
  if (!j.contains("value")) protocol_fail(where + "/value", "missing");
  q.value = j["value"];
  if (j.contains("sensitivity"))
    q.range = protocol_values(j["sensitivity"], where + "/sensitivity");
  return q;
}

/// A variant object's label as parse_experiment derives it.
std::string protocol_variant_label(const Json& v) {
  std::string l = v.value("label", std::string());
  if (l.empty() && v.contains("algorithm") && v["algorithm"].is_string()) {
    l = v["algorithm"].get<std::string>();
  }
  if (l.empty() && v.contains("chain") && v["chain"].is_array()) {
    for (const auto& s : v["chain"])
      l += (l.empty() ? "" : "+") + s.value("label", s.value("algorithm", std::string()));
  }
  return l;
}

/// The variant object of `config` labelled `label` (labels as parse_experiment derives them).
Json* protocol_find_variant(Json& config, const std::string& label) {
  if (!config.contains("variants") || !config["variants"].is_array()) return nullptr;
  for (auto& v : config["variants"])
    if (protocol_variant_label(v) == label) return &v;
  return nullptr;
}

/// Calls `fn(scanner, where)` for every scanner entry that scans in a config's (or a tuning
/// block's) "scanners" and "datasets[i].scanners" lists; a string entry is first made the object
/// {"preset": name}, which parse_scanner reads the same (label = the preset).
template <class Fn>
void for_each_scanning_scanner(Json& c, const std::string& where, Fn&& fn) {
  auto list = [&](Json& scanners, const std::string& w) {
    if (!scanners.is_array()) return;
    for (std::size_t i = 0; i < scanners.size(); ++i) {
      Json& sc = scanners[i];
      const std::string preset = sc.is_string() ? sc.get<std::string>() : sc.value("preset", "");
      if (preset.empty() || preset == kGroundTruthInput) continue;
      if (sc.is_string()) sc = Json{{"preset", preset}};
      fn(sc, fmt::format("{}/{}", w, i));
    }
  };
  if (c.contains("scanners")) list(c["scanners"], where + "/scanners");
  if (c.contains("datasets") && c["datasets"].is_array())
    for (std::size_t i = 0; i < c["datasets"].size(); ++i) {
      Json& d = c["datasets"][i];
      if (d.is_object() && d.contains("scanners"))
        list(d["scanners"], fmt::format("{}/datasets/{}/scanners", where, i));
    }
}

/// Sets the protocol's scanner values in every scanning scanner of `c` (a config or the tuning
/// data).
void set_scanner_values(Json& c, const Protocol& p) {
  if (p.scanner.empty()) return;
  for_each_scanning_scanner(c, "", [&](Json& sc, const std::string&) {
    for (const auto& q : p.scanner)
      sc["params"][q.param] = q.value;
  });
}

/// The params object of the step `step` of a variant object (one-step or chain form).
Json* protocol_step_params(Json& variant, const std::string& step) {
  if (variant.contains("algorithm")) {
    if (variant["algorithm"] != step) return nullptr;
    if (!variant.contains("params")) variant["params"] = Json::object();
    return &variant["params"];
  }
  for (auto& s : variant["chain"]) {
    if (s.value("label", s.value("algorithm", std::string())) != step) continue;
    if (!s.contains("params")) s["params"] = Json::object();
    return &s["params"];
  }
  return nullptr;
}

/// The sweep objects of a variant (its "sweep" as a list; empty when it has none).
std::vector<Json> protocol_variant_sweeps(const Json& variant) {
  if (!variant.contains("sweep")) return {};
  if (variant["sweep"].is_array()) return {variant["sweep"].begin(), variant["sweep"].end()};
  return {variant["sweep"]};
}

/// Sets every protocol value of `p` in the config's steps (tuned, not yet chosen: the first value
/// of the range, for validation) and drops "protocol".
Json protocol_with_values(const Json& config, const Protocol& p) {
  Json c = config;
  c.erase("protocol");
  for (const auto& q : p.params) {
    Json* v = protocol_find_variant(c, q.variant);
    Json* params = v ? protocol_step_params(*v, q.step) : nullptr;
    if (params == nullptr) continue;  // check_protocol reports it
    // An h0_multiples range is known only when the tuning runs: the step's default stands in.
    if (q.value.is_null() && q.range.empty()) continue;
    (*params)[q.param] = q.value.is_null() && !q.range.empty() ? q.range.front() : q.value;
  }
  set_scanner_values(c, p);
  return c;
}

using ProtocolDataKey =
    std::tuple<std::string, std::string, std::string, std::string, std::uint64_t>;

std::set<ProtocolDataKey> protocol_data_keys(const Plan& plan) {
  std::set<ProtocolDataKey> keys;
  for (const auto& j : plan.jobs)
    keys.emplace(j.dataset, j.dataset_params.dump(), j.scanner_preset, j.scanner_params.dump(),
                 j.seed);
  return keys;
}

/// One step of a variant as compared by check_fair_chains: everything that decides what it does.
struct ChainStepView {
  std::string label;
  Json what;  ///< {"algorithm", "params", "sweep", "protocol"}
};

/// The steps of a variant object, each with its params, the variant's sweep values of that step
/// and the protocol entries of that step (from config["protocol"]["variants"][label]).
std::vector<ChainStepView> chain_steps(const Json& config, const Json& variant,
                                       const std::string& label) {
  std::vector<Json> steps;
  if (variant.contains("chain") && variant["chain"].is_array()) {
    steps.assign(variant["chain"].begin(), variant["chain"].end());
  } else {
    steps.push_back({{"algorithm", variant.value("algorithm", std::string())},
                     {"params", variant.value("params", Json::object())}});
  }
  const Json entries =
      config.contains("protocol") && config["protocol"].is_object()
          ? config["protocol"].value("variants", Json::object()).value(label, Json::object())
          : Json::object();
  std::vector<ChainStepView> out;
  for (const auto& st : steps) {
    ChainStepView v;
    v.label = st.value("label", st.value("algorithm", std::string()));
    const std::string prefix = v.label + ".";
    Json sweep = Json::object(), protocol = Json::object();
    for (const auto& sw : protocol_variant_sweeps(variant))
      for (const auto& [k, x] : sw.items())
        if (k.rfind(prefix, 0) == 0 && k.find('.', prefix.size()) == std::string::npos)
          sweep[k].push_back(x);
    for (const auto& [k, x] : entries.items())
      if (k.rfind(prefix, 0) == 0 && k.find('.', prefix.size()) == std::string::npos)
        protocol[k] = x;
    v.what = {{"algorithm", st.value("algorithm", std::string())},
              {"params", st.value("params", Json::object())},
              {"sweep", sweep},
              {"protocol", protocol}};
    out.push_back(std::move(v));
  }
  return out;
}

/// What differs between two steps, in a few words ("" when nothing).
std::string chain_step_difference(const ChainStepView& a, const ChainStepView& b) {
  if (a.label != b.label || a.what["algorithm"] != b.what["algorithm"]) {
    return fmt::format("'{}' vs '{}'", a.label, b.label);
  }
  for (const char* part : {"params", "sweep", "protocol"})
    if (a.what[part] != b.what[part]) {
      return fmt::format("'{}' with {} {} vs {}", a.label, part, a.what[part].dump(),
                         b.what[part].dump());
    }
  return "";
}

}  // namespace

namespace detail {

bool protocol_same_value(const Json& a, const Json& b) {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    return std::abs(x - y) <= 1e-9 * std::max(1.0, std::abs(y));
  }
  return a == b;
}

/// The protocol's ranged parameters of one variant, in the order their sensitivity sweeps are
/// built: its step parameters with a range (in declaration order), then the scanner entries with
/// sensitivity values (every variant's).
std::vector<const ProtocolParam*> ranged_params(const Protocol& p, const std::string& variant) {
  std::vector<const ProtocolParam*> out;
  for (const auto& q : p.params)
    if (q.variant == variant && !q.range.empty()) out.push_back(&q);
  for (const auto& q : p.scanner)
    if (!q.range.empty()) out.push_back(&q);
  return out;
}

}  // namespace detail

Json ProtocolObjective::to_json() const {
  return {{"quantity", quantity}, {"direction", direction}, {"stat", stat}};
}

std::vector<const ProtocolParam*> Protocol::tuned(const std::string& variant) const {
  std::vector<const ProtocolParam*> out;
  for (const auto& q : params)
    if (q.variant == variant && q.source == "tuned") out.push_back(&q);
  return out;
}

Protocol parse_protocol(const Json& j, const std::string& where) {
  harness::check_keys(j, where, {"tuning", "objective", "variants", "chains", "scanner"});
  Protocol p;
  p.where = where;
  if (j.contains("chains")) p.chains = parse_chains(j["chains"], where + "/chains");
  if (j.contains("tuning")) {
    harness::check_keys(j["tuning"], where + "/tuning", {"datasets", "scanners", "seed", "seeds"});
    if (!j["tuning"].contains("datasets")) {
      protocol_fail(where + "/tuning/datasets", "missing (the tuning datasets)");
    }
    p.tuning = j["tuning"];
  }
  ProtocolObjective objective;
  const bool has_objective = j.contains("objective");
  if (has_objective) objective = parse_protocol_objective(j["objective"], where + "/objective");
  if (!j.contains("variants") || !j["variants"].is_object() || j["variants"].empty()) {
    protocol_fail(where + "/variants", "expected an object: variant label -> its parameters");
  }
  for (const auto& [label, params] : j["variants"].items()) {
    // The label names the tuning folder OUT/tuning-<label> (resolve_protocol): checked here too,
    // not only as a variant's label, for callers that parse a protocol on its own.
    check_label(label, where + "/variants");
    const std::string w = where + "/variants/" + label;
    if (!params.is_object() || params.empty()) {
      protocol_fail(w, "expected an object: \"<step>.<param>\" -> its source");
    }
    for (const auto& [key, entry] : params.items())
      p.params.push_back(
          parse_protocol_param(entry, label, key, w + "/" + key, p, has_objective, objective));
  }
  if (j.contains("scanner")) {
    const std::string w = where + "/scanner";
    if (!j["scanner"].is_object() || j["scanner"].empty())
      protocol_fail(w, "expected an object: \"<scanner param>\" -> its source");
    if (j["variants"].contains("scanner")) {
      protocol_fail(where + "/variants/scanner",
                    "a variant labelled 'scanner' collides with the protocol's scanner entries");
    }
    for (const auto& [param, entry] : j["scanner"].items()) {
      const std::string we = w + "/" + param;
      if (param.empty() || param.find('.') != std::string::npos)
        protocol_fail(we, "expected a scanner parameter's name");
      if (entry.is_object() && entry.value("source", Json()) == "tuned")
        protocol_fail(we + "/source", "a scanner reading is declared (paper or rule), never tuned");
      p.scanner.push_back(parse_protocol_param(entry, "", "scanner." + param, we, p, false, {}));
    }
  }
  return p;
}

void check_protocol(const Protocol& p, const Json& config) {
  Json c = config;
  // Scanner entries: one source per parameter (no scanner of the experiment or of the tuning data
  // sets it, no sweep varies it).
  for (const auto& q : p.scanner) {
    const std::string w = p.where + "/scanner/" + q.param;
    Json tuning = p.tuning;
    for (auto [data, name] : {std::pair<Json*, const char*>{&c, ""}, {&tuning, "/protocol/tuning"}})
      for_each_scanning_scanner(*data, name, [&](Json& sc, const std::string& at) {
        if (sc.contains("params") && sc["params"].is_object() && sc["params"].contains(q.param))
          protocol_fail(w, fmt::format("also set in the params of the scanner at {} (give each "
                                       "parameter one source)",
                                       at));
      });
    std::vector<Json> sweeps = protocol_variant_sweeps(c);
    if (c.contains("variants") && c["variants"].is_array())
      for (const auto& v : c["variants"])
        for (const auto& s : protocol_variant_sweeps(v))
          sweeps.push_back(s);
    for (const auto& s : sweeps)
      if (s.is_object() && s.contains(q.key))
        protocol_fail(w, fmt::format("also swept ({}; give each parameter one source)", q.key));
  }
  for (const auto& q : p.params) {
    const std::string w = p.where + "/variants/" + q.variant;
    Json* v = protocol_find_variant(c, q.variant);
    if (v == nullptr) protocol_fail(w, "no variant labelled '" + q.variant + "'");
    Json* params = protocol_step_params(*v, q.step);
    if (params == nullptr)
      protocol_fail(w + "/" + q.key, "the variant has no step '" + q.step + "'");
    if (params->contains(q.param)) {
      protocol_fail(w + "/" + q.key,
                    "also set in the step's params (give each parameter one source)");
    }
    for (const auto& s : protocol_variant_sweeps(*v))
      if (s.is_object() && s.contains(q.key)) {
        protocol_fail(w + "/" + q.key,
                      "also swept by the variant (give each parameter one source)");
      }
  }
  if (!p.chains.empty()) {
    std::vector<std::string> labels;
    for (const auto& q : p.params)
      if (std::find(labels.begin(), labels.end(), q.variant) == labels.end())
        labels.push_back(q.variant);
    std::vector<std::pair<std::string, std::string>> pairs;
    for (std::size_t i = 0; i < labels.size(); ++i)
      for (std::size_t k = i + 1; k < labels.size(); ++k)
        pairs.emplace_back(labels[i], labels[k]);
    check_fair_chains(config, p.chains, pairs, p.where + "/chains");
  }
  // Every value and range value must be accepted by the parameter's declaration: the config with
  // the values set and swept over the ranges must load.
  const Json swept = protocol_config(config, p, true);
  // (expand checks the sweep values against the declarations.)
  std::set<ProtocolDataKey> verdict;
  bool any_tuned = false;
  for (const auto& q : p.params)
    any_tuned = any_tuned || q.source == "tuned";
  try {
    const Plan plan = expand(parse_experiment(swept, "the config at the protocol's values"));
    if (any_tuned) verdict = protocol_data_keys(plan);
  } catch (const ParamError& err) {
    protocol_fail(p.where, fmt::format("a protocol value is not accepted: {}", err.what()));
  }
  for (const auto& q : p.params) {
    if (q.source != "tuned" || q.key != p.tuned(q.variant).front()->key) continue;
    const Experiment t = parse_experiment(tuning_config(config, p, q.variant), p.where + "/tuning");
    for (const auto& k : protocol_data_keys(expand(t)))
      if (verdict.count(k)) {
        protocol_fail(
            p.where + "/tuning",
            fmt::format("the tuning data overlap the experiment's data (dataset {}, scanner {}, "
                        "seed {}): tune on another shape or another seed and noise draw",
                        std::get<0>(k), std::get<2>(k), std::get<4>(k)));
      }
  }
}

Json tuning_config(const Json& config, const Protocol& p, const std::string& variant) {
  Json c = protocol_with_values(config, p);
  Json* v = protocol_find_variant(c, variant);
  if (v == nullptr) protocol_fail(p.where + "/variants/" + variant, "no such variant");
  Json tv = *v;
  tv.erase("sweep");  // the variant's own swept parameters stay at their base values
  Json sweep = Json::object();
  for (const ProtocolParam* q : p.tuned(variant))
    if (!q->range.empty()) sweep[q->key] = q->range;  // empty: an h0 rule not yet resolved
  if (!sweep.empty()) tv["sweep"] = sweep;
  c["variants"] = Json::array({tv});
  c["datasets"] = p.tuning["datasets"];
  if (p.tuning.contains("scanners")) c["scanners"] = p.tuning["scanners"];
  set_scanner_values(c, p);  // the tuning data are made the same way
  for (const char* k : {"seed", "seeds"})
    if (p.tuning.contains(k)) {
      c.erase("seed");
      c.erase("seeds");
      c[k] = p.tuning[k];
    }
  c.erase("sweep");  // global scanner/dataset sweeps belong to the experiment's data
  c["repeats"] = 1;
  c["name"] = c.value("name", std::string("experiment")) + "-tuning-" + variant;
  return c;
}

Json ChainDeclaration::to_json() const {
  Json j = Json::object();
  for (const auto& [v, steps] : methods)
    j["methods"][v] = steps;
  for (const auto& [v, reason] : differs)
    j["downstream_differs"][v] = {{"reason", reason}};
  return j;
}

ChainDeclaration parse_chains(const Json& j, const std::string& where) {
  harness::check_keys(j, where, {"methods", "downstream_differs"});
  ChainDeclaration d;
  if (j.contains("methods")) {
    const std::string w = where + "/methods";
    if (!j["methods"].is_object()) protocol_fail(w, "expected an object: variant -> its steps");
    for (const auto& [label, steps] : j["methods"].items()) {
      if (!steps.is_array() || steps.empty())
        protocol_fail(w + "/" + label, "expected a non-empty list of step labels");
      for (const auto& st : steps) {
        if (!st.is_string() || st.get<std::string>().empty())
          protocol_fail(w + "/" + label, "expected a non-empty list of step labels");
        d.methods[label].push_back(st.get<std::string>());
      }
    }
  }
  if (j.contains("downstream_differs")) {
    const std::string w = where + "/downstream_differs";
    if (!j["downstream_differs"].is_object())
      protocol_fail(w, "expected an object: variant -> {\"reason\": ...}");
    for (const auto& [label, e] : j["downstream_differs"].items()) {
      harness::check_keys(e, w + "/" + label, {"reason"});
      d.differs[label] = protocol_text(e, "reason", w + "/" + label);
    }
  }
  return d;
}

void check_fair_chains(const Json& config, const ChainDeclaration& d,
                       const std::vector<std::pair<std::string, std::string>>& compared,
                       const std::string& where) {
  Json c = config;
  for (const auto& [label, reason] : d.differs)
    if (protocol_find_variant(c, label) == nullptr)
      protocol_fail(where + "/downstream_differs/" + label, "no variant labelled '" + label + "'");
  // Each variant: its steps split at its method (upstream, method, downstream).
  struct Split {
    std::vector<ChainStepView> up, down;
  };
  auto split = [&](const std::string& label) {
    Json* v = protocol_find_variant(c, label);
    if (v == nullptr) protocol_fail(where, "no variant labelled '" + label + "'");
    const std::vector<ChainStepView> steps = chain_steps(config, *v, label);
    const auto m = d.methods.find(label);
    const std::string w = where + "/methods/" + label;
    if (m == d.methods.end()) {
      if (steps.size() == 1) return Split{};  // a one-step variant is its own method
      protocol_fail(
          w, "missing: variant '" + label + "' is a chain that is compared; name its method steps");
    }
    std::size_t first = steps.size();
    for (std::size_t i = 0; i < steps.size() && first == steps.size(); ++i)
      if (steps[i].label == m->second.front()) first = i;
    for (std::size_t k = 0; k < m->second.size(); ++k)
      if (first + k >= steps.size() || steps[first + k].label != m->second[k]) {
        protocol_fail(w, fmt::format("'{}' is not the next step of variant '{}' (the method steps "
                                     "must be consecutive steps of its chain)",
                                     m->second[k], label));
      }
    Split s;
    s.up.assign(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(first));
    s.down.assign(steps.begin() + static_cast<std::ptrdiff_t>(first + m->second.size()),
                  steps.end());
    return s;
  };
  for (const auto& [label, steps] : d.methods)
    split(label);
  for (const auto& [a, b] : compared) {
    if (a.empty() || b.empty() || a == b) continue;
    if (d.differs.count(a) || d.differs.count(b)) continue;
    const Split sa = split(a), sb = split(b);
    for (const auto& [part, la, lb] :
         {std::tuple{"upstream", &sa.up, &sb.up}, std::tuple{"downstream", &sa.down, &sb.down}}) {
      const std::size_t n = std::max(la->size(), lb->size());
      for (std::size_t i = 0; i < n; ++i) {
        std::string diff;
        if (i >= la->size() || i >= lb->size()) {
          diff = fmt::format("'{}' vs none", i < la->size() ? (*la)[i].label : (*lb)[i].label);
          if (i >= la->size()) diff = fmt::format("none vs '{}'", (*lb)[i].label);
        } else {
          diff = chain_step_difference((*la)[i], (*lb)[i]);
        }
        if (diff.empty()) continue;
        protocol_fail(where, fmt::format("variants '{}' and '{}' differ outside their methods: {} "
                                         "step {} ({}); make the chains equal there or declare "
                                         "the difference (downstream_differs with a reason)",
                                         a, b, part, i + 1, diff));
      }
    }
  }
}

std::string chains_summary(const Json& chains) {
  std::string s;
  const Json differs = chains.value("downstream_differs", Json::object());
  for (const auto& [label, e] : differs.items())
    s += fmt::format("{}{}: chain differs outside its method ({})", s.empty() ? "" : "; ", label,
                     e.value("reason", std::string()));
  return s;
}

const std::vector<KernelConvention>& kernel_conventions() {
  static const double kStd = 1.0 / (4.0 * std::sqrt(2.0));  // exp(-16 r^2/h^2) = N(0, h/4/sqrt 2)
  static const std::vector<KernelConvention> table = {
      {"resample.lop", "h", 1.0, kStd},      {"resample.wlop", "h", 1.0, kStd},
      {"resample.clop", "h", 1.0, kStd},     {"normals.csw", "h", 1.0, kStd},
      {"filter.gpf", "h", 0.25, kStd},       {"peer.cgal_wlop", "h", 0.5, kStd},
      {"normals.bilateral", "h", 1.0, kStd},
  };
  return table;
}

double radius_param(const std::string& algorithm, double radius, const std::string& same) {
  for (const auto& k : kernel_conventions()) {
    if (k.algorithm != algorithm) continue;
    if (same == "support") return radius / k.support;
    if (same == "std") return radius / k.kernel_std;
    throw ParamError(fmt::format("radius_param: expected \"support\" or \"std\", got '{}'", same));
  }
  throw ParamError(
      fmt::format("radius_param: '{}' has no radius parameter in the kernel table", algorithm));
}

std::string Protocol::inconclusive() const {
  std::string s;
  for (const auto& q : params)
    if (q.boundary.value("status", std::string()) == "inconclusive")
      s += (s.empty() ? "" : "; ") + q.variant + " " + q.boundary.value("text", std::string());
  return s;
}

Json protocol_config(const Json& config, const Protocol& p, bool sweep_ranges) {
  Json c = protocol_with_values(config, p);
  if (!sweep_ranges) return c;
  if (!c.contains("variants") || !c["variants"].is_array()) return c;
  for (Json& vj : c["variants"]) {
    const std::vector<const ProtocolParam*> qs = ranged_params(p, protocol_variant_label(vj));
    if (qs.empty()) continue;
    Json* v = &vj;
    std::vector<Json> base = protocol_variant_sweeps(*v);
    if (base.empty()) base.push_back(Json::object());
    Json sweeps = Json::array();
    // One parameter at a time, the others at their value; the point at every value is run
    // once, in the sweep of the variant's first ranged parameter.
    for (const ProtocolParam* q : qs) {
      // Not yet tuned (validation): the first value of the range stands in.
      const Json& value = q->value.is_null() ? q->range.front() : q->value;
      std::vector<Json> values;
      if (q == qs.front()) values.push_back(value);
      for (const Json& x : q->range)
        if (!protocol_same_value(x, value)) values.push_back(x);
      if (values.empty()) continue;
      for (Json s : base) {
        s[q->key] = values;
        sweeps.push_back(s);
      }
    }
    (*v)["sweep"] = sweeps;
  }
  return c;
}

Json protocol_json(const Protocol& p) {
  Json j = Json::object();
  for (const auto& q : p.params) {
    Json e = {{"source", q.source}, {"value", q.value}};
    if (q.source == "paper") e["cite"] = q.cite;
    if (q.source == "rule") e["rule"] = q.cite;
    if (q.source == "tuned") {
      e["range"] = q.range;
      e["tuning_data"] = p.tuning;
      e["objective"] = q.objective.to_json();
      e["tuning_curve"] = q.tuning_curve;
      if (!q.range_rule.empty()) {
        e["rule"] = q.range_rule;
        e["multiples"] = q.multiples;
        e["extend_limit"] = q.extend_limit;
        e["scan_points"] = q.scan_points;
        e["h0"] = q.h0;
      }
      if (!q.declared_range.empty()) e["declared_range"] = q.declared_range;
      if (!q.boundary.empty()) e["boundary"] = q.boundary;
    } else if (!q.range.empty()) {
      e["sensitivity"] = q.range;
    }
    j[q.variant][q.key] = e;
  }
  for (const auto& q : p.scanner) {
    Json e = {{"source", q.source}, {"value", q.value}};
    e[q.source == "paper" ? "cite" : "rule"] = q.cite;
    if (!q.range.empty()) e["sensitivity"] = q.range;
    j["scanner"][q.key] = e;
  }
  return j;
}

std::string protocol_summary(const Json& protocol) {
  std::string s;
  for (const auto& [variant, params] : protocol.items()) {
    std::string v;
    for (const auto& [key, e] : params.items()) {
      const std::string src = e.value("source", std::string());
      std::string item = fmt::format("{} {} {}", key, src, e.value("value", Json()).dump());
      if (src == "tuned") {
        std::string data;
        for (const auto& d : e["tuning_data"].value("datasets", Json::array()))
          data += (data.empty() ? "" : "+") +
                  (d.is_object() ? d.value("label", d.value("name", std::string("?"))) : d.dump());
        const Json& t = e["tuning_data"];
        const std::string seed = t.contains("seed")    ? " seed " + t["seed"].dump()
                                 : t.contains("seeds") ? " seeds " + t["seeds"].dump()
                                                       : "";
        item += fmt::format(" ({} {} over {} on {}{})", e["objective"].value("direction", ""),
                            e["objective"].value("quantity", ""), e["range"].dump(), data, seed);
      } else {
        item += fmt::format(" ({})", e.value(src == "paper" ? "cite" : "rule", std::string()));
      }
      v += (v.empty() ? "" : ", ") + item;
    }
    s += fmt::format("{}{}: {}", s.empty() ? "" : "; ", variant, v);
  }
  return s;
}

}  // namespace scanbench::harness
