#pragma once
// TEMPORARY local draft of core's CovarianceMesh (stage-data interface, not yet on main).
// Removed when main's core/covariance_mesh.h lands.
#include <Eigen/Core>
#include <cstdint>
#include <string_view>
#include <vector>

#include "scanbench/core/triangle_mesh.h"

namespace scanbench {

struct CovarianceMesh {
  Eigen::Matrix3Xd means;
  Eigen::Matrix<double, 6, Eigen::Dynamic> covariances;  // xx, xy, xz, yy, yz, zz
  std::vector<std::uint32_t> face_offsets{0};
  std::vector<std::uint32_t> face_vertices;
  Eigen::Index num_vertices() const { return means.cols(); }
  Eigen::Index num_faces() const { return static_cast<Eigen::Index>(face_offsets.size()) - 1; }
};

}  // namespace scanbench
