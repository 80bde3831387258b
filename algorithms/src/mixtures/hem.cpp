#include "scanbench/algorithms/hem.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>
#include <type_traits>
#include <utility>

#include "mixtures/hem_internal.h"
#include "spatial/neighbor_grid.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/simd_dispatch.h"
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

constexpr double kLog2Pi = 1.8378770664093453;
// Relative slack of float distance bounds; the exact tests decide membership.
constexpr float kSlack = 1e-5f;

// Stores in c the symmetric `sym` with its eigenvalues clamped to >= max(abs_floor, 1e-6
// lambda_max), with its largest eigenvalue and log-determinant. `ev`: the eigenvalues of `sym`
// (ascending); `vectors()`: its eigenvectors, asked for only when clamping is needed.
template <class Vectors>
void store_conditioned(Component& c, const Matrix3d& sym, Vector3d ev, double abs_floor,
                       Vectors&& vectors) {
  const double floor = std::max(abs_floor, 1e-6 * ev(2));
  if (ev(0) >= floor) {
    c.cov = sym;
  } else {
    ev = ev.cwiseMax(floor);
    const Matrix3d v = vectors();
    const Matrix3d r = v * ev.asDiagonal() * v.transpose();
    c.cov = 0.5 * (r + r.transpose());
  }
  c.lmax = ev(2);
  c.logdet = std::log(ev(0)) + std::log(ev(1)) + std::log(ev(2));
}

// The covariance guard: symmetric, eigenvalues clamped (closed-form 3x3 eigenvalues; the
// iterative solver only for the rare matrix that needs clamping).
}  // namespace

namespace hem_detail {

void set_conditioned(Component& c, const Matrix3d& cov, double abs_floor) {
  const Matrix3d s = 0.5 * (cov + cov.transpose());
  Eigen::SelfAdjointEigenSolver<Matrix3d> es;
  es.computeDirect(s, Eigen::EigenvaluesOnly);
  store_conditioned(c, s, es.eigenvalues(), abs_floor, [&] {
    es.compute(s);
    return Matrix3d(es.eigenvectors());
  });
}

}  // namespace hem_detail

namespace {

using hem_detail::set_conditioned;

// Eigen decomposition of a symmetric 3x3 matrix: the closed form where its eigenvectors are
// provably accurate (residual |A v - lambda v| below 1e-6 of the eigenvalue gap, so the angle
// error is below 1e-6 rad), otherwise the iterative solver (near-degenerate eigenvalues).
Eigen::SelfAdjointEigenSolver<Matrix3d> eigen_decomposition(const Matrix3d& a) {
  Eigen::SelfAdjointEigenSolver<Matrix3d> es;
  es.computeDirect(a);
  const Vector3d ev = es.eigenvalues();
  bool accurate = ev.allFinite();
  for (int i = 0; i < 3 && accurate; ++i) {
    double gap = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k)
      if (k != i) gap = std::min(gap, std::abs(ev(i) - ev(k)));
    const double residual =
        (a * es.eigenvectors().col(i) - ev(i) * es.eigenvectors().col(i)).norm();
    accurate = residual <= 1e-6 * gap;
  }
  if (!accurate) es.compute(a);
  return es;
}

// Points sorted into a two-level grid: coarse cubes of width `width`, each split into split^3
// fine cubes. Every point within `width` of a point lies in the 3 x 3 x 3 block of coarse cells
// around that point's cell, so a neighbour search of radius <= width needs no tree: it reads the
// block's contiguous ranges of the sorted coordinates.
struct Grid {
  double width = 0.0;
  Vector3d origin = Vector3d::Zero();   // cell (i, j, k) spans origin + width * [i, i + 1) x ...
  std::vector<Index> order;             // point indices in grid order
  std::vector<float> x, y, z;           // their coordinates (structure of arrays)
  std::vector<std::uint64_t> key;       // coarse cells, ascending
  std::vector<std::size_t> start;       // coarse cell c: positions start[c] .. start[c + 1]
  std::vector<std::size_t> fine_first;  // coarse cell c: fine cells fine_first[c] .. [c + 1]
  std::vector<std::size_t> fine_start;  // fine cell f: positions fine_start[f] .. [f + 1]
  std::vector<Vector3f> fine_centre;    // bounding-box centre of a fine cell's points
  std::vector<float> fine_reach;        // largest distance of its points from that centre

  std::size_t cells() const { return key.size(); }

