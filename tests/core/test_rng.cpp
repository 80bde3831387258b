#include <gtest/gtest.h>

#include <cmath>

#include "scanbench/core/rng.h"

namespace scanbench {
namespace {

TEST(Rng, DeterministicAndDistributed) {
  Rng a(7), b(7);
  for (int i = 0; i < 100; ++i)
    EXPECT_EQ(a.next(), b.next());
  Rng r(11);
  const int n = 200000;
  double s = 0, s2 = 0, u = 0;
  for (int i = 0; i < n; ++i) {
    const double x = r.normal();
    s += x;
    s2 += x * x;
    u += r.uniform();
  }
  EXPECT_NEAR(s / n, 0.0, 0.01);
  EXPECT_NEAR(s2 / n, 1.0, 0.015);
  EXPECT_NEAR(u / n, 0.5, 0.005);
  for (int i = 0; i < 1000; ++i)
    EXPECT_LT(r.below(7), 7u);
  EXPECT_NE(derive_seed(1, 0), derive_seed(1, 1));
  EXPECT_NE(derive_seed(1, "scan"), derive_seed(1, "hem"));
}

}  // namespace
}  // namespace scanbench
