#include "scanbench/algorithms/lop/lop.h"

#include <fmt/format.h>

#include <optional>
#include <string_view>

#include "input_checks.h"
#include "lop/projection_kernels.h"
#include "scanbench/core/errors.h"

namespace scanbench::algorithms {

namespace {

PointCloud project(const PointCloud& input, const LopParams& p, RunContext& ctx, bool weighted,
                   std::string_view stage) {
  const float diag = detail::checked_diagonal(input, stage);
  const float h = static_cast<float>(p.h) * diag;
  const Eigen::Matrix3Xf& pts = input.positions;
  const Eigen::Index m = kernels::particle_count(p.particles, input.size(), stage);

  Eigen::Matrix3Xf q;
  Eigen::Matrix3Xf next;
  std::optional<detail::NeighborGrid> point_grid;
  {
    auto timer = ctx.phase("init");
    point_grid.emplace(kernels::query_grid(pts, h));
    // Copies (upsampling) are jittered by a small fraction of h so that they can separate.
    q = kernels::initial_particles(pts, m, ctx.stream_seed("particles"), 0.01f * h);
    q = kernels::l2_means(q, *point_grid, h);
  }
  if (weighted && p.iterations > 1) {
    auto timer = ctx.phase("density");
    point_grid->set_weights(kernels::density_weights(*point_grid, pts, h, h).cwiseInverse());
  }
  const float mu = static_cast<float>(p.mu);
  Eigen::Matrix3Xf rep;
  const int steps = p.iterations - 1;
  for (int t = 0; t < steps; ++t) {
    ctx.check_cancelled(stage);
    {
      auto timer = ctx.phase("attraction");
      next = kernels::attractions(q, *point_grid, h);
    }
    // Interleaved repulsion (CLOP paper sec. 8): F2 of the previous computation is reused in
    // every other iteration; the first and the last always compute it.
    const bool recompute = !p.interleave || t % 2 == 0 || t == steps - 1;
    if (recompute) {
      auto timer = ctx.phase("repulsion");
      detail::NeighborGrid particle_grid = kernels::query_grid(q, h);
      if (weighted) particle_grid.set_weights(kernels::density_weights(particle_grid, q, h, h));
      rep = kernels::repulsions(q, particle_grid, h, h);
    }
    next += mu * rep;
    q.swap(next);
  }
  PointCloud out;
  out.positions = std::move(q);
  return out;
}

}  // namespace

PointCloud lop(const PointCloud& input, const LopParams& p, RunContext& ctx) {
  return project(input, p, ctx, false, "resample.lop");
}

PointCloud wlop(const PointCloud& input, const LopParams& p, RunContext& ctx) {
  return project(input, p, ctx, true, "resample.wlop");
}

}  // namespace scanbench::algorithms
