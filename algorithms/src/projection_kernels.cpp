#include "projection_kernels.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"

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

// Queries grouped into cubic cells (sorted by cell key, then index).
struct Cells {
  std::vector<Eigen::Index> order;  // query indices, cell by cell
  std::vector<Eigen::Index> begin;  // cell c holds order[begin[c] .. begin[c + 1])
  std::vector<Eigen::Vector3f> centre;
};

Cells make_cells(const Eigen::Matrix3Xf& q, float cell) {
  Cells c;
  const Eigen::Index n = q.cols();
  if (n == 0) {
    c.begin.push_back(0);
    return c;
  }
  const Eigen::Vector3f lo = q.rowwise().minCoeff();
  std::vector<std::pair<std::uint64_t, Eigen::Index>> keys(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    std::uint64_t key = 0;
    for (int d = 0; d < 3; ++d) {
      const auto k = static_cast<std::uint64_t>(std::floor((q(d, i) - lo[d]) / cell));
      key = (key << 21) | std::min<std::uint64_t>(k, (1u << 21) - 1);
    }
    keys[static_cast<std::size_t>(i)] = {key, i};
  }
  std::sort(keys.begin(), keys.end());
  c.order.reserve(static_cast<std::size_t>(n));
  for (std::size_t k = 0; k < keys.size(); ++k) {
    if (k == 0 || keys[k].first != keys[k - 1].first) {
      c.begin.push_back(static_cast<Eigen::Index>(k));
      const std::uint64_t key = keys[k].first;
      const Eigen::Vector3f ijk(static_cast<float>((key >> 42) & 0x1fffff),
                                static_cast<float>((key >> 21) & 0x1fffff),
                                static_cast<float>(key & 0x1fffff));
      c.centre.push_back(lo + (ijk.array() + 0.5f).matrix() * cell);
    }
    c.order.push_back(keys[k].second);
  }
  c.begin.push_back(n);
  return c;
}

// The candidates of one cell in structure-of-arrays form, padded to a multiple of the packet
// size with far-away dummies (their squared distance overflows to +inf and the support mask
// zeroes them).
// Candidates are stored shell by shell (kShells shells of equal width in distance from the cell
// centre, kd-tree order within a shell), so a query at distance dq from the centre only visits the
// shells up to radius + dq: by the triangle inequality nothing farther can be in its support.
constexpr int kShells = 16;
struct Candidates {
  std::vector<std::pair<Eigen::Index, float>> hits;
  std::vector<float> x, y, z, weight;
  std::vector<Eigen::Index> index;
  std::vector<int> shell;
  std::array<Eigen::Index, kShells + 1> shell_begin{};
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  float reach = 0.0f;
  Eigen::Index n = 0;       // real candidates
  Eigen::Index padded = 0;  // n rounded up to the packet size
};

using Packet = Eigen::internal::packet_traits<float>::type;
constexpr int kLanes = Eigen::internal::packet_traits<float>::size;

