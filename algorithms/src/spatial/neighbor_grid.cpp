#include "spatial/neighbor_grid.h"

#include "scanbench/core/radix_sort.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace scanbench::algorithms::detail {

NeighborGrid::NeighborGrid(const Eigen::Matrix3Xf& points, float cell,
                           const std::vector<Eigen::Index>* rank)
    : NeighborGrid(points, GridLayout{cell, GridLayout::Rule::kReciprocal, 1, rank}) {}

NeighborGrid::NeighborGrid(const Eigen::Matrix3Xf& points, const GridLayout& layout)
    : n_(points.cols()),
      rule_(layout.rule),
      width_(layout.cell),
      cell_(static_cast<float>(layout.cell)),
      inv_cell_(1.0f / static_cast<float>(layout.cell)) {
  const auto n = static_cast<std::size_t>(n_);
  if (layout.rank && layout.rank->size() != n)
    throw std::logic_error("NeighborGrid: the rank is not a permutation of the points");
  if (layout.split < 1 || layout.split > 1024)
    throw std::logic_error("NeighborGrid: the split is not in 1..1024");
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
    fine_first_.push_back(0);
    fine_begin_.push_back(0);
    return;
  }
  lo_ = points.rowwise().minCoeff();
  const Eigen::Vector3f hi = points.rowwise().maxCoeff();
  for (int d = 0; d < 3; ++d)
    dims_[d] = axis_cell(d, hi[d]) + 1;
  if (dims_[2] >= std::numeric_limits<std::int32_t>::max())
    throw std::logic_error("NeighborGrid: 2^31 cells or more along z");
  sort_points(points, layout);
  column_tables();
}

void NeighborGrid::sort_points(const Eigen::Matrix3Xf& points, const GridLayout& layout) {
  const auto n = static_cast<std::size_t>(n_);
  const std::vector<Eigen::Index>* rank = layout.rank;
  const int split = layout.split;
  // Per point (original index): its fine cell within its cell, (x, y, z) order; with split 1
  // the array stays empty.
  std::vector<std::uint32_t> fine_of(split > 1 ? n : 0);
  const double fine_width = width_ / split;
  const float inv_fine = 1.0f / static_cast<float>(fine_width);
  std::vector<std::pair<std::uint64_t, Eigen::Index>> keys(n);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n_, 4096), [&](const auto& r) {
    for (Eigen::Index i = r.begin(); i != r.end(); ++i) {
      Cell c = cell_of(points(0, i), points(1, i), points(2, i));
      // Rounding at the upper face can give dims; the point belongs to the last cell.
      c.x = std::min(c.x, dims_[0] - 1);
      c.y = std::min(c.y, dims_[1] - 1);
      c.z = std::min(c.z, dims_[2] - 1);
      const Eigen::Index at = rank ? (*rank)[static_cast<std::size_t>(i)] : i;
      keys[static_cast<std::size_t>(at)] = {key(c.x, c.y, c.z), i};
      if (split == 1) continue;
      std::uint32_t sub = 0;
      const std::int64_t own[3] = {c.x, c.y, c.z};
      for (int d = 0; d < 3; ++d) {
        const float v = points(d, i);
        const double t =
            rule_ == GridLayout::Rule::kReciprocal
                ? std::floor(static_cast<double>((v - lo_[d]) * inv_fine))
                : std::floor((static_cast<double>(v) - static_cast<double>(lo_[d])) / fine_width);
        const double f = std::clamp(t - static_cast<double>(own[d]) * split, 0.0, split - 1.0);
        sub = sub * static_cast<std::uint32_t>(split) + static_cast<std::uint32_t>(f);
      }
      fine_of[static_cast<std::size_t>(i)] = sub;
    }
  });
  // Stable passes: (fine cell, rank) order, then (key, fine cell, rank).
  if (split > 1)
    radix_sort(keys, [&](const auto& e) { return fine_of[static_cast<std::size_t>(e.second)]; });
  radix_sort(keys, [](const auto& e) { return e.first; });  // (key, rank) order
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
          static_cast<std::int32_t>(keys[k].first % static_cast<std::uint64_t>(dims_[2])));
      cell_begin_.push_back(static_cast<Eigen::Index>(k));
    }
  }
  cell_begin_.push_back(n_);
  fine_tables(fine_of);
}

