#pragma once
// Peers: Open3D 0.16 (Debian's libopen3d-dev) surface reconstruction, outlier removal and normal
// estimation, wrapped as scanbench algorithms to compare against. Open3D stays inside
// open3d_peers.cpp; no Open3D type appears here.
//
// Boundary conversions: Open3D works in double on its own PointCloud; positions and normals are
// copied in (float -> double) and results copied out (double -> float). Every length parameter is
// a fraction of the input's bounding-box diagonal (the harness's convention) and is multiplied by
// that diagonal before Open3D sees it; counts and ratios pass unchanged. Open3D's errors
// (utility::LogError throws std::runtime_error) become Error("<step>: Open3D: ...") on one line;
// Open3D's console log is silenced below errors.
//
// Threads and determinism: Open3D parallelises with OpenMP, not TBB. Before each call the OpenMP
// thread count of the calling thread is set to the run's thread count (RunContext::threads(), 0 =
// every hardware thread). The wrapped per-point loops (normal estimation, outlier statistics) write
// one result per point and reduce serially, so their bytes do not depend on that count; the
// Poisson solver's output does (its thread pool splits sums), so peer.open3d_poisson always runs
// with one thread. Ball pivoting, alpha shapes (Qhull) and the tangent-plane orientation (MST) are
// serial. Timers: "open3d".
#include <string>

#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

/// Open3D's version ("0.16.1"), for the run context's library list.
const char* open3d_version();

// peer.open3d_poisson: TriangleMesh::CreateFromPointCloudPoisson (Kazhdan and Hoppe 2013, Open3D's
// copy of PoissonRecon): degree-1 B-splines, Neumann boundary, screening weight alpha fixed at 2
// (point_weight = 2 x FEM degree), samples per node 1.5, no confidence; none of these is
// exposed by Open3D. Needs oriented normals (chain normals.pca -> peer.open3d_poisson). It returns
// a per-vertex density (the number of samples supporting the vertex, Open3D's `densities`);
// density_trim removes the vertices whose density lies below that quantile (the Open3D
// tutorial's trimming; 0 = keep all) with their faces, then unreferenced vertices.
struct Open3dPoissonParams {
  int depth = 8;
  double scale = 1.1;
  bool linear_fit = false;
  double density_trim = 0.0;

  static void declare(ParamDeclarer<Open3dPoissonParams>& d) {
    d.integer("depth", &Open3dPoissonParams::depth, Range::closed(2, 14), "",
              "maximum octree depth (Open3D `depth`; PoissonRecon --depth)");
    d.real("scale", &Open3dPoissonParams::scale, Range::closed(1.0, 4.0), "",
           "ratio of the reconstruction cube to the samples' bounding cube (Open3D `scale`)");
    d.flag("linear_fit", &Open3dPoissonParams::linear_fit,
           "place iso-vertices by linear interpolation of the implicit function (Open3D "
           "`linear_fit`)");
    d.real("density_trim", &Open3dPoissonParams::density_trim, Range::half_open(0.0, 1.0), "",
           "quantile of Open3D's per-vertex densities below which vertices (and their faces) "
           "are removed; 0 = keep all");
  }
};

// peer.open3d_ball_pivoting: TriangleMesh::CreateFromPointCloudBallPivoting (Bernardini et al.
// 1999). Radii: `levels` balls radius, 2 radius, 4 radius, ... (radius a fraction of the diagonal,
// each multiplied by it). Needs oriented normals (Open3D orients faces by them). Interpolating:
// the output vertices are the input points (unreferenced ones removed), holes where no ball
// pivots.
struct Open3dBallPivotingParams {
  double radius = 0.01;
  int levels = 3;

  static void declare(ParamDeclarer<Open3dBallPivotingParams>& d) {
    d.real("radius", &Open3dBallPivotingParams::radius, Range::open_min(0.0, 1.0), "diag",
           "smallest ball radius as a fraction of the bbox diagonal (Open3D gets radius x "
           "diagonal)");
    d.integer("levels", &Open3dBallPivotingParams::levels, Range::closed(1, 8), "",
              "number of radii: radius, 2 radius, 4 radius, ... (Open3D `radii`)");
  }
};

// peer.open3d_alpha_shape: TriangleMesh::CreateFromPointCloudAlphaShape (Edelsbrunner and Muecke
// 1994): the boundary of the union of the Delaunay tetrahedra (Qhull) whose circumradius is below
// alpha. Needs no normals; the faces' orientation is Open3D's.
struct Open3dAlphaShapeParams {
  double alpha = 0.03;