// Runs f(query index, candidates, self) for every query, where self is the position of the query
// itself among the candidates (-1 when absent; only meaningful when queries and points are the
// same set). Candidates hold every point of `pts` within reach of the query's cell, a superset of
// the query's own ball of `radius`. `weight_of(j)` fills the per-candidate weight.
template <class WeightOf, class F>
void for_each_query(const Eigen::Matrix3Xf& queries, const Eigen::Matrix3Xf& pts,
                    const KdTree& tree, float radius, bool find_self, WeightOf weight_of, F f) {
  // Cell side = radius (reach 1.87 radius; the distance shells keep per-query work near the ball
  // of radius + offset). Measured on the noisy camel (30K and 87K points): sides radius/2, /1.5,
  // /1.33 and 2 radius were 1-15% slower (more tree queries vs more candidates).
  const float cell = radius;
  const Cells cells = make_cells(queries, cell);
  const float reach = radius + 0.5f * std::sqrt(3.0f) * cell;
  const auto ncells = static_cast<Eigen::Index>(cells.centre.size());
  // Per thread: slot[j] = position of point j among the current cell's candidates (-1 else).
  tbb::enumerable_thread_specific<std::vector<Eigen::Index>> slots(
      [&] { return std::vector<Eigen::Index>(find_self ? pts.cols() : 0, -1); });
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, ncells, 1), [&](const auto& range) {
    Candidates c;
    std::vector<Eigen::Index>& slot = slots.local();
    for (Eigen::Index cc = range.begin(); cc != range.end(); ++cc) {
      const auto b = static_cast<std::size_t>(cells.begin[static_cast<std::size_t>(cc)]);
      const auto e = static_cast<std::size_t>(cells.begin[static_cast<std::size_t>(cc) + 1]);
      tree.radius(cells.centre[static_cast<std::size_t>(cc)], reach, c.hits, false);
      c.n = static_cast<Eigen::Index>(c.hits.size());
      c.padded = (c.n + kLanes - 1) / kLanes * kLanes;
      const auto np = static_cast<std::size_t>(c.padded);
      c.x.assign(np, 1e30f);
      c.y.assign(np, 1e30f);
      c.z.assign(np, 1e30f);
      c.weight.assign(np, 0.0f);
      c.index.assign(np, -1);
      c.centre = cells.centre[static_cast<std::size_t>(cc)];
      c.reach = reach;
      // Counting sort of the hits into distance shells (stable: kd-tree order within a shell).
      c.shell.resize(c.hits.size());
      std::array<Eigen::Index, kShells + 1> next{};
      for (std::size_t t = 0; t < c.hits.size(); ++t) {
        const int sh =
            std::min(kShells - 1, static_cast<int>(std::sqrt(c.hits[t].second) * kShells / reach));
        c.shell[t] = sh;
        ++next[static_cast<std::size_t>(sh) + 1];
      }
      for (int sh = 0; sh < kShells; ++sh)
        next[static_cast<std::size_t>(sh) + 1] += next[static_cast<std::size_t>(sh)];
      c.shell_begin = next;
      for (std::size_t t = 0; t < c.hits.size(); ++t) {
        const Eigen::Index j = c.hits[t].first;
        const auto pos = static_cast<std::size_t>(next[static_cast<std::size_t>(c.shell[t])]++);
        c.x[pos] = pts(0, j);
        c.y[pos] = pts(1, j);
        c.z[pos] = pts(2, j);
        c.index[pos] = j;
        c.weight[pos] = weight_of(j);
        if (find_self) slot[static_cast<std::size_t>(j)] = static_cast<Eigen::Index>(pos);
      }
      // A query lies in its cell, hence within reach of the centre: it is among the candidates.
      for (std::size_t k = b; k < e; ++k) {
        const Eigen::Index i = cells.order[k];
        f(i, c, find_self ? slot[static_cast<std::size_t>(i)] : Eigen::Index{-1});
      }
      if (find_self) {
        for (std::size_t t = 0; t < c.hits.size(); ++t)
          slot[static_cast<std::size_t>(c.hits[t].first)] = -1;
      }
    }
  });
}