  // Position ranges of the existing coarse cells of the block around cell c, in key order.
  void block(std::size_t c, std::vector<Range>& out) const {
    out.clear();
    constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
    const std::uint64_t k = key[c];
    const auto ix = static_cast<std::int64_t>(k >> 42),
               iy = static_cast<std::int64_t>((k >> 21) & kMask),
               iz = static_cast<std::int64_t>(k & kMask);
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        const std::int64_t a = ix + dx, b = iy + dy;
        if (a < 0 || b < 0 || a > static_cast<std::int64_t>(kMask) ||
            b > static_cast<std::int64_t>(kMask))
          continue;
        // The three cells (a, b, iz - 1 .. iz + 1) are consecutive keys: one search.
        const std::uint64_t lo_key = (static_cast<std::uint64_t>(a) << 42) |
                                     (static_cast<std::uint64_t>(b) << 21) |
                                     static_cast<std::uint64_t>(std::max<std::int64_t>(iz - 1, 0));
        const std::uint64_t hi_key =
            (static_cast<std::uint64_t>(a) << 42) | (static_cast<std::uint64_t>(b) << 21) |
            static_cast<std::uint64_t>(std::min<std::int64_t>(iz + 1, kMask));
        const auto first = std::lower_bound(key.begin(), key.end(), lo_key);
        const auto last = std::upper_bound(first, key.end(), hi_key);
        if (first != last)
          out.emplace_back(start[static_cast<std::size_t>(first - key.begin())],
                           start[static_cast<std::size_t>(last - key.begin())]);
      }
  }

  struct Cell {
    std::size_t begin, end;  // positions
    Vector3d lo;             // lower corner of the cube (upper: lo + width)
  };
  // The existing cells of the block around cell c, cell c first, then in key order.
  void block_cells(std::size_t c, std::vector<Cell>& out) const {
    constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
    const std::uint64_t k = key[c];
    cells_around({static_cast<std::int64_t>(k >> 42), static_cast<std::int64_t>((k >> 21) & kMask),
                  static_cast<std::int64_t>(k & kMask)},
                 1, out);
    const auto own = std::find_if(out.begin(), out.end(),
                                  [&](const Cell& cell) { return cell.begin == start[c]; });
    std::rotate(out.begin(), own, own + 1);
  }

  // Integer cell coordinates of q (q may lie outside the grid's points).
  std::array<std::int64_t, 3> coords(const Vector3d& q) const {
    std::array<std::int64_t, 3> c{};
    for (int d = 0; d < 3; ++d) {
      const double t = std::floor((q(d) - origin(d)) / width);
      c[static_cast<std::size_t>(d)] =
          static_cast<std::int64_t>(std::clamp(t, -4.0 * (1 << 21), 4.0 * (1 << 21)));
    }
    return c;
  }

  // The existing cells within `span` cells of coordinates c on every axis, in key order: they
  // hold every point within span * width * (1 - 1e-5) of any point of cell c.
  void cells_around(const std::array<std::int64_t, 3>& c, std::int64_t span,
                    std::vector<Cell>& out) const {
    out.clear();
    constexpr std::int64_t kMask = (std::int64_t{1} << 21) - 1;
    auto corner = [&](std::uint64_t k) {
      return Vector3d(origin.x() + width * static_cast<double>(k >> 42),
                      origin.y() + width * static_cast<double>((k >> 21) & kMask),
                      origin.z() + width * static_cast<double>(k & kMask));
    };
    auto make_key = [](std::int64_t a, std::int64_t b, std::int64_t z) {
      return (static_cast<std::uint64_t>(a) << 42) | (static_cast<std::uint64_t>(b) << 21) |
             static_cast<std::uint64_t>(z);
    };
    const std::int64_t zlo = std::max<std::int64_t>(c[2] - span, 0);
    const std::int64_t zhi = std::min<std::int64_t>(c[2] + span, kMask);
    if (zlo > zhi) return;
    const double columns = (2.0 * static_cast<double>(span) + 1.0) * (2.0 * span + 1.0);
    if (columns >= static_cast<double>(key.size())) {  // a huge span: every cell, in key order
      for (std::size_t ci = 0; ci < key.size(); ++ci)
        out.push_back({start[ci], start[ci + 1], corner(key[ci])});
      return;
    }
    for (std::int64_t a = std::max<std::int64_t>(c[0] - span, 0);
         a <= std::min<std::int64_t>(c[0] + span, kMask); ++a)
      for (std::int64_t b = std::max<std::int64_t>(c[1] - span, 0);
           b <= std::min<std::int64_t>(c[1] + span, kMask); ++b) {
        // The cells (a, b, zlo .. zhi) are consecutive keys: one search.
        const std::uint64_t last_key = make_key(a, b, zhi);
        for (auto it = std::lower_bound(key.begin(), key.end(), make_key(a, b, zlo));
             it != key.end() && *it <= last_key; ++it) {
          const auto ci = static_cast<std::size_t>(it - key.begin());
          out.push_back({start[ci], start[ci + 1], corner(*it)});
        }
      }
  }

  // A lower bound of the squared distance from q to the points of `cell`: the distance to its
  // cube grown by 1e-9 width (points sit in their cube up to the rounding of the cell index),
  // shrunk by 1e-6 relative (the float distances it is compared with).
  double box_distance2(const Vector3d& q, const Cell& cell) const {
    const double hair = 1e-9 * width;
    const Vector3d below = cell.lo - q - Vector3d::Constant(hair);
    const Vector3d above = q - (cell.lo + Vector3d::Constant(width + hair));
    return below.cwiseMax(above).cwiseMax(0.0).squaredNorm() * (1.0 - 1e-6);
  }
};

Grid make_grid(const Eigen::Matrix3Xf& pts, double width, int split) {
  const Index n = pts.cols();
  const Vector3f lo = pts.rowwise().minCoeff();
  const Vector3f hi = pts.rowwise().maxCoeff();
  constexpr double kAxisCells = 1 << 20;  // 21-bit keys per axis never clamp
  Grid g;
  g.width = std::max(width, static_cast<double>((hi - lo).maxCoeff()) / kAxisCells);
  if (!(g.width > 0.0) || !std::isfinite(g.width)) g.width = 1.0;
  g.origin = lo.cast<double>();
  const double fine = g.width / split;
  struct Entry {
    std::uint64_t key;
    std::uint32_t sub;
    Index i;
    bool operator<(const Entry& o) const {
      return key != o.key ? key < o.key : sub != o.sub ? sub < o.sub : i < o.i;
    }
  };
  std::vector<Entry> e(static_cast<std::size_t>(n));
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, 4096), [&](const tbb::blocked_range<Index>& r) {
    for (Index i = r.begin(); i < r.end(); ++i) {
      std::uint64_t key = 0;
      std::uint32_t sub = 0;
      for (int d = 0; d < 3; ++d) {
        const double t = static_cast<double>(pts(d, i)) - static_cast<double>(lo(d));  // exact
        const auto c =
            static_cast<std::uint64_t>(std::clamp(std::floor(t / g.width), 0.0, kAxisCells));
        const auto f = static_cast<std::uint32_t>(
            std::clamp(std::floor(t / fine) - static_cast<double>(c) * split, 0.0, split - 1.0));
        key = (key << 21) | c;
        sub = sub * static_cast<std::uint32_t>(split) + f;
      }
      e[static_cast<std::size_t>(i)] = {key, sub, i};
    }
  });
  tbb::parallel_sort(e.begin(), e.end());  // a total order: the same result for any thread count
  g.order.resize(e.size());
  g.x.resize(e.size());
  g.y.resize(e.size());
  g.z.resize(e.size());
  for (std::size_t k = 0; k < e.size(); ++k) {
    const Index i = e[k].i;
    g.order[k] = i;
    g.x[k] = pts(0, i);
    g.y[k] = pts(1, i);
    g.z[k] = pts(2, i);
    if (k == 0 || e[k].key != e[k - 1].key) {
      g.key.push_back(e[k].key);
      g.start.push_back(k);
      g.fine_first.push_back(g.fine_start.size());
    }
    if (k == 0 || e[k].key != e[k - 1].key || e[k].sub != e[k - 1].sub) g.fine_start.push_back(k);
  }
  g.start.push_back(e.size());
  g.fine_first.push_back(g.fine_start.size());
  g.fine_start.push_back(e.size());
  const std::size_t nf = g.fine_start.size() - 1;
  g.fine_centre.resize(nf);
  g.fine_reach.resize(nf);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 256), [&](const auto& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      const std::size_t b = g.fine_start[f], end = g.fine_start[f + 1];
      Vector3f mn(g.x[b], g.y[b], g.z[b]), mx = mn;
      for (std::size_t k = b + 1; k < end; ++k) {
        mn = mn.cwiseMin(Vector3f(g.x[k], g.y[k], g.z[k]));
        mx = mx.cwiseMax(Vector3f(g.x[k], g.y[k], g.z[k]));
      }
      const Vector3f centre = 0.5f * (mn + mx);
      float reach = 0.0f;
      for (std::size_t k = b; k < end; ++k)
        reach = std::max(reach, (Vector3f(g.x[k], g.y[k], g.z[k]) - centre).norm());
      g.fine_centre[f] = centre;
      g.fine_reach[f] = reach * (1.0f + kSlack);
    }
  });
  return g;
}

