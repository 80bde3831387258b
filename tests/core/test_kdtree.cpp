#include <gtest/gtest.h>

#include <algorithm>

#include "scanbench/core/kdtree.h"
#include "scanbench/core/rng.h"

namespace scanbench {
namespace {

Eigen::Matrix3Xf random_points(int n, std::uint64_t seed) {
  Rng rng(seed);
  Eigen::Matrix3Xf p(3, n);
  for (int i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d)
      p(d, i) = static_cast<float>(rng.uniform(-1, 1));
  }
  return p;
}

// Oracle: brute force over every point.
TEST(KdTree, MatchesBruteForce) {
  const Eigen::Matrix3Xf pts = random_points(2000, 1);
  const Eigen::Matrix3Xf queries = random_points(100, 2);
  KdTree tree(pts);
  std::vector<Eigen::Index> idx;
  std::vector<float> d2;
  std::vector<std::pair<Eigen::Index, float>> ball;
  for (int q = 0; q < queries.cols(); ++q) {
    const Eigen::Vector3f x = queries.col(q);
    std::vector<std::pair<float, Eigen::Index>> all;
    for (int i = 0; i < pts.cols(); ++i)
      all.emplace_back((pts.col(i) - x).squaredNorm(), i);
    std::sort(all.begin(), all.end());
    tree.knn(x, 8, idx, d2);
    ASSERT_EQ(idx.size(), 8u);
    for (int k = 0; k < 8; ++k) {
      EXPECT_EQ(idx[k], all[k].second);
      EXPECT_NEAR(d2[k], all[k].first, 1e-6);
    }
    float dn = 0;
    EXPECT_EQ(tree.nearest(x, &dn), all[0].second);
    const float r = 0.2f;
    tree.radius(x, r, ball, true);
    std::size_t expected = 0;
    while (expected < all.size() && all[expected].first < r * r)
      ++expected;
    EXPECT_EQ(ball.size(), expected);
  }
}

TEST(KdTree, SmallAndEmpty) {
  Eigen::Matrix3Xf none(3, 0);
  KdTree empty(none);
  EXPECT_EQ(empty.nearest(Eigen::Vector3f::Zero()), -1);
  Eigen::Matrix3Xf two = random_points(2, 3);
  KdTree t(two);
  std::vector<Eigen::Index> idx;
  std::vector<float> d2;
  t.knn(Eigen::Vector3f::Zero(), 5, idx, d2);
  EXPECT_EQ(idx.size(), 2u);
}

}  // namespace
}  // namespace scanbench