// Sums over the candidates within `radius` of q (vectorised, fixed order):
//   s = sum_t g_t, d = sum_t g_t (c_t - q),  g_t = kernel(r_t^2) * weight_t
// where kernel is theta (Alpha = false) or alpha with the eps*h clamp (Alpha = true).
// Candidate `skip` (position, or -1) is left out.
template <bool Alpha>
std::pair<float, Eigen::Vector3f> kernel_sums(const Eigen::Vector3f& q, float radius, float h,
                                              Eigen::Index skip, Candidates& c) {
  namespace ei = Eigen::internal;
  float saved = 0.0f;
  if (skip >= 0) std::swap(saved, c.weight[static_cast<std::size_t>(skip)]);
  const Packet qx = ei::pset1<Packet>(q.x()), qy = ei::pset1<Packet>(q.y()),
               qz = ei::pset1<Packet>(q.z());
  const Packet r2max = ei::pset1<Packet>(radius * radius);
  const Packet kk = ei::pset1<Packet>(-kThetaFactor / (h * h));
  const Packet floor2 = ei::pset1<Packet>(kClampRatio * kClampRatio * h * h);
  Packet sw = ei::pset1<Packet>(0.0f), sx = sw, sy = sw, sz = sw;
  // Last shell that can hold a point of the support (with a margin against float rounding).
  const float dq = (q - c.centre).norm();
  const int last =
      std::min(kShells - 1, static_cast<int>((radius + dq) * 1.0001f * kShells / c.reach));
  const Eigen::Index end = std::min(
      c.padded, (c.shell_begin[static_cast<std::size_t>(last) + 1] + kLanes - 1) / kLanes * kLanes);
  for (Eigen::Index t = 0; t < end; t += kLanes) {
    const Packet dx = ei::psub(ei::ploadu<Packet>(c.x.data() + t), qx);
    const Packet dy = ei::psub(ei::ploadu<Packet>(c.y.data() + t), qy);
    const Packet dz = ei::psub(ei::ploadu<Packet>(c.z.data() + t), qz);
    const Packet r2 = ei::padd(ei::padd(ei::pmul(dx, dx), ei::pmul(dy, dy)), ei::pmul(dz, dz));
    const Packet inside = ei::pcmp_le(r2, r2max);
    // Candidates come in kd-tree leaf order, so whole packets often lie outside the support:
    // skipping them adds nothing but +0 to the sums, so the result is unchanged.
    if (!ei::predux_any(inside)) continue;
    Packet g;
    if constexpr (Alpha) {
      const Packet rc2 = ei::pmax(r2, floor2);
      g = ei::pdiv(ei::pexp(ei::pmul(kk, rc2)), ei::psqrt(rc2));
    } else {
      g = ei::pexp(ei::pmul(kk, r2));
    }
    g = ei::pand(ei::pmul(g, ei::ploadu<Packet>(c.weight.data() + t)), inside);
    sw = ei::padd(sw, g);
    sx = ei::padd(sx, ei::pmul(g, dx));
    sy = ei::padd(sy, ei::pmul(g, dy));
    sz = ei::padd(sz, ei::pmul(g, dz));
  }
  if (skip >= 0) std::swap(saved, c.weight[static_cast<std::size_t>(skip)]);
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

Eigen::VectorXf density_weights(const Eigen::Matrix3Xf& points, const KdTree& tree, float h) {
  Eigen::VectorXf v(points.cols());
  for_each_query(
      points, points, tree, h, true, [](Eigen::Index) { return 1.0f; },
      [&](Eigen::Index j, Candidates& c, Eigen::Index self) {
        v[j] = 1.0f + kernel_sums<false>(points.col(j), h, h, self, c).first;
      });
  return v;
}

Eigen::Matrix3Xf l2_means(const Eigen::Matrix3Xf& q, const Eigen::Matrix3Xf& points,
                          const KdTree& tree, float h) {
  Eigen::Matrix3Xf out(3, q.cols());
  for_each_query(
      q, points, tree, h, false, [](Eigen::Index) { return 1.0f; },
      [&](Eigen::Index i, Candidates& c, Eigen::Index) {
        out.col(i) = mean_or_stay(q.col(i), kernel_sums<false>(q.col(i), h, h, -1, c));
      });
  return out;
}

Eigen::Matrix3Xf attractions(const Eigen::Matrix3Xf& q, const Eigen::Matrix3Xf& points,
                             const KdTree& tree, const Eigen::VectorXf& inverse_density, float h) {
  Eigen::Matrix3Xf out(3, q.cols());
  const bool weighted = inverse_density.size() > 0;
  for_each_query(
      q, points, tree, h, false,
      [&](Eigen::Index j) { return weighted ? inverse_density[j] : 1.0f; },
      [&](Eigen::Index i, Candidates& c, Eigen::Index) {
        out.col(i) = mean_or_stay(q.col(i), kernel_sums<true>(q.col(i), h, h, -1, c));
      });
  return out;
}

Eigen::Matrix3Xf repulsions(const Eigen::Matrix3Xf& particles, const KdTree& tree,
                            const Eigen::VectorXf& particle_weights, float h, float cutoff) {
  Eigen::Matrix3Xf out(3, particles.cols());
  const bool weighted = particle_weights.size() > 0;
  for_each_query(
      particles, particles, tree, cutoff, true,
      [&](Eigen::Index j) { return weighted ? particle_weights[j] : 1.0f; },
      [&](Eigen::Index i, Candidates& c, Eigen::Index self) {
        const auto s = kernel_sums<true>(particles.col(i), cutoff, h, self, c);
        // Offsets are q_i' - q_i; F2 sums q_i - q_i'.
        out.col(i) =
            s.first > 0.0f ? Eigen::Vector3f(-s.second / s.first) : Eigen::Vector3f::Zero();
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

Eigen::Matrix3Xf initial_particles(const Eigen::Matrix3Xf& points, Eigen::Index m,
                                   std::uint64_t seed, float jitter) {
  const Eigen::Index n = points.cols();
  if (m > 0 && n == 0) throw InputError("particles: the input has no points");
  Rng rng(seed);
  const Eigen::Index copies = m / std::max<Eigen::Index>(n, 1);
  const Eigen::Index rest = m - copies * n;
  // A seeded subset of `rest` indices: partial Fisher-Yates, then input order.
  std::vector<Eigen::Index> perm(static_cast<std::size_t>(n));
  std::iota(perm.begin(), perm.end(), Eigen::Index{0});
  for (Eigen::Index k = 0; k < rest; ++k) {
    const auto j = k + static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(n - k)));
    std::swap(perm[static_cast<std::size_t>(k)], perm[static_cast<std::size_t>(j)]);
  }
  std::vector<char> extra(static_cast<std::size_t>(n), 0);
  for (Eigen::Index k = 0; k < rest; ++k)
    extra[static_cast<std::size_t>(perm[static_cast<std::size_t>(k)])] = 1;

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
