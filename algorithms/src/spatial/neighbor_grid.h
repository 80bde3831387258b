#pragma once
// Internal to the algorithms module: a uniform grid over a static point set for the fixed-radius
// kernel sums of the projection operators (LOP, WLOP, CLOP repulsion and densities).
//
// Why not the kd-tree (core's KdTree, nanoflann): the kernels sum over every point within a
// radius of every query, hundreds of neighbours each, every iteration. A kd-tree radius query
// per query (or per cell of queries) returns the neighbours scattered in memory and costs more
// than the kernel arithmetic itself (profiled on the camel case: 35% of CLOP in nanoflann's
// searchLevel). Here the points are sorted by cell once (z fastest), so the points of the cells
// of one grid column with consecutive z are one contiguous range of structure-of-arrays memory:
// a query's neighbourhood is a handful of ranges streamed with SIMD loads, found without any
// tree walk. nanoflann has no such fixed-radius grid; this is the classic cell-list of particle
// methods.
//
// Determinism: a query's ranges and their order depend only on the query position and the grid,
// never on the thread count or on the other queries.
//
// The same grid serves mixture.hem's level 0 (CLOP paper Algorithm 1 lines 1-9): its neighbour
// searches walk the occupied cells around a cell (cells_in_box, with box distance bounds from
// cell_corner), and its eq. 25 density pass the fine cells (GridLayout::split). Its bounds need
// cells exact to 1e-9 of their width, hence GridLayout::Rule::kExactQuotient; the kernels above
// keep the float rule their ranges were written for (the rules place 0 to 2 points in 100,000
// in another cell, which changes the order of their sums, so one rule for both would change
// the bits of one of them).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

namespace scanbench::algorithms::detail {

/// A half-open range [begin, end) of sorted positions in a NeighborGrid.
struct GridRange {
  Eigen::Index begin = 0;
  Eigen::Index end = 0;
};

/// How a NeighborGrid places its points: cubic cells of side `cell` (> 0) from the points'
/// lower corner lo, cell (x, y, z) spanning lo + cell * [x, x + 1) x [y, y + 1) x [z, z + 1).
struct GridLayout {
  enum class Rule {
    /// floor((p - lo) * (1 / cell)) in float (the projection kernels' rule).
    kReciprocal,
    /// floor((p - lo) / cell) in double: the subtraction is exact and the quotient correctly
    /// rounded, so a point lies in its cell's cube up to 1e-9 of the side (mixture.hem level 0).
    kExactQuotient,
  };
  double cell = 1.0;
  Rule rule = Rule::kReciprocal;
  /// Fine cells per axis of a cell: with split > 1 the points of a cell are ordered by fine cell
  /// (cubes of side cell / split, found by the same rule, in (x, y, z) order), and each fine
  /// cell's range, centre and reach are kept (fine_cells()).
  int split = 1;
  /// When given, a permutation of 0..n-1 (rank[i] the place of point i): the points of one
  /// (fine) cell are in the order of `rank` instead of index order, so a caller that stores its
  /// points in another order than their identity (clop_project's spatial order) gets the sums
  /// of the identity order.
  const std::vector<Eigen::Index>* rank = nullptr;
};

class NeighborGrid {
 public:
  /// Float lanes the sorted arrays are padded with (far-away dummies of weight 0), so that SIMD
  /// loads of up to kPad floats from any position below size() stay inside the arrays.
  static constexpr Eigen::Index kPad = 16;

  /// Cell coordinates (x, y, z).
  using Coords = std::array<std::int64_t, 3>;

  /// Sorts the columns of `points` (finite coordinates) into cubic cells of side `cell` > 0
  /// (the float rule); the points of one cell in index order, or in the order of `rank`.
  NeighborGrid(const Eigen::Matrix3Xf& points, float cell,
               const std::vector<Eigen::Index>* rank = nullptr);
  /// Sorts the columns of `points` (finite coordinates) into the cells of `layout`.
  NeighborGrid(const Eigen::Matrix3Xf& points, const GridLayout& layout);

