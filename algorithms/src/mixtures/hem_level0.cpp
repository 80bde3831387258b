// mixture.hem, level 0 (CLOP paper Algorithm 1 lines 1-9): the initial mixture of eq. 12 with
// the eq. 26 density weights, on grids of the points.
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include "mixtures/hem_internal.h"
#include "mixtures/sym_eigen3.h"
#include "scanbench/core/kdtree.h"
#include "scanbench/core/simd_dispatch.h"
#include "spatial/compact.h"
#include "spatial/neighbor_grid.h"
#include "spatial/simd_exp.h"

// Eigen's packet types (__m128, __m256, __m512) carry vector attributes that GCC reports as
// ignored when they are template arguments (the kernels are templates over the packet type of
// the active ISA, scanbench/core/simd_dispatch.h); the attributes do not matter there.
#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::algorithms {

namespace {

using Eigen::Index;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::Vector3f;
using Hits = std::vector<std::pair<Index, float>>;
using Range = std::pair<std::size_t, std::size_t>;

using hem_detail::Component;
using hem_detail::Components;

// Relative slack of float distance bounds; the exact tests decide membership.
constexpr float kSlack = 1e-5f;

// The level-0 grids are the project's neighbour grid (spatial/neighbor_grid.h) with cubes of
// width W located by the exact quotient floor((p - lo) / W) in double (CellBoxes's 1e-9 width
// margin relies on it), each split into split^3 fine cubes by which the points of a cube are
// ordered (the density pass bounds each pair of fine cells by their centres and reach). Every
// point within W of a point lies in the 3 x 3 x 3 block of cubes around that point's cube, so a
// neighbour search of radius <= W needs no tree: it reads the block's contiguous ranges of the
// sorted coordinates. The sums below (eq. 12 moments, eq. 25 densities) are added in the grid's
// order.
using detail::GridLayout;
using detail::NeighborGrid;

// A grid of cubes of width >= `width` (at most 2^20 per axis), split into split^3 fine cubes.
NeighborGrid make_grid(const Eigen::Matrix3Xf& pts, double width, int split) {
  const Vector3f lo = pts.rowwise().minCoeff();
  const Vector3f hi = pts.rowwise().maxCoeff();
  constexpr double kAxisCells = 1 << 20;
  double w = std::max(width, static_cast<double>((hi - lo).maxCoeff()) / kAxisCells);
  if (!(w > 0.0) || !std::isfinite(w)) w = 1.0;
  return NeighborGrid(pts, GridLayout{w, GridLayout::Rule::kExactQuotient, split, nullptr});
}

// One occupied cube of a level-0 grid.
struct Cell {
  std::size_t begin, end;  // positions
  Vector3d lo;             // lower corner of the cube (upper: lo + width)
};

Cell cell_at(const NeighborGrid& g, std::size_t c) {
  const detail::GridRange r = g.cell_range(c);
  return {static_cast<std::size_t>(r.begin), static_cast<std::size_t>(r.end),
          g.cell_corner(g.cell_coords(c))};
}

// Position ranges of the occupied cells of the block around cell c, one per column of the
// block, in key order.
void block_ranges(const NeighborGrid& g, std::size_t c, std::vector<Range>& out) {
  out.clear();
  const NeighborGrid::Coords k = g.cell_coords(c);
  for (std::int64_t dx = -1; dx <= 1; ++dx)
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      // The three cells (x, y, z - 1 .. z + 1) are consecutive: one range.
      std::size_t first = std::numeric_limits<std::size_t>::max(), last = 0;
      g.cells_in_box({k[0] + dx, k[1] + dy, k[2] - 1}, {k[0] + dx, k[1] + dy, k[2] + 1},
                     [&](std::size_t ci) {
                       first = std::min(first, ci);
                       last = ci + 1;
                     });
      if (first < last)
        out.emplace_back(static_cast<std::size_t>(g.cell_range(first).begin),
                         static_cast<std::size_t>(g.cell_range(last - 1).end));
    }
}

// The occupied cells within `span` cells of coordinates c on every axis, in key order: they
// hold every point within span * width * (1 - 1e-5) of any point of cell c.
void cells_around(const NeighborGrid& g, const NeighborGrid::Coords& c, std::int64_t span,
                  std::vector<Cell>& out) {
  out.clear();
  constexpr std::int64_t kAxisMax = (std::int64_t{1} << 21) - 1;  // beyond any level-0 grid
  if (std::max<std::int64_t>(c[2] - span, 0) > std::min<std::int64_t>(c[2] + span, kAxisMax))
    return;
  const double columns = (2.0 * static_cast<double>(span) + 1.0) * (2.0 * span + 1.0);
  if (columns >= static_cast<double>(g.cells())) {  // a huge span: every cell, in key order
    for (std::size_t ci = 0; ci < g.cells(); ++ci)
      out.push_back(cell_at(g, ci));
    return;
  }
  g.cells_in_box({c[0] - span, c[1] - span, c[2] - span}, {c[0] + span, c[1] + span, c[2] + span},
                 [&](std::size_t ci) { out.push_back(cell_at(g, ci)); });
}

// The occupied cells of the block around cell c, cell c first, then in key order.
void block_cells(const NeighborGrid& g, std::size_t c, std::vector<Cell>& out) {
  cells_around(g, g.cell_coords(c), 1, out);
  const auto begin = static_cast<std::size_t>(g.cell_range(c).begin);
  const auto own =
      std::find_if(out.begin(), out.end(), [&](const Cell& cell) { return cell.begin == begin; });
  std::rotate(out.begin(), own, own + 1);
}

