#include "lop/projection_kernels.h"
#include "spatial/grid_packets.h"
#include "spatial/simd_exp.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>

#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/simd_dispatch.h"

// Eigen's packet types (__m128, __m256, __m512) carry vector attributes that GCC reports as
// ignored when they are template arguments (the kernels are templates over the packet type of
// the active ISA, scanbench/core/simd_dispatch.h); the attributes do not matter there.
#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::algorithms::kernels {

namespace {

// Collects the neighbours of q within `radius` (skipping index `skip`) as offsets p - q in
// s.dx/s.dy/s.dz and squared distances in s.a. Buffers only grow, so the hot loop does not
// allocate once they are warm; the arrays are used through head(n). Returns n.
Eigen::Index gather(const Eigen::Vector3f& q, const Eigen::Matrix3Xf& pts, const KdTree& tree,
                    float radius, Scratch& s, Eigen::Index skip = -1) {
  tree.radius(q, radius, s.hits, false);
  const auto cap = static_cast<Eigen::Index>(s.hits.size());
  if (s.dx.size() < cap) {
    const Eigen::Index grow = std::max<Eigen::Index>(cap, 2 * s.dx.size());
    s.a.resize(grow);
    s.b.resize(grow);
    s.dx.resize(grow);
    s.dy.resize(grow);
    s.dz.resize(grow);
  }
  Eigen::Index n = 0;
  for (const auto& [j, d2] : s.hits) {
    if (j == skip) continue;
    const float x = pts(0, j) - q.x();
    const float y = pts(1, j) - q.y();
    const float z = pts(2, j) - q.z();
    s.dx[n] = x;
    s.dy[n] = y;
    s.dz[n] = z;
    s.a[n] = x * x + y * y + z * z;
    ++n;
  }
  return n;
}

// s.a.head(n) holds r^2; replaces it with alpha(r) = theta(r_c) / r_c, r_c = max(r, eps h).
void alpha_in_place(Eigen::Index n, float h, Scratch& s) {
  const float floor2 = kClampRatio * kClampRatio * h * h;
  const float k = -kThetaFactor / (h * h);
  auto r2 = s.a.head(n);
  r2 = r2.max(floor2);
  s.b.head(n) = r2.sqrt();
  r2 = (k * r2).exp() / s.b.head(n);
}

// Sums over the grid points within `radius` of q (vectorised, fixed order: range by range):
//   s = sum_t g_t, d = sum_t g_t (p_t - q),  g_t = kernel(r_t^2) * weight_t
// where kernel is theta (Alpha = false) or alpha with the eps*h clamp (Alpha = true), and weight_t
// the grid's weight of the point (1 when not Weighted).
// The point at sorted position `self` (or none, -1) is left out. Packet is the Eigen float packet
// of the active ISA (scanbench/core/simd.h); its lanes are summed in the same order at any thread
// count.
template <class Packet, bool Alpha, bool Weighted = true>
std::pair<float, Eigen::Vector3f> kernel_sums(const detail::NeighborGrid& g,
                                              const Eigen::Vector3f& q, float radius, float h,
                                              Eigen::Index self, const detail::GridRange* ranges,
                                              std::size_t count) {
  namespace ei = Eigen::internal;
  const Packet kk = ei::pset1<Packet>(-kThetaFactor / (h * h));
  const Packet floor2 = ei::pset1<Packet>(kClampRatio * kClampRatio * h * h);
  Packet sw = ei::pset1<Packet>(0.0f), sx = sw, sy = sw, sz = sw;
  const float* pw = g.weight();
  // Packets wholly outside the support are skipped: they would add nothing but +0 to the sums.
  detail::for_each_packet<Packet>(g, q, radius, self, ranges, count,
                                  [&](Eigen::Index t, const Packet& dx, const Packet& dy,
                                      const Packet& dz, const Packet& r2, const Packet& inside) {
                                    Packet k;
                                    if constexpr (Alpha) {
                                      const Packet rc2 = ei::pmax(r2, floor2);
                                      k = ei::pmul(detail::fast_pexp(ei::pmul(kk, rc2)),
                                                   detail::fast_prsqrt(rc2));
                                    } else {
                                      k = detail::fast_pexp(ei::pmul(kk, r2));
                                    }
                                    if constexpr (Weighted)
                                      k = ei::pmul(k, ei::ploadu<Packet>(pw + t));
                                    k = ei::pand(k, inside);
                                    sw = ei::padd(sw, k);
                                    sx = ei::padd(sx, ei::pmul(k, dx));
                                    sy = ei::padd(sy, ei::pmul(k, dy));
                                    sz = ei::padd(sz, ei::pmul(k, dz));
                                  });
  return {ei::predux(sw), Eigen::Vector3f(ei::predux(sx), ei::predux(sy), ei::predux(sz))};
}

// q + d / s, or q when nothing lies in the support.
Eigen::Vector3f mean_or_stay(const Eigen::Vector3f& q, const std::pair<float, Eigen::Vector3f>& s) {
  return s.first > 0.0f ? Eigen::Vector3f(q + s.second / s.first) : q;
}

}  // namespace

