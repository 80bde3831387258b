#include "projection_kernels.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
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

}  // namespace

float theta(float r, float h) {
  return std::exp(-kThetaFactor * r * r / (h * h));
}

float alpha(float r, float h) {
  const float rc = std::max(r, kClampRatio * h);
  return theta(rc, h) / rc;
}

Eigen::VectorXf density_weights(const Eigen::Matrix3Xf& points, const KdTree& tree, float h) {
  const Eigen::Index n = points.cols();
  Eigen::VectorXf v(n);
  const float k = -kThetaFactor / (h * h);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 256), [&](const auto& range) {
    Scratch s;
    for (Eigen::Index j = range.begin(); j != range.end(); ++j) {
      const Eigen::Index m = gather(points.col(j), points, tree, h, s, j);
      v[j] = 1.0f + (k * s.a.head(m)).exp().sum();
    }
  });
  return v;
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