void NeighborGrid::fine_tables(const std::vector<std::uint32_t>& fine_of) {
  const auto n = static_cast<std::size_t>(n_);
  if (fine_of.empty()) {  // one fine cell per cell; no centres (nobody asks without a split)
    fine_first_.resize(cell_begin_.size());
    for (std::size_t c = 0; c < fine_first_.size(); ++c)
      fine_first_[c] = c;
    fine_begin_ = cell_begin_;
    return;
  }
  std::size_t c = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t sub = fine_of[static_cast<std::size_t>(index_[k])];
    const bool new_cell = static_cast<Eigen::Index>(k) == cell_begin_[c];
    if (new_cell) fine_first_.push_back(fine_begin_.size());
    if (new_cell || sub != fine_of[static_cast<std::size_t>(index_[k - 1])])
      fine_begin_.push_back(static_cast<Eigen::Index>(k));
    if (new_cell) ++c;
  }
  fine_first_.push_back(fine_begin_.size());
  fine_begin_.push_back(n_);
  const std::size_t nf = fine_begin_.size() - 1;
  fine_centre_.resize(nf);
  fine_reach_.resize(nf);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 256), [&](const auto& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      const auto b = static_cast<std::size_t>(fine_begin_[f]),
                 end = static_cast<std::size_t>(fine_begin_[f + 1]);
      Eigen::Vector3f mn(x_[b], y_[b], z_[b]), mx = mn;
      for (std::size_t k = b + 1; k < end; ++k) {
        mn = mn.cwiseMin(Eigen::Vector3f(x_[k], y_[k], z_[k]));
        mx = mx.cwiseMax(Eigen::Vector3f(x_[k], y_[k], z_[k]));
      }
      const Eigen::Vector3f centre = 0.5f * (mn + mx);
      float reach = 0.0f;
      for (std::size_t k = b; k < end; ++k)
        reach = std::max(reach, (Eigen::Vector3f(x_[k], y_[k], z_[k]) - centre).norm());
      fine_centre_[f] = centre;
      fine_reach_[f] = reach;
    }
  });
}

void NeighborGrid::column_tables() {
  // A dense table costs 4 bytes per cell of the box, a column table 4 per column: allowed up to
  // 8 per point (32 bytes, the size of the sorted arrays) and while occupied-cell numbers fit 32
  // bits.
  const double box =
      static_cast<double>(dims_[0]) * static_cast<double>(dims_[1]) * static_cast<double>(dims_[2]);
  const double columns = static_cast<double>(dims_[0]) * static_cast<double>(dims_[1]);
  const double budget = 8.0 * static_cast<double>(n_) + 4096.0;
  if (cell_key_.size() >= std::numeric_limits<std::uint32_t>::max()) return;
  // first[k]: the occupied cells whose key divided by `per` is below k (one entry per k).
  const auto first_table = [&](std::size_t entries, std::uint64_t per) {
    std::vector<std::uint32_t> first(entries + 1);
    std::size_t c = 0;
    for (std::size_t k = 0; k < first.size(); ++k) {
      while (c < cell_key_.size() && cell_key_[c] / per < k)
        ++c;
      first[k] = static_cast<std::uint32_t>(c);
    }
    return first;
  };
  if (box <= budget)
    dense_first_ = first_table(static_cast<std::size_t>(box), 1);
  else if (columns <= budget)
    column_first_ =
        first_table(static_cast<std::size_t>(columns), static_cast<std::uint64_t>(dims_[2]));
}

NeighborGrid::Coords NeighborGrid::cell_coords(std::size_t c) const {
  const std::uint64_t k = cell_key_[c];
  const auto dy = static_cast<std::uint64_t>(dims_[1]), dz = static_cast<std::uint64_t>(dims_[2]);
  return {static_cast<std::int64_t>(k / dz / dy), static_cast<std::int64_t>(k / dz % dy),
          static_cast<std::int64_t>(k % dz)};
}

NeighborGrid::Coords NeighborGrid::coords_of(const Eigen::Vector3f& q) const {
  return {axis_cell(0, q.x()), axis_cell(1, q.y()), axis_cell(2, q.z())};
}

void NeighborGrid::set_weights(const Eigen::VectorXf& w) {
  for (Eigen::Index k = 0; k < n_; ++k)
    w_[static_cast<std::size_t>(k)] = w[index_[static_cast<std::size_t>(k)]];
}

