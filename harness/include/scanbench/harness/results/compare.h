#pragma once
// Comparing two result sets (`scanbench compare BASE NEW`, `scanbench nightly`).
//
// Jobs are matched by their readable key (dataset|scanner|variant|point|seed).
//  - Status: a job ok in BASE that failed in NEW, or is missing from NEW, is a regression.
//  - Accuracy: every numeric metric present on both sides. Direction: the one the metric's
//    registry entry declares for the key (metrics/registry.h: lower, higher, or none =
//    informational, e.g. sample counts and mesh vertex counts); a key no metric declares is
//    informational. A config may override it per key ("better" below). A change is significant when
//    |new - base| > abs + rel * |base|; significant and worse = regression, significant and better
//    = improvement.
//  - Timing: for "time.total" and every phase, the repeat samples are compared with a two-sided
//    Mann-Whitney U test (as Google Benchmark's compare.py and asv do): a change is flagged only
//    when p < alpha AND the relative change of the medians exceeds time_threshold AND the
//    medians differ by more than min_time_s. Slower = regression, faster = improvement. When
//    the samples are too few for the test ever to reach alpha (its smallest attainable p,
//    stats.h mann_whitney_min_p, is not below alpha: 2 vs 2 repeats give at best p = 0.333) the
//    verdict is "not decidable", with the repeats per side the test needs, never "same" and
//    never a regression.
//  - ISA: when the baseline's records ran another SIMD path (context.isa) than the new ones, the
//    result says so (notes, table). Accuracy is still judged by the tolerances below: packet
//    widths sum in different orders, so metrics agree only within float rounding, far inside
//    them. Timings then compare different code.
// Tolerances come from the "compare" object of NEW's config.json (when present), overridden by
// command-line options:
//   {"alpha": 0.05, "time_threshold": 0.1, "min_time_s": 0.001, "timing": true,
//    "default": {"rel": 0.05, "abs": 1e-9},
//    "metrics": {"<metric key>": {"rel": r, "abs": a, "better": "lower"|"higher"|"none"}},
//    "ignore": ["<metric key>", ...]}
// Names are checked where they are used (compare_records): a key in "metrics" or "ignore" that
// no metric declares and no record holds, or a CompareOptions::only quantity no record holds, is
// a ParamError with a "did you mean" suggestion.
#include <map>
#include <string>
#include <vector>

#include "scanbench/core/params.h"
#include "scanbench/harness/config/compare_options.h"

namespace scanbench::harness {

struct Verdict {
  std::string key;       ///< job key
  std::string quantity;  ///< "status", a metric key, or "time.<phase>"
  std::string kind;      ///< "status" | "accuracy" | "time"
  double base = 0, now = 0;
  double change = 0;  ///< relative change (now - base) / |base| (0 when base is 0)
  double p = 1;       ///< Mann-Whitney p (time only)
  /// "regression" | "improvement" | "same" | "changed" | "new" | "not decidable" (time: too few
  /// repeats for the test to reach alpha; note says how many it needs)
  std::string verdict;
  std::string note;
  bool notable = false;  ///< an undecidable timing whose change would count: listed by table()
  Json to_json() const;
};

struct CompareResult {
  std::vector<Verdict> verdicts;  ///< every comparison made
  int regressions = 0, improvements = 0, unchanged = 0;
  int undecidable = 0;     ///< timing comparisons "not decidable" (too few repeats)
  int repeats_needed = 0;  ///< repeats per side the U test needs at alpha (when undecidable)
  /// The SIMD paths (records' context.isa, scanbench/core/simd.h) of each side, e.g. {"sse2"},
  /// "unrecorded" for records written before the ISA was recorded.
  std::vector<std::string> base_isas, new_isas;
  /// Notes on the comparison itself (e.g. the baseline ran another ISA).
  std::vector<std::string> notes;
  bool regressed() const { return regressions > 0; }
  Json to_json() const;
  /// Markdown table of the regressions, improvements and the undecidable timings whose change
  /// would count (and a summary: counts, and how many repeats a decision needs).
  std::string table(bool all = false) const;
};

CompareResult compare_records(const std::vector<Json>& base, const std::vector<Json>& now,
                              const CompareOptions& options);

}  // namespace scanbench::harness
