#pragma once
// CovarianceMesh: a polygon mesh whose vertices carry a 3D Gaussian (a mean and a symmetric
// positive definite covariance), the control mesh of Gaussian-product subdivision (GPS paper,
// Preiner et al. 2019, sec. 4-5: "covmesh"). Faces are general polygons in compressed rows
// (PolygonFaces: triangles for Loop, quads for Catmull-Clark, any mix as input). Values are
// double: the dual map of GPS sec. 5 inverts covariances, and its identities (eq. 14) are tested
// to 1e-12.
#include <Eigen/Core>
#include <string_view>
#include <vector>

#include "scanbench/core/polygon_faces.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench {

struct CovarianceMesh {
  /// 3 x v vertex means.
  Eigen::Matrix3Xd means;
  /// 6 x v symmetric covariances stored as (xx, xy, xz, yy, yz, zz), one per vertex.
  Eigen::Matrix<double, 6, Eigen::Dynamic> covariances;
  /// The polygons (polygon_faces.h); a mesh without faces is a valid covariance point set.
  PolygonFaces faces;
  /// Local origin (see stage_data.h, "Local origin"): the world position of vertex i is
  /// origin + means.col(i) in double; zero for data near the world origin.
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();

  Eigen::Index num_vertices() const { return means.cols(); }
  Eigen::Index num_faces() const { return faces.num_faces(); }

  /// Sets the vertex count (means and covariances uninitialised) and removes every face.
  void resize(Eigen::Index v);

  Eigen::Matrix3d covariance(Eigen::Index i) const;
  /// Stores the symmetric part of `c`.
  void set_covariance(Eigen::Index i, const Eigen::Matrix3d& c);

  /// Throws InputError("<where>: ...") for no vertices, non-finite values, a covariance that is not
  /// symmetric positive definite ("vertex 12: covariance is not positive definite (eigenvalues
  /// ...)"), a face with fewer than 3 vertices, a vertex index out of range or repeated in a face.
  void validate(std::string_view where) const;

  /// The mean mesh: the vertices' means with every face fan-triangulated (float positions).
  TriangleMesh mean_mesh() const;
};

}  // namespace scanbench