// GCC/Clang vector extensions: 4 floats, portable SIMD for the nearest-neighbour scans of the
// initial mixture (the density pass uses the packet of the active ISA).
using Float4 = float __attribute__((vector_size(16)));
using Int4 = std::int32_t __attribute__((vector_size(16)));

inline Float4 load4(const float* p) {
  Float4 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

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
std::vector<double> density_weights_impl(const Grid& g, double h) {
  namespace ei = Eigen::internal;
  constexpr std::size_t kLanes = ei::unpacket_traits<Packet>::size;
  static_assert(kLanes <= Candidates::kMaxLanes);
  const std::size_t n = g.order.size();
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
      g.block(c, ranges);
      for (std::size_t f = g.fine_first[c]; f < g.fine_first[c + 1]; ++f) {
        const std::size_t own_b = g.fine_start[f], own_e = g.fine_start[f + 1];
        own.reserve(own_e - own_b);
        own.size = 0;
        for (std::size_t k = own_b; k < own_e; ++k, ++own.size) {
          own.x[own.size] = g.x[k];
          own.y[own.size] = g.y[k];
          own.z[own.size] = g.z[k];
          own.pos[own.size] = k;
        }
        own.pad(kLanes);
        const Vector3f centre = g.fine_centre[f];
        const float reach = hf * (1.0f + kSlack) + g.fine_reach[f];
        const float reach2 = reach * reach;
        // Branch-free compaction.
        std::size_t bound = 0;
        for (const auto& [b, e] : ranges)
          bound += e - std::min(e, std::max(b, own_e));
        cand.reserve(bound);
        std::size_t m = 0;
        for (const auto& [b, e] : ranges)
          for (std::size_t k = std::max(b, own_e); k < e; ++k) {
            const float dx = g.x[k] - centre.x(), dy = g.y[k] - centre.y(),
                        dz = g.z[k] - centre.z();
            cand.x[m] = g.x[k];
            cand.y[m] = g.y[k];
            cand.z[m] = g.z[k];
            cand.pos[m] = k;
            m += dx * dx + dy * dy + dz * dz <= reach2 ? 1 : 0;
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
    v[static_cast<std::size_t>(g.order[k])] = static_cast<double>(total[k]) / scale;
  return v;
}

// The density pass with the packet of the active ISA (scanbench/core/simd.h).
std::vector<double> density_weights(const Grid& g, double h) {
  return simd::with_packet(
      [&](auto tag) { return density_weights_impl<typename decltype(tag)::type>(g, h); });
}

}  // namespace

namespace hem_detail {

Components initial_mixture(const Eigen::Matrix3Xf& pts, const HemParams& p, double h_abs,
                           double abs_floor) {
  const Index n = pts.cols();
  // The kd-tree serves only the searches that outgrow the grids (none on typical scans): built on
  // first use, once.
  std::once_flag tree_once;
  std::optional<KdTree> tree_storage;
  auto tree = [&]() -> const KdTree& {
    std::call_once(tree_once, [&] { tree_storage.emplace(pts); });
    return *tree_storage;
  };
  std::optional<Grid> density_grid;
  std::vector<double> density;
  if (p.weighted) {
    density_grid.emplace(make_grid(pts, h_abs * (1.0 + 10.0 * kSlack), 3));
    // density "kernel": summed in the eq. 12 kernel pass below (set_initial).
    if (p.density == "support") density = density_weights(*density_grid, h_abs);
  }
  const int k_nn = p.init_neighbors;
  const int k_query = k_nn + 8;  // the nearest k_query points, duplicates included

  // Mean distance to the k_nn nearest distinct points among the k_query nearest (squared
  // distances ascending: `d2`, of the k_query nearest or of all points when fewer).
  auto mean_nn = [&](const auto& d2) {
    double sum = 0.0;
    int found = 0;
    for (float d : d2) {
      if (d > 0.0f && found < k_nn) {
        sum += std::sqrt(static_cast<double>(d));
        ++found;
      }
    }
    return found > 0 ? sum / found : 0.0;
  };
  auto tree_nn = [&](Index j) {
    std::vector<Index> idx;
    std::vector<float> d2;
    tree().knn(pts.col(j), k_query, idx, d2);
    return mean_nn(d2);
  };

  // Typical spacing from a fixed subset: sizes the grid of the neighbour searches. With the
  // density grid (cells of width >= h), the k_query nearest come from the block of cells around
  // the point when the farthest of them lies within the block's guaranteed reach; the squared
  // distances are the kd-tree's ((dx^2 + dy^2) + dz^2 in float), so the mean is the same.
  double spacing = 0.0;
  {
    std::vector<double> all((static_cast<std::size_t>(n) + 60) / 61);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, all.size(), 16), [&](const auto& r) {
      std::vector<Grid::Cell> block;
      std::vector<float> best(static_cast<std::size_t>(k_query));
      for (std::size_t k = r.begin(); k != r.end(); ++k) {
        const Index j = static_cast<Index>(k) * 61;
        if (!density_grid) {
          all[k] = tree_nn(j);
          continue;
        }
        const Grid& dg = *density_grid;
        const Vector3f qf = pts.col(j);
        dg.cells_around(dg.coords(qf.cast<double>()), 1, block);
        std::fill(best.begin(), best.end(), std::numeric_limits<float>::infinity());
        for (const Grid::Cell& cell : block)
          for (std::size_t i = cell.begin; i < cell.end; ++i) {
            const float dx = qf.x() - dg.x[i], dy = qf.y() - dg.y[i], dz = qf.z() - dg.z[i];
            const float d = dx * dx + dy * dy + dz * dz;
            if (!(d < best.back())) continue;
            auto at = best.end() - 1;
            for (; at != best.begin() && *(at - 1) > d; --at)
              *at = *(at - 1);
            *at = d;
          }
        const auto reach = static_cast<float>(dg.width) * (1.0f - 4.0f * kSlack);
        all[k] = best.back() <= reach * reach ? mean_nn(best) : tree_nn(j);
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
  }
  if (!(spacing > 0.0)) spacing = std::max(h_abs * 0.1, std::sqrt(abs_floor) * 10.0);

  // Grid cells of width W: every neighbour within W * (1 - slack) of a point is in its block
  // (nearest neighbours), within span * W * (1 - slack) in the cells within `span` (radius r).
  // A point whose neighbours reach further (span > kMaxSpan) asks the kd-tree.
  const Grid g = make_grid(pts, std::max(3.0, 2.0 * p.init_radius_factor) * spacing, 2);
  constexpr std::int64_t kMaxSpan = 4;
  const float guaranteed = static_cast<float>(g.width) * (1.0f - 4.0f * kSlack);
  std::vector<double> nn(static_cast<std::size_t>(n), 0.0);
  Components comps(static_cast<std::size_t>(n));
  const bool kernel_density = p.weighted && p.density == "kernel";
  const double k_theta = -16.0 / (h_abs * h_abs);
  if (kernel_density) density.assign(static_cast<std::size_t>(n), 1.0);

  // Eq. 12 for point j from its neighbours within r (`for_each` calls back with indices).
  auto set_initial = [&](Index j, double r, auto&& for_each) {
    const double r2 = r * r;
    const Vector3d pj = pts.col(j).cast<double>();
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
    Component& comp = comps[static_cast<std::size_t>(j)];
    comp.mu = pj;
    if (kernel_density) density[static_cast<std::size_t>(j)] = std::max(v, 1.0);
    const double bias = p.cov_bias * r2;
    if (count < 1.0) count = 1.0;  // the point itself is always within r
    const Vector3d mean = sum / count;
    const Matrix3d cov_r = sum2 / count - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Matrix3d> es = eigen_decomposition(cov_r);
    const double lmax = std::max(es.eigenvalues()(2), 0.0);
    const double sigma_max = std::sqrt(lmax);
    // eq. 12: Sigma0 = Sigma_r * scale + bias I, whose eigenvalues are ev_r * scale + bias.
    const double scale = sigma_max > 0.0 ? r / (sigma_max * std::cbrt(count)) : 0.0;
    const Matrix3d cov0 = cov_r * scale + Matrix3d::Identity() * bias;
    const Vector3d ev = es.eigenvalues() * scale + Vector3d::Constant(bias);
    store_conditioned(comp, 0.5 * (cov0 + cov0.transpose()), ev, abs_floor,
                      [&] { return Matrix3d(es.eigenvectors()); });
    comp.axis = sigma_max > 0.0 ? Vector3d(es.eigenvectors().col(0)) : Vector3d::UnitZ();
    comp.spread = p.normal_spread0;
  };
  auto tree_initial = [&](Index j, double r) {
    Hits own;
    tree().radius(pts.col(j), static_cast<float>(r) * (1.0f + kSlack), own);
    set_initial(j, r, [&](auto&& f) {
      for (const auto& hit : own)
        f(pts(0, hit.first), pts(1, hit.first), pts(2, hit.first));
    });
  };

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, g.cells(), 4), [&](const auto& rr) {
    std::vector<Grid::Cell> block, wide;
    std::vector<float> best(static_cast<std::size_t>(k_nn));
    for (std::size_t c = rr.begin(); c != rr.end(); ++c) {
      g.block_cells(c, block);
      // Squared float distances from q as the kd-tree evaluates them ((dx^2 + dy^2) + dz^2),
      // four at a time: `visit(i, d2)` sees only the groups in which any lane passes `below`.
      auto scan = [&](const Vector3f& q, const Grid::Cell& cell, auto&& below, auto&& visit) {
        std::size_t i = cell.begin;
        for (; i + 4 <= cell.end; i += 4) {
          const Float4 dx = load4(g.x.data() + i) - q.x(), dy = load4(g.y.data() + i) - q.y(),
                       dz = load4(g.z.data() + i) - q.z();
          const Float4 dd = dx * dx + dy * dy + dz * dz;
          if (!any_lane(below(dd))) continue;
          for (int l = 0; l < 4; ++l)
            visit(i + static_cast<std::size_t>(l), dd[l]);
        }
        for (; i < cell.end; ++i) {
          const float dx = g.x[i] - q.x(), dy = g.y[i] - q.y(), dz = g.z[i] - q.z();
          visit(i, dx * dx + dy * dy + dz * dz);
        }
      };
      // Nearest-neighbour distances of the cell's points from its block (span 1).
      double r_max = 0.0;
      for (std::size_t k = g.start[c]; k < g.start[c + 1]; ++k) {
        const Index j = g.order[k];
        const Vector3f qf(g.x[k], g.y[k], g.z[k]);
        const Vector3d q = qf.cast<double>();
        // The k_nn smallest positive distances and the zeros (duplicates, the point itself
        // included: all in its own cell, visited first). A cell farther than the current k-th
        // nearest is skipped.
        int zeros = 0;
        std::fill(best.begin(), best.end(), std::numeric_limits<float>::infinity());
        float worst = best.back();
        for (const Grid::Cell& cell : block) {
          if (g.box_distance2(q, cell) > static_cast<double>(worst)) continue;
          scan(
              qf, cell, [&](Float4 dd) { return dd < worst; },
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
        // The k_query nearest hold min(zeros, k_query) duplicates (the point itself included),
        // so the wanted distances are the `want` smallest positive ones.
        const int want = std::min(k_nn, k_query - std::min(zeros, k_query));
        double nnd = 0.0;
        if (want > 0) {
          const auto uw = static_cast<std::size_t>(want - 1);
          if (best[uw] <= guaranteed * guaranteed) {  // infinite if fewer candidates
            double sum = 0.0;
            for (std::size_t i = 0; i <= uw; ++i)
              sum += std::sqrt(static_cast<double>(best[i]));
            nnd = sum / want;
          } else {
            nnd = tree_nn(j);
          }
        }
        nn[static_cast<std::size_t>(j)] = nnd;
        r_max = std::max(r_max, p.init_radius_factor * nnd);
      }
      // Eq. 12 from the cells within `span` of this one: they hold every point within
      // span * guaranteed of the cell's points; a point reaching further asks the kd-tree.
      const std::int64_t span = std::min<std::int64_t>(
          static_cast<std::int64_t>(std::floor(r_max / guaranteed)) + 1, kMaxSpan);
      const std::vector<Grid::Cell>* cells = &block;
      if (span > 1) {
        constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
        const std::uint64_t key = g.key[c];
        g.cells_around(
            {static_cast<std::int64_t>(key >> 42), static_cast<std::int64_t>((key >> 21) & kMask),
             static_cast<std::int64_t>(key & kMask)},
            span, wide);
        cells = &wide;
      }
      const auto reach = static_cast<float>(span) * guaranteed;
      for (std::size_t k = g.start[c]; k < g.start[c + 1]; ++k) {
        const Index j = g.order[k];
        const double nnd = nn[static_cast<std::size_t>(j)];
        if (!(nnd > 0.0)) continue;  // only duplicates: r needs the median, below
        const double r = p.init_radius_factor * nnd;
        const auto rf = static_cast<float>(r);
        if (rf * (1.0f + kSlack) > reach) {
          tree_initial(j, r);
          continue;
        }
        const Vector3f qf(g.x[k], g.y[k], g.z[k]);
        const Vector3d q = qf.cast<double>();
        const float pre = rf * rf * (1.0f + 4.0f * kSlack);
        set_initial(j, r, [&](auto&& f) {
          for (const Grid::Cell& cell : *cells) {
            if (g.box_distance2(q, cell) > r * r) continue;
            scan(
                qf, cell, [&](Float4 dd) { return dd <= pre; },
                [&](std::size_t i, float d) {
                  if (d <= pre) f(g.x[i], g.y[i], g.z[i]);
                });
          }
        });
      }
    }
  });
  // Points with only duplicates among their nearest take the median distinct spacing.
  std::vector<double> positive;
  for (double d : nn)
    if (d > 0.0) positive.push_back(d);
  double median_nn = 0.0;
  if (!positive.empty()) {
    auto mid = positive.begin() + static_cast<std::ptrdiff_t>(positive.size() / 2);
    std::nth_element(positive.begin(), mid, positive.end());
    median_nn = *mid;
  }
  if (median_nn <= 0.0) median_nn = std::max(h_abs * 0.1, std::sqrt(abs_floor) * 10.0);
  for (Index j = 0; j < n; ++j)
    if (!(nn[static_cast<std::size_t>(j)] > 0.0)) tree_initial(j, p.init_radius_factor * median_nn);

  // Eq. 26 as written, w_j = (v_j |P|)^-1 (unweighted: 1/|P|), NOT renormalised: the HEM
  // likelihood exponent w_i |P| of eq. 9 is then 1/v_j at level 0 and the sum of the merged
  // children's 1/v_j (eq. 10) above it, as in the paper and the authors' code. hem_mixture()
  // normalises the final weights to sum 1 (only their ratios matter to CLOP's eq. 18 and 23).
  const double n_points = static_cast<double>(comps.size());
  for (std::size_t j = 0; j < comps.size(); ++j)
    comps[j].w = (p.weighted ? 1.0 / density[j] : 1.0) / n_points;
  return comps;
}

bool chosen_as_parent(std::uint64_t level_seed, Index i, double probability) {
  Rng rng(derive_seed(level_seed, static_cast<std::uint64_t>(i)));
  return rng.uniform() < probability;
}

struct Child {
  Index i;
  double log_term;  // log(w_s L_is)
};

// The candidate children of one parent and, per candidate i, eq. 11's D_KL(i || s) and eq. 9's
// log L_is = w_i |P| (log N(mu_i; mu_s, Sigma_s) - tr(Sigma_s^-1 Sigma_i) / 2).
struct KlBatch {
  std::vector<Index> ids;
  std::vector<double> kl, log_l;
  // Structure of arrays of the gathered candidates: mu_i - mu_s (3), Sigma_i's upper triangle
  // (xx, xy, xz, yy, yz, zz), log |Sigma_i|, w_i |P|; padded to whole packets.
  std::vector<double> f[11];
};

// Fills batch.kl and batch.log_l for batch.ids in double packets of the active ISA. Every lane
// is one candidate evaluated by the same operations in the same order, so each value is the
// same on every ISA and at any thread count (no sum runs across lanes).
template <class PacketD>
void kl_terms(const Components& comps, const Component& ps, double n_points, KlBatch& batch) {
  namespace ei = Eigen::internal;
  constexpr std::size_t kLanes = ei::unpacket_traits<PacketD>::size;
  const std::size_t m = batch.ids.size();
  const std::size_t padded = (m + kLanes - 1) / kLanes * kLanes;
  for (auto& f : batch.f)
    if (f.size() < padded) f.resize(padded);
  batch.kl.resize(padded);
  batch.log_l.resize(padded);
  for (std::size_t t = 0; t < padded; ++t) {
    if (t < m) {
      const Component& ci = comps[static_cast<std::size_t>(batch.ids[t])];
      batch.f[0][t] = ci.mu.x() - ps.mu.x();
      batch.f[1][t] = ci.mu.y() - ps.mu.y();
      batch.f[2][t] = ci.mu.z() - ps.mu.z();
      batch.f[3][t] = ci.cov(0, 0);
      batch.f[4][t] = ci.cov(0, 1);
      batch.f[5][t] = ci.cov(0, 2);
      batch.f[6][t] = ci.cov(1, 1);
      batch.f[7][t] = ci.cov(1, 2);
      batch.f[8][t] = ci.cov(2, 2);
      batch.f[9][t] = ci.logdet;
      batch.f[10][t] = ci.w * n_points;
    } else {  // padding: finite values, results ignored
      for (int e = 0; e < 11; ++e)
        batch.f[e][t] = 0.0;
    }
  }
  // Sigma_s is stored symmetric (set_conditioned, store_conditioned), and so is its inverse.
  const Matrix3d inv = ps.cov.inverse();
  const PacketD i00 = ei::pset1<PacketD>(inv(0, 0)), i01 = ei::pset1<PacketD>(inv(0, 1)),
                i02 = ei::pset1<PacketD>(inv(0, 2)), i11 = ei::pset1<PacketD>(inv(1, 1)),
                i12 = ei::pset1<PacketD>(inv(1, 2)), i22 = ei::pset1<PacketD>(inv(2, 2));
  const PacketD two = ei::pset1<PacketD>(2.0), half = ei::pset1<PacketD>(0.5);
  const PacketD three_minus_lds = ei::pset1<PacketD>(3.0 - ps.logdet);
  const PacketD log_norm = ei::pset1<PacketD>(-0.5 * (3.0 * kLog2Pi + ps.logdet));
  for (std::size_t t = 0; t < padded; t += kLanes) {
    auto ld = [&](int e) { return ei::ploadu<PacketD>(batch.f[e].data() + t); };
    const PacketD dx = ld(0), dy = ld(1), dz = ld(2);
    // d^T Sigma_s^-1 d
    const PacketD tx = ei::padd(ei::padd(ei::pmul(i00, dx), ei::pmul(i01, dy)), ei::pmul(i02, dz));
    const PacketD ty = ei::padd(ei::padd(ei::pmul(i01, dx), ei::pmul(i11, dy)), ei::pmul(i12, dz));
    const PacketD tz = ei::padd(ei::padd(ei::pmul(i02, dx), ei::pmul(i12, dy)), ei::pmul(i22, dz));
    const PacketD maha = ei::padd(ei::padd(ei::pmul(dx, tx), ei::pmul(dy, ty)), ei::pmul(dz, tz));
    // tr(Sigma_s^-1 Sigma_i) of two symmetric matrices: diagonal products + 2 x off-diagonal.
    const PacketD diag =
        ei::padd(ei::padd(ei::pmul(i00, ld(3)), ei::pmul(i11, ld(6))), ei::pmul(i22, ld(8)));
    const PacketD off =
        ei::padd(ei::padd(ei::pmul(i01, ld(4)), ei::pmul(i02, ld(5))), ei::pmul(i12, ld(7)));
    const PacketD tr = ei::padd(diag, ei::pmul(two, off));
    // eq. 11: D_KL = (d_M^2 + tr - 3 - log(|Sigma_i| / |Sigma_s|)) / 2
    const PacketD kl =
        ei::pmul(half, ei::psub(ei::padd(maha, tr), ei::padd(three_minus_lds, ld(9))));
    // eq. 9: log L_is = w_i |P| (log g(mu_i; mu_s, Sigma_s) - tr / 2)
    const PacketD log_g = ei::psub(log_norm, ei::pmul(half, maha));
    const PacketD log_l = ei::pmul(ld(10), ei::psub(log_g, ei::pmul(half, tr)));
    ei::pstoreu(batch.kl.data() + t, kl);
    ei::pstoreu(batch.log_l.data() + t, log_l);
  }
}

// One HEM level. Returns the next level's components.
Components cluster_level(const Components& comps, const HemParams& p, std::uint64_t level_seed,
                         double n_points, double abs_floor) {
  const Index n = static_cast<Index>(comps.size());
  std::vector<char> is_parent(comps.size(), 0);
  std::vector<Index> parents;
  std::vector<Index> others;  // the components that are not parents, in index order
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, 4096), [&](const tbb::blocked_range<Index>& r) {
    for (Index i = r.begin(); i < r.end(); ++i)
      is_parent[static_cast<std::size_t>(i)] =
          chosen_as_parent(level_seed, i, p.parent_probability) ? 1 : 0;
  });
  for (Index i = 0; i < n; ++i)
    (is_parent[static_cast<std::size_t>(i)] ? parents : others).push_back(i);
  if (parents.empty()) return comps;

  // Candidate children of a parent: itself, and the non-parents (other parents are never
  // children) within alpha * sigma_max(s) of mu_s.
  Eigen::Matrix3Xf centers(3, static_cast<Index>(others.size()));
  for (std::size_t k = 0; k < others.size(); ++k)
    centers.col(static_cast<Index>(k)) =
        comps[static_cast<std::size_t>(others[k])].mu.cast<float>();
  const double kl_max = 0.5 * p.alpha * p.alpha;
  const Index np = static_cast<Index>(parents.size());
  // D_KL >= d_M^2 / 2, so every admissible child of parent s is within alpha * sigma_max(s) of
  // mu_s; the float search gets a hair of slack, the exact test (eq. 11) decides.
  std::vector<float> radius(static_cast<std::size_t>(np));
  for (Index k = 0; k < np; ++k) {
    const Component& ps = comps[static_cast<std::size_t>(parents[static_cast<std::size_t>(k)])];
    radius[static_cast<std::size_t>(k)] = static_cast<float>(p.alpha * std::sqrt(ps.lmax) * 1.001 +
                                                             1e-6 * ps.mu.cwiseAbs().maxCoeff());
  }
  // The candidates come from a uniform grid of the non-parents' means (cells of the 90th
  // percentile of the search radii: at most 3 x 3 contiguous column ranges for 90% of the
  // parents, no tree walk); a parent whose radius spans more than kMaxCells cells asks a kd-tree
  // (built on first use). Either way the candidates
  // within the radius are visited in index order, so the result does not depend on the search.
  constexpr float kMaxCells = 4.0f;
  float cell = 1.0f;
  if (np > 0) {
    std::vector<float> sorted_radius = radius;
    const Index at = np * 9 / 10;
    std::nth_element(sorted_radius.begin(), sorted_radius.begin() + at, sorted_radius.end());
    cell = sorted_radius[static_cast<std::size_t>(at)];
  }
  // At most 2^20 cells per axis (the grid's keys stay far from overflow).
  if (centers.cols() > 0)
    cell = std::max(cell, (centers.rowwise().maxCoeff() - centers.rowwise().minCoeff()).maxCoeff() /
                              static_cast<float>(1 << 20));
  if (!(cell > 0.0f) || !std::isfinite(cell)) cell = 1.0f;
  const detail::NeighborGrid grid(centers, cell);
  std::once_flag tree_once;
  std::optional<KdTree> tree_storage;
  auto tree = [&]() -> const KdTree& {
    std::call_once(tree_once, [&] { tree_storage.emplace(centers); });
    return *tree_storage;
  };

  // Children of parent k: block b = k / kBlock holds the sets of its parents back to back;
  // offsets[k] .. offsets[k + 1] index into it. Fixed blocks: thread-independent.
  constexpr Index kBlock = 64;
  const Index nblocks = (np + kBlock - 1) / kBlock;
  std::vector<std::vector<Child>> block_sets(static_cast<std::size_t>(nblocks));
  std::vector<std::size_t> offsets(static_cast<std::size_t>(np) + 1, 0);
  simd::with_packet([&](auto tag) {
    using PacketD = typename simd::DoublePacket<typename decltype(tag)::type>::type;
    tbb::parallel_for(tbb::blocked_range<Index>(0, nblocks, 1),
                      [&](const tbb::blocked_range<Index>& r) {
                        Hits nb;
                        std::vector<detail::GridRange> ranges;
                        std::vector<Index> near;  // positions in `others`
                        KlBatch batch;
                        for (Index b = r.begin(); b < r.end(); ++b) {
                          auto& set = block_sets[static_cast<std::size_t>(b)];
                          for (Index k = b * kBlock; k < std::min(np, (b + 1) * kBlock); ++k) {
                            const Index s = parents[static_cast<std::size_t>(k)];
                            const Component& ps = comps[static_cast<std::size_t>(s)];
                            const float rad = radius[static_cast<std::size_t>(k)];
                            const Vector3f mu = ps.mu.cast<float>();
                            near.clear();
                            if (rad <= kMaxCells * cell) {
                              grid.ranges_near(mu, rad, ranges);
                              const float r2 = rad * rad;
                              for (const detail::GridRange& gr : ranges)
                                for (Index t = gr.begin; t < gr.end; ++t) {
                                  const float dx = grid.x()[t] - mu.x(), dy = grid.y()[t] - mu.y(),
                                              dz = grid.z()[t] - mu.z();
                                  if (dx * dx + dy * dy + dz * dz <= r2)
                                    near.push_back(grid.index(t));
                                }
                            } else {
                              tree().radius(mu, rad, nb);
                              for (const auto& hit : nb)
                                near.push_back(hit.first);
                            }
                            std::sort(near.begin(), near.end());
                            offsets[static_cast<std::size_t>(k)] = set.size();
                            // Candidates in index order, the parent itself among them.
                            batch.ids.clear();
                            bool self_done = false;
                            for (const Index at : near) {
                              const Index i = others[static_cast<std::size_t>(at)];
                              if (!self_done && s < i) {
                                batch.ids.push_back(s);
                                self_done = true;
                              }
                              batch.ids.push_back(i);
                            }
                            if (!self_done) batch.ids.push_back(s);
                            kl_terms<PacketD>(comps, ps, n_points, batch);
                            const double log_ws = std::log(ps.w);
                            for (std::size_t t = 0; t < batch.ids.size(); ++t) {
                              const Index i = batch.ids[t];
                              // eq. 11 (a parent always keeps itself)
                              if (!(batch.kl[t] < kl_max) && i != s) continue;
                              set.push_back({i, log_ws + batch.log_l[t]});
                            }
                          }
                        }
                      });
  });
  // Global offsets: block by block, in parent order.
  std::vector<std::size_t> block_base(static_cast<std::size_t>(nblocks) + 1, 0);
  for (Index b = 0; b < nblocks; ++b)
    block_base[static_cast<std::size_t>(b) + 1] =
        block_base[static_cast<std::size_t>(b)] + block_sets[static_cast<std::size_t>(b)].size();
  auto set_range = [&](Index k) {
    const auto b = static_cast<std::size_t>(k / kBlock);
    const std::size_t end = k + 1 < std::min(np, (static_cast<Index>(b) + 1) * kBlock)
                                ? offsets[static_cast<std::size_t>(k) + 1]
                                : block_sets[b].size();
    return std::pair<const Child*, const Child*>(
        block_sets[b].data() + offsets[static_cast<std::size_t>(k)], block_sets[b].data() + end);
  };

  // Log-sum-exp per child over the parents that hold it, in parent order (deterministic).
  const double neg_inf = -std::numeric_limits<double>::infinity();
  std::vector<double> cmax(comps.size(), neg_inf);
  for (const auto& set : block_sets)
    for (const Child& c : set)
      cmax[static_cast<std::size_t>(c.i)] =
          std::max(cmax[static_cast<std::size_t>(c.i)], c.log_term);
  std::vector<double> csum(comps.size(), 0.0);
  for (const auto& set : block_sets)
    for (const Child& c : set)
      csum[static_cast<std::size_t>(c.i)] +=
          std::exp(c.log_term - cmax[static_cast<std::size_t>(c.i)]);

  Components next(parents.size());
  tbb::parallel_for(tbb::blocked_range<Index>(0, np, 64), [&](const tbb::blocked_range<Index>& r) {
    for (Index k = r.begin(); k < r.end(); ++k) {
      const Component& ps = comps[static_cast<std::size_t>(parents[static_cast<std::size_t>(k)])];
      double ws = 0.0;
      Vector3d sum_mu = Vector3d::Zero();
      Matrix3d sum_cov = Matrix3d::Zero();
      Vector3d resultant = Vector3d::Zero();
      double sum_spread = 0.0;
      const auto [first, last] = set_range(k);
      for (const Child* c = first; c != last; ++c) {
        const auto ui = static_cast<std::size_t>(c->i);
        const double ris = std::exp(c->log_term - cmax[ui]) / csum[ui];
        const Component& ci = comps[ui];
        const double a = ris * ci.w;       // r_is w_i (proportional to r_is w_i |P| of eq. 29-30)
        const Vector3d d = ci.mu - ps.mu;  // centred at the old parent mean for precision
        ws += a;
        sum_mu += a * d;
        sum_cov += a * (ci.cov + d * d.transpose());
        const Vector3d axis = ci.axis.dot(ps.axis) < 0.0 ? Vector3d(-ci.axis) : ci.axis;
        resultant += a * axis;
        sum_spread += a * ci.spread;
      }
      Component& out = next[static_cast<std::size_t>(k)];
      const Vector3d shift = sum_mu / ws;
      out.w = ws;                                                                 // eq. 10
      out.mu = ps.mu + shift;                                                     // eq. 10
      set_conditioned(out, sum_cov / ws - shift * shift.transpose(), abs_floor);  // eq. 10
      const double len = resultant.norm();
      const double rho = std::min(len / ws, 1.0);
      if (len > 0.0) {
        out.axis = resultant / len;                          // eq. 29
        out.spread = sum_spread / ws - 2.0 * std::log(rho);  // eq. 30
      } else {
        out.axis = ps.axis;  // opposite axes cancelled exactly: maximal spread
        out.spread = sum_spread / ws + 2.0 * std::log(1e8);
      }
    }
  });
  for (Index i = 0; i < n; ++i)  // orphans, carried unchanged
    if (cmax[static_cast<std::size_t>(i)] == neg_inf)
      next.push_back(comps[static_cast<std::size_t>(i)]);
  return next;
}

}  // namespace hem_detail

GaussianMixture hem_mixture(const Eigen::Matrix3Xf& points, const HemParams& p, double h_abs,
                            double diagonal, RunContext& ctx, HemStats* stats) {
  if (points.cols() == 0) throw InputError("mixture.hem: empty point cloud");
  if (!points.allFinite()) throw InputError("mixture.hem: non-finite point coordinates");
  if (!(h_abs > 0.0) || !std::isfinite(h_abs))
    throw InputError(fmt::format("mixture.hem: kernel width h = {} is not positive", h_abs));
  const double diag = diagonal > 0.0 ? diagonal : h_abs;
  const double abs_floor = (1e-7 * diag) * (1e-7 * diag);
  const double n_points = static_cast<double>(points.cols());

  Components comps = hem_detail::initial_mixture(points, p, h_abs, abs_floor);
  if (p.sigma0 > 0.0) {  // GPS Appendix A: isotropic level-0 covariances sigma0^2 I
    const double s0 = p.sigma0 * diag;
    for (auto& c : comps)
      hem_detail::set_conditioned(c, Eigen::Matrix3d::Identity() * (s0 * s0), abs_floor);
  }
  if (stats) stats->level_sizes = {static_cast<Index>(comps.size())};
  const std::uint64_t seed = ctx.stream_seed("hem");
  for (int level = 0; level < p.levels; ++level) {
    ctx.check_cancelled("mixture.hem");
    const std::size_t before = comps.size();
    comps = hem_detail::cluster_level(
        comps, p, derive_seed(seed, static_cast<std::uint64_t>(level)), n_points, abs_floor);
    if (stats) stats->level_sizes.push_back(static_cast<Index>(comps.size()));
    const double removed = static_cast<double>(before - comps.size());
    if (removed < p.min_reduction * static_cast<double>(before)) break;
  }

  GaussianMixture m;
  const Index k = static_cast<Index>(comps.size());
  m.resize(k);
  m.normal_axes.resize(3, k);
  m.normal_spreads.resize(k);
  double total = 0.0;
  for (const auto& c : comps)
    total += c.w;
  for (Index s = 0; s < k; ++s) {
    const Component& c = comps[static_cast<std::size_t>(s)];
    m.weights(s) = static_cast<float>(c.w / total);
    m.means.col(s) = c.mu.cast<float>();
    m.set_covariance(s, c.cov.cast<float>());
    m.normal_axes.col(s) = c.axis.normalized().cast<float>();
    m.normal_spreads(s) = static_cast<float>(c.spread);
  }
  return m;
}

AlgorithmOutput hem(const PointCloud& in, const HemParams& p, RunContext& ctx) {
  in.validate("mixture.hem");
  if (in.empty()) throw InputError("mixture.hem: empty point cloud");
  const double diag = in.bbox().diagonal();
  const double h_abs = p.h * (diag > 0.0 ? diag : 1.0);
  AlgorithmOutput out;
  {
    auto timer = ctx.phase("hem");
    out.mixture = hem_mixture(in.positions, p, h_abs, diag, ctx);
  }
  out.points = out.mixture->component_points();
  return out;
}

StageData hem_step(const PointCloud& in, const HemParams& p, RunContext& ctx) {
  StageData out;
  out.mixture = hem(in, p, ctx).mixture;
  return out;
}

}  // namespace scanbench::algorithms
