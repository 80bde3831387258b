#pragma once
// Closest point on a triangle (Ericson, Real-Time Collision Detection, section 5.1.5: Voronoi
// regions of the vertices, edges and face, tested in that order). Computed in double precision so
// the exact oracle is exact to rounding; degenerate triangles (collinear or repeated vertices)
// are handled because every region test falls back to an edge or vertex.
#include <Eigen/Core>

namespace scanbench::metrics {

/// The point of triangle (a, b, c) nearest to p. Never throws; all inputs must be finite.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace scanbench::metrics
