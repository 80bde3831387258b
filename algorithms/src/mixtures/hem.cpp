// mixture.hem, its face (CLOP paper sec. 5, 7, 9.2, Algorithm 1): level 0 (hem_level0.cpp), the
// merge levels (hem_merge.cpp), and the mixture they leave.
#include "scanbench/algorithms/mixtures/hem.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>

#include "input_checks.h"
#include "mixtures/hem_internal.h"
#include "mixtures/sym_eigen3.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {

namespace hem_detail {

// The covariance guard: symmetric, eigenvalues clamped; the eigenvalues a packet of matrices at a
// time, the eigenvectors only for a matrix that needs clamping (sym_eigen3.h).
void set_conditioned(Component* out, const std::vector<Eigen::Matrix3d>& covs, double abs_floor) {
  using Eigen::Matrix3d;
  const std::size_t n = covs.size();
  std::vector<Matrix3d> sym(n);
  for (std::size_t i = 0; i < n; ++i)
    sym[i] = 0.5 * (covs[i] + covs[i].transpose());
  std::vector<Eigen::Vector3d> values(n);
  detail::sym_eigen3(sym.data(), n, values.data(), nullptr);
  for (std::size_t i = 0; i < n; ++i)
    store_conditioned(out[i], sym[i], values[i], abs_floor, [&] {
      Eigen::Vector3d v;
      Matrix3d vectors;
      detail::sym_eigen3(&sym[i], 1, &v, &vectors);
      return vectors;
    });
}

}  // namespace hem_detail

namespace {

using Eigen::Index;
using hem_detail::Component;
using hem_detail::Components;

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

  Components comps = hem_detail::initial_mixture(points, p, h_abs, abs_floor);
  if (p.sigma0 > 0.0) {  // GPS Appendix A: isotropic level-0 covariances sigma0^2 I
    const double s0 = p.sigma0 * diag;
    hem_detail::set_conditioned(
        comps.data(),
        std::vector<Eigen::Matrix3d>(comps.size(), Eigen::Matrix3d::Identity() * (s0 * s0)),
        abs_floor);
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
  detail::check_points(in, "mixture.hem");
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