float theta(float r, float h) {
  return std::exp(-kThetaFactor * r * r / (h * h));
}

float alpha(float r, float h) {
  const float rc = std::max(r, kClampRatio * h);
  return theta(rc, h) / rc;
}

detail::NeighborGrid query_grid(const Eigen::Matrix3Xf& points, float radius,
                                const std::vector<Eigen::Index>* rank) {
  {
    detail::NeighborGrid coarse(points, radius, rank);
    if (static_cast<double>(coarse.size()) <
        kDenseOccupancy * static_cast<double>(std::max<std::size_t>(coarse.cells(), 1)))
      return coarse;
  }  // freed before the finer grid is built: one grid at a time at the peak of memory
  return detail::NeighborGrid(points, 0.5f * radius, rank);
}

Eigen::VectorXf density_weights(const detail::NeighborGrid& grid, const Eigen::Matrix3Xf& points,
                                float h, float cutoff) {
  Eigen::VectorXf v(points.cols());
  simd::with_packet([&](auto tag) {
    using P = typename decltype(tag)::type;
    grid.for_each_query(
        points, cutoff, true,
        [&](Eigen::Index j, Eigen::Index self, const detail::GridRange* r, std::size_t count) {
          v[j] = 1.0f +
                 kernel_sums<P, false, false>(grid, points.col(j), cutoff, h, self, r, count).first;
        });
  });
  return v;
}

Eigen::Matrix3Xf l2_means(const Eigen::Matrix3Xf& q, const detail::NeighborGrid& grid, float h) {
  Eigen::Matrix3Xf out(3, q.cols());
  simd::with_packet([&](auto tag) {
    using P = typename decltype(tag)::type;
    grid.for_each_query(
        q, h, false,
        [&](Eigen::Index i, Eigen::Index, const detail::GridRange* r, std::size_t count) {
          out.col(i) = mean_or_stay(
              q.col(i), kernel_sums<P, false, false>(grid, q.col(i), h, h, -1, r, count));
        });
  });
  return out;
}

Eigen::Matrix3Xf attractions(const Eigen::Matrix3Xf& q, const detail::NeighborGrid& grid, float h) {
  Eigen::Matrix3Xf out(3, q.cols());
  simd::with_packet([&](auto tag) {
    using P = typename decltype(tag)::type;
    grid.for_each_query(
        q, h, false,
        [&](Eigen::Index i, Eigen::Index, const detail::GridRange* r, std::size_t count) {
          out.col(i) =
              mean_or_stay(q.col(i), kernel_sums<P, true>(grid, q.col(i), h, h, -1, r, count));
        });
  });
  return out;
}

Eigen::Matrix3Xf repulsions(const Eigen::Matrix3Xf& particles, const detail::NeighborGrid& grid,
                            float h, float cutoff) {
  Eigen::Matrix3Xf out(3, particles.cols());
  simd::with_packet([&](auto tag) {
    using P = typename decltype(tag)::type;
    grid.for_each_query(
        particles, cutoff, true,
        [&](Eigen::Index i, Eigen::Index self, const detail::GridRange* r, std::size_t count) {
          const auto s = kernel_sums<P, true>(grid, particles.col(i), cutoff, h, self, r, count);
          // Offsets are q_i' - q_i; F2 sums q_i - q_i'.
          out.col(i) =
              s.first > 0.0f ? Eigen::Vector3f(-s.second / s.first) : Eigen::Vector3f::Zero();
        });
  });
  return out;
}

Eigen::Vector3f l2_mean(const Eigen::Vector3f& q, const Eigen::Matrix3Xf& points,
                        const KdTree& tree, float h, Scratch& s) {
  const Eigen::Index n = gather(q, points, tree, h, s);
  if (n == 0) return q;
  auto t = s.a.head(n);
  t = (-kThetaFactor / (h * h) * t).exp();
  const float sum = t.sum();
  if (!(sum > 0.0f)) return q;
  return q + Eigen::Vector3f((t * s.dx.head(n)).sum(), (t * s.dy.head(n)).sum(),
                             (t * s.dz.head(n)).sum()) /
                 sum;
}

