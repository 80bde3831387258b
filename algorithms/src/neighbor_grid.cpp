#include "neighbor_grid.h"

#include <tbb/parallel_sort.h>

#include <limits>

namespace scanbench::algorithms::detail {

NeighborGrid::NeighborGrid(const Eigen::Matrix3Xf& points, float cell)
    : n_(points.cols()), cell_(cell), inv_cell_(1.0f / cell) {
  const auto n = static_cast<std::size_t>(n_);
  const std::size_t padded = n + static_cast<std::size_t>(kPad);
  // Dummies: far away (their squared distance overflows to +inf) and of weight 0.
  x_.assign(padded, std::numeric_limits<float>::max());
  y_.assign(padded, std::numeric_limits<float>::max());
  z_.assign(padded, std::numeric_limits<float>::max());
  w_.assign(padded, 0.0f);
  index_.resize(n);
  position_.resize(n);
  point_key_.resize(n);
  if (n_ == 0) {
    cell_begin_.push_back(0);
    return;
  }
  lo_ = points.rowwise().minCoeff();
  const Eigen::Vector3f hi = points.rowwise().maxCoeff();
  for (int d = 0; d < 3; ++d)
    dims_[d] = static_cast<std::int64_t>(std::floor((hi[d] - lo_[d]) * inv_cell_)) + 1;
  std::vector<std::pair<std::uint64_t, Eigen::Index>> keys(n);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n_, 4096), [&](const auto& r) {
    for (Eigen::Index i = r.begin(); i != r.end(); ++i) {
      Cell c = cell_of(points(0, i), points(1, i), points(2, i));
      // Rounding at the upper face can give dims; the point belongs to the last cell.
      c.x = std::min(c.x, dims_[0] - 1);
      c.y = std::min(c.y, dims_[1] - 1);
      c.z = std::min(c.z, dims_[2] - 1);
      keys[static_cast<std::size_t>(i)] = {key(c.x, c.y, c.z), i};
    }
  });
  tbb::parallel_sort(keys.begin(), keys.end());
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Index i = keys[k].second;
    x_[k] = points(0, i);
    y_[k] = points(1, i);
    z_[k] = points(2, i);
    w_[k] = 1.0f;
    index_[k] = i;
    position_[static_cast<std::size_t>(i)] = static_cast<Eigen::Index>(k);
    point_key_[k] = keys[k].first;
    if (k == 0 || keys[k].first != keys[k - 1].first) {
      cell_key_.push_back(keys[k].first);
      cell_z_.push_back(
          static_cast<std::int64_t>(keys[k].first % static_cast<std::uint64_t>(dims_[2])));
      cell_begin_.push_back(static_cast<Eigen::Index>(k));
    }
  }
  cell_begin_.push_back(n_);
}

void NeighborGrid::set_weights(const Eigen::VectorXf& w) {
  for (Eigen::Index k = 0; k < n_; ++k)
    w_[static_cast<std::size_t>(k)] = w[index_[static_cast<std::size_t>(k)]];
}

std::pair<std::size_t, std::size_t> NeighborGrid::column(std::int64_t cx, std::int64_t cy,
                                                         std::int64_t z0, std::int64_t z1) const {
  z0 = std::max<std::int64_t>(z0, 0);
  z1 = std::min<std::int64_t>(z1, dims_[2] - 1);
  if (z0 > z1) return {0, 0};
  const auto a = std::lower_bound(cell_key_.begin(), cell_key_.end(), key(cx, cy, z0));
  const auto b = std::upper_bound(a, cell_key_.end(), key(cx, cy, z1));
  return {static_cast<std::size_t>(a - cell_key_.begin()),
          static_cast<std::size_t>(b - cell_key_.begin())};
}

}  // namespace scanbench::algorithms::detail
