#pragma once
// Axis-aligned bounding box. Every length parameter of scanbench is a fraction of the diagonal of
// the input's (or the ground truth's) bounding box, so this is the unit of the whole project.
#include <Eigen/Core>
#include <limits>

namespace scanbench {

struct BoundingBox {
  Eigen::Vector3f min = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f max = Eigen::Vector3f::Constant(-std::numeric_limits<float>::infinity());

  bool empty() const { return (max.array() < min.array()).any(); }
  void extend(const Eigen::Vector3f& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  Eigen::Vector3f center() const { return 0.5f * (min + max); }
  Eigen::Vector3f extent() const { return max - min; }
  /// Length of the diagonal; 0 for an empty box.
  float diagonal() const { return empty() ? 0.0f : (max - min).norm(); }
  /// The box grown by `factor` about its centre (1.1 = 10% larger).
  BoundingBox scaled(float factor) const {
    BoundingBox b;
    b.min = center() - 0.5f * factor * extent();
    b.max = center() + 0.5f * factor * extent();
    return b;
  }
};

/// Bounding box of the columns of a 3 x n matrix.
inline BoundingBox bounding_box(const Eigen::Matrix3Xf& points) {
  BoundingBox b;
  if (points.cols() > 0) {
    b.min = points.rowwise().minCoeff();
    b.max = points.rowwise().maxCoeff();
  }
  return b;
}

}  // namespace scanbench
