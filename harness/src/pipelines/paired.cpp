#include "scanbench/harness/pipelines/paired.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>

#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/timing.h"

namespace scanbench::harness {

Sample timed(const std::function<void()>& f) {
  const double w0 = wall_seconds();
  const double c0 = process_cpu_seconds();
  f();
  return {wall_seconds() - w0, process_cpu_seconds() - c0};
}

double load_average_1min() {
  double l[1] = {-1.0};
  return getloadavg(l, 1) == 1 ? l[0] : -1.0;
}

Rounds run_rounds(const std::vector<TimedCase>& cases, int rounds, int warmup,
                  const std::function<void(int)>& on_round) {
  if (rounds < 1) throw ParamError(fmt::format("bench: rounds must be >= 1 (got {})", rounds));
  if (warmup < 0) throw ParamError(fmt::format("bench: warm-up must be >= 0 (got {})", warmup));
  Rounds r;
  r.warmup = warmup;
  std::set<std::string> seen;
  for (const TimedCase& c : cases) {
    if (c.name.empty() || !seen.insert(c.name).second || !c.run)
      throw ParamError(
          fmt::format("bench: case name '{}' is empty, repeated or has no run", c.name));
    r.order.push_back(c.name);
    r.samples[c.name];
  }
  r.load_before = load_average_1min();
  for (int i = -warmup; i < rounds; ++i) {
    for (const TimedCase& c : cases) {
      const Sample s = c.run();
      if (i >= 0) r.samples[c.name].push_back(s);
    }
    if (on_round) on_round(i);
  }
  r.load_after = load_average_1min();
  return r;
}

RatioSummary summarize_ratios(const std::vector<double>& values, std::uint64_t seed,
                              int resamples) {
  if (values.empty()) throw ParamError("bench: no ratio to summarize");
  RatioSummary s;
  s.n = static_cast<int>(values.size());
  s.median = median(values);
  s.min = *std::min_element(values.begin(), values.end());
  s.max = *std::max_element(values.begin(), values.end());
  if (values.size() == 1 || resamples < 1) {
    s.ci_low = s.ci_high = s.median;
    return s;
  }
  Rng rng(seed);
  std::vector<double> medians(static_cast<std::size_t>(resamples));
  std::vector<double> draw(values.size());
  for (double& m : medians) {
    for (double& d : draw)
      d = values[rng.below(values.size())];
    m = median(draw);
  }
  std::sort(medians.begin(), medians.end());
  // Percentiles by the nearest-rank rule on the sorted bootstrap medians.
  auto pct = [&](double q) {
    const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(medians.size())));
    return medians[std::clamp<std::size_t>(k, 1, medians.size()) - 1];
  };
  s.ci_low = pct(0.025);
  s.ci_high = pct(0.975);
  return s;
}

std::string decide(const RatioSummary& s, const Target& t) {
  if (t.at_least ? s.ci_low >= t.value : s.ci_high <= t.value) return "met";
  if (t.at_least ? s.ci_high < t.value : s.ci_low > t.value) return "missed";
  return "not decided";
}

namespace {

const std::vector<Sample>& samples_of(const Rounds& r, const std::string& name) {
  const auto it = r.samples.find(name);
  if (it == r.samples.end()) throw ParamError(fmt::format("bench: no case named '{}'", name));
  return it->second;
}

// Per kept round: the case's sample plus the named cases' samples of the same round.
std::vector<Sample> summed(const Rounds& r, const std::string& name,
                           const std::vector<std::string>& plus) {
  std::vector<Sample> s = samples_of(r, name);
  for (const std::string& p : plus) {
    const std::vector<Sample>& q = samples_of(r, p);
    for (std::size_t i = 0; i < s.size(); ++i) {
      s[i].wall_s += q[i].wall_s;
      s[i].cpu_s += q[i].cpu_s;
    }
  }
  return s;
}

}  // namespace

Sample median_sample(const Rounds& r, const std::string& name,
                     const std::vector<std::string>& plus) {
  const std::vector<Sample> s = summed(r, name, plus);
  std::vector<double> w, c;
  for (const Sample& x : s) {
    w.push_back(x.wall_s);
    c.push_back(x.cpu_s);
  }
  return {median(w), median(c)};
}

PairedRatio paired_ratio(const Rounds& r, const std::string& name, const std::string& numerator,
                         const std::string& denominator, std::optional<Target> target,
                         std::uint64_t seed, const std::vector<std::string>& add_to_numerator,
                         const std::vector<std::string>& add_to_denominator) {
  PairedRatio p;
  p.name = name;
  p.numerator = numerator;
  p.denominator = denominator;
  p.target = target;
  const std::vector<Sample> a = summed(r, numerator, add_to_numerator);
  const std::vector<Sample> b = summed(r, denominator, add_to_denominator);
  for (std::size_t i = 0; i < a.size(); ++i) {
    p.wall_ratios.push_back(a[i].wall_s / b[i].wall_s);
    p.cpu_ratios.push_back(a[i].cpu_s / b[i].cpu_s);
  }
  p.wall = summarize_ratios(p.wall_ratios, derive_seed(seed, name));
  p.cpu = summarize_ratios(p.cpu_ratios, derive_seed(seed, name + ":cpu"));
  if (target) p.verdict = decide(p.wall, *target);
  return p;
}

Json to_json(const RatioSummary& s) {
  return {{"median", s.median},   {"min", s.min},           {"max", s.max},
          {"ci95_low", s.ci_low}, {"ci95_high", s.ci_high}, {"n", s.n}};
}

Json to_json(const PairedRatio& p) {
  Json j = {{"name", p.name},
            {"numerator", p.numerator},
            {"denominator", p.denominator},
            {"wall", to_json(p.wall)},
            {"cpu", to_json(p.cpu)},
            {"wall_ratios", p.wall_ratios},
            {"cpu_ratios", p.cpu_ratios}};
  j["target"] =
      p.target ? Json{{"value", p.target->value}, {"direction", p.target->at_least ? ">=" : "<="}}
               : Json();
  j["verdict"] = p.target ? Json(p.verdict) : Json();
  return j;
}

Json ratios_json(const std::vector<PairedRatio>& ratios) {
  Json j = Json::object();
  for (const PairedRatio& r : ratios)
    j[r.name] = to_json(r);
  return j;
}

Json to_json(const Rounds& r) {
  Json cases = Json::object();
  for (const auto& [name, samples] : r.samples) {
    Json w = Json::array(), c = Json::array();
    for (const Sample& s : samples) {
      w.push_back(s.wall_s);
      c.push_back(s.cpu_s);
    }
    cases[name] = {{"wall_s", w}, {"cpu_s", c}};
  }
  return {{"order", r.order},
          {"warmup_rounds", r.warmup},
          {"load_before", r.load_before},
          {"load_after", r.load_after},
          {"samples", cases}};
}

std::string describe(const PairedRatio& p) {
  std::string s = fmt::format("{:<22} {:7.2f} [{:.2f} .. {:.2f}] 95% [{:.2f}, {:.2f}]", p.name,
                              p.wall.median, p.wall.min, p.wall.max, p.wall.ci_low, p.wall.ci_high);
  if (p.target)
    s += fmt::format("  target {} {:g}: {}", p.target->at_least ? ">=" : "<=", p.target->value,
                     p.verdict);
  s += fmt::format("  (CPU {:.2f} [{:.2f}, {:.2f}], {} rounds)", p.cpu.median, p.cpu.ci_low,
                   p.cpu.ci_high, p.wall.n);
  return s;
}

}  // namespace scanbench::harness
