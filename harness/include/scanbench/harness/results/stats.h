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

/// The smallest p-value mann_whitney_u can give with n1 and n2 samples: that of two fully
/// separated samples (no ties), e.g. 2 / C(4, 2) = 0.333 for 2 vs 2, 0.1 for 3 vs 3, 0.0286 for
/// 4 vs 4. 1 when either is 0.
double mann_whitney_min_p(int n1, int n2);
/// The fewest samples per side (n vs n) at which mann_whitney_min_p(n, n) < alpha; alpha in
/// (0, 1]. 0 when even 1000 per side cannot (alpha below about 1e-300).
int mann_whitney_repeats_needed(double alpha);

}  // namespace scanbench::harness