  Eigen::Index size() const { return n_; }
  float cell() const { return cell_; }
  /// The cell side as given to the layout.
  double width() const { return width_; }
  /// Sorted coordinates and weights (weights are 1 until set_weights()).
  const float* x() const { return x_.data(); }
  const float* y() const { return y_.data(); }
  const float* z() const { return z_.data(); }
  const float* weight() const { return w_.data(); }
  /// Original index of the point at sorted position k.
  Eigen::Index index(Eigen::Index k) const { return index_[static_cast<std::size_t>(k)]; }
  /// Per-point weights in original order (size() values), stored in sorted order.
  void set_weights(const Eigen::VectorXf& w);

  /// Calls f(query index i, self, ranges, count) for every column i of `queries`, where the
  /// `count` ranges hold every point within `radius` of the query (and some beyond it; the
  /// caller applies the exact test), and self is the sorted position of query i in this grid
  /// when `queries_are_points` (the grid was built from the same matrix), -1 otherwise.
  /// TBB-parallel over cells of queries; each call depends only on its own query.
  template <class F>
  void for_each_query(const Eigen::Matrix3Xf& queries, float radius, bool queries_are_points,
                      F&& f) const;

  /// Replaces `out` with ranges that hold every point within `radius` of q (and some beyond it),
  /// column by column in increasing (x, y): one query anywhere, not necessarily in the grid.
  void ranges_near(const Eigen::Vector3f& q, float radius, std::vector<GridRange>& out) const;

  // Cell by cell: the occupied cells are numbered 0..cells()-1 in (x, y, z) order.

  /// Number of occupied cells.
  std::size_t cells() const { return cell_key_.size(); }
  /// The sorted positions of the points of occupied cell c.
  GridRange cell_range(std::size_t c) const { return {cell_begin_[c], cell_begin_[c + 1]}; }
  /// The coordinates of occupied cell c.
  Coords cell_coords(std::size_t c) const;
  /// The coordinates of the cell of q by the grid's rule (q anywhere; with kExactQuotient
  /// clamped to +-2^40, with kReciprocal within the int64 range).
  Coords coords_of(const Eigen::Vector3f& q) const;
  /// Lower corner of cell `c`, lo + width() * c in double.
  Eigen::Vector3d cell_corner(const Coords& c) const {
    const Eigen::Vector3d lo = lo_.cast<double>();
    return {lo.x() + width_ * static_cast<double>(c[0]),
            lo.y() + width_ * static_cast<double>(c[1]),
            lo.z() + width_ * static_cast<double>(c[2])};
  }
  /// Calls f(c) for every occupied cell c with coordinates in [lo, hi] (per axis, inclusive), in
  /// increasing c, column (x, y) by column.
  template <class F>
  void cells_in_box(const Coords& lo, const Coords& hi, F&& f) const {
    const std::int64_t x1 = std::min(hi[0], dims_[0] - 1), y1 = std::min(hi[1], dims_[1] - 1);
    for (std::int64_t cx = std::max<std::int64_t>(lo[0], 0); cx <= x1; ++cx)
      for (std::int64_t cy = std::max<std::int64_t>(lo[1], 0); cy <= y1; ++cy) {
        const auto [a, b] = column(cx, cy, lo[2], hi[2]);
        for (std::size_t c = a; c < b; ++c)
          f(c);
      }
  }

  /// With GridLayout::split > 1: the fine cells of occupied cell c are [first, last) (in sorted
  /// order, each non-empty); otherwise every cell is one fine cell.
  std::pair<std::size_t, std::size_t> fine_cells(std::size_t c) const {
    return {fine_first_[c], fine_first_[c + 1]};
  }
  /// The sorted positions of the points of fine cell f.
  GridRange fine_range(std::size_t f) const { return {fine_begin_[f], fine_begin_[f + 1]}; }
  /// With GridLayout::split > 1: the centre of the bounding box of fine cell f's points and their
  /// largest distance from it (float, |p - centre| as Eigen's norm).
  const Eigen::Vector3f& fine_centre(std::size_t f) const { return fine_centre_[f]; }
  float fine_reach(std::size_t f) const { return fine_reach_[f]; }

