#pragma once
// Internal to the algorithms module: the one input prologue of the steps that consume points
// (validate, too few points, zero bbox diagonal), so that every step rejects bad input with the
// same one-line errors, and the input check of the stages that consume normals (normals.bilateral,
// filter.gpf and the peers that need normals): they never estimate normals silently, a missing or
// degenerate normal stops the stage with one line naming the property and the chain that supplies
// it.
#include <fmt/format.h>

#include <string_view>

#include "scanbench/core/errors.h"
#include "scanbench/core/point_cloud.h"

namespace scanbench::algorithms::detail {

/// PointCloud::validate, then at least `min_points` points. Throws InputError "<stage>: the input
/// has no points" (min_points = 1) or "<stage>: needs at least N points, got n".
inline void check_points(const PointCloud& in, std::string_view stage,
                         Eigen::Index min_points = 1) {
  in.validate(stage);
  if (in.size() >= min_points) return;
  if (min_points <= 1) throw InputError(fmt::format("{}: the input has no points", stage));
  throw InputError(
      fmt::format("{}: needs at least {} points, got {}", stage, min_points, in.size()));
}

/// check_points, then the bbox diagonal of `in` (the unit of every length parameter), returned.
/// Throws InputError "<stage>: the input's bounding box has a zero diagonal" when it is 0.
inline float checked_diagonal(const PointCloud& in, std::string_view stage,
                              Eigen::Index min_points = 1) {
  check_points(in, stage, min_points);
  const float diag = in.bbox().diagonal();
  if (!(diag > 0.0f)) {
    throw InputError(fmt::format("{}: the input's bounding box has a zero diagonal", stage));
  }
  return diag;
}

/// Throws InputError "<stage>: ..." when `cloud` has no normals or a normal of zero length (below
/// 1e-6; non-finite normals are caught by PointCloud::validate). `chain` names the chain that
/// supplies normals, e.g. "normals.pca -> normals.bilateral -> filter.gpf".
inline void require_unit_normals(const PointCloud& cloud, std::string_view stage,
                                 std::string_view chain) {
  if (!cloud.has_normals()) {
    throw InputError(fmt::format(
        "{}: the input has no normals (properties nx, ny, nz); supply them with the chain {}",
        stage, chain));
  }
  for (Eigen::Index i = 0; i < cloud.size(); ++i) {
    const float len = cloud.normals.col(i).norm();
    if (!(len >= 1e-6f)) {
      throw InputError(fmt::format(
          "{}: the normal (nx, ny, nz) of point {} has zero length; supply normals with the "
          "chain {}",
          stage, i, chain));
    }
  }
}

/// The normals of `cloud` scaled to unit length (after require_unit_normals).
inline Eigen::Matrix3Xf unit_normals(const PointCloud& cloud) {
  return cloud.normals.colwise().normalized();
}

}  // namespace scanbench::algorithms::detail
