#include "scanbench/algorithms/lop.h"

#include <fmt/format.h>

#include <optional>
#include <string_view>

#include "projection_kernels.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"

namespace scanbench::algorithms {

namespace {

PointCloud project(const PointCloud& input, const LopParams& p, RunContext& ctx, bool weighted,
                   std::string_view stage) {
  input.validate(stage);
  if (input.empty()) throw InputError(fmt::format("{}: the input has no points", stage));
  const float diag = input.bbox().diagonal();
  if (!(diag > 0.0f)) {
    throw InputError(fmt::format("{}: the input's bounding box has a zero diagonal", stage));
  }
  const float h = static_cast<float>(p.h) * diag;
  const Eigen::Matrix3Xf& pts = input.positions;
  const Eigen::Index m = kernels::particle_count(p.particles, input.size(), stage);

  Eigen::Matrix3Xf q;
  Eigen::Matrix3Xf next;
  Eigen::VectorXf inverse_density;  // empty for LOP
  std::optional<KdTree> point_tree;
  {
    auto timer = ctx.phase("init");
    point_tree.emplace(pts);
    // Copies (upsampling) are jittered by a small fraction of h so that they can separate.
    q = kernels::initial_particles(pts, m, ctx.stream_seed("particles"), 0.01f * h);
    q = kernels::l2_means(q, pts, *point_tree, h);
  }
  if (weighted && p.iterations > 1) {
    auto timer = ctx.phase("density");
    inverse_density = kernels::density_weights(pts, *point_tree, h).cwiseInverse();
  }
  const float mu = static_cast<float>(p.mu);
  for (int it = 1; it < p.iterations; ++it) {
    ctx.check_cancelled(stage);
    {
      auto timer = ctx.phase("attraction");
      next = kernels::attractions(q, pts, *point_tree, inverse_density, h);
    }
    {
      auto timer = ctx.phase("repulsion");
      const KdTree particle_tree(q);
      Eigen::VectorXf w;  // empty for LOP
      if (weighted) w = kernels::density_weights(q, particle_tree, h);
      next += mu * kernels::repulsions(q, particle_tree, w, h, h);
    }
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
