#pragma once
// TriangleMesh: indexed triangles on Eigen storage. Faces are counter-clockwise seen from outside
// (outward normals by the right-hand rule) for the closed meshes scanbench generates.
#include <Eigen/Core>
#include <string_view>

#include "scanbench/core/bbox.h"

namespace scanbench {

struct TriangleMesh {
  /// 3 x v vertex positions.
  Eigen::Matrix3Xf vertices;
  /// 3 x f vertex indices per triangle.
  Eigen::Matrix3Xi faces;
  /// Local origin (see stage_data.h, "Local origin"): the world position of a point is
  /// origin + vertices.col(i) in double. Zero for data near the world origin (most data); a reader
  /// sets it for survey-scale files whose coordinates float32 cannot hold, and writers restore it.
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();

  Eigen::Index num_vertices() const { return vertices.cols(); }
  Eigen::Index num_faces() const { return faces.cols(); }
  bool empty() const { return faces.cols() == 0; }
  BoundingBox bbox() const { return bounding_box(vertices); }

  /// Throws InputError("<where>: ...") for no faces, non-finite vertices, or face indices out of
  /// range. Degenerate (zero-area) triangles are allowed here; consumers that cannot take them
  /// check count_degenerate_faces().
  void validate(std::string_view where) const;

  /// Unit face normal (zero vector for a degenerate face).
  Eigen::Vector3f face_normal(Eigen::Index f) const;
  /// Face area.
  float face_area(Eigen::Index f) const;
  /// Sum of face areas.
  double area() const;
  /// Signed enclosed volume (positive for a closed mesh with outward orientation).
  double signed_volume() const;
  /// Number of faces with zero area (or repeated vertex indices).
  Eigen::Index count_degenerate_faces() const;
  /// True when every undirected edge is shared by exactly two faces with opposite directions
  /// (a closed, consistently oriented 2-manifold edge structure).
  bool is_closed_and_oriented() const;
};

}  // namespace scanbench