 private:
  struct Cell {
    std::int64_t x, y, z;
  };
  /// Cell coordinate along axis d of the value v (by the grid's rule).
  std::int64_t axis_cell(int d, float v) const {
    if (rule_ == GridLayout::Rule::kReciprocal)
      return static_cast<std::int64_t>(std::floor((v - lo_[d]) * inv_cell_));
    const double t = std::floor((static_cast<double>(v) - static_cast<double>(lo_[d])) / width_);
    return static_cast<std::int64_t>(std::clamp(t, -kFar, kFar));
  }
  Cell cell_of(float px, float py, float pz) const {
    return {axis_cell(0, px), axis_cell(1, py), axis_cell(2, pz)};
  }
  void sort_points(const Eigen::Matrix3Xf& points, const GridLayout& layout);
  void fine_tables(const std::vector<std::uint32_t>& fine_of);
  void column_tables();
  std::uint64_t key(std::int64_t cx, std::int64_t cy, std::int64_t cz) const {
    return (static_cast<std::uint64_t>(cx) * static_cast<std::uint64_t>(dims_[1]) +
            static_cast<std::uint64_t>(cy)) *
               static_cast<std::uint64_t>(dims_[2]) +
           static_cast<std::uint64_t>(cz);
  }
  /// The range of occupied-cell numbers of column (cx, cy) with z in [z0, z1] (clamped); when
  /// none and z0 <= z1 after clamping, an empty range at the place they would take.
  std::pair<std::size_t, std::size_t> column(std::int64_t cx, std::int64_t cy, std::int64_t z0,
                                             std::int64_t z1) const;
  /// All occupied cells of column (cx, cy) (inside the grid; with the per-column table).
  std::pair<std::size_t, std::size_t> column_span(std::int64_t cx, std::int64_t cy) const;
  /// The occupied cells of one column up to `end`, and [a, b) those within a z window (empty
  /// when the column is outside the grid or the window misses it).
  struct Window {
    std::size_t end, a, b;
  };
  /// The windows of the (2 reach + 1)^2 columns around cell c (dx, dy order) for z within
  /// c.z +- reach. With `next` (c follows the cell of the last call in its column), each window
  /// slides forward from where it was; otherwise it is found by search. False (every window
  /// empty, none to slide from) when c.z +- reach misses the grid.
  bool slide_windows(const Cell& c, std::int64_t reach, bool next,
                     std::vector<Window>& windows) const;

  static constexpr double kFar = 1099511627776.0;  // 2^40: beyond any grid, no overflow

