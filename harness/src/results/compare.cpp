#include "scanbench/harness/compare.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "config/json_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/records.h"
#include "scanbench/harness/stats.h"
#include "scanbench/harness/table.h"
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

/// Unknown names refused where they are used: the config's per-metric tolerances and ignore list
/// (a key no metric declares and no record holds) and the quantities of --metric (one no record
/// holds).
void check_names(const CompareOptions& o, const std::vector<Json>& base,
                 const std::vector<Json>& now) {
  std::vector<Json> all = base;
  all.insert(all.end(), now.begin(), now.end());
  const std::vector<std::string> present = record_quantities(all);
  auto known = [&](const std::string& k) {
    return metrics::key_direction(k).has_value() ||
           std::find(present.begin(), present.end(), k) != present.end();
  };
  for (const auto& [k, t] : o.metric_tolerances) {
    if (!known(k)) {
      throw ParamError(fmt::format("{}/metrics/{}: unknown metric key{}", o.source, k,
                                   did_you_mean(k, present)));
    }
  }
  for (const auto& k : o.ignore) {
    if (!known(k)) {
      throw ParamError(fmt::format("{}/ignore: unknown metric key '{}'{}", o.source, k,
                                   did_you_mean(k, present)));
    }
  }
  for (const auto& q : o.only)
    if (!all.empty()) check_quantity(all, q, "compare: --metric");
}

std::string fmt_num(double v) {
  if (std::isnan(v)) return "-";
  return fmt::format("{:.4g}", v);
}

}  // namespace

void check_keys(const Json& j, const std::string& where,
                std::initializer_list<const char*> allowed) {
  if (!j.is_object()) {
    throw ParamError(fmt::format("{}: expected an object, got {}", where, j.type_name()));
  }
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    if (std::none_of(allowed.begin(), allowed.end(), [&](const char* a) { return key == a; })) {
      std::string list;
      for (const char* a : allowed)
        list += (list.empty() ? "" : ", ") + std::string(a);
      throw ParamError(fmt::format("{}/{}: unknown key (expected one of: {})", where, key, list));
    }
  }
}

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

Json Verdict::to_json() const {
  auto num = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  return {{"key", key},      {"quantity", quantity},  {"kind", kind}, {"base", num(base)},
          {"new", num(now)}, {"change", num(change)}, {"p", num(p)},  {"verdict", verdict},
          {"note", note},    {"notable", notable}};
}

Json CompareResult::to_json() const {
  Json j = Json::object();
  j["regressions"] = regressions;
  j["improvements"] = improvements;
  j["unchanged"] = unchanged;
  j["undecidable"] = undecidable;
  if (undecidable > 0) j["repeats_needed"] = repeats_needed;
  j["verdict"] = regressed() ? "regression" : "ok";
  j["isa"] = {{"base", base_isas}, {"new", new_isas}};
  j["notes"] = notes;
  Json a = Json::array();
  for (const auto& v : verdicts)
    a.push_back(v.to_json());
  j["comparisons"] = std::move(a);
  return j;
}

