#include "scanbench/algorithms/hem.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "mixture_index.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {

namespace {

using Eigen::Index;
using Eigen::Matrix3d;
using Eigen::Vector3d;

// Double precision inside HEM: the likelihood exponent w_i|P| and the determinants of flat
// Gaussians are where float loses everything.
struct Component {
  Vector3d mu;
  Matrix3d cov;
  double w = 0.0;
  Vector3d axis;
  double spread = 0.0;
};

constexpr double kLog2Pi = 1.8378770664093453;

// Symmetric, eigenvalues >= max(abs_floor, 1e-6 lambda_max).
Matrix3d condition(const Matrix3d& c, double abs_floor) {
  const Matrix3d s = 0.5 * (c + c.transpose());
  Eigen::SelfAdjointEigenSolver<Matrix3d> es(s);
  Vector3d ev = es.eigenvalues();
  const double floor = std::max(abs_floor, 1e-6 * ev(2));
  if (ev(0) >= floor) return s;
  ev = ev.cwiseMax(floor);
  Matrix3d r = es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose();
  return 0.5 * (r + r.transpose());
}

double largest_eigenvalue(const Matrix3d& c) {
  Eigen::SelfAdjointEigenSolver<Matrix3d> es(c, Eigen::EigenvaluesOnly);
  return es.eigenvalues()(2);
}

std::vector<Component> initial_mixture(const Eigen::Matrix3Xf& pts, const HemParams& p,
                                       double h_abs, double abs_floor) {
  const Index n = pts.cols();
  const KdTree tree(pts);
  // Mean distance to the init_neighbors nearest distinct points (duplicates skipped).
  std::vector<double> nn(static_cast<std::size_t>(n), 0.0);
  const int k_nn = p.init_neighbors;
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, 256), [&](const tbb::blocked_range<Index>& r) {
    std::vector<Index> idx;
    std::vector<float> d2;
    for (Index j = r.begin(); j < r.end(); ++j) {
      tree.knn(pts.col(j), k_nn + 8, idx, d2);
      double sum = 0.0;
      int found = 0;
      for (float d : d2) {
        if (d > 0.0f && found < k_nn) {
          sum += std::sqrt(static_cast<double>(d));
          ++found;
        }
      }
      if (found > 0) nn[static_cast<std::size_t>(j)] = sum / found;
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

  std::vector<Component> comps(static_cast<std::size_t>(n));
  std::vector<double> inv_v(static_cast<std::size_t>(n), 1.0);
  const std::vector<double> density =
      p.weighted
          ? detail::cell_density(pts, tree, static_cast<float>(h_abs), static_cast<float>(h_abs))
          : std::vector<double>();
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, 128), [&](const tbb::blocked_range<Index>& rr) {
    std::vector<std::pair<Index, float>> nb;
    for (Index j = rr.begin(); j < rr.end(); ++j) {
      const auto uj = static_cast<std::size_t>(j);
      const double nnd = nn[uj] > 0.0 ? nn[uj] : median_nn;
      const double r = p.init_radius_factor * nnd;
      tree.radius(pts.col(j), static_cast<float>(r), nb);
      const Vector3d pj = pts.col(j).cast<double>();
      Vector3d sum = Vector3d::Zero();
      Matrix3d sum2 = Matrix3d::Zero();
      double count = 0.0;
      const double r2 = r * r;
      for (const auto& hit : nb) {
        const Vector3d dlt =
            pts.col(hit.first).cast<double>() - pj;  // centred at p_j for precision
        const double dd = dlt.squaredNorm();
        if (dd <= r2) {
          sum += dlt;
          sum2 += dlt * dlt.transpose();
          count += 1.0;
        }
      }
      Component& c = comps[uj];
      c.mu = pj;
      const double bias = p.cov_bias * r2;
      if (count < 1.0) count = 1.0;  // the point itself is always within r
      const Vector3d mean = sum / count;
      const Matrix3d cov_r = sum2 / count - mean * mean.transpose();
      Eigen::SelfAdjointEigenSolver<Matrix3d> es(0.5 * (cov_r + cov_r.transpose()));
      const double lmax = std::max(es.eigenvalues()(2), 0.0);
      const double sigma_max = std::sqrt(lmax);
      Matrix3d cov0 = Matrix3d::Identity() * bias;
      if (sigma_max > 0.0) cov0 += cov_r * (r / (sigma_max * std::cbrt(count)));  // eq. 12
      c.cov = condition(cov0, abs_floor);
      c.axis = sigma_max > 0.0 ? Vector3d(es.eigenvectors().col(0)) : Vector3d::UnitZ();
      c.spread = p.normal_spread0;
      inv_v[uj] = p.weighted ? 1.0 / density[uj] : 1.0;
    }
  });
  double total = 0.0;  // fixed order: thread-independent
  for (double v : inv_v)
    total += v;
  for (std::size_t j = 0; j < comps.size(); ++j)
    comps[j].w = inv_v[j] / total;  // eq. 26 renormalised
  return comps;
}

