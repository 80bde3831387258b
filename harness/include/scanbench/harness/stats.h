#pragma once
// Small statistics for comparing runs.
#include <vector>

namespace scanbench::harness {

struct MannWhitneyResult {
  double u = 0;       ///< U statistic of the first sample (count of pairs a > b, ties count 1/2)
  double p = 1;       ///< two-sided p-value
  bool exact = true;  ///< exact null distribution (else normal approximation)
};

/// Two-sided Mann-Whitney U test, as scipy.stats.mannwhitneyu(a, b, alternative="two-sided")
/// with method "auto" (what Google Benchmark's compare.py calls): the exact null distribution
/// when there are no ties and one sample has at most 8 values, otherwise the normal
/// approximation with tie correction and continuity correction. p = 1 when either sample is
/// empty. Note: with 3 vs 3 samples the smallest exact p is 0.1, so a test at alpha 0.05 needs at
/// least 4 repeats on each side.
MannWhitneyResult mann_whitney_u(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace scanbench::harness
