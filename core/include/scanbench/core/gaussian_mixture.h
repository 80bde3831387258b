#pragma once
// GaussianMixture: weights, means and covariances of a 3D mixture, plus the optional normal-axis
// distribution (a wrapped normal on the sphere: unit axis and its spread sigma^2, CLOP section 9)
// that rides on each component for CSW normals.
#include <Eigen/Core>
#include <string_view>

#include "scanbench/core/point_cloud.h"

namespace scanbench {

struct GaussianMixture {
  /// k weights (sum to 1 for a normalised mixture).
  Eigen::VectorXf weights;
  /// 3 x k means.
  Eigen::Matrix3Xf means;
  /// 6 x k symmetric covariances stored as (xx, xy, xz, yy, yz, zz).
  Eigen::Matrix<float, 6, Eigen::Dynamic> covariances;
  /// 3 x k unit normal axes, or empty.
  Eigen::Matrix3Xf normal_axes;
  /// k normal-axis spreads sigma^2 in radians^2, or empty (present iff normal_axes is).
  Eigen::VectorXf normal_spreads;
  /// Local origin (see stage_data.h, "Local origin"): the world position of component i is
  /// origin + means.col(i) in double; zero for data near the world origin.
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();

  Eigen::Index size() const { return means.cols(); }
  bool has_normal_axes() const { return normal_axes.cols() > 0; }
  void resize(Eigen::Index k);

  Eigen::Matrix3f covariance(Eigen::Index i) const;
  void set_covariance(Eigen::Index i, const Eigen::Matrix3f& c);

  /// The components as points: positions = means, normals = normal axes (when present),
  /// weights = mixture weights. How a chain ending in a mixture is scored.
  PointCloud component_points() const;

  /// Throws InputError("<where>: ...") on size mismatch, non-finite values, negative weights.
  void validate(std::string_view where) const;
};

}  // namespace scanbench