std::string CompareResult::table(bool all) const {
  std::string out;
  for (const auto& n : notes)
    out += "Note: " + n + "\n\n";
  out += "| job | quantity | base | new | change | p | verdict |\n";
  out += "|---|---|---:|---:|---:|---:|---|\n";
  int shown = 0;
  for (const auto& v : verdicts) {
    if (!all && v.verdict != "regression" && v.verdict != "improvement" && v.verdict != "new" &&
        !v.notable) {
      continue;
    }
    ++shown;
    const std::string base = v.kind == "status" ? v.note : fmt_num(v.base);
    out += fmt::format("| {} | {} | {} | {} | {} | {} | {} |\n", v.key, v.quantity, base,
                       v.kind == "status" ? "" : fmt_num(v.now),
                       v.kind == "status" ? "" : fmt::format("{:+.1f}%", 100 * v.change),
                       v.kind == "time" && std::isfinite(v.p) ? fmt::format("{:.3g}", v.p) : "",
                       v.verdict == "regression"      ? std::string("**REGRESSION**")
                       : v.verdict == "not decidable" ? v.verdict + ": " + v.note
                                                      : v.verdict);
  }
  if (shown == 0) out += "| (no significant changes) | | | | | | |\n";
  out += fmt::format("\n{} comparisons: {} regressions, {} improvements, {} unchanged",
                     verdicts.size(), regressions, improvements, unchanged);
  if (undecidable > 0) out += fmt::format(", {} timings not decidable", undecidable);
  out += fmt::format(" -> {}\n", regressed() ? "REGRESSION" : "OK");
  if (undecidable > 0) {
    out += fmt::format(
        "{} timing comparisons are not decidable: too few repeats for the U test to reach its "
        "threshold; {}\n",
        undecidable,
        repeats_needed > 0 ? fmt::format("it needs {} repeats per side (\"repeats\" in the config)",
                                         repeats_needed)
                           : std::string("no number of repeats reaches this alpha"));
  }
  return out;
}