void NeighborGrid::ranges_near(const Eigen::Vector3f& q, float radius,
                               std::vector<GridRange>& out) const {
  out.clear();
  if (n_ == 0) return;
  const float r2 = radius * radius;
  const auto lo = [&](int d) { return axis_cell(d, q[d] - radius); };
  const auto hi = [&](int d) { return axis_cell(d, q[d] + radius); };
  const std::int64_t x0 = std::max<std::int64_t>(lo(0), 0), x1 = std::min(hi(0), dims_[0] - 1);
  const std::int64_t y0 = std::max<std::int64_t>(lo(1), 0), y1 = std::min(hi(1), dims_[1] - 1);
  const std::int64_t z0 = lo(2), z1 = hi(2);
  for (std::int64_t cx = x0; cx <= x1; ++cx) {
    const float cx0 = lo_.x() + static_cast<float>(cx) * cell_;
    const float ex = std::max({cx0 - q.x(), q.x() - (cx0 + cell_), 0.0f});
    for (std::int64_t cy = y0; cy <= y1; ++cy) {
      const float cy0 = lo_.y() + static_cast<float>(cy) * cell_;
      const float ey = std::max({cy0 - q.y(), q.y() - (cy0 + cell_), 0.0f});
      if (ex * ex + ey * ey > r2) continue;
      const auto [a, b] = column(cx, cy, z0, z1);
      if (a != b) out.push_back({cell_begin_[a], cell_begin_[b]});
    }
  }
}

std::pair<std::size_t, std::size_t> NeighborGrid::column(std::int64_t cx, std::int64_t cy,
                                                         std::int64_t z0, std::int64_t z1) const {
  z0 = std::max<std::int64_t>(z0, 0);
  z1 = std::min<std::int64_t>(z1, dims_[2] - 1);
  if (z0 > z1) return {0, 0};
  if (!dense_first_.empty())
    return {dense_first_[static_cast<std::size_t>(key(cx, cy, z0))],
            dense_first_[static_cast<std::size_t>(key(cx, cy, z1)) + 1]};
  if (!column_first_.empty()) {
    // The column's occupied cells hold increasing z: [a, b) those within [z0, z1]. Branch-free
    // lower bounds (a conditional move per halving) over 4-byte z: at 10M points the columns of
    // the particle grids hold tens of cells and these searches missed the caches and the branch
    // predictor (docs/performance.md).
    const std::size_t col = static_cast<std::size_t>(cx) * static_cast<std::size_t>(dims_[1]) +
                            static_cast<std::size_t>(cy);
    const std::size_t first = column_first_[col], last = column_first_[col + 1];
    if (first == last) return {first, first};
    const std::int32_t* z = cell_z_.data() + first;
    const auto lower_bound = [z, len0 = last - first](std::int64_t v) {
      const std::int32_t* base = z;
      std::size_t len = len0;
      while (len > 1) {
        const std::size_t half = len / 2;
        base = base[half] < v ? base + half : base;
        len -= half;
      }
      return static_cast<std::size_t>(base - z) + (*base < v ? 1 : 0);
    };
    return {first + lower_bound(z0), first + lower_bound(z1 + 1)};
  }
  const auto a = std::lower_bound(cell_key_.begin(), cell_key_.end(), key(cx, cy, z0));
  const auto b = std::upper_bound(a, cell_key_.end(), key(cx, cy, z1));
  return {static_cast<std::size_t>(a - cell_key_.begin()),
          static_cast<std::size_t>(b - cell_key_.begin())};
}

std::pair<std::size_t, std::size_t> NeighborGrid::column_span(std::int64_t cx,
                                                              std::int64_t cy) const {
  const std::size_t col = static_cast<std::size_t>(cx) * static_cast<std::size_t>(dims_[1]) +
                          static_cast<std::size_t>(cy);
  return {column_first_[col], column_first_[col + 1]};
}

bool NeighborGrid::slide_windows(const Cell& c, std::int64_t reach, bool next,
                                 std::vector<Window>& windows) const {
  const std::int64_t z0 = std::max<std::int64_t>(c.z - reach, 0);
  const std::int64_t z1 = std::min<std::int64_t>(c.z + reach, dims_[2] - 1);
  if (z0 > z1) {  // a query cell beyond the grid in z: no window
    for (Window& w : windows)
      w = {0, 0, 0};
    return false;
  }
  if (next) {
    for (Window& w : windows) {
      while (w.a < w.end && cell_z_[w.a] < z0)
        ++w.a;
      w.b = std::max(w.b, w.a);
      while (w.b < w.end && cell_z_[w.b] <= z1)
        ++w.b;
    }
    return true;
  }
  std::size_t k = 0;
  for (std::int64_t dx = -reach; dx <= reach; ++dx)
    for (std::int64_t dy = -reach; dy <= reach; ++dy, ++k) {
      const std::int64_t cx = c.x + dx, cy = c.y + dy;
      Window& w = windows[k];
      if (cx < 0 || cx >= dims_[0] || cy < 0 || cy >= dims_[1]) {
        w = {0, 0, 0};
        continue;
      }
      w.end = column_span(cx, cy).second;
      std::tie(w.a, w.b) = column(cx, cy, z0, z1);
    }
  return true;
}

}  // namespace scanbench::algorithms::detail
