#pragma once
// Speed ratios measured by interleaved rounds: the one timing loop of `scanbench bench`.
//
// A ratio "A over B" (A's time divided by B's, so > 1 means B is faster) is decided from rounds
// run back to back in one process: every round runs each case once, in a fixed order, so both
// sides of a ratio see the same machine state within a few seconds of each other. The first
// `warmup` rounds are discarded (caches, page faults, the allocator's first growth). Each kept
// round gives one ratio; the summary is the median of those per-round ratios with its min, max and
// a percentile-bootstrap 95% interval of the median. A ratio with a target is "met" when the whole
// interval lies at or above the target, "missed" when it lies below, and "not decided" when it
// crosses the target: on a shared machine a single run's ratio is noise until its interval says
// otherwise (asv and Google Benchmark's compare.py use the same idea with a U test).
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

/// One timed run of a case: wall seconds (monotonic clock) and process CPU seconds (all threads).
struct Sample {
  double wall_s = 0.0;
  double cpu_s = 0.0;
};

/// A case of a benchmark: a name and a function that runs it once. The function does its own
/// set-up outside the timed part by timing with `timed` (below), or returns the sample it measured.
struct TimedCase {
  std::string name;
  std::function<Sample()> run;
};

/// Runs `f` once and returns its wall and CPU seconds (scanbench/core/timing.h's clocks).
Sample timed(const std::function<void()>& f);

/// The samples of interleaved rounds: samples.at(case name)[round], warm-up rounds removed.
struct Rounds {
  std::vector<std::string> order;  ///< the cases in their run order within a round
  std::map<std::string, std::vector<Sample>> samples;
  int warmup = 0;
  double load_before = -1.0;  ///< 1-minute load average before the first round (-1: unknown)
  double load_after = -1.0;   ///< and after the last
};

/// Runs `rounds + warmup` rounds of every case in the given order (case names must be unique and
/// non-empty; throws ParamError otherwise, and when rounds < 1 or warmup < 0). `on_round`, when
/// given, is called after each round with its index (warm-up rounds negative) for progress output.
Rounds run_rounds(const std::vector<TimedCase>& cases, int rounds, int warmup,
                  const std::function<void(int)>& on_round = {});

/// Median, spread and the bootstrap 95% interval of the median of a set of per-round ratios.
struct RatioSummary {
  double median = 0.0, min = 0.0, max = 0.0;
  double ci_low = 0.0, ci_high = 0.0;  ///< 2.5% and 97.5% percentiles of the bootstrap medians
  int n = 0;
};

/// Percentile bootstrap of the median: `resamples` resamples with replacement drawn by the
/// project's Rng from `seed` (deterministic for a seed). Hand-written: neither Boost nor Eigen in
/// Debian 12 offers a bootstrap, and the loop is a dozen lines. Throws ParamError when `values` is
/// empty. With one value the interval is that value.
RatioSummary summarize_ratios(const std::vector<double>& values, std::uint64_t seed,
                              int resamples = 4000);

/// A ratio's target: at least `value` (a speedup), or at most `value` (a slowdown bound).
struct Target {
  double value = 1.0;
  bool at_least = true;
};

/// At least: "met" when ci_low >= value, "missed" when ci_high < value; at most: "met" when
/// ci_high <= value, "missed" when ci_low > value; otherwise "not decided".
std::string decide(const RatioSummary& s, const Target& target);

/// One ratio of a benchmark, numerator's time over denominator's, per round, wall and CPU.
struct PairedRatio {
  std::string name;         ///< e.g. "cgal_wlop_over_clop"
  std::string numerator;    ///< case name
  std::string denominator;  ///< case name
  std::optional<Target> target;
  RatioSummary wall, cpu;
  std::vector<double> wall_ratios, cpu_ratios;  ///< per kept round
  std::string verdict;                          ///< decide(wall, target), "" without a target
};

/// The ratio numerator/denominator of every kept round of `r`. A side may add other cases'
/// samples of the same round (e.g. a preprocessing step timed as its own case and counted in a
/// method's total): their names go in `add_to_numerator` / `add_to_denominator`. Throws
/// ParamError when a name is not a case of `r`.
PairedRatio paired_ratio(const Rounds& r, const std::string& name, const std::string& numerator,
                         const std::string& denominator, std::optional<Target> target,
                         std::uint64_t seed, const std::vector<std::string>& add_to_numerator = {},
                         const std::vector<std::string>& add_to_denominator = {});

/// The median wall and CPU seconds of a case's kept rounds (plus the named cases' per round).
Sample median_sample(const Rounds& r, const std::string& name,
                     const std::vector<std::string>& plus = {});

/// JSON of a summary: median, min, max, ci95_low, ci95_high, n.
Json to_json(const RatioSummary& s);
/// JSON of a ratio: name, numerator, denominator, target, verdict, wall and cpu summaries, the
/// per-round ratios.
Json to_json(const PairedRatio& p);
/// {name: to_json(ratio)} of every ratio, in one object.
Json ratios_json(const std::vector<PairedRatio>& ratios);
/// JSON of the rounds: order, warm-up, load averages, every kept sample per case.
Json to_json(const Rounds& r);

/// One line for the terminal: "name  median [min .. max] 95% [lo, hi]  target >= T: verdict  (CPU
/// ...)".
std::string describe(const PairedRatio& p);

/// The 1-minute load average (getloadavg), -1 when unavailable.
double load_average_1min();

}  // namespace scanbench::harness