  Eigen::Index n_ = 0;
  GridLayout::Rule rule_ = GridLayout::Rule::kReciprocal;
  double width_ = 1.0;
  float cell_ = 1.0f, inv_cell_ = 1.0f;
  Eigen::Vector3f lo_ = Eigen::Vector3f::Zero();
  std::int64_t dims_[3] = {1, 1, 1};
  std::vector<float> x_, y_, z_, w_;
  std::vector<Eigen::Index> index_;       // sorted position -> original index
  std::vector<Eigen::Index> position_;    // original index -> sorted position
  std::vector<std::uint64_t> cell_key_;   // occupied cells, increasing
  std::vector<std::int32_t> cell_z_;      // their z coordinate (dims_[2] < 2^31, checked)
  std::vector<Eigen::Index> cell_begin_;  // points of cell c: [cell_begin_[c], cell_begin_[c+1])
  std::vector<std::uint64_t> point_key_;  // per sorted point: its cell key
  std::vector<std::size_t> fine_first_;   // fine cells of cell c: [fine_first_[c], [c + 1])
  std::vector<Eigen::Index> fine_begin_;  // points of fine cell f: [fine_begin_[f], [f + 1])
  std::vector<Eigen::Vector3f> fine_centre_;
  std::vector<float> fine_reach_;
  // When the grid's box has few enough cells: per cell key (and one past the last), the number
  // of occupied cells with a smaller key, so that column() reads two entries instead of two
  // binary searches. Empty otherwise.
  std::vector<std::uint32_t> dense_first_;
  // Otherwise, when the box has few enough columns (cx, cy): the same per column, so that
  // column() searches by z only within the column's own occupied cells (a few) instead of all.
  // The box's cells grow as N^1.5 when the cell side shrinks as 1/sqrt(N) (a surface sampled N
  // times), its columns as N: large grids stay off the binary searches over every cell.
  std::vector<std::uint32_t> column_first_;
};

template <class F>
void NeighborGrid::for_each_query(const Eigen::Matrix3Xf& queries, float radius,
                                  bool queries_are_points, F&& f) const {
  const Eigen::Index nq = queries.cols();
  if (queries_are_points && nq != n_)
    throw std::logic_error("NeighborGrid::for_each_query: the queries are not the grid's points");
  if (nq == 0) return;
  // Group the queries by grid cell (for points: the grid's own order), then by index.
  std::vector<std::pair<std::uint64_t, Eigen::Index>> order;
  std::vector<std::size_t> starts;
  if (queries_are_points) {
    order.resize(static_cast<std::size_t>(n_));
    for (Eigen::Index k = 0; k < n_; ++k)
      order[static_cast<std::size_t>(k)] = {point_key_[static_cast<std::size_t>(k)], index(k)};
    for (std::size_t k = 0; k < order.size(); ++k)
      if (k == 0 || order[k].first != order[k - 1].first) starts.push_back(k);
  } else {
    std::vector<std::pair<Cell, Eigen::Index>> cells(static_cast<std::size_t>(nq));
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nq, 4096), [&](const auto& r) {
      for (Eigen::Index i = r.begin(); i != r.end(); ++i)
        cells[static_cast<std::size_t>(i)] = {cell_of(queries(0, i), queries(1, i), queries(2, i)),
                                              i};
    });
    const auto less = [](const auto& a, const auto& b) {
      return std::tie(a.first.x, a.first.y, a.first.z, a.second) <
             std::tie(b.first.x, b.first.y, b.first.z, b.second);
    };
    tbb::parallel_sort(cells.begin(), cells.end(), less);
    order.resize(cells.size());
    for (std::size_t k = 0; k < cells.size(); ++k) {
      order[k] = {0, cells[k].second};
      const Cell& a = cells[k].first;
      if (k == 0 || a.x != cells[k - 1].first.x || a.y != cells[k - 1].first.y ||
          a.z != cells[k - 1].first.z)
        starts.push_back(k);
    }
  }
  starts.push_back(order.size());

  const std::int64_t reach = static_cast<std::int64_t>(std::ceil(radius * inv_cell_));
  const float r2 = radius * radius;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, starts.size() - 1, 1), [&](const auto& rr) {
    // Per query cell: the occupied cells of every column within reach.
    struct Column {
      float x0, x1, y0, y1;  // the column's extent
      std::size_t c0, c1;    // its occupied cells [c0, c1)
    };
    // Per column within reach of the last query cell (dx, dy order): its occupied cells up to
    // `end` and the window [a, b) of those within reach in z. The query cells come in key order,
    // so with the per-column table the next cell of the same column only slides every window
    // forward: a few steps instead of two searches per column (at 10M points the columns hold
    // tens of cells). The dense table finds a window in two reads of adjacent entries.
    const std::size_t side = static_cast<std::size_t>(2 * reach + 1);
    const bool slide = !column_first_.empty();
    std::vector<Window> windows(slide ? side * side : 0);
    bool have_windows = false;
    Cell last{0, 0, 0};
    std::vector<Column> cols;
    std::vector<GridRange> ranges;
    for (std::size_t qc = rr.begin(); qc != rr.end(); ++qc) {
      const Eigen::Index first = order[starts[qc]].second;
      const Cell c = cell_of(queries(0, first), queries(1, first), queries(2, first));
      cols.clear();
      const auto add = [&](std::int64_t cx, std::int64_t cy, std::size_t c0, std::size_t c1) {
        const float x0 = lo_.x() + static_cast<float>(cx) * cell_;
        const float y0 = lo_.y() + static_cast<float>(cy) * cell_;
        cols.push_back({x0, x0 + cell_, y0, y0 + cell_, c0, c1});
      };
      if (!slide) {
        for (std::int64_t dx = -reach; dx <= reach; ++dx) {
          const std::int64_t cx = c.x + dx;
          if (cx < 0 || cx >= dims_[0]) continue;
          for (std::int64_t dy = -reach; dy <= reach; ++dy) {
            const std::int64_t cy = c.y + dy;
            if (cy < 0 || cy >= dims_[1]) continue;
            const auto [c0, c1] = column(cx, cy, c.z - reach, c.z + reach);
            if (c0 != c1) add(cx, cy, c0, c1);
          }
        }
      } else {
        have_windows = slide_windows(
            c, reach, have_windows && c.x == last.x && c.y == last.y && c.z > last.z, windows);
        last = c;
        std::size_t k = 0;
        for (std::int64_t dx = -reach; dx <= reach; ++dx)
          for (std::int64_t dy = -reach; dy <= reach; ++dy, ++k)
            if (windows[k].a != windows[k].b) add(c.x + dx, c.y + dy, windows[k].a, windows[k].b);
      }
      for (std::size_t k = starts[qc]; k < starts[qc + 1]; ++k) {
        const Eigen::Index i = order[k].second;
        const float qx = queries(0, i), qy = queries(1, i), qz = queries(2, i);
        const std::int64_t zlo = axis_cell(2, qz - radius), zhi = axis_cell(2, qz + radius);
        ranges.clear();
        for (const Column& col : cols) {
          const float ex = std::max({col.x0 - qx, qx - col.x1, 0.0f});
          const float ey = std::max({col.y0 - qy, qy - col.y1, 0.0f});
          if (ex * ex + ey * ey > r2) continue;
          std::size_t a = col.c0, b = col.c1;
          while (a < b && cell_z_[a] < zlo)
            ++a;
          while (b > a && cell_z_[b - 1] > zhi)
            --b;
          if (a == b) continue;
          ranges.push_back({cell_begin_[a], cell_begin_[b]});
        }
        const Eigen::Index self =
            queries_are_points ? position_[static_cast<std::size_t>(i)] : Eigen::Index{-1};
        f(i, self, ranges.data(), ranges.size());
      }
    }
  });
}

/// Float lanes of the SIMD packet the kernels over this grid use.
constexpr int kPacketLanes = Eigen::internal::packet_traits<float>::size;
static_assert(kPacketLanes <= NeighborGrid::kPad);

/// Lane masks as float bit patterns for the packet loops over a grid's ranges: first + kPacketLanes
/// - k holds k all-ones lanes then zeros (the valid lanes of a range's last packet); hole +
/// kPacketLanes - k is all-ones except lane k (a query's own position).
struct LaneMasks {
  float first[2 * kPacketLanes];
  float hole[2 * kPacketLanes + 1];
  LaneMasks() {
    float ones;
    const std::uint32_t bits = 0xffffffffu;
    std::memcpy(&ones, &bits, sizeof ones);
    for (int k = 0; k < 2 * kPacketLanes; ++k)
      first[k] = k < kPacketLanes ? ones : 0.0f;
    for (int k = 0; k < 2 * kPacketLanes + 1; ++k)
      hole[k] = k == kPacketLanes ? 0.0f : ones;
  }
};
inline const LaneMasks kLaneMasks;

}  // namespace scanbench::algorithms::detail
