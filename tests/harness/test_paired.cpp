// Interleaved rounds and paired ratios (harness/paired.h): the run order, the warm-up, the
// per-round ratios, the bootstrap interval and the verdict rule, against hand computations.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/pipelines/paired.h"

namespace scanbench::harness {
namespace {

// Cases whose "time" is scripted: each call returns the next value of its list and logs its name.
struct Scripted {
  std::vector<std::string>* log;
  std::string name;
  std::vector<double> walls;
  std::size_t next = 0;
  TimedCase as_case() {
    return {name, [this] {
              log->push_back(name);
              const double w = walls.at(next++);
              return Sample{w, 2.0 * w};
            }};
  }
};

TEST(Paired, RoundsInterleaveCasesAndDropTheWarmup) {
  std::vector<std::string> log;
  Scripted a{&log, "a", {100.0, 1.0, 2.0, 3.0}};
  Scripted b{&log, "b", {100.0, 2.0, 2.0, 9.0}};
  const Rounds r = run_rounds({a.as_case(), b.as_case()}, 3, 1);
  EXPECT_EQ(log, (std::vector<std::string>{"a", "b", "a", "b", "a", "b", "a", "b"}));
  ASSERT_EQ(r.samples.at("a").size(), 3u);
  EXPECT_EQ(r.samples.at("a")[0].wall_s, 1.0);  // the warm-up's 100 is gone
  const PairedRatio p = paired_ratio(r, "b_over_a", "b", "a", std::nullopt, 1);
  EXPECT_EQ(p.wall_ratios, (std::vector<double>{2.0, 1.0, 3.0}));
  EXPECT_EQ(p.cpu_ratios, (std::vector<double>{2.0, 1.0, 3.0}));
  EXPECT_EQ(p.wall.median, 2.0);
  EXPECT_EQ(p.wall.min, 1.0);
  EXPECT_EQ(p.wall.max, 3.0);
  EXPECT_TRUE(p.verdict.empty());
}

TEST(Paired, AddedCasesCountInTheirRoundOnly) {
  std::vector<std::string> log;
  Scripted a{&log, "a", {1.0, 2.0}};
  Scripted n{&log, "n", {1.0, 4.0}};
  Scripted b{&log, "b", {6.0, 6.0}};
  const Rounds r = run_rounds({a.as_case(), n.as_case(), b.as_case()}, 2, 0);
  // Round 1: 6 / (1 + 1) = 3; round 2: 6 / (2 + 4) = 1 (not 6 / median sums).
  const PairedRatio p = paired_ratio(r, "b_over_an", "b", "a", std::nullopt, 1, {}, {"n"});
  EXPECT_EQ(p.wall_ratios, (std::vector<double>{3.0, 1.0}));
  EXPECT_EQ(median_sample(r, "a", {"n"}).wall_s, 4.0);
}

TEST(Paired, BadCasesAndNamesAreParamErrors) {
  const TimedCase c{"x", [] { return Sample{}; }};
  EXPECT_THROW(run_rounds({c, c}, 1, 0), ParamError);
  EXPECT_THROW(run_rounds({c}, 0, 0), ParamError);
  EXPECT_THROW(run_rounds({c}, 1, -1), ParamError);
  const Rounds r = run_rounds({c}, 1, 0);
  EXPECT_THROW(paired_ratio(r, "y", "x", "nope", std::nullopt, 1), ParamError);
  EXPECT_THROW(summarize_ratios({}, 1), ParamError);
}

// The percentile bootstrap of the median, recomputed by hand with the same draws: a different
// seed gives other draws, the same seed the same interval; the interval holds the median and lies
// within [min, max].
TEST(Paired, BootstrapIntervalIsSeededAndBracketsTheMedian) {
  const std::vector<double> v = {0.9, 1.1, 1.0, 1.3, 0.95, 1.05, 1.2, 0.85, 1.0, 1.15};
  const RatioSummary s1 = summarize_ratios(v, 7);
  const RatioSummary s2 = summarize_ratios(v, 7);
  EXPECT_EQ(s1.ci_low, s2.ci_low);
  EXPECT_EQ(s1.ci_high, s2.ci_high);
  EXPECT_EQ(s1.median, median(v));
  EXPECT_LE(s1.ci_low, s1.median);
  EXPECT_GE(s1.ci_high, s1.median);
  EXPECT_GE(s1.ci_low, s1.min);
  EXPECT_LE(s1.ci_high, s1.max);
  EXPECT_LT(s1.ci_low, s1.ci_high);
  // A constant sample has a zero-width interval at its value.
  const RatioSummary c = summarize_ratios({2.0, 2.0, 2.0, 2.0, 2.0}, 3);
  EXPECT_EQ(c.ci_low, 2.0);
  EXPECT_EQ(c.ci_high, 2.0);
}

TEST(Paired, VerdictIsNotDecidedWhileTheIntervalCrossesTheTarget) {
  RatioSummary s;
  s.ci_low = 0.9;
  s.ci_high = 1.2;
  EXPECT_EQ(decide(s, Target{1.0}), "not decided");
  EXPECT_EQ(decide(s, Target{0.9}), "met");
  EXPECT_EQ(decide(s, Target{1.25}), "missed");
  EXPECT_EQ(decide(s, Target{1.2, false}), "met");
  EXPECT_EQ(decide(s, Target{1.0, false}), "not decided");
  EXPECT_EQ(decide(s, Target{0.5, false}), "missed");
}

}  // namespace
}  // namespace scanbench::harness
