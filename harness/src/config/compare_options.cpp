#include "scanbench/harness/config/compare_options.h"

#include <fmt/format.h>

#include <cmath>
#include <string>

#include "config/json_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/metrics/registry.h"

namespace scanbench::harness {

namespace {

double get_num(const Json& j, const char* key, double def, const std::string& where, double lo,
               double hi) {
  if (!j.contains(key)) return def;
  const Json& v = j[key];
  if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < lo ||
      v.get<double>() > hi) {
    throw ParamError(
        fmt::format("{}/{}: expected a number in [{}, {}], got {}", where, key, lo, hi, v.dump()));
  }
  return v.get<double>();
}

Tolerance parse_tolerance(const Json& j, const std::string& where, Tolerance t) {
  check_keys(j, where, {"rel", "abs", "better"});
  t.rel = get_num(j, "rel", t.rel, where, 0, 1e9);
  t.abs = get_num(j, "abs", t.abs, where, 0, 1e300);
  if (j.contains("better")) {
    const std::string b = j["better"].is_string() ? j["better"].get<std::string>() : "";
    if (b == "lower") {
      t.better = -1;
    } else if (b == "higher") {
      t.better = 1;
    } else if (b == "none") {
      t.better = 0;
    } else {
      throw ParamError(fmt::format("{}/better: expected one of lower|higher|none, got {}", where,
                                   j["better"].dump()));
    }
  }
  return t;
}

}  // namespace

int quantity_direction(const std::string& q) {
  if (q.rfind("time.", 0) == 0 || q == "peak_rss_mb") return -1;
  if (q.rfind("sizes.", 0) == 0) return 0;
  const auto b = metrics::key_direction(q);
  if (!b) return 0;  // declared by no metric (e.g. a record of an older build): informational
  return *b == metrics::Better::Lower ? -1 : (*b == metrics::Better::Higher ? 1 : 0);
}

CompareOptions CompareOptions::from_json(const Json& j, const std::string& where) {
  CompareOptions o;
  if (j.is_null()) return o;
  check_keys(j, where,
             {"alpha", "time_threshold", "min_time_s", "timing", "default", "metrics", "ignore"});
  o.alpha = get_num(j, "alpha", o.alpha, where, 0, 1);
  o.time_threshold = get_num(j, "time_threshold", o.time_threshold, where, 0, 1e9);
  o.min_time_s = get_num(j, "min_time_s", o.min_time_s, where, 0, 1e9);
  if (j.contains("timing")) {
    if (!j["timing"].is_boolean()) throw ParamError(where + "/timing: expected a boolean");
    o.timing = j["timing"].get<bool>();
  }
  if (j.contains("default")) {
    o.default_tolerance = parse_tolerance(j["default"], where + "/default", o.default_tolerance);
  }
  if (j.contains("metrics")) {
    if (!j["metrics"].is_object()) throw ParamError(where + "/metrics: expected an object");
    for (const auto& [k, v] : j["metrics"].items()) {
      Tolerance t = o.default_tolerance;
      t.better = quantity_direction(k);
      o.metric_tolerances[k] = parse_tolerance(v, where + "/metrics/" + k, t);
    }
  }
  if (j.contains("ignore")) {
    const Json& ig = j["ignore"];
    if (!ig.is_array()) throw ParamError(where + "/ignore: expected a list of metric keys");
    for (const auto& x : ig) {
      if (!x.is_string()) throw ParamError(where + "/ignore: expected strings");
      o.ignore.push_back(x.get<std::string>());
    }
  }
  o.source = where;
  return o;
}

Tolerance CompareOptions::tolerance(const std::string& metric) const {
  auto it = metric_tolerances.find(metric);
  if (it != metric_tolerances.end()) return it->second;
  Tolerance t = default_tolerance;
  t.better = quantity_direction(metric);
  return t;
}

}  // namespace scanbench::harness
