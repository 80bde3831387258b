#pragma once
// PointCloud: structure-of-arrays on Eigen storage. Positions are required; every
// other attribute is either empty or has one entry per point. validate() checks exactly that.
#include <Eigen/Core>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "scanbench/core/bbox.h"

namespace scanbench {

struct PointCloud {
  /// 3 x n positions.
  Eigen::Matrix3Xf positions;
  /// 3 x n unit normals, or empty. Orientation may be arbitrary (see the producing algorithm).
  Eigen::Matrix3Xf normals;
  /// n weights, or empty.
  Eigen::VectorXf weights;
  /// n scan ids (index into sensor_origins), or empty.
  Eigen::VectorXi scan_ids;
  /// Any further named float property with one value per point (e.g. "outlier", "clean_x").
  std::map<std::string, Eigen::VectorXf> properties;
  /// 3 x s sensor positions, one per scan id (metadata: not per point). Empty when unknown.
  Eigen::Matrix3Xf sensor_origins;
  /// Sensor positions are in the same local frame as `positions`.
  /// Local origin (see stage_data.h, "Local origin"): the world position of a point is
  /// origin + positions.col(i) in double. Zero for data near the world origin (most data); a reader
  /// sets it for survey-scale files whose coordinates float32 cannot hold, and writers restore it.
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();

  Eigen::Index size() const { return positions.cols(); }
  bool empty() const { return positions.cols() == 0; }
  bool has_normals() const { return normals.cols() > 0; }
  bool has_weights() const { return weights.size() > 0; }
  bool has_scan_ids() const { return scan_ids.size() > 0; }
  bool has_property(std::string_view name) const {
    return properties.find(std::string(name)) != properties.end();
  }
  BoundingBox bbox() const { return bounding_box(positions); }

  /// Resizes positions and clears every other attribute.
  void resize(Eigen::Index n);

  /// Throws InputError("<where>: ...") when an attribute's size differs from the point count,
  /// when a scan id has no sensor origin, or when any position or normal is not finite.
  void validate(std::string_view where) const;

  /// The points whose indices are listed, with every per-point attribute; metadata is kept.
  PointCloud subset(const std::vector<Eigen::Index>& indices) const;
};

}  // namespace scanbench