struct Child {
  Index i;
  double log_term;  // log(w_s L_is)
};

// One HEM level. Returns the next level's components.
std::vector<Component> cluster_level(const std::vector<Component>& comps, const HemParams& p,
                                     std::uint64_t level_seed, double n_points, double abs_floor) {
  const Index n = static_cast<Index>(comps.size());
  std::vector<char> is_parent(comps.size(), 0);
  std::vector<Index> parents;
  for (Index i = 0; i < n; ++i) {
    Rng rng(derive_seed(level_seed, static_cast<std::uint64_t>(i)));
    if (rng.uniform() < p.parent_probability) {
      is_parent[static_cast<std::size_t>(i)] = 1;
      parents.push_back(i);
    }
  }
  if (parents.empty()) return comps;

  Eigen::Matrix3Xf centers(3, n);
  std::vector<double> logdet(comps.size());
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, 1024), [&](const tbb::blocked_range<Index>& r) {
    for (Index i = r.begin(); i < r.end(); ++i) {
      const auto& c = comps[static_cast<std::size_t>(i)];
      centers.col(i) = c.mu.cast<float>();
      logdet[static_cast<std::size_t>(i)] = std::log(c.cov.determinant());
    }
  });
  const KdTree tree(centers);
  const double kl_max = 0.5 * p.alpha * p.alpha;
  const Index np = static_cast<Index>(parents.size());
  std::vector<std::vector<Child>> sets(parents.size());
  tbb::parallel_for(tbb::blocked_range<Index>(0, np, 64), [&](const tbb::blocked_range<Index>& r) {
    std::vector<std::pair<Index, float>> nb;
    for (Index k = r.begin(); k < r.end(); ++k) {
      const Index s = parents[static_cast<std::size_t>(k)];
      const Component& ps = comps[static_cast<std::size_t>(s)];
      const Matrix3d inv = ps.cov.inverse();
      const double ld_s = logdet[static_cast<std::size_t>(s)];
      const double log_ws = std::log(ps.w);
      // D_KL >= d_M^2 / 2, so every admissible child is within alpha * sigma_max(s); the float
      // kd-tree gets a hair of slack, the exact test below decides.
      const double radius = p.alpha * std::sqrt(largest_eigenvalue(ps.cov)) * 1.001 +
                            1e-6 * ps.mu.cwiseAbs().maxCoeff();
      tree.radius(ps.mu.cast<float>(), static_cast<float>(radius), nb);
      std::sort(nb.begin(), nb.end(),
                [](const auto& a, const auto& b) { return a.first < b.first; });
      auto& set = sets[static_cast<std::size_t>(k)];
      for (const auto& nbi : nb) {
        const Index i = nbi.first;
        if (is_parent[static_cast<std::size_t>(i)] && i != s) continue;
        const Component& ci = comps[static_cast<std::size_t>(i)];
        const Vector3d d = ci.mu - ps.mu;
        const double maha = d.dot(inv * d);
        const double tr = (inv * ci.cov).trace();
        const double kl = 0.5 * (maha + tr - 3.0 - (logdet[static_cast<std::size_t>(i)] - ld_s));
        if (!(kl < kl_max) && i != s) continue;  // eq. 11 (a parent always keeps itself)
        const double log_g = -0.5 * (3.0 * kLog2Pi + ld_s + maha);
        const double log_l = ci.w * n_points * (log_g - 0.5 * tr);  // eq. 9, exponent w_i |P|
        set.push_back({i, log_ws + log_l});
      }
    }
  });

  // Log-sum-exp per child over the parents that hold it, in parent order (deterministic).
  const double neg_inf = -std::numeric_limits<double>::infinity();
  std::vector<double> cmax(comps.size(), neg_inf);
  for (const auto& set : sets)
    for (const Child& c : set)
      cmax[static_cast<std::size_t>(c.i)] =
          std::max(cmax[static_cast<std::size_t>(c.i)], c.log_term);
  std::vector<double> csum(comps.size(), 0.0);
  for (const auto& set : sets)
    for (const Child& c : set)
      csum[static_cast<std::size_t>(c.i)] +=
          std::exp(c.log_term - cmax[static_cast<std::size_t>(c.i)]);

  std::vector<Component> next(parents.size());
  tbb::parallel_for(tbb::blocked_range<Index>(0, np, 64), [&](const tbb::blocked_range<Index>& r) {
    for (Index k = r.begin(); k < r.end(); ++k) {
      const Component& ps = comps[static_cast<std::size_t>(parents[static_cast<std::size_t>(k)])];
      double ws = 0.0;
      Vector3d sum_mu = Vector3d::Zero();
      Matrix3d sum_cov = Matrix3d::Zero();
      Vector3d resultant = Vector3d::Zero();
      double sum_spread = 0.0;
      for (const Child& c : sets[static_cast<std::size_t>(k)]) {
        const auto ui = static_cast<std::size_t>(c.i);
        const double ris = std::exp(c.log_term - cmax[ui]) / csum[ui];
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
      out.w = ws;                                                                // eq. 10
      out.mu = ps.mu + shift;                                                    // eq. 10
      out.cov = condition(sum_cov / ws - shift * shift.transpose(), abs_floor);  // eq. 10
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

}  // namespace

GaussianMixture hem_mixture(const Eigen::Matrix3Xf& points, const HemParams& p, double h_abs,
                            double diagonal, RunContext& ctx, HemStats* stats) {
  if (points.cols() == 0) throw InputError("mixture.hem: empty point cloud");
  if (!points.allFinite()) throw InputError("mixture.hem: non-finite point coordinates");
  if (!(h_abs > 0.0) || !std::isfinite(h_abs))
    throw InputError(fmt::format("mixture.hem: kernel width h = {} is not positive", h_abs));
  const double diag = diagonal > 0.0 ? diagonal : h_abs;
  const double abs_floor = (1e-7 * diag) * (1e-7 * diag);
  const double n_points = static_cast<double>(points.cols());

  std::vector<Component> comps = initial_mixture(points, p, h_abs, abs_floor);
  if (stats) stats->level_sizes = {static_cast<Index>(comps.size())};
  const std::uint64_t seed = ctx.stream_seed("hem");
  for (int level = 0; level < p.levels; ++level) {
    ctx.check_cancelled("mixture.hem");
    const std::size_t before = comps.size();
    comps = cluster_level(comps, p, derive_seed(seed, static_cast<std::uint64_t>(level)), n_points,
                          abs_floor);
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
  const GaussianMixture& m = *out.mixture;
  out.points.positions = m.means;
  out.points.normals = m.normal_axes;
  out.points.weights = m.weights;
  return out;
}

}  // namespace scanbench::algorithms