  static void declare(ParamDeclarer<Open3dAlphaShapeParams>& d) {
    d.real("alpha", &Open3dAlphaShapeParams::alpha, Range::open_min(0.0, 10.0), "diag",
           "alpha (circumradius bound) as a fraction of the bbox diagonal (Open3D gets alpha x "
           "diagonal)");
  }
};

// peer.open3d_outlier_removal: PointCloud::RemoveStatisticalOutliers (a point is removed when its
// mean distance to its k nearest neighbours exceeds the mean of those means plus std_ratio
// standard deviations) or RemoveRadiusOutliers (removed when fewer than min_points points lie
// within radius, the point itself included). Kept points keep every attribute of the input.
struct Open3dOutlierParams {
  std::string method = "statistical";
  int k = 20;
  double std_ratio = 2.0;
  double radius = 0.02;
  int min_points = 8;

  static void declare(ParamDeclarer<Open3dOutlierParams>& d) {
    d.choice("method", &Open3dOutlierParams::method, {"statistical", "radius"},
             "Open3D RemoveStatisticalOutliers or RemoveRadiusOutliers");
    d.integer("k", &Open3dOutlierParams::k, Range::closed(1, 1000), "",
              "statistical: nearest neighbours of the mean distance (Open3D `nb_neighbors`)");
    d.real("std_ratio", &Open3dOutlierParams::std_ratio, Range::open_min(0.0, 100.0), "",
           "statistical: standard deviations above the mean (Open3D `std_ratio`)");
    d.real("radius", &Open3dOutlierParams::radius, Range::open_min(0.0, 1.0), "diag",
           "radius: search radius as a fraction of the bbox diagonal (Open3D `search_radius`)");
    d.integer("min_points", &Open3dOutlierParams::min_points, Range::closed(1, 100000), "",
              "radius: fewest points within the radius, itself included (Open3D `nb_points`)");
  }
};

// peer.open3d_normals: PointCloud::EstimateNormals (PCA of the k nearest neighbours, or of at
// most k neighbours within radius when radius > 0: KDTreeSearchParamHybrid) from scratch (input
// normals are dropped first, since Open3D would otherwise flip toward them), then
// OrientNormalsConsistentTangentPlane(orient_k) (Hoppe et al. 1992: propagation along a minimum
// spanning tree of the Riemannian graph). The propagation fixes signs relative to each other
// only; the global sign is then chosen as normals.pca does: the normal of the point farthest
// from the centroid points away from the centroid. orient = none keeps Open3D's unoriented
// normals (arbitrary signs).
struct Open3dNormalsParams {
  int k = 30;
  double radius = 0.0;
  std::string orient = "tangent_plane";
  int orient_k = 10;

  static void declare(ParamDeclarer<Open3dNormalsParams>& d) {
    d.integer("k", &Open3dNormalsParams::k, Range::closed(3, 1000), "",
              "nearest neighbours of each PCA fit (Open3D `knn` / `max_nn`)");
    d.real("radius", &Open3dNormalsParams::radius, Range::closed(0.0, 1.0), "diag",
           "when > 0: neighbours within radius (fraction of the bbox diagonal), at most k "
           "(KDTreeSearchParamHybrid); 0 = the k nearest");
    d.choice("orient", &Open3dNormalsParams::orient, {"tangent_plane", "none"},
             "OrientNormalsConsistentTangentPlane then outward at the farthest point, or none");
    d.integer("orient_k", &Open3dNormalsParams::orient_k, Range::closed(3, 1000), "",
              "neighbours of the Riemannian graph of the orientation (Open3D `k`)");
  }
};

/// peer.open3d_poisson. Throws InputError for points without normals or fewer than 4 points,
/// Error when Open3D fails or trimming leaves no face. Output: the mesh.
StageData open3d_poisson(const StageData& in, const Open3dPoissonParams& p, RunContext& ctx);
/// peer.open3d_ball_pivoting. Throws InputError without normals, Error when no face results.
StageData open3d_ball_pivoting(const StageData& in, const Open3dBallPivotingParams& p,
                               RunContext& ctx);
/// peer.open3d_alpha_shape. Throws InputError for fewer than 4 points, Error when no face results.
StageData open3d_alpha_shape(const StageData& in, const Open3dAlphaShapeParams& p, RunContext& ctx);
/// peer.open3d_outlier_removal. Throws InputError for empty input.
PointCloud open3d_outlier_removal(const PointCloud& in, const Open3dOutlierParams& p,
                                  RunContext& ctx);
/// peer.open3d_normals. Throws InputError for fewer than 3 points. Output: the input with normals.
PointCloud open3d_normals(const PointCloud& in, const Open3dNormalsParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
