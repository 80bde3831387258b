#pragma once
// Internal to the metrics module: orders of query points that visit space coherently (Morton
// order), so that consecutive queries walk the same BVH nodes or OpenVDB leaves. Used by the
// exact path (ground_truth.cpp) and the field path (distance_field.cpp).
//
// Each key is packed above its query index into one 64-bit word and radix-sorted on the key:
// the order is total and depends on the positions alone, never on the thread count.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Core>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "scanbench/core/radix_sort.h"

namespace scanbench::metrics::detail {

/// Bits needed for the indices 0..n-1.
inline int index_bits(Eigen::Index n) {
  return static_cast<int>(
      std::bit_width(static_cast<std::uint64_t>(std::max<Eigen::Index>(n - 1, 0))));
}

/// The indices 0..n-1 ordered by key(i), ties by index. key(i) must be below 2^key_bits, and
/// key_bits + index_bits(n) <= 64. Keys are computed in parallel (TBB).
template <class KeyFn>
std::vector<Eigen::Index> order_by_key(Eigen::Index n, int key_bits, KeyFn key) {
  if (n <= 0) return {};
  const int idx_bits = index_bits(n);
  if (key_bits + idx_bits > 64) throw std::logic_error("order_by_key: keys do not fit");
  std::vector<std::uint64_t> packed(static_cast<std::size_t>(n));
  tbb::parallel_for(
      tbb::blocked_range<Eigen::Index>(0, n, 8192), [&](const tbb::blocked_range<Eigen::Index>& r) {
        for (Eigen::Index i = r.begin(); i < r.end(); ++i)
          packed[static_cast<std::size_t>(i)] = key(i) << idx_bits | static_cast<std::uint64_t>(i);
      });
  radix_sort(packed, [idx_bits](std::uint64_t k) { return k >> idx_bits; });
  const std::uint64_t mask = (std::uint64_t{1} << idx_bits) - 1;
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  for (std::size_t k = 0; k < packed.size(); ++k)
    order[k] = static_cast<Eigen::Index>(packed[k] & mask);
  return order;
}

/// The column indices of q (finite) in Morton order of a 2^b lattice over q's bounding box,
/// b = min(16, (64 - index bits) / 3); ties in index order.
inline std::vector<Eigen::Index> morton_order(const Eigen::Matrix3Xf& q) {
  const Eigen::Index n = q.cols();
  if (n == 0) return {};
  const int axis_bits = std::min(16, (64 - index_bits(n)) / 3);
  const Eigen::Vector3f lo = q.rowwise().minCoeff();
  const Eigen::Vector3f extent = (q.rowwise().maxCoeff() - lo).cwiseMax(1e-30f);
  const float cells = static_cast<float>((1u << axis_bits) - 1);
  return order_by_key(n, 3 * axis_bits, [&](Eigen::Index i) {
    std::uint64_t key = 0;
    for (int k = 0; k < 3; ++k) {
      const float c = std::clamp((q(k, i) - lo[k]) / extent[k], 0.0f, 1.0f);
      key |= morton_spread3(static_cast<std::uint64_t>(c * cells)) << k;
    }
    return key;
  });
}

}  // namespace scanbench::metrics::detail
