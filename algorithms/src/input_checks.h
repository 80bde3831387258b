#pragma once
// Internal to the algorithms module: the one input prologue of the steps that consume points
// (validate, too few points, zero bbox diagonal), so that every step rejects bad input with the
// same one-line errors. The checks of normals are in gpf/normal_checks.h.
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

}  // namespace scanbench::algorithms::detail
