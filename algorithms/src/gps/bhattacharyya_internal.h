#pragma once
// Internals of triangulate.bhattacharyya shared by its two candidate modes:
// bhattacharyya_triangulation.cpp ("free" candidates, and the common pre- and post-processing) and
// bhattacharyya_afsr.cpp ("delaunay" candidates through CGAL's advancing front; CGAL stays in
// that translation unit).
#include <Eigen/Core>
#include <array>
#include <vector>

#include "scanbench/core/run_context.h"

namespace scanbench::algorithms::bhattacharyya {

/// One mixture component with the quantities eq. 19 needs.
struct Gaussian {
  Eigen::Vector3d mu;
  Eigen::Matrix3d sigma;
  double log_det = 0;
  double lambda_max = 0;
};

/// log BC_ij of GPS eq. 19 (the one kernel definition used by both modes).
double log_bc(const Gaussian& a, const Gaussian& b);

/// Whether every interior angle of the triangle (a, b, c) has a cosine of at least
/// `cos_max_angle` (Cohen-Steiner and Da's bound on the angles of a candidate, see
/// bhattacharyya_triangulation.h); false for a degenerate triangle.
bool angles_within(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                   double cos_max_angle);

/// The faces (indices into `g`) of CGAL's advancing-front surface reconstruction over the means,
/// its candidates graded by GPS eq. 19-22 (see bhattacharyya_triangulation.h). `components`
/// receives the number of connected components CGAL started (its seeds).
std::vector<std::array<int, 3>> delaunay_front(const std::vector<Gaussian>& g, double bc_min,
                                               double beta_min_rad, double cos_max_angle,
                                               RunContext& ctx, long* components);

}  // namespace scanbench::algorithms::bhattacharyya
