#include "scanbench/harness/results/stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace scanbench::harness {

namespace {

/// Number of orderings of n1 + n2 distinct values whose U equals u, for every u (DP on the
/// recurrence f(n1, n2, u) = f(n1 - 1, n2, u - n2) + f(n1, n2 - 1, u)).
std::vector<double> exact_counts(int n1, int n2) {
  // f[j][u] for the current i.
  const int umax = n1 * n2;
  std::vector<std::vector<double>> prev(n2 + 1, std::vector<double>(umax + 1, 0.0));
  for (int j = 0; j <= n2; ++j)
    prev[j][0] = 1.0;  // i = 0: U is 0
  for (int i = 1; i <= n1; ++i) {
    std::vector<std::vector<double>> cur(n2 + 1, std::vector<double>(umax + 1, 0.0));
    cur[0][0] = 1.0;  // j = 0
    for (int j = 1; j <= n2; ++j) {
      for (int u = 0; u <= i * j; ++u) {
        // The largest value belongs to sample 1 (beats all j) or to sample 2.
        const double a = u - j >= 0 ? prev[j][u - j] : 0.0;
        cur[j][u] = a + cur[j - 1][u];
      }
    }
    prev = std::move(cur);
  }
  return prev[n2];
}

}  // namespace

MannWhitneyResult mann_whitney_u(const std::vector<double>& a, const std::vector<double>& b) {
  MannWhitneyResult r;
  const int n1 = static_cast<int>(a.size());
  const int n2 = static_cast<int>(b.size());
  if (n1 == 0 || n2 == 0) return r;
  // Ranks of the pooled sample (average ranks for ties).
  std::vector<std::pair<double, int>> pooled;
  for (double x : a)
    pooled.push_back({x, 0});
  for (double x : b)
    pooled.push_back({x, 1});
  std::sort(pooled.begin(), pooled.end(),
            [](const auto& l, const auto& r2) { return l.first < r2.first; });
  const int n = n1 + n2;
  double rank_sum1 = 0;
  double tie_term = 0;
  bool ties = false;
  for (int i = 0; i < n;) {
    int j = i;
    while (j + 1 < n && pooled[j + 1].first == pooled[i].first)
      ++j;
    const double avg = 0.5 * (i + j) + 1.0;
    const double t = j - i + 1;
    if (t > 1) {
      ties = true;
      tie_term += t * t * t - t;
    }
    for (int k = i; k <= j; ++k)
      if (pooled[k].second == 0) rank_sum1 += avg;
    i = j + 1;
  }
  const double u1 = rank_sum1 - n1 * (n1 + 1) / 2.0;
  const double u2 = static_cast<double>(n1) * n2 - u1;
  r.u = u1;
  const double umax = std::max(u1, u2);
  if (!ties && (n1 <= 8 || n2 <= 8)) {
    r.exact = true;
    const std::vector<double> counts = exact_counts(n1, n2);
    const double total = std::accumulate(counts.begin(), counts.end(), 0.0);
    // P(U >= umax) under the null; the distribution is symmetric.
    double tail = 0;
    for (int u = static_cast<int>(std::llround(umax)); u < static_cast<int>(counts.size()); ++u)
      tail += counts[u];
    r.p = std::min(1.0, 2.0 * tail / total);
    return r;
  }
  r.exact = false;
  const double mu = n1 * static_cast<double>(n2) / 2.0;
  const double var = n1 * static_cast<double>(n2) / 12.0 *
                     ((n + 1.0) - tie_term / (static_cast<double>(n) * (n - 1.0)));
  if (var <= 0) {
    r.p = 1.0;
    return r;
  }
  const double z = (umax - mu - 0.5) / std::sqrt(var);
  r.p = std::min(1.0, std::erfc(z / std::sqrt(2.0)));
  return r;
}

double mann_whitney_min_p(int n1, int n2) {
  if (n1 <= 0 || n2 <= 0) return 1.0;
  // The test itself on the most extreme arrangement, so the bound follows whichever branch
  // (exact or normal approximation) the test takes at these sizes.
  std::vector<double> a(static_cast<std::size_t>(n1)), b(static_cast<std::size_t>(n2));
  std::iota(a.begin(), a.end(), 0.0);
  std::iota(b.begin(), b.end(), static_cast<double>(n1));
  return mann_whitney_u(a, b).p;
}

int mann_whitney_repeats_needed(double alpha) {
  for (int n = 1; n <= 1000; ++n)
    if (mann_whitney_min_p(n, n) < alpha) return n;
  return 0;
}

}  // namespace scanbench::harness
