#include "scanbench/algorithms/lop.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <optional>
#include <string_view>

#include "projection_kernels.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"

namespace scanbench::algorithms {

namespace {

constexpr Eigen::Index kGrain = 256;

template <class Body>
void for_each_particle(Eigen::Index m, Body body) {
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, m, kGrain), [&](const auto& range) {
    kernels::Scratch s;
    for (Eigen::Index i = range.begin(); i != range.end(); ++i)
      body(i, s);
  });
}

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
  Eigen::Matrix3Xf next(3, m);
  Eigen::VectorXf inverse_density;  // empty for LOP
  std::optional<KdTree> point_tree;
  {
    auto timer = ctx.phase("init");
    point_tree.emplace(pts);
    // Copies (upsampling) are jittered by a small fraction of h so that they can separate.
    q = kernels::initial_particles(pts, m, ctx.stream_seed("particles"), 0.01f * h);
    for_each_particle(m, [&](Eigen::Index i, kernels::Scratch& s) {
      next.col(i) = kernels::l2_mean(q.col(i), pts, *point_tree, h, s);
    });
    q.swap(next);
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
      for_each_particle(m, [&](Eigen::Index i, kernels::Scratch& s) {
        next.col(i) = kernels::attraction(q.col(i), pts, *point_tree, inverse_density, h, s);
      });
    }
    {
      auto timer = ctx.phase("repulsion");
      const KdTree particle_tree(q);
      Eigen::VectorXf w;  // empty for LOP
      if (weighted) w = kernels::density_weights(q, particle_tree, h);
      for_each_particle(m, [&](Eigen::Index i, kernels::Scratch& s) {
        next.col(i) += mu * kernels::repulsion(i, q, particle_tree, w, h, h, s);
      });
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
