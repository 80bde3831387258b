#pragma once
// In core: the metrics and the photogrammetric scanner's outlier flag share it.
// Closest point on a triangle (Ericson, Real-Time Collision Detection, section 5.1.5: Voronoi
// regions of the vertices, edges and face, tested in that order). Computed in double precision so
// the exact oracle is exact to rounding; degenerate triangles (collinear or repeated vertices)
// are handled because every region test falls back to an edge or vertex.
#include <Eigen/Core>

namespace scanbench {

/// A triangle prepared for many closest-point queries: the products of its edges and the
/// degeneracy test are computed once. closest_point gives exactly the answer of
/// closest_point_on_triangle (which is this same routine), bit for bit.
struct PreparedTriangle {
  Eigen::Vector3d a, b, c;
  double abab = 0.0, abac = 0.0, acac = 0.0;  // (b-a).(b-a), (b-a).(c-a), (c-a).(c-a)
  bool degenerate = false;                    // collinear or repeated vertices

  PreparedTriangle() = default;
  PreparedTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

  /// The point of the triangle nearest to p (finite). Never throws.
  Eigen::Vector3d closest_point(const Eigen::Vector3d& p) const;
};

/// The point of triangle (a, b, c) nearest to p. Never throws; all inputs must be finite.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace scanbench
