#include "scanbench/harness/results/tuning.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>

#include "config/protocol_values.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

using detail::protocol_same_value;
using detail::ranged_params;

namespace {

std::string protocol_point_text(const Json& point) {
  std::string s;
  for (const auto& [k, v] : point.items())
    s += fmt::format("{}{}={}", s.empty() ? "" : " ", k, v.dump());
  return s;
}

/// One point of a tuning curve: the tuned keys' values and the objective statistic.
struct TuningPoint {
  Json key;
  double stat = 0;
};

bool protocol_same_point(const Json& a, const Json& b) {
  if (a.size() != b.size()) return false;
  for (const auto& [k, v] : b.items())
    if (!a.contains(k) || !protocol_same_value(a.at(k), v)) return false;
  return true;
}

/// The tuning curve: every point with a value, sorted by range order (ties: the first in range
/// order wins, so the order matters).
std::vector<TuningPoint> tuning_points(const std::vector<Json>& records,
                                       const std::vector<const ProtocolParam*>& tuned,
                                       const ProtocolObjective& objective) {
  std::vector<std::pair<Json, std::vector<double>>> points;  // in order of first appearance
  for (const auto& r : records) {
    if (r.value("status", std::string()) != "ok") continue;
    const double x = record_value(r, objective.quantity);
    if (std::isnan(x)) continue;
    const Json pt = r.value("point", Json::object());
    Json key = Json::object();
    for (const ProtocolParam* q : tuned)
      if (pt.contains(q->key)) key[q->key] = pt[q->key];
    auto it = std::find_if(points.begin(), points.end(),
                           [&](const auto& e) { return protocol_same_point(e.first, key); });
    if (it == points.end()) {
      points.emplace_back(key, std::vector<double>{});
      it = points.end() - 1;
    }
    it->second.push_back(x);
  }
  // Range order for ties: sort the points by their index in each range.
  auto rank = [&](const Json& key) {
    std::vector<std::size_t> idx;
    for (const ProtocolParam* q : tuned) {
      std::size_t i = 0;
      while (i < q->range.size() &&
             !(key.contains(q->key) && protocol_same_value(q->range[i], key[q->key])))
        ++i;
      idx.push_back(i);
    }
    return idx;
  };
  std::stable_sort(points.begin(), points.end(),
                   [&](const auto& a, const auto& b) { return rank(a.first) < rank(b.first); });
  std::vector<TuningPoint> out;
  for (const auto& [key, vals] : points) {
    std::vector<double> v = vals;
    double s = median(v);
    if (objective.stat == "mean") {
      s = 0;
      for (double x : vals)
        s += x / static_cast<double>(vals.size());
    } else if (objective.stat == "min") {
      s = *std::min_element(vals.begin(), vals.end());
    } else if (objective.stat == "max") {
      s = *std::max_element(vals.begin(), vals.end());
    }
    out.push_back({key, s});
  }
  return out;
}

/// A tuned parameter's chosen value against its range: on which boundary ("" inside, or a range
/// that is not all numbers), and whether the curve still falls there (the neighbour inside the
/// range is strictly worse, or has no value: a boundary is never taken as flat unseen).
struct BoundaryCheck {
  std::string side;
  bool falling = false;
  Json at;  ///< the boundary value
};

BoundaryCheck boundary_check(const ProtocolParam& q, const Json& best,
                             const std::vector<TuningPoint>& points,
                             const ProtocolObjective& objective) {
  BoundaryCheck c;
  if (!best.contains(q.key) || q.range.size() < 2) return c;
  std::vector<double> xs;
  for (const Json& x : q.range) {
    if (!x.is_number()) return c;
    xs.push_back(x.get<double>());
  }
  std::sort(xs.begin(), xs.end());
  const Json& v = best[q.key];
  double inner = 0;
  if (protocol_same_value(v, Json(xs.back()))) {
    c.side = "upper";
    inner = xs[xs.size() - 2];
  } else if (protocol_same_value(v, Json(xs.front()))) {
    c.side = "lower";
    inner = xs[1];
  } else {
    return c;
  }
  c.at = v;
  Json nb = best;
  nb[q.key] = inner;
  double best_v = 0;
  const TuningPoint* n = nullptr;
  for (const auto& pt : points) {
    if (protocol_same_point(pt.key, best)) best_v = pt.stat;
    if (protocol_same_point(pt.key, nb)) n = &pt;
  }
  c.falling = n == nullptr || (objective.direction == "min" ? n->stat > best_v : n->stat < best_v);
  return c;
}

/// 4 significant digits: h0 multiples as readable sweep values.
double protocol_round(double x) {
  return std::stod(fmt::format("{:.4g}", x));
}

/// The next multiples of an h0_multiples rule beyond `side`, within its limit.
std::vector<double> next_multiples(const ProtocolParam& q, const std::string& side,
                                   double declared_lo, double declared_hi) {
  std::vector<double> out;
  const std::vector<double>& m = q.multiples;
  const std::size_t n = m.size();
  if (side == "upper") {
    const double ratio = m[n - 1] / m[n - 2], limit = declared_hi * q.extend_limit * (1 + 1e-9);
    for (double x = m[n - 1] * ratio; x <= limit; x *= ratio)
      out.push_back(x);
  } else {
    const double ratio = m[0] / m[1], limit = declared_lo / q.extend_limit * (1 - 1e-9);
    for (double x = m[0] * ratio; x >= limit; x *= ratio)
      out.push_back(x);
  }
  return out;
}

/// The next values of a fixed numeric range beyond `side` (the ratio of its two values on that
/// side, as next_multiples), within `limit` times the declared top (the declared bottom divided by
/// it); when the first step already overshoots, the limit itself. All positive values are
/// required; a range of integers stays integers (rounded, values already in the range dropped).
/// Empty when the range is not all positive numbers.
/// A fixed range read as numbers: its values sorted, and whether all are integers; nullopt when
/// a value is not a positive number (such a range is neither extended nor checked at its ends).
struct NumericRange {
  std::vector<double> xs;
  bool integers = true;
  /// `x` as a value of this range: an integer, or 4 significant digits.
  Json value(double x) const {
    return integers ? Json(static_cast<long long>(std::llround(x))) : Json(protocol_round(x));
  }
};
std::optional<NumericRange> numeric_range(const std::vector<Json>& range) {
  NumericRange r;
  for (const Json& x : range) {
    if (!x.is_number() || !(x.get<double>() > 0)) return std::nullopt;
    r.integers = r.integers && x.is_number_integer();
    r.xs.push_back(x.get<double>());
  }
  std::sort(r.xs.begin(), r.xs.end());
  return r;
}

std::vector<Json> next_range_values(const ProtocolParam& q, const std::string& side) {
  const std::optional<NumericRange> nr = numeric_range(q.range);
  if (!nr) return {};
  const std::vector<double>& xs = nr->xs;
  std::vector<double> declared;
  for (const Json& x : q.declared_range)
    declared.push_back(x.get<double>());
  std::sort(declared.begin(), declared.end());
  const std::size_t n = xs.size();
  std::vector<double> raw;
  if (side == "upper") {
    const double ratio = xs[n - 1] / xs[n - 2], limit = declared.back() * q.extend_limit;
    for (double x = xs[n - 1] * ratio; x <= limit * (1 + 1e-9); x *= ratio)
      raw.push_back(x);
    if (raw.empty() && limit > xs[n - 1] * (1 + 1e-9)) raw.push_back(limit);
  } else {
    const double ratio = xs[0] / xs[1], limit = declared.front() / q.extend_limit;
    for (double x = xs[0] * ratio; x >= limit * (1 - 1e-9); x *= ratio)
      raw.push_back(x);
    if (raw.empty() && limit < xs[0] * (1 - 1e-9)) raw.push_back(limit);
  }
  std::vector<Json> out;
  for (double x : raw) {
    const Json v = nr->value(x);
    const bool known = std::any_of(q.range.begin(), q.range.end(),
                                   [&](const Json& r) { return protocol_same_value(r, v); }) ||
                       std::any_of(out.begin(), out.end(),
                                   [&](const Json& r) { return protocol_same_value(r, v); });
    if (!known) out.push_back(v);
  }
  return out;
}

/// Whether a fixed range's boundary value `b.at` is the end of the parameter's own domain: the next
/// value beyond it by the range's ratio rounds back to it (integers) or is not `accepted`.
template <class Accepted>
bool at_domain_edge(const ProtocolParam& q, const BoundaryCheck& b, Accepted&& accepted) {
  const std::optional<NumericRange> nr = numeric_range(q.range);
  if (!nr) return false;
  const std::vector<double>& xs = nr->xs;
  const std::size_t n = xs.size();
  const double x = b.side == "upper" ? xs[n - 1] * xs[n - 1] / xs[n - 2] : xs[0] * xs[0] / xs[1];
  const Json v = nr->value(x);
  return protocol_same_value(v, b.at) || !accepted(v);
}

/// The median point count of the tuning scans (sizes.scan_points of the probe's records).
double tuning_scan_points(const std::vector<Json>& records) {
  std::vector<double> n;
  for (const auto& r : records) {
    const Json sizes = r.value("sizes", Json::object());
    if (sizes.contains("scan_points") && sizes["scan_points"].is_number())
      n.push_back(sizes["scan_points"].get<double>());
  }
  if (n.empty()) {
    throw Error(
        "tuning: the h0_multiples rule needs the tuning scans' point counts, and no tuning scan "
        "has one (sizes.scan_points; the tuning data must be point scans)");
  }
  return median(n);
}

}  // namespace