// For a list of cells, per cell a lower bound of the squared distance from a query q to its
// points: the distance to its cube grown by 1e-9 width (points sit in their cube up to the
// rounding of the cell index), shrunk by 1e-6 relative (the float distances it is compared
// with). 8 cells per packet of doubles, from the lower corners stored by axis (padded with cells
// at infinity). The shrink is far wider than the rounding of the bound's last bits, so a cell
// whose test could go either way holds only points beyond the bound it is tested against.
class CellBoxes {
 public:
  void set(const std::vector<Cell>& cells) {
    const std::size_t padded = (cells.size() + kLanes - 1) / kLanes * kLanes;
    x_.resize(padded);
    y_.resize(padded);
    z_.resize(padded);
    bound_.resize(padded);
    for (std::size_t t = 0; t < padded; ++t) {
      const bool real = t < cells.size();
      constexpr double inf = std::numeric_limits<double>::infinity();
      x_[t] = real ? cells[t].lo.x() : inf;
      y_[t] = real ? cells[t].lo.y() : inf;
      z_[t] = real ? cells[t].lo.z() : inf;
    }
  }

  // The bounds of every cell for query q (cubes of the width of g's cells).
  void measure(const NeighborGrid& g, const Vector3d& q) {
    const double width = g.width();
    const double hair = 1e-9 * width;
    const double far = width + hair;
    for (std::size_t t = 0; t < x_.size(); t += kLanes) {
      const Double8 ex = gap(x_.data() + t, q.x(), hair, far);
      const Double8 ey = gap(y_.data() + t, q.y(), hair, far);
      const Double8 ez = gap(z_.data() + t, q.z(), hair, far);
      const Double8 d2 = (ex * ex + ey * ey + ez * ez) * (1.0 - 1e-6);
      std::memcpy(bound_.data() + t, &d2, sizeof d2);
    }
  }

  // Cell t's bound from the last measure().
  double bound(std::size_t t) const { return bound_[t]; }

 private:
  using Double8 = double __attribute__((vector_size(64)));
  static constexpr std::size_t kLanes = 8;

  // Per lane the distance from q to the cube [lo - hair, lo + far] along one axis.
  static Double8 gap(const double* lo_ptr, double q, double hair, double far) {
    Double8 lo;
    std::memcpy(&lo, lo_ptr, sizeof lo);
    const Double8 below = lo - q - hair;
    const Double8 above = q - (lo + far);
    const Double8 d = below > above ? below : above;
    return d > 0.0 ? d : Double8{};
  }

  std::vector<double> x_, y_, z_, bound_;
};

// GCC/Clang vector extensions: 4 floats, portable SIMD for the nearest-neighbour scans of the
// initial mixture (the density pass uses the packet of the active ISA).
using Float4 = float __attribute__((vector_size(16)));
using Int4 = std::int32_t __attribute__((vector_size(16)));

inline Float4 load4(const float* p) {
  Float4 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// 16 floats for the k-nearest scan: a sorted list of the k smallest distances per lane.
using Float16 = float __attribute__((vector_size(64)));
using Int16 = std::int32_t __attribute__((vector_size(64)));

// The smallest of the 16 lanes of v, in every lane (four rounds of lane swaps and minima).
template <class V>
inline V all_lanes_min(V v) {
  V s = __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15, 0, 1, 2, 3, 4, 5, 6, 7);
  v = s < v ? s : v;
  s = __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3, 12, 13, 14, 15, 8, 9, 10, 11);
  v = s < v ? s : v;
  s = __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13);
  v = s < v ? s : v;
  s = __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14);
  return s < v ? s : v;
}

// The position ranges of `cells`, merged where consecutive.
void merged_ranges(const std::vector<Cell>& cells, std::vector<Range>& out) {
  out.clear();
  for (const Cell& cell : cells) {
    if (!out.empty() && out.back().second == cell.begin)
      out.back().second = cell.end;
    else if (cell.end > cell.begin)
      out.emplace_back(cell.begin, cell.end);
  }
}

// The k smallest positive squared distances (ascending, +inf where fewer) from q to the points
// xs, ys, zs[b, e) of the `ranges` and the number of zero distances (the arrays readable 16
// floats past each range). Per lane of 16 a sorted list of its k smallest (a min/max insertion
// network, no branch per point); then the k smallest of the 16 lists. The distances are computed
// as in scan_cell, so the values are the same.
template <int K>
void nearest_k(const float* xs, const float* ys, const float* zs, const Vector3f& q,
               const std::vector<Range>& ranges, float* best, int& zeros) {
  constexpr float inf = std::numeric_limits<float>::infinity();
  Float16 lists[K];
  for (auto& l : lists)
    l = Float16{} + inf;
  Int16 zero_count{};
  Int16 lane{};
  for (int l = 0; l < 16; ++l)
    lane[l] = l;
  auto scan = [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; i += 16) {  // the arrays are padded by kPad >= 16 floats
      Float16 x, y, z;
      std::memcpy(&x, xs + i, sizeof x);
      std::memcpy(&y, ys + i, sizeof y);
      std::memcpy(&z, zs + i, sizeof z);
      const Float16 dx = x - q.x(), dy = y - q.y(), dz = z - q.z();
      const Float16 dd = dx * dx + dy * dy + dz * dz;
      const Int16 valid = lane < static_cast<std::int32_t>(std::min<std::size_t>(e - i, 16));
      zero_count -= valid & (dd == 0.0f);
      Float16 t = (valid & (dd != 0.0f)) ? dd : Float16{} + inf;
      for (int k = 0; k < K; ++k) {
        const Float16 lo = lists[k] < t ? lists[k] : t;
        t = lists[k] < t ? t : lists[k];
        lists[k] = lo;
      }
    }
  };
  for (const auto& [b, e] : ranges)
    scan(b, e);
  // The k smallest of the lists, in ascending order: k times the smallest head, taken off its
  // lane (the lowest lane holding it), whose list moves up by one. Branch-free.
  for (int k = 0; k < K; ++k) {
    const Float16 m = all_lanes_min(lists[0]);
    best[k] = m[0];
    const Int16 first = all_lanes_min(lists[0] == m ? lane : Int16{} + 16);
    const Int16 take = lane == first;
    for (int t = 0; t + 1 < K; ++t)
      lists[t] = take ? lists[t + 1] : lists[t];
    lists[K - 1] = take ? Float16{} + inf : lists[K - 1];
  }
  zeros = 0;
  for (int l = 0; l < 16; ++l)
    zeros += zero_count[l];
}

