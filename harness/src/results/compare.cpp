#include "scanbench/harness/results/compare.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "config/json_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/config/compare_options.h"
#include "scanbench/harness/results/records.h"
#include "scanbench/harness/results/stats.h"
#include "scanbench/harness/results/table.h"
#include "scanbench/metrics/registry.h"

namespace scanbench::harness {

namespace {

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
