#pragma once
// Internal to the algorithms module: the input check of the stages that consume normals
// (normals.bilateral, filter.gpf, peer.cgal_ear). They never estimate normals silently: a missing
// or degenerate normal stops the stage with one line naming the property and the chain that
// supplies it.
#include <fmt/format.h>

#include <string_view>

#include "scanbench/core/errors.h"
#include "scanbench/core/point_cloud.h"

namespace scanbench::algorithms::detail {

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