// nearest_k<1> ... nearest_k<kMaxListK>, by k - 1: the k nearest by per-lane lists.
constexpr int kMaxListK = 8;
using NearestK = void (*)(const float*, const float*, const float*, const Vector3f&,
                          const std::vector<Range>&, float*, int&);
template <int... K>
constexpr std::array<NearestK, sizeof...(K)> nearest_table(std::integer_sequence<int, K...>) {
  return {&nearest_k<K + 1>...};
}
constexpr auto kNearestK = nearest_table(std::make_integer_sequence<int, kMaxListK>{});

// Whether any lane of a comparison result is set.
inline bool any_lane(Int4 mask) {
  std::uint64_t lo = 0, hi = 0;
  std::memcpy(&lo, &mask, sizeof lo);
  std::memcpy(&hi, reinterpret_cast<const char*>(&mask) + sizeof lo, sizeof hi);
  return (lo | hi) != 0;
}

// Candidate coordinates and grid positions; `padded` rounds `size` up to whole packets of
// `lanes` floats with points at infinity. The arrays only grow (no zero-filling per use).
struct Candidates {
  static constexpr std::size_t kMaxLanes = 16;
  std::vector<float> x, y, z;
  std::vector<std::size_t> pos;
  std::size_t size = 0, padded = 0;

  void reserve(std::size_t bound) {
    if (x.size() >= bound + kMaxLanes) return;
    x.resize(bound + kMaxLanes);
    y.resize(bound + kMaxLanes);
    z.resize(bound + kMaxLanes);
    pos.resize(bound + kMaxLanes);
  }
  void pad(std::size_t lanes) {
    padded = (size + lanes - 1) / lanes * lanes;
    for (std::size_t i = size; i < padded; ++i) {
      x[i] = std::numeric_limits<float>::infinity();
      y[i] = 0.0f;
      z[i] = 0.0f;
    }
  }
};

// The lanes of a packet summed pairwise ((l0 + l1) + (l2 + l3)) + ..., the same tree for every
// width (for 4 lanes the order of the original 4-lane pass).
template <class Packet>
float pairwise_sum(const Packet& p) {
  constexpr int kLanes = Eigen::internal::unpacket_traits<Packet>::size;
  float a[kLanes];
  Eigen::internal::pstoreu(a, p);
  for (int w = 1; w < kLanes; w *= 2)
    for (int l = 0; l + w < kLanes; l += 2 * w)
      a[l] += a[l + w];
  return a[0];
}

// WLOP density v_j = 1 + sum_{j' != j, |p_j - p_j'| <= h} exp(-16 |p_j - p_j'|^2 / h^2) of every
// point, on a grid of coarse width >= h split into fine cells of width h/3. Each pair is
// evaluated once: within a fine cell both ways, across fine cells by the earlier cell (its
// candidates: the later points of its block within h + reach of its centre), adding the term to
// both points. Partial sums are added in 2^-b fixed point: integer sums are exact and
// order-free, so the result is the same for any thread count.
template <class Packet>
std::vector<double> density_weights_impl(const NeighborGrid& g, double h) {
  namespace ei = Eigen::internal;
  constexpr std::size_t kLanes = ei::unpacket_traits<Packet>::size;
  static_assert(kLanes <= Candidates::kMaxLanes);
  const auto n = static_cast<std::size_t>(g.size());
  const auto hf = static_cast<float>(h);
  const float c2 = hf * hf;
  const float k_theta = -16.0f / c2;
  // v <= n: 2^b n < 2^62.
  const int bits = 62 - static_cast<int>(std::ceil(std::log2(static_cast<double>(n) + 1.0)));
  const double scale = std::ldexp(1.0, bits);
  auto fixed = [&](float x) {  // x >= 0; rounding to nearest (any fixed rule is deterministic)
    return static_cast<long long>(static_cast<double>(x) * scale + 0.5);
  };
  tbb::enumerable_thread_specific<std::vector<long long>> sums(
      [n] { return std::vector<long long>(n, 0); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, g.cells(), 1), [&](const auto& rr) {
    std::vector<long long>& sum = sums.local();
    std::vector<Range> ranges;
    Candidates own, cand;
    std::vector<float> col;
    for (std::size_t c = rr.begin(); c != rr.end(); ++c) {
      block_ranges(g, c, ranges);
      const auto [fine_b, fine_e] = g.fine_cells(c);
      for (std::size_t f = fine_b; f < fine_e; ++f) {
        const auto own_b = static_cast<std::size_t>(g.fine_range(f).begin),
                   own_e = static_cast<std::size_t>(g.fine_range(f).end);
        own.reserve(own_e - own_b);
        own.size = 0;
        for (std::size_t k = own_b; k < own_e; ++k, ++own.size) {
          own.x[own.size] = g.x()[k];
          own.y[own.size] = g.y()[k];
          own.z[own.size] = g.z()[k];
          own.pos[own.size] = k;
        }
        own.pad(kLanes);
        const Vector3f centre = g.fine_centre(f);
        const float own_reach = g.fine_reach(f) * (1.0f + kSlack);
        const float reach = hf * (1.0f + kSlack) + own_reach;
        const float reach2 = reach * reach;
        std::size_t bound = 0;
        for (const auto& [b, e] : ranges)
          bound += e - std::min(e, std::max(b, own_e));
        cand.reserve(bound + detail::kCompactSlack);
        std::size_t m = 0;
        for (const auto& [b, e] : ranges)
          if (std::max(b, own_e) < e)
            m = detail::compact_within(g.x(), g.y(), g.z(), std::max(b, own_e), e, centre, reach2,
                                       cand.pos.data(), m);
        for (std::size_t i = 0; i < m; ++i) {
          cand.x[i] = g.x()[cand.pos[i]];
          cand.y[i] = g.y()[cand.pos[i]];
          cand.z[i] = g.z()[cand.pos[i]];
        }
        cand.size = m;
        cand.pad(kLanes);
        if (col.size() < cand.padded) col.resize(cand.padded);
        std::fill_n(col.begin(), cand.padded, 0.0f);
        // theta for a packet of candidates; beyond h the exponent is -80, a term under 2e-35
        // that vanishes exactly next to the terms >= theta(h) = 1.1e-7 (and in the fixed point).
        const Packet c2v = ei::pset1<Packet>(c2), kv = ei::pset1<Packet>(k_theta),
                     far = ei::pset1<Packet>(-80.0f);
        auto theta = [&](const Candidates& cs, std::size_t m4, const Packet& qx, const Packet& qy,
                         const Packet& qz) {
          const Packet dx = ei::psub(ei::ploadu<Packet>(cs.x.data() + m4), qx),
                       dy = ei::psub(ei::ploadu<Packet>(cs.y.data() + m4), qy),
                       dz = ei::psub(ei::ploadu<Packet>(cs.z.data() + m4), qz);
          const Packet d2 =
              ei::padd(ei::padd(ei::pmul(dx, dx), ei::pmul(dy, dy)), ei::pmul(dz, dz));
          return detail::fast_pexp(ei::pselect(ei::pcmp_le(d2, c2v), ei::pmul(d2, kv), far));
        };
        for (std::size_t a = 0; a < own.size; ++a) {
          const Packet qx = ei::pset1<Packet>(own.x[a]), qy = ei::pset1<Packet>(own.y[a]),
                       qz = ei::pset1<Packet>(own.z[a]);
          Packet row = ei::pset1<Packet>(0.0f);
          // The own cell, self included: theta(0) = 1 is the leading 1.
          for (std::size_t m4 = 0; m4 < own.padded; m4 += kLanes)
            row = ei::padd(row, theta(own, m4, qx, qy, qz));
          for (std::size_t m4 = 0; m4 < cand.padded; m4 += kLanes) {
            const Packet t = theta(cand, m4, qx, qy, qz);
            row = ei::padd(row, t);
            ei::pstoreu(col.data() + m4, ei::padd(ei::ploadu<Packet>(col.data() + m4), t));
          }
          sum[own.pos[a]] += fixed(pairwise_sum(row));
        }
        for (std::size_t i = 0; i < cand.size; ++i)
          sum[cand.pos[i]] += fixed(col[i]);
      }
    }
  });
  std::vector<long long> total(n, 0);
  for (const auto& s : sums)
    for (std::size_t k = 0; k < n; ++k)
      total[k] += s[k];
  std::vector<double> v(n);
  for (std::size_t k = 0; k < n; ++k)
    v[static_cast<std::size_t>(g.index(static_cast<Index>(k)))] =
        static_cast<double>(total[k]) / scale;
  return v;
}

