// normals.bilateral (filter.gpf's normal step, GPF paper sec. 4.1): a Highway kernel compiled for
// every target (cmake/Simd.cmake) and dispatched to the active ISA's (scanbench/core/simd.h).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "gpf/bilateral_normals.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cmath>
#include <string_view>
#include <vector>

#include "spatial/grid_packets-inl.h"
#include "spatial/neighbor_grid.h"
#include "spatial/simd_math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace scanbench::algorithms::detail::HWY_NAMESPACE {

// The sum over the grid points t within h of q of theta(|p_t - q|) psi(n_i, n_t) n_t', with n_t'
// the neighbour's normal turned to n_i's side: theta = exp(k d^2), psi = exp(-((1 - |n_i.n_t|) /
// (1 - cos sigma_n))^2). Vectors of the target's width, range by range (a fixed order at any
// thread count), lanes summed in Eigen's order; `n` holds the normals' x, y, z in the grid's
// order, padded like its coordinates.
template <class D>
HWY_INLINE Eigen::Vector3f BilateralSum(D d, const NeighborGrid& grid, const Eigen::Vector3f& q,
                                        const Eigen::Vector3f& ni, const std::vector<float> (&n)[3],
                                        float k, float h, float inv_sharp, const GridRange* r,
                                        std::size_t count) {
  using V = hn::Vec<D>;
  const V nix = hn::Set(d, ni.x()), niy = hn::Set(d, ni.y()), niz = hn::Set(d, ni.z());
  const V kk = hn::Set(d, k), sharp = hn::Set(d, inv_sharp), one = hn::Set(d, 1.0f),
          sign_bit = hn::Set(d, -0.0f), zero = hn::Zero(d);
  V sx = zero, sy = zero, sz = zero;
  ForEachVector(
      d, grid, q, h, -1, r, count, [&](Eigen::Index t, V, V, V, V d2, auto inside) HWY_ATTR {
        const V mx = hn::LoadU(d, n[0].data() + t), my = hn::LoadU(d, n[1].data() + t),
                mz = hn::LoadU(d, n[2].data() + t);
        const V dot = hn::Add(hn::Add(hn::Mul(nix, mx), hn::Mul(niy, my)), hn::Mul(niz, mz));
        // A neighbour facing away (n_i . n_t < 0) is turned to n_i's side: flip its sign
        // bit.
        const V sign = hn::IfThenElseZero(hn::Lt(dot, zero), sign_bit);
        const V adot = hn::Xor(dot, sign);  // |n_i . n_t|
        const V a = hn::Mul(hn::Sub(one, adot), sharp);
        const V w = hn::Xor(
            hn::IfThenElseZero(inside, FastExp(d, hn::Sub(hn::Mul(kk, d2), hn::Mul(a, a)))), sign);
        sx = hn::Add(sx, hn::Mul(w, mx));
        sy = hn::Add(sy, hn::Mul(w, my));
        sz = hn::Add(sz, hn::Mul(w, mz));
      });
  return {SumOfLanesInEigenOrder(d, sx), SumOfLanesInEigenOrder(d, sy),
          SumOfLanesInEigenOrder(d, sz)};
}

// One iteration: next.col(i) = the normalised sum of point i (its old normal when the sum is 0
// or not finite).
void BilateralPass(const NeighborGrid& grid, const Eigen::Matrix3Xf& positions,
                   const Eigen::Matrix3Xf& normals, const std::vector<float> (&sorted)[3], float k,
                   float h, float inv_sharp, Eigen::Matrix3Xf& next) {
  const hn::ScalableTag<float> d;
  grid.for_each_query(
      positions, h, true,
      [&](Eigen::Index i, Eigen::Index, const GridRange* r, std::size_t count) HWY_ATTR {
        const Eigen::Vector3f ni = normals.col(i);
        const Eigen::Vector3f sum =
            BilateralSum(d, grid, positions.col(i), ni, sorted, k, h, inv_sharp, r, count);
        const float len = sum.norm();
        next.col(i) = len > 0.0f && std::isfinite(len) ? Eigen::Vector3f(sum / len) : ni;
      });
}

}  // namespace scanbench::algorithms::detail::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <fmt/format.h>

#include "input_checks.h"
#include "lop/projection_kernels.h"
#include "scanbench/algorithms/gpf/bilateral_normals.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/simd.h"
#include "spatial/grid_packets.h"

namespace scanbench::algorithms {

namespace detail {
HWY_EXPORT(BilateralPass);
}  // namespace detail

namespace {

constexpr std::string_view kBilateralStage = "normals.bilateral";

}  // namespace

PointCloud bilateral_normals(const PointCloud& input, const BilateralNormalsParams& p,
                             RunContext& ctx) {
  detail::check_points(input, kBilateralStage, 0);  // one point or none: nothing to smooth
  detail::require_unit_normals(input, kBilateralStage, "normals.pca -> normals.bilateral");
  PointCloud out = input;
  const Eigen::Index n = input.size();
  if (n <= 1) return out;
  const float diag = detail::checked_diagonal(input, kBilateralStage);
  auto timer = ctx.phase("bilateral");
  const float h = static_cast<float>(p.h) * diag;
  const float k = -kernels::kThetaFactor / (h * h);
  const float inv_sharp = 1.0f / (1.0f - static_cast<float>(std::cos(p.sigma_n * M_PI / 180.0)));
  const detail::NeighborGrid grid = kernels::query_grid(input.positions, h);
  Eigen::Matrix3Xf normals = detail::unit_normals(input);
  Eigen::Matrix3Xf next(3, n);
  for (int it = 0; it < p.iterations; ++it) {
    ctx.check_cancelled(kBilateralStage);
    // The normals in the grid's sorted order, beside its coordinates (refreshed every iteration).
    const std::vector<float> sorted[3] = {detail::sorted_values(grid, normals.data(), 3),
                                          detail::sorted_values(grid, normals.data() + 1, 3),
                                          detail::sorted_values(grid, normals.data() + 2, 3)};
    SCANBENCH_DISPATCH(detail::BilateralPass)
    (grid, input.positions, normals, sorted, k, h, inv_sharp, next);
    normals.swap(next);
  }
  out.normals = std::move(normals);
  out.validate(kBilateralStage);
  return out;
}

}  // namespace scanbench::algorithms
#endif  // HWY_ONCE
