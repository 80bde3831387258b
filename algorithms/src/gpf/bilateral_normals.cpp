#include "scanbench/algorithms/bilateral_normals.h"

#include <fmt/format.h>

#include <cmath>
#include <string_view>
#include <vector>

#include "gpf/normal_checks.h"
#include "input_checks.h"
#include "lop/projection_kernels.h"
#include "scanbench/core/errors.h"
#include "spatial/neighbor_grid.h"

namespace scanbench::algorithms {

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
  const float r2max = h * h;
  const float inv_sharp = 1.0f / (1.0f - static_cast<float>(std::cos(p.sigma_n * M_PI / 180.0)));
  const detail::NeighborGrid grid(input.positions, kernels::grid_cell(h));
  Eigen::Matrix3Xf normals = detail::unit_normals(input);
  Eigen::Matrix3Xf next(3, n);
  // Normals in the grid's sorted order (refreshed every iteration), beside its coordinates.
  std::vector<float> nx(static_cast<std::size_t>(n)), ny(nx.size()), nz(nx.size());
  for (int it = 0; it < p.iterations; ++it) {
    ctx.check_cancelled(kBilateralStage);
    for (Eigen::Index s = 0; s < n; ++s) {
      const Eigen::Index j = grid.index(s);
      nx[static_cast<std::size_t>(s)] = normals(0, j);
      ny[static_cast<std::size_t>(s)] = normals(1, j);
      nz[static_cast<std::size_t>(s)] = normals(2, j);
    }
    grid.for_each_query(
        input.positions, h, true,
        [&](Eigen::Index i, Eigen::Index, const detail::GridRange* r, std::size_t count) {
          const Eigen::Vector3f q = input.positions.col(i);
          const Eigen::Vector3f ni = normals.col(i);
          Eigen::Vector3f sum = Eigen::Vector3f::Zero();
          for (std::size_t c = 0; c < count; ++c) {
            for (Eigen::Index t = r[c].begin; t < r[c].end; ++t) {
              const float dx = grid.x()[t] - q.x(), dy = grid.y()[t] - q.y(),
                          dz = grid.z()[t] - q.z();
              const float d2 = dx * dx + dy * dy + dz * dz;
              if (d2 > r2max) continue;
              const auto u = static_cast<std::size_t>(t);
              Eigen::Vector3f nj(nx[u], ny[u], nz[u]);
              float dot = ni.dot(nj);
              if (dot < 0.0f) {  // align signs first
                nj = -nj;
                dot = -dot;
              }
              const float a = (1.0f - dot) * inv_sharp;
              sum += std::exp(k * d2 - a * a) * nj;  // theta * psi
            }
          }
          const float len = sum.norm();
          next.col(i) = len > 0.0f && std::isfinite(len) ? Eigen::Vector3f(sum / len) : ni;
        });
    normals.swap(next);
  }
  out.normals = std::move(normals);
  out.validate(kBilateralStage);
  return out;
}

}  // namespace scanbench::algorithms