// The density pass with the packet of the active ISA (scanbench/core/simd.h).
std::vector<double> density_weights(const NeighborGrid& g, double h) {
  return simd::with_packet(
      [&](auto tag) { return density_weights_impl<typename decltype(tag)::type>(g, h); });
}

// Squared float distances from q to the points of `cell` as the kd-tree evaluates them
// ((dx^2 + dy^2) + dz^2), four at a time: `visit(i, d2)` sees only the groups in which any lane
// passes `below`.
template <class Below, class Visit>
inline void scan_cell(const NeighborGrid& g, const Vector3f& q, const Cell& cell, Below&& below,
                      Visit&& visit) {
  std::size_t i = cell.begin;
  for (; i + 4 <= cell.end; i += 4) {
    const Float4 dx = load4(g.x() + i) - q.x(), dy = load4(g.y() + i) - q.y(),
                 dz = load4(g.z() + i) - q.z();
    const Float4 dd = dx * dx + dy * dy + dz * dz;
    if (!any_lane(below(dd))) continue;
    for (int l = 0; l < 4; ++l)
      visit(i + static_cast<std::size_t>(l), dd[l]);
  }
  for (; i < cell.end; ++i) {
    const float dx = g.x()[i] - q.x(), dy = g.y()[i] - q.y(), dz = g.z()[i] - q.z();
    visit(i, dx * dx + dy * dy + dz * dz);
  }
}

// The level-0 mixture of one point set (Algorithm 1 lines 1-9): per point its nearest-neighbour
// spacing, eq. 12 from its neighbours within init_radius_factor times that spacing, and the
// eq. 26 weights. Searches run on grids of the points; the kd-tree serves only the searches that
// outgrow kMaxWide cells (isolated points), built on first use, once.
class Level0 {
 public:
  Level0(const Eigen::Matrix3Xf& pts, const HemParams& p, double h_abs, double abs_floor)
      : pts_(pts),
        p_(p),
        h_abs_(h_abs),
        abs_floor_(abs_floor),
        k_nn_(p.init_neighbors),
        k_query_(p.init_neighbors + 8),
        kernel_density_(p.weighted && p.density == "kernel"),
        k_theta_(-16.0 / (h_abs * h_abs)) {}

