#include "scanbench/algorithms/bilateral_normals.h"

#include <fmt/format.h>

#include <cmath>
#include <string_view>
#include <vector>

#include "gpf/normal_checks.h"
#include "input_checks.h"
#include "lop/projection_kernels.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/simd_dispatch.h"
#include "spatial/grid_packets.h"
#include "spatial/neighbor_grid.h"
#include "spatial/simd_exp.h"

// Eigen's packet types carry vector attributes that GCC reports as ignored when they are
// template arguments (the kernel is a template over the active ISA's packet); they do not matter.
#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::algorithms {

namespace {

constexpr std::string_view kBilateralStage = "normals.bilateral";

// The sum over the grid points t within h of q of theta(|p_t - q|) psi(n_i, n_t) n_t', with n_t'
// the neighbour's normal turned to n_i's side: theta = exp(k d^2), psi = exp(-((1 - |n_i.n_t|) /
// (1 - cos sigma_n))^2). Packets of the active ISA, range by range (a fixed order at any thread
// count); `n` holds the normals' x, y, z in the grid's order, padded like its coordinates.
template <class Packet>
Eigen::Vector3f bilateral_sum(const detail::NeighborGrid& grid, const Eigen::Vector3f& q,
                              const Eigen::Vector3f& ni, const std::vector<float> (&n)[3], float k,
                              float h, float inv_sharp, const detail::GridRange* r,
                              std::size_t count) {
  namespace ei = Eigen::internal;
  const Packet nix = ei::pset1<Packet>(ni.x()), niy = ei::pset1<Packet>(ni.y()),
               niz = ei::pset1<Packet>(ni.z());
  const Packet kk = ei::pset1<Packet>(k), sharp = ei::pset1<Packet>(inv_sharp),
               one = ei::pset1<Packet>(1.0f), sign_bit = ei::pset1<Packet>(-0.0f),
               zero = ei::pset1<Packet>(0.0f);
  Packet sx = zero, sy = zero, sz = zero;
  detail::for_each_packet<Packet>(
      grid, q, h, -1, r, count,
      [&](Eigen::Index t, const Packet&, const Packet&, const Packet&, const Packet& d2,
          const Packet& inside) {
        const Packet mx = ei::ploadu<Packet>(n[0].data() + t),
                     my = ei::ploadu<Packet>(n[1].data() + t),
                     mz = ei::ploadu<Packet>(n[2].data() + t);
        const Packet dot =
            ei::padd(ei::padd(ei::pmul(nix, mx), ei::pmul(niy, my)), ei::pmul(niz, mz));
        // A neighbour facing away (n_i . n_t < 0) is turned to n_i's side: flip its sign bit.
        const Packet sign = ei::pand(ei::pcmp_lt(dot, zero), sign_bit);
        const Packet adot = ei::pxor(dot, sign);  // |n_i . n_t|
        const Packet a = ei::pmul(ei::psub(one, adot), sharp);
        const Packet w = ei::pxor(
            ei::pand(detail::fast_pexp(ei::psub(ei::pmul(kk, d2), ei::pmul(a, a))), inside), sign);
        sx = ei::padd(sx, ei::pmul(w, mx));
        sy = ei::padd(sy, ei::pmul(w, my));
        sz = ei::padd(sz, ei::pmul(w, mz));
      });
  return {ei::predux(sx), ei::predux(sy), ei::predux(sz)};
}

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
  simd::with_packet([&](auto tag) {
    using Packet = typename decltype(tag)::type;
    for (int it = 0; it < p.iterations; ++it) {
      ctx.check_cancelled(kBilateralStage);
      // The normals in the grid's sorted order, beside its coordinates (refreshed every
      // iteration).
      const std::vector<float> sorted[3] = {detail::sorted_values(grid, normals.data(), 3),
                                            detail::sorted_values(grid, normals.data() + 1, 3),
                                            detail::sorted_values(grid, normals.data() + 2, 3)};
      grid.for_each_query(
          input.positions, h, true,
          [&](Eigen::Index i, Eigen::Index, const detail::GridRange* r, std::size_t count) {
            const Eigen::Vector3f ni = normals.col(i);
            const Eigen::Vector3f sum = bilateral_sum<Packet>(grid, input.positions.col(i), ni,
                                                              sorted, k, h, inv_sharp, r, count);
            const float len = sum.norm();
            next.col(i) = len > 0.0f && std::isfinite(len) ? Eigen::Vector3f(sum / len) : ni;
          });
      normals.swap(next);
    }
  });
  out.normals = std::move(normals);
  out.validate(kBilateralStage);
  return out;
}

}  // namespace scanbench::algorithms