Json choose_point(const std::vector<Json>& records, const std::vector<const ProtocolParam*>& tuned,
                  const ProtocolObjective& objective, Json& curve) {
  curve = Json::object();
  Json best;
  double best_v = std::numeric_limits<double>::quiet_NaN();
  for (const auto& [key, s] : tuning_points(records, tuned, objective)) {
    curve[protocol_point_text(key)] = s;
    const bool better = objective.direction == "min" ? s < best_v : s > best_v;
    if (std::isnan(best_v) || better) {
      best_v = s;
      best = key;
    }
  }
  if (best.is_null()) {
    throw Error(fmt::format("tuning: no tuning record has a value of '{}'", objective.quantity));
  }
  return best;
}

Protocol resolve_protocol(const Json& config, Protocol p, const fs::path& out,
                          const RecordsRunner& run) {
  // h0_multiples: the ranges of the tuning data's own size, from one probe of the tuning scans.
  const bool any_rule = std::any_of(p.params.begin(), p.params.end(),
                                    [](const ProtocolParam& q) { return !q.range_rule.empty(); });
  if (any_rule) {
    const ProtocolParam& first =
        *std::find_if(p.params.begin(), p.params.end(),
                      [](const ProtocolParam& q) { return !q.range_rule.empty(); });
    Json probe = tuning_config(config, p, first.variant);
    probe["variants"] = Json::array(
        {{{"label", "scan-size"}, {"algorithm", "normals.pca"}, {"params", {{"k", 3}}}}});
    probe["metrics"] = Json::array();
    probe.erase("report");
    probe["name"] = config.value("name", std::string("experiment")) + "-scan-sizes";
    const double n = tuning_scan_points(run(probe, out / "scan-sizes"));
    for (auto& q : p.params) {
      if (q.range_rule.empty()) continue;
      q.scan_points = n;
      q.h0 = 1.0 / std::sqrt(n);
      q.range.clear();
      for (double m : q.multiples)
        q.range.emplace_back(protocol_round(m * q.h0));
    }
  }
  std::set<std::string> done;
  for (std::size_t qi = 0; qi < p.params.size(); ++qi) {
    const std::string variant = p.params[qi].variant;
    if (p.params[qi].source != "tuned" || !done.insert(variant).second) continue;
    std::vector<ProtocolParam*> mine;
    for (auto& r : p.params)
      if (r.variant == variant && r.source == "tuned") {
        r.declared_range = r.range;
        mine.push_back(&r);
      }
    const std::vector<const ProtocolParam*> tuned(mine.begin(), mine.end());
    // The objective of the variant's first tuned parameter decides the joint choice.
    const ProtocolObjective objective = tuned.front()->objective;
    std::vector<Json> records = run(tuning_config(config, p, variant), out / ("tuning-" + variant));
    // Boundary optima: extend a range on its falling side, once (all the next values within the
    // limit at once: h0 multiples, or a fixed range's own ratio, next_range_values, as far as the
    // parameter's declaration accepts them), and choose again over all records.
    std::map<std::string, Json> extended;                           // key/side -> {"side", "from"}
    std::map<std::string, std::vector<double>> declared_multiples;  // the limits' reference
    for (const ProtocolParam* q : mine)
      declared_multiples[q->key] = q->multiples;
    // Whether the parameter's declaration accepts `v` (a value past its own domain is not tried).
    auto accepted = [&](const ProtocolParam& q, const Json& v) {
      Json tc = tuning_config(config, p, variant);
      tc["variants"][0]["sweep"] = {{q.key, Json::array({v})}};
      try {
        (void)expand(parse_experiment(tc, "extension"));
        return true;
      } catch (const ParamError&) {
        return false;
      }
    };
    int round = 0;
    Json best, curve;
    for (;;) {
      best = choose_point(records, tuned, objective, curve);
      const std::vector<TuningPoint> points = tuning_points(records, tuned, objective);
      bool more = false;
      for (ProtocolParam* q : mine) {
        // Once per side: a joint optimum may move to a parameter's other side after an extension.
        const BoundaryCheck b = boundary_check(*q, best, points, objective);
        if (b.side.empty() || !b.falling || extended.count(q->key + "/" + b.side) > 0) continue;
        std::vector<Json> values;
        if (!q->range_rule.empty()) {
          const double lo = declared_multiples.at(q->key).front(),
                       hi = declared_multiples.at(q->key).back();
          const std::vector<double> add = next_multiples(*q, b.side, lo, hi);
          for (double m : add)
            values.emplace_back(protocol_round(m * q->h0));
          for (std::size_t i = 0; i < add.size(); ++i) {
            if (b.side == "upper") {
              q->multiples.push_back(add[i]);
            } else {
              q->multiples.insert(q->multiples.begin(), add[i]);
            }
          }
        } else {
          for (const Json& v : next_range_values(*q, b.side)) {
            if (!accepted(*q, v)) break;  // past the parameter's own domain
            values.push_back(v);
          }
        }
        if (values.empty()) continue;  // nothing to try (past the limit or the domain)
        extended[q->key + "/" + b.side] = {{"side", b.side}, {"from", b.at}};
        for (const Json& v : values) {
          if (b.side == "upper") {
            q->range.push_back(v);
          } else {
            q->range.insert(q->range.begin(), v);
          }
        }
        // The new values against the current ranges of the others.
        Json tc = tuning_config(config, p, variant);
        tc["variants"][0]["sweep"][q->key] = values;
        const std::vector<Json> more_records =
            run(tc, out / fmt::format("tuning-{}.ext{}", variant, ++round));
        records.insert(records.end(), more_records.begin(), more_records.end());
        more = true;
      }
      if (!more) break;
    }
    const std::vector<TuningPoint> points = tuning_points(records, tuned, objective);
    for (ProtocolParam* q : mine) {
      q->value = best.value(q->key, Json());
      q->tuning_curve = curve;
      const BoundaryCheck b = boundary_check(*q, best, points, objective);
      std::string sides;  // "at the lower boundary 15, extended to 4; at the upper ..."
      for (const char* side : {"lower", "upper"}) {
        const auto e = extended.find(q->key + "/" + side);
        if (e == extended.end()) continue;
        sides +=
            fmt::format("{}at the {} boundary {}, extended to {}", sides.empty() ? "" : "; ", side,
                        e->second["from"].dump(),
                        (std::string(side) == "upper" ? q->range.back() : q->range.front()).dump());
      }
      const bool grown = q->range.size() > q->declared_range.size();
      std::string status = "interior", text;
      if (!b.side.empty() && b.falling && q->range_rule.empty() &&
          at_domain_edge(*q, b, [&](const Json& v) { return accepted(*q, v); })) {
        // The range ends where the parameter itself does (a PCA k of 1 has no smaller value):
        // no range could be wider there, so the verdict stands.
        status = "limit";
        text =
            fmt::format("{} optimum at {}, the end of the parameter's own domain (still falling)",
                        q->key, b.at.dump());
      } else if (!b.side.empty() && b.falling) {
        status = "inconclusive";
        text = fmt::format(
            "{} optimum on the {} boundary {} (the range extended up to {}x), still falling: "
            "inconclusive",
            q->key, b.side, b.at.dump(), q->extend_limit);
      } else if (!sides.empty() && grown) {
        status = "extended";
        text = fmt::format("{} tuned {}: optimum {}", q->key, sides, q->value.dump());
      } else if (!b.side.empty()) {
        status = "flat";
        text = fmt::format("{} optimum on the {} boundary {}, the curve flat there", q->key, b.side,
                           b.at.dump());
      }
      q->boundary = {{"status", status}, {"text", text}};
      if (!b.side.empty()) q->boundary["side"] = b.side;
    }
  }
  return p;
}

std::vector<Json> records_at_protocol(const std::vector<Json>& records, const Protocol& p,
                                      const ProtocolParam* vary, const Json& at) {
  std::map<std::string, const ProtocolParam*> first;  // variant -> its first ranged parameter
  std::vector<Json> out;
  for (const auto& r : records) {
    const std::string label = r.value("variant", Json::object()).value("label", std::string());
    auto it = first.find(label);
    if (it == first.end()) {
      const auto qs = ranged_params(p, label);
      it = first.emplace(label, qs.empty() ? nullptr : qs.front()).first;
    }
    if (it->second == nullptr) {
      out.push_back(r);
      continue;
    }
    const Json pt = r.value("point", Json::object());
    // A scanner entry (variant "") is varied for every variant.
    const bool varied = vary != nullptr && (vary->variant == label || vary->variant.empty()) &&
                        !protocol_same_value(at, vary->value);
    const ProtocolParam* q = varied ? vary : it->second;
    const Json& want = varied ? at : q->value;
    if (pt.contains(q->key) && protocol_same_value(pt[q->key], want)) out.push_back(r);
  }
  return out;
}

}  // namespace scanbench::harness
