// The scanner's ziggurat normal sampler against the analytic normal distribution: the table
// identities of Marsaglia and Tsang (equal layer areas), a Kolmogorov-Smirnov test against the
// normal CDF, the first four moments, and the share of the tail beyond R (erfc).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "ziggurat.h"

namespace scanbench::scanner::detail {
namespace {

TEST(ScannerZiggurat, LayersHaveEqualAreas) {
  const ZigguratNormal& z = ZigguratNormal::instance();
  constexpr double v = ZigguratNormal::kV;
  EXPECT_EQ(z.x(1), ZigguratNormal::kR);
  EXPECT_EQ(z.x(ZigguratNormal::kLayers), 0.0);
  // Base layer: the rectangle [0, R] x [0, f(R)] plus the tail integral equals V.
  const double tail = std::sqrt(M_PI / 2.0) * std::erfc(ZigguratNormal::kR / std::sqrt(2.0));
  EXPECT_NEAR(ZigguratNormal::kR * z.f(1) + tail, v, 1e-9);
  EXPECT_NEAR(z.x(0) * z.f(1), v, 1e-12);
  for (int i = 1; i < ZigguratNormal::kLayers; ++i) {
    ASSERT_GT(z.x(i), z.x(i + 1)) << i;
    ASSERT_NEAR(z.x(i) * (z.f(i + 1) - z.f(i)), v, 1e-9) << i;  // rectangle of layer i
  }
}

TEST(ScannerZiggurat, DeviatesFollowTheStandardNormal) {
  const ZigguratNormal& z = ZigguratNormal::instance();
  Rng rng(derive_seed(2024, "ziggurat"));
  const int n = 1000000;
  std::vector<double> x(n);
  double s1 = 0, s2 = 0, s3 = 0, s4 = 0;
  int tail = 0;
  for (double& v : x) {
    v = z(rng);
    ASSERT_TRUE(std::isfinite(v));
    s1 += v;
    s2 += v * v;
    s3 += v * v * v;
    s4 += v * v * v * v;
    tail += std::abs(v) > ZigguratNormal::kR;
  }
  const double m = static_cast<double>(n);
  // Moments of N(0, 1): 0, 1, 0, 3; standard errors sqrt(1/n), sqrt(2/n), sqrt(15/n), sqrt(96/n).
  EXPECT_NEAR(s1 / m, 0.0, 5.0 * std::sqrt(1.0 / m));
  EXPECT_NEAR(s2 / m, 1.0, 5.0 * std::sqrt(2.0 / m));
  EXPECT_NEAR(s3 / m, 0.0, 5.0 * std::sqrt(15.0 / m));
  EXPECT_NEAR(s4 / m, 3.0, 5.0 * std::sqrt(96.0 / m));
  // Tail share P(|x| > R) = erfc(R / sqrt 2) (about 2.6e-4): binomial, 5 sigma.
  const double p_tail = std::erfc(ZigguratNormal::kR / std::sqrt(2.0));
  EXPECT_NEAR(tail / m, p_tail, 5.0 * std::sqrt(p_tail * (1.0 - p_tail) / m));
  // Kolmogorov-Smirnov against Phi; 1.95 / sqrt(n) is the 0.1% critical value.
  std::sort(x.begin(), x.end());
  double d = 0;
  for (int i = 0; i < n; ++i) {
    const double cdf = 0.5 * std::erfc(-x[static_cast<std::size_t>(i)] / std::sqrt(2.0));
    d = std::max({d, cdf - i / m, (i + 1) / m - cdf});
  }
  EXPECT_LT(d, 1.95 / std::sqrt(m));
}

TEST(ScannerZiggurat, SameStreamSameDeviates) {
  const ZigguratNormal& z = ZigguratNormal::instance();
  Rng a(7), b(7);
  for (int i = 0; i < 1000; ++i)
    ASSERT_EQ(z(a), z(b));
}

}  // namespace
}  // namespace scanbench::scanner::detail