  Components build() {
    const Index n = pts_.cols();
    if (p_.weighted) {
      density_grid_.emplace(make_grid(pts_, h_abs_ * (1.0 + 10.0 * kSlack), 3));
      // density "kernel": summed in the eq. 12 kernel pass below (moments).
      if (p_.density == "support") density_ = density_weights(*density_grid_, h_abs_);
    }
    double spacing = typical_spacing();
    if (!(spacing > 0.0)) spacing = std::max(h_abs_ * 0.1, std::sqrt(abs_floor_) * 10.0);
    density_grid_.reset();  // its last use: the grid of the searches below takes its place

    // Grid cells of width W: every neighbour within W * (1 - slack) of a point is in its block
    // (nearest neighbours), within span * W * (1 - slack) in the cells within `span` (radius r).
    // A point whose neighbours reach further searches its own wider block (up to kMaxWide),
    // then the kd-tree.
    g_.emplace(make_grid(pts_, std::max(3.0, 2.0 * p_.init_radius_factor) * spacing, 2));
    guaranteed_ = static_cast<float>(g_->width()) * (1.0f - 4.0f * kSlack);
    nn_.assign(static_cast<std::size_t>(n), 0.0);
    comps_ = Components(static_cast<std::size_t>(n));
    if (kernel_density_) density_.assign(static_cast<std::size_t>(n), 1.0);

    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, g_->cells(), 4), [&](const auto& rr) {
      std::vector<Cell> block;
      NnScratch nn;
      nn.best.resize(static_cast<std::size_t>(k_nn_));
      CellScratch sc;
      for (std::size_t c = rr.begin(); c != rr.end(); ++c) {
        block_cells(*g_, c, block);
        const double r_max = nearest_in_block(c, block, nn);
        initial_in_cell(c, r_max, block, sc);
      }
    });
    initial_of_duplicates();

    // Eq. 26 as written, w_j = (v_j |P|)^-1 (unweighted: 1/|P|), NOT renormalised: the HEM
    // likelihood exponent w_i |P| of eq. 9 is then 1/v_j at level 0 and the sum of the merged
    // children's 1/v_j (eq. 10) above it, as in the paper and the authors' code. hem_mixture()
    // normalises the final weights to sum 1 (only their ratios matter to CLOP's eq. 18 and 23).
    const double n_points = static_cast<double>(comps_.size());
    for (std::size_t j = 0; j < comps_.size(); ++j)
      comps_[j].w = (p_.weighted ? 1.0 / density_[j] : 1.0) / n_points;
    return std::move(comps_);
  }

 private:
  static constexpr std::int64_t kMaxSpan = 4;
  // A point whose nearest neighbours or eq. 12 radius reach past its block (or past kMaxSpan)
  // searches the cells within up to kMaxWide of its own before it asks the kd-tree: from a
  // million points on a few thousand points per million do (sparse places of a scan), and one
  // kd-tree query builds the tree over every point, serially (docs/performance.md). The spans
  // grow by a third to a half per step, so an isolated point costs a few (2 kMaxWide + 1)^2
  // column lookups.
  static constexpr std::int64_t kMaxWide = 16;
  static constexpr std::array<std::int64_t, 7> kWideSpans{2, 3, 4, 6, 8, 12, kMaxWide};

  const KdTree& tree() const {
    std::call_once(tree_once_, [&] { tree_storage_.emplace(pts_); });
    return *tree_storage_;
  }

  // Mean distance to the k_nn nearest distinct points among the k_query nearest (squared
  // distances ascending: `d2`, of the k_query nearest or of all points when fewer).
  double mean_nn(const std::vector<float>& d2) const {
    const int k_nn = k_nn_;
    double sum = 0.0;
    int found = 0;
    for (float d : d2) {
      if (d > 0.0f && found < k_nn) {
        sum += std::sqrt(static_cast<double>(d));
        ++found;
      }
    }
    return found > 0 ? sum / found : 0.0;
  }

  double tree_nn(Index j) const {
    std::vector<Index> idx;
    std::vector<float> d2;
    tree().knn(pts_.col(j), k_query_, idx, d2);
    return mean_nn(d2);
  }

  // The best.size() smallest squared distances from qf to the points of `cells` into `best`
  // (ascending, +inf where fewer; the point itself and duplicates included), each computed as the
  // kd-tree does ((dx^2 + dy^2) + dz^2 in float).
  static void k_nearest(const NeighborGrid& g, const Vector3f& qf, const std::vector<Cell>& cells,
                        std::vector<float>& best) {
    std::fill(best.begin(), best.end(), std::numeric_limits<float>::infinity());
    for (const Cell& cell : cells)
      for (std::size_t i = cell.begin; i < cell.end; ++i) {
        const float dx = qf.x() - g.x()[i], dy = qf.y() - g.y()[i], dz = qf.z() - g.z()[i];
        const float d = dx * dx + dy * dy + dz * dz;
        if (!(d < best.back())) continue;
        auto at = best.end() - 1;
        for (; at != best.begin() && *(at - 1) > d; --at)
          *at = *(at - 1);
        *at = d;
      }
  }

  // tree_nn(j) from the cells of `g` within the kWideSpans of point j's cell: the first span
  // whose guaranteed reach (span * `guaranteed`) holds the k_query nearest gives them exactly,
  // with the kd-tree's float distances, so the same mean. `cells` and `best` are scratch.
  double wide_nn(const NeighborGrid& g, Index j, float guaranteed, std::vector<Cell>& cells,
                 std::vector<float>& best) const {
    const Vector3f qf = pts_.col(j);
    const auto coords = g.coords_of(qf);
    best.resize(static_cast<std::size_t>(k_query_));
    for (const std::int64_t span : kWideSpans) {
      cells_around(g, coords, span, cells);
      k_nearest(g, qf, cells, best);
      const float reach = static_cast<float>(span) * guaranteed;
      if (best.back() <= reach * reach) return mean_nn(best);
    }
    return tree_nn(j);
  }

  // Typical spacing from a fixed subset: sizes the grid of the neighbour searches. With the
  // density grid (cells of width >= h), each point's nearest come from the block of cells
  // around it (block_nn). 0 when no point has a distinct neighbour.
  double typical_spacing() const {
    const Index n = pts_.cols();
    double spacing = 0.0;
    std::vector<double> all((static_cast<std::size_t>(n) + 60) / 61);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, all.size(), 16), [&](const auto& r) {
      std::vector<Cell> block;
      NnScratch nn;
      nn.best.resize(static_cast<std::size_t>(k_nn_));
      for (std::size_t k = r.begin(); k != r.end(); ++k) {
        const Index j = static_cast<Index>(k) * 61;
        if (!density_grid_) {
          all[k] = tree_nn(j);
          continue;
        }
        const NeighborGrid& dg = *density_grid_;
        const Vector3f qf = pts_.col(j);
        cells_around(dg, dg.coords_of(qf), 1, block);
        const auto reach = static_cast<float>(dg.width()) * (1.0f - 4.0f * kSlack);
        all[k] = block_nn(dg, j, qf, block, reach, nn);
      }
    });
    std::vector<double> sample;
    for (double d : all)
      if (d > 0.0) sample.push_back(d);
    if (!sample.empty()) {
      auto mid = sample.begin() + static_cast<std::ptrdiff_t>(sample.size() / 2);
      std::nth_element(sample.begin(), mid, sample.end());
      spacing = *mid;
    }
    return spacing;
  }

  // Eq. 12's sums for point j over its neighbours within r (`for_each` calls back with their
  // coordinates): Sigma_r, centred at their mean, for finish_initial().
  struct Moments {
    Index j;
    double r, count;
    Matrix3d cov_r;
  };
  template <class ForEach>
  Moments moments(Index j, double r, ForEach&& for_each) {
    const bool kernel_density = kernel_density_;
    const double k_theta = k_theta_;
    const double r2 = r * r;
    const Vector3d pj = pts_.col(j).cast<double>();
    // Moments centred at p_j for precision (six scalars: no temporaries in the hot loop).
    double sx = 0.0, sy = 0.0, sz = 0.0, sxx = 0.0, sxy = 0.0, sxz = 0.0, syy = 0.0, syz = 0.0,
           szz = 0.0, count = 0.0, v = 0.0;
    for_each([&](double qx, double qy, double qz) {
      const double dx = qx - pj.x(), dy = qy - pj.y(), dz = qz - pj.z();
      const double d2 = dx * dx + dy * dy + dz * dz;
      if (d2 <= r2) {
        // eq. 25 over the kernel's neighbours: the point itself adds theta(0) = 1.
        if (kernel_density) v += std::exp(k_theta * d2);
        sx += dx;
        sy += dy;
        sz += dz;
        sxx += dx * dx;
        sxy += dx * dy;
        sxz += dx * dz;
        syy += dy * dy;
        syz += dy * dz;
        szz += dz * dz;
        count += 1.0;
      }
    });
    const Vector3d sum(sx, sy, sz);
    Matrix3d sum2;
    sum2 << sxx, sxy, sxz, sxy, syy, syz, sxz, syz, szz;
    if (kernel_density) density_[static_cast<std::size_t>(j)] = std::max(v, 1.0);
    if (count < 1.0) count = 1.0;  // the point itself is always within r
    const Vector3d mean = sum / count;
    return {j, r, count, sum2 / count - mean * mean.transpose()};
  }

  // Scratch of finish_initial, per thread.
  struct FinishScratch {
    std::vector<Matrix3d> covs, vectors;
    std::vector<Vector3d> values;
  };

  // Eq. 12 from the moments: Sigma0 = Sigma_r r / (sigma_max(Sigma_r) count^(1/3)) + bias I,
  // with the normal axis (the eigenvector of the smallest eigenvalue). The eigen decompositions
  // run a packet at a time (sym_eigen3.h); each point's result is the same in any batch.
  void finish_initial(const std::vector<Moments>& batch, FinishScratch& sc) {
    const std::size_t n = batch.size();
    sc.covs.resize(n);
    sc.values.resize(n);
    sc.vectors.resize(n);
    for (std::size_t t = 0; t < n; ++t)
      sc.covs[t] = batch[t].cov_r;
    detail::sym_eigen3(sc.covs.data(), n, sc.values.data(), sc.vectors.data());
    for (std::size_t t = 0; t < n; ++t) {
      const Moments& mo = batch[t];
      const Vector3d& values = sc.values[t];
      const Matrix3d& vectors = sc.vectors[t];
      Component& comp = comps_[static_cast<std::size_t>(mo.j)];
      comp.mu = pts_.col(mo.j).cast<double>();
      const double bias = p_.cov_bias * mo.r * mo.r;
      const double lmax = std::max(values(2), 0.0);
      const double sigma_max = std::sqrt(lmax);
      // eq. 12: Sigma0 = Sigma_r * scale + bias I, whose eigenvalues are ev_r * scale + bias.
      const double scale = sigma_max > 0.0 ? mo.r / (sigma_max * std::cbrt(mo.count)) : 0.0;
      const Matrix3d cov0 = mo.cov_r * scale + Matrix3d::Identity() * bias;
      const Vector3d ev = values * scale + Vector3d::Constant(bias);
      hem_detail::store_conditioned(comp, 0.5 * (cov0 + cov0.transpose()), ev, abs_floor_,
                                    [&] { return vectors; });
      comp.axis = sigma_max > 0.0 ? Vector3d(vectors.col(0)) : Vector3d::UnitZ();
      comp.spread = p_.normal_spread0;
    }
  }

  // Eq. 12's moments of point j from the kd-tree's neighbours within r.
  Moments tree_moments(Index j, double r) {
    Hits own;
    tree().radius(pts_.col(j), static_cast<float>(r) * (1.0f + kSlack), own);
    return moments(j, r, [&](auto&& f) {
      for (const auto& hit : own)
        f(pts_(0, hit.first), pts_(1, hit.first), pts_(2, hit.first));
    });
  }

  // Scratch of block_nn, per thread.
  struct NnScratch {
    std::vector<float> best;  // k_nn entries
    std::vector<Cell> wide;
    std::vector<float> wide_best;
    CellBoxes boxes;
    std::vector<Range> ranges;
    Candidates near;  // nearest_in_block's candidates of a cell
    std::vector<Range> near_range;
  };

  // The k_nn smallest positive squared distances from q to the points of `block` into `best`
  // (ascending, +inf where fewer); returns the number of zero distances. nearest_k for k_nn up
  // to 8; beyond, cell by cell, a cell farther than the current k-th nearest skipped (`boxes`:
  // scratch).
  int nearest_lists(const NeighborGrid& g, const Vector3f& qf, const std::vector<Cell>& block,
                    NnScratch& sc, std::vector<float>& best) const {
    int zeros = 0;
    if (k_nn_ >= 1 && k_nn_ <= kMaxListK) {
      merged_ranges(block, sc.ranges);
      kNearestK[static_cast<std::size_t>(k_nn_ - 1)](g.x(), g.y(), g.z(), qf, sc.ranges,
                                                     best.data(), zeros);
      return zeros;
    }
    CellBoxes& boxes = sc.boxes;
    boxes.set(block);
    boxes.measure(g, qf.cast<double>());
    std::fill(best.begin(), best.end(), std::numeric_limits<float>::infinity());
    float worst = best.back();
    for (std::size_t t = 0; t < block.size(); ++t) {
      const Cell& cell = block[t];
      if (boxes.bound(t) > static_cast<double>(worst)) continue;
      scan_cell(
          g, qf, cell, [&](Float4 dd) { return dd < worst; },
          [&](std::size_t, float d) {
            if (!(d < worst)) return;
            if (d == 0.0f) {
              ++zeros;
              return;
            }
            auto at = best.end() - 1;
            for (; at != best.begin() && *(at - 1) > d; --at)
              *at = *(at - 1);
            *at = d;
            worst = best.back();
          });
    }
    return zeros;
  }

  // The wanted count among the k_nn smallest positive distances: the k_query nearest hold
  // min(zeros, k_query) duplicates (the point itself included).
  int wanted(int zeros) const { return std::min(k_nn_, k_query_ - std::min(zeros, k_query_)); }
  static double mean_of(const std::vector<float>& best, int want) {
    double sum = 0.0;
    for (std::size_t i = 0; i < static_cast<std::size_t>(want); ++i)
      sum += std::sqrt(static_cast<double>(best[i]));
    return sum / want;
  }

  // mean_nn of point j (at qf) from the cells of `g` in `cells` when its wanted nearest lie within
  // `guaranteed` of it (every point within that distance is in `cells`), else wide_nn.
  double block_nn(const NeighborGrid& g, Index j, const Vector3f& qf,
                  const std::vector<Cell>& cells, float guaranteed, NnScratch& sc) const {
    std::vector<float>& best = sc.best;
    // The k_nn smallest positive distances and the zeros (duplicates, the point itself
    // included).
    const int want = wanted(nearest_lists(g, qf, cells, sc, best));
    if (want <= 0) return 0.0;
    if (!(best[static_cast<std::size_t>(want - 1)] <= guaranteed * guaranteed))
      return wide_nn(g, j, guaranteed, sc.wide, sc.wide_best);  // (infinite if fewer)
    return mean_of(best, want);
  }

  // Nearest-neighbour distances (nn_) of the points of grid cell c from its block (span 1);
  // returns the largest eq. 12 radius among them. For k_nn <= 8 the block's points within
  // near_reach of some point of the cell (a bound about the cell's centre) are gathered once:
  // a point whose wanted nearest all lie within near_reach of it has them among those, the
  // same distances as from the whole block; the others search the block (block_nn).
  double nearest_in_block(std::size_t c, const std::vector<Cell>& block, NnScratch& sc) {
    const NeighborGrid& g = *g_;
    double r_max = 0.0;
    const detail::GridRange own = g.cell_range(c);
    const auto ob = static_cast<std::size_t>(own.begin), oe = static_cast<std::size_t>(own.end);
    const bool lists = k_nn_ >= 1 && k_nn_ <= kMaxListK;
    const float near_reach = kNearShare * guaranteed_;
    const float limit = near_reach * (1.0f - 4.0f * kSlack);  // what the gathered points hold
    if (lists) gather_near(g, ob, oe, block, near_reach, sc);
    for (std::size_t k = ob; k < oe; ++k) {
      const Index j = g.index(static_cast<Index>(k));
      const Vector3f qf(g.x()[k], g.y()[k], g.z()[k]);
      double nnd = -1.0;
      if (lists) {
        int zeros = 0;
        kNearestK[static_cast<std::size_t>(k_nn_ - 1)](sc.near.x.data(), sc.near.y.data(),
                                                       sc.near.z.data(), qf, sc.near_range,
                                                       sc.best.data(), zeros);
        const int want = wanted(zeros);
        if (want <= 0)
          nnd = 0.0;
        else if (sc.best[static_cast<std::size_t>(want - 1)] <= limit * limit)
          nnd = mean_of(sc.best, want);
      }
      if (nnd < 0.0) nnd = block_nn(g, j, qf, block, guaranteed_, sc);
      nn_[static_cast<std::size_t>(j)] = nnd;
      r_max = std::max(r_max, p_.init_radius_factor * nnd);
    }
    return r_max;
  }

  // Share of the grid width within which nearest_in_block's gathered candidates hold every
  // point: the wanted nearest (about 1.4 typical spacings) of almost every point lie within it.
  static constexpr float kNearShare = 0.4f;

  // Into sc.near: the points of `block` within near_reach of any of the points [ob, oe) (a float
  // bound with slack about their box's centre), in position order.
  void gather_near(const NeighborGrid& g, std::size_t ob, std::size_t oe,
                   const std::vector<Cell>& block, float near_reach, NnScratch& sc) const {
    Vector3f lo(g.x()[ob], g.y()[ob], g.z()[ob]), hi = lo;
    for (std::size_t k = ob + 1; k < oe; ++k) {
      const Vector3f p(g.x()[k], g.y()[k], g.z()[k]);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const Vector3f centre = 0.5f * (lo + hi);
    float reach = 0.0f;
    for (std::size_t k = ob; k < oe; ++k)
      reach = std::max(reach, (Vector3f(g.x()[k], g.y()[k], g.z()[k]) - centre).norm());
    const float bound = (reach * (1.0f + kSlack) + near_reach) * (1.0f + kSlack);
    merged_ranges(block, sc.ranges);
    std::size_t room = detail::kCompactSlack;
    for (const auto& [b, e] : sc.ranges)
      room += e - b;
    Candidates& near = sc.near;
    near.reserve(room);
    std::size_t m = 0;
    for (const auto& [b, e] : sc.ranges)
      m = detail::compact_within(g.x(), g.y(), g.z(), b, e, centre, bound * bound, near.pos.data(),
                                 m);
    for (std::size_t i = 0; i < m; ++i) {
      near.x[i] = g.x()[near.pos[i]];
      near.y[i] = g.y()[near.pos[i]];
      near.z[i] = g.z()[near.pos[i]];
    }
    near.size = m;
    near.pad(Candidates::kMaxLanes);
    sc.near_range.assign(1, Range{0, m});
  }

  // Scratch of initial_in_cell, per thread.
  struct CellScratch {
    std::vector<Cell> wide, far;
    CellBoxes boxes, far_boxes;
    std::vector<std::size_t> hits;
    std::vector<Moments> batch;
    FinishScratch finish;
  };

  // Eq. 12 for the points of grid cell c from the cells within `span` of it: they hold every
  // point within span * guaranteed of the cell's points; a point reaching further takes the
  // cells within its own span (up to kMaxWide; `far`), or else the kd-tree. Either way its
  // neighbours are summed in cell and position order, except from the kd-tree (tree order).
  // Points with only duplicates among their nearest wait for initial_of_duplicates().
  void initial_in_cell(std::size_t c, double r_max, const std::vector<Cell>& block,
                       CellScratch& sc) {
    const NeighborGrid& g = *g_;
    const float guaranteed = guaranteed_;
    const std::int64_t span = std::min<std::int64_t>(
        static_cast<std::int64_t>(std::floor(r_max / guaranteed)) + 1, kMaxSpan);
    const std::vector<Cell>* cells = &block;
    if (span > 1) {
      cells_around(g, g.cell_coords(c), span, sc.wide);
      cells = &sc.wide;
    }
    sc.boxes.set(*cells);
    sc.batch.clear();
    const auto reach = static_cast<float>(span) * guaranteed;
    const detail::GridRange own = g.cell_range(c);
    for (auto k = static_cast<std::size_t>(own.begin); k < static_cast<std::size_t>(own.end); ++k) {
      const Index j = g.index(static_cast<Index>(k));
      const double nnd = nn_[static_cast<std::size_t>(j)];
      if (!(nnd > 0.0)) continue;  // only duplicates: r needs the median, below
      const double r = p_.init_radius_factor * nnd;
      const auto rf = static_cast<float>(r);
      const std::vector<Cell>* point_cells = cells;
      CellBoxes* boxes = &sc.boxes;
      if (rf * (1.0f + kSlack) > reach) {  // the cells within its own span, or the kd-tree
        const auto own_span =
            static_cast<std::int64_t>(std::floor(rf * (1.0f + kSlack) / guaranteed)) + 1;
        if (own_span > kMaxWide) {
          sc.batch.push_back(tree_moments(j, r));
          continue;
        }
        cells_around(g, g.cell_coords(c), own_span, sc.far);
        sc.far_boxes.set(sc.far);
        point_cells = &sc.far;
        boxes = &sc.far_boxes;
      }
      const Vector3f qf(g.x()[k], g.y()[k], g.z()[k]);
      const Vector3d q = qf.cast<double>();
      const float pre = rf * rf * (1.0f + 4.0f * kSlack);
      // The positions within the float bound, in cell and position order, then eq. 12's sums
      // over them in that order (moments' exact test decides). The cells within reach that
      // follow each other in the sorted arrays are filtered as one range (compact_within tests
      // each point alone: the same positions as cell by cell).
      boxes->measure(g, q);
      std::vector<std::size_t>& hits = sc.hits;
      std::size_t m = 0, b = 0, e = 0;
      const auto filter = [&] {
        const std::size_t room = m + (e - b) + detail::kCompactSlack;
        if (hits.size() < room) hits.resize(2 * room);
        m = detail::compact_within(g.x(), g.y(), g.z(), b, e, qf, pre, hits.data(), m);
      };
      for (std::size_t t = 0; t < point_cells->size(); ++t) {
        if (boxes->bound(t) > r * r) continue;
        const Cell& cell = (*point_cells)[t];
        if (cell.begin == e && e > b) {
          e = cell.end;
          continue;
        }
        if (e > b) filter();
        b = cell.begin;
        e = cell.end;
      }
      if (e > b) filter();
      sc.batch.push_back(moments(j, r, [&](auto&& f) {
        for (std::size_t t = 0; t < m; ++t)
          f(g.x()[hits[t]], g.y()[hits[t]], g.z()[hits[t]]);
      }));
    }
    finish_initial(sc.batch, sc.finish);
  }

  // Points with only duplicates among their nearest take the median distinct spacing.
  void initial_of_duplicates() {
    const Index n = pts_.cols();
    if (std::all_of(nn_.begin(), nn_.end(), [](double d) { return d > 0.0; })) return;
    std::vector<double> positive;
    for (double d : nn_)
      if (d > 0.0) positive.push_back(d);
    double median_nn = 0.0;
    if (!positive.empty()) {
      auto mid = positive.begin() + static_cast<std::ptrdiff_t>(positive.size() / 2);
      std::nth_element(positive.begin(), mid, positive.end());
      median_nn = *mid;
    }
    if (median_nn <= 0.0) median_nn = std::max(h_abs_ * 0.1, std::sqrt(abs_floor_) * 10.0);
    std::vector<Moments> batch;
    for (Index j = 0; j < n; ++j)
      if (!(nn_[static_cast<std::size_t>(j)] > 0.0))
        batch.push_back(tree_moments(j, p_.init_radius_factor * median_nn));
    FinishScratch sc;
    finish_initial(batch, sc);
  }

  const Eigen::Matrix3Xf& pts_;
  const HemParams& p_;
  const double h_abs_, abs_floor_;
  const int k_nn_;
  const int k_query_;  // the nearest k_query points, duplicates included
  const bool kernel_density_;
  const double k_theta_;
  mutable std::once_flag tree_once_;
  mutable std::optional<KdTree> tree_storage_;
  std::optional<NeighborGrid> density_grid_;  // cells of width >= h (weighted only)
  std::optional<NeighborGrid> g_;             // the grid of the neighbour searches
  float guaranteed_ = 0.0f;
  std::vector<double> density_;  // v_j of eq. 25
  std::vector<double> nn_;       // per point: mean distance to its k_nn nearest distinct points
  Components comps_;
};

}  // namespace

namespace hem_detail {

Components initial_mixture(const Eigen::Matrix3Xf& pts, const HemParams& p, double h_abs,
                           double abs_floor) {
  return Level0(pts, p, h_abs, abs_floor).build();
}

}  // namespace hem_detail

}  // namespace scanbench::algorithms