CompareResult compare_records(const std::vector<Json>& base, const std::vector<Json>& now,
                              const CompareOptions& o) {
  check_names(o, base, now);
  CompareResult res;
  res.repeats_needed = mann_whitney_repeats_needed(o.alpha);
  const auto wanted = [&o](const std::string& q) {
    return o.only.empty() || std::find(o.only.begin(), o.only.end(), q) != o.only.end();
  };
  std::map<std::string, const Json*> new_by_key;
  for (const auto& r : now)
    new_by_key[r.value("key", std::string())] = &r;
  // The SIMD path of each side (scanbench/core/simd.h).
  const auto isas = [](const std::vector<Json>& records) {
    std::set<std::string> s;
    for (const auto& r : records) {
      const Json c = r.value("context", Json::object());
      s.insert(c.is_object() ? c.value("isa", std::string("unrecorded")) : "unrecorded");
    }
    return std::vector<std::string>(s.begin(), s.end());
  };
  res.base_isas = isas(base);
  res.new_isas = isas(now);
  if (!base.empty() && !now.empty() && res.base_isas != res.new_isas) {
    res.notes.push_back(fmt::format(
        "the baseline ran SIMD path {} and this run {}: accuracy is compared within the "
        "tolerances (packet widths differ only in float summation order); timings compare "
        "different code",
        fmt::join(res.base_isas, "+"), fmt::join(res.new_isas, "+")));
  }
  std::set<std::string> base_keys;
  auto add = [&](Verdict v) {
    if (v.verdict == "regression") {
      ++res.regressions;
    } else if (v.verdict == "improvement") {
      ++res.improvements;
    } else if (v.verdict == "not decidable") {
      ++res.undecidable;
    } else {
      ++res.unchanged;
    }
    res.verdicts.push_back(std::move(v));
  };
  for (const auto& b : base) {
    const std::string key = b.value("key", std::string());
    base_keys.insert(key);
    const std::string bstatus = b.value("status", std::string("?"));
    auto it = new_by_key.find(key);
    Verdict sv;
    sv.key = key;
    sv.quantity = "status";
    sv.kind = "status";
    if (it == new_by_key.end()) {
      sv.verdict = bstatus == "ok" ? "regression" : "same";
      sv.note = bstatus + " -> missing";
      add(sv);
      continue;
    }
    const Json& n = *it->second;
    const std::string nstatus = n.value("status", std::string("?"));
    sv.note = bstatus + " -> " + nstatus;
    if (bstatus == "ok" && nstatus != "ok") {
      sv.verdict = "regression";
      sv.note += ": " + n.value("error", std::string());
    } else if (bstatus != "ok" && nstatus == "ok") {
      sv.verdict = "improvement";
    } else {
      sv.verdict = "same";
    }
    add(sv);
    if (bstatus != "ok" || nstatus != "ok") continue;

    // Accuracy.
    const Json bm = b.value("metrics", Json::object());
    const Json nm = n.value("metrics", Json::object());
    for (const auto& [k, bv] : bm.items()) {
      if (!bv.is_number() || !nm.contains(k) || !nm[k].is_number()) continue;
      if (std::find(o.ignore.begin(), o.ignore.end(), k) != o.ignore.end()) continue;
      if (!wanted(k)) continue;
      const Tolerance t = o.tolerance(k);
      Verdict v;
      v.key = key;
      v.quantity = k;
      v.kind = "accuracy";
      v.base = bv.get<double>();
      v.now = nm[k].get<double>();
      v.change = v.base != 0 ? (v.now - v.base) / std::abs(v.base) : 0.0;
      const double diff = v.now - v.base;
      const bool nan_change = std::isnan(v.base) != std::isnan(v.now);
      const bool significant = nan_change || std::abs(diff) > t.abs + t.rel * std::abs(v.base);
      if (!significant) {
        v.verdict = "same";
      } else if (t.better == 0) {
        v.verdict = "changed";
      } else if (nan_change || diff * t.better < 0) {
        v.verdict = "regression";
        v.note = fmt::format("tolerance rel {} abs {}", t.rel, t.abs);
      } else {
        v.verdict = "improvement";
      }
      add(v);
    }

    // Timing.
    if (!o.timing) continue;
    std::vector<std::string> quantities{"time.total"};
    const Json bt = b.value("timing", Json::object());
    const Json bphases = bt.value("phases", Json::object());
    for (const auto& [phase, samples] : bphases.items())
      quantities.push_back("time." + phase);
    for (const auto& q : quantities) {
      if (!wanted(q)) continue;
      const std::vector<double> bs = record_samples(b, q);
      const std::vector<double> ns = record_samples(n, q);
      if (bs.empty() || ns.empty()) continue;
      Verdict v;
      v.key = key;
      v.quantity = q;
      v.kind = "time";
      v.base = median(bs);
      v.now = median(ns);
      v.change = v.base > 0 ? (v.now - v.base) / v.base : 0.0;
      const int n1 = static_cast<int>(bs.size()), n2 = static_cast<int>(ns.size());
      const double min_p = mann_whitney_min_p(n1, n2);
      if (!(min_p < o.alpha)) {
        // The test cannot reach alpha with these samples, whatever they are: no verdict.
        v.verdict = "not decidable";
        v.p = NAN;
        v.note = fmt::format(
            "not decidable with {}: the U test's smallest p is {:.3g}, not below alpha {}; {}",
            n1 == n2 ? fmt::format("{} {}", n1, n1 == 1 ? "repeat" : "repeats")
                     : fmt::format("{} and {} repeats", n1, n2),
            min_p, o.alpha,
            res.repeats_needed > 0 ? fmt::format("needs {} per side", res.repeats_needed)
                                   : std::string("no number of repeats reaches it"));
        v.notable =
            std::abs(v.change) > o.time_threshold && std::abs(v.now - v.base) > o.min_time_s;
        add(v);
        continue;
      }
      const MannWhitneyResult u = mann_whitney_u(bs, ns);
      v.p = u.p;
      const bool significant = u.p < o.alpha && std::abs(v.change) > o.time_threshold &&
                               std::abs(v.now - v.base) > o.min_time_s;
      v.verdict = !significant ? "same" : (v.change > 0 ? "regression" : "improvement");
      if (significant) {
        v.note = fmt::format("U test p={:.3g} < {}, change above {:.0f}%", u.p, o.alpha,
                             100 * o.time_threshold);
      }
      add(v);
    }
  }
  for (const auto& r : now) {
    const std::string key = r.value("key", std::string());
    if (base_keys.count(key)) continue;
    Verdict v;
    v.key = key;
    v.quantity = "status";
    v.kind = "status";
    v.verdict = "new";
    v.note = "new job (" + r.value("status", std::string("?")) + ")";
    add(v);
  }
  return res;
}

}  // namespace scanbench::harness
