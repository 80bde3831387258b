#include "scanbench/algorithms/poisson.h"

#include <fmt/format.h>

#include "input_checks.h"
#include "peers/run_program.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"

namespace scanbench::algorithms {

StageData poisson(const StageData& in, const PoissonParams& p, RunContext& ctx) {
  constexpr const char* stage = "reconstruct.poisson";
  const PointCloud& points = in.points;
  detail::check_points(points, stage);
  if (!points.has_normals()) {
    throw InputError(
        fmt::format("{}: needs oriented normals, the input points have none (chain "
                    "normals.pca -> reconstruct.poisson)",
                    stage));
  }
  const detail::TempDir dir("poisson");
  const auto input = dir.path() / "points.ply";
  const auto output = dir.path() / "mesh.ply";
  write_point_cloud_rgb(points, input);
  {
    auto timer = ctx.phase("poisson");
    detail::run_program(
        {"colmap", "poisson_mesher", "--input_path", input.string(), "--output_path",
         output.string(), "--PoissonMeshing.depth", std::to_string(p.depth),
         "--PoissonMeshing.point_weight", fmt::format("{}", p.point_weight),
         "--PoissonMeshing.trim", fmt::format("{}", p.trim), "--PoissonMeshing.num_threads", "1"},
        dir.path(), p.timeout_s, stage, ctx);
  }
  detail::require_output(output, dir.path(), "colmap poisson_mesher", "mesh", stage);
  StageData out;
  try {
    out.mesh = read_mesh(output);
  } catch (const IoError& e) {
    throw Error(
        fmt::format("{}: colmap poisson_mesher exited with code 0 but its mesh is "
                    "unusable{}: {}",
                    stage, p.trim > 0.0 ? " (trim may have removed every vertex)" : "", e.what()));
  }
  return out;
}

}  // namespace scanbench::algorithms