Eigen::Vector3f attraction(const Eigen::Vector3f& q, const Eigen::Matrix3Xf& points,
                           const KdTree& tree, const Eigen::VectorXf& inverse_density, float h,
                           Scratch& s) {
  const Eigen::Index n = gather(q, points, tree, h, s);
  if (n == 0) return q;
  alpha_in_place(n, h, s);
  auto w = s.a.head(n);
  if (inverse_density.size() > 0) {
    Eigen::Index k = 0;
    for (const auto& hit : s.hits)
      w[k++] *= inverse_density[hit.first];
  }
  const float sum = w.sum();
  if (!(sum > 0.0f)) return q;
  return q + Eigen::Vector3f((w * s.dx.head(n)).sum(), (w * s.dy.head(n)).sum(),
                             (w * s.dz.head(n)).sum()) /
                 sum;
}

Eigen::Vector3f repulsion(Eigen::Index i, const Eigen::Matrix3Xf& particles, const KdTree& tree,
                          const Eigen::VectorXf& particle_weights, float h, float cutoff,
                          Scratch& s) {
  const Eigen::Index n = gather(particles.col(i), particles, tree, cutoff, s, i);
  if (n == 0) return Eigen::Vector3f::Zero();
  alpha_in_place(n, h, s);
  auto w = s.a.head(n);
  if (particle_weights.size() > 0) {
    Eigen::Index k = 0;
    for (const auto& hit : s.hits) {
      if (hit.first == i) continue;
      w[k++] *= particle_weights[hit.first];
    }
  }
  const float sum = w.sum();
  if (!(sum > 0.0f)) return Eigen::Vector3f::Zero();
  // Offsets were gathered as q_i' - q_i; F2 sums q_i - q_i'.
  return -Eigen::Vector3f((w * s.dx.head(n)).sum(), (w * s.dy.head(n)).sum(),
                          (w * s.dz.head(n)).sum()) /
         sum;
}

Eigen::Index particle_count(double particles, Eigen::Index n, std::string_view where) {
  if (!(particles > 0.0) || !std::isfinite(particles)) {
    throw ParamError(fmt::format("{}.particles: expected a share in (0, 1] or a count > 1, got {}",
                                 where, particles));
  }
  if (particles <= 1.0) {
    if (n == 0) return 0;
    return std::max<Eigen::Index>(1, std::llround(particles * static_cast<double>(n)));
  }
  if (std::floor(particles) != particles) {
    throw ParamError(
        fmt::format("{}.particles: a value above 1 is a count and must be an integer, got {}",
                    where, particles));
  }
  return static_cast<Eigen::Index>(particles);
}

std::vector<char> seeded_subset(Eigen::Index n, Eigen::Index m, Rng& rng) {
  // Partial Fisher-Yates: m draws.
  std::vector<Eigen::Index> perm(static_cast<std::size_t>(n));
  std::iota(perm.begin(), perm.end(), Eigen::Index{0});
  for (Eigen::Index k = 0; k < m; ++k) {
    const auto j = k + static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(n - k)));
    std::swap(perm[static_cast<std::size_t>(k)], perm[static_cast<std::size_t>(j)]);
  }
  std::vector<char> flags(static_cast<std::size_t>(n), 0);
  for (Eigen::Index k = 0; k < m; ++k)
    flags[static_cast<std::size_t>(perm[static_cast<std::size_t>(k)])] = 1;
  return flags;
}

Eigen::Matrix3Xf initial_particles(const Eigen::Matrix3Xf& points, Eigen::Index m,
                                   std::uint64_t seed, float jitter) {
  const Eigen::Index n = points.cols();
  if (m > 0 && n == 0) throw InputError("particles: the input has no points");
  Rng rng(seed);
  const Eigen::Index copies = m / std::max<Eigen::Index>(n, 1);
  const Eigen::Index rest = m - copies * n;
  // A seeded subset of `rest` indices, then input order.
  const std::vector<char> extra = seeded_subset(n, rest, rng);

  Eigen::Matrix3Xf q(3, m);
  Eigen::Index out = 0;
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::Index c = copies + extra[static_cast<std::size_t>(j)];
    for (Eigen::Index r = 0; r < c; ++r) {
      q.col(out) = points.col(j);
      if (r > 0 && jitter > 0.0f) {
        for (int d = 0; d < 3; ++d)
          q(d, out) += static_cast<float>(rng.normal(0.0, jitter));
      }
      ++out;
    }
  }
  return q;
}

}  // namespace scanbench::algorithms::kernels
