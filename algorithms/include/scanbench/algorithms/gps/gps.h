#pragma once
// Gaussian-product subdivision surfaces (Preiner et al. 2019, "Gaussian-Product Subdivision
// Surfaces", ACM TOG 38(4); "GPS paper" below): covariance meshes (a Gaussian (mu_i, Sigma_i) per
// vertex), GP-Loop and GP-Catmull-Clark, their limit positions, normals and curvature, and the
// inference of covariances for an ordinary mesh.
//
// Dual map (sec. 4, eq. 10-12): F(mu, Sigma) = q = (vech(Sigma^-1), Sigma^-1 mu), 9 numbers,
// vech = (xx, xy, xz, yy, yz, zz). A linear scheme with non-negative weights alpha_i applied to
// the q's is the Gaussian product of eq. 6 (eq. 9, 13); F^-1(q) = (Sigma = [q_quad]^-1,
// mu = Sigma q_lin). The refined q's stay in the positive-definite cone because the weights are
// convex (sec. 5), so every refined covariance is symmetric positive definite.
// Properties (tested): equal isotropic covariances give the linear scheme (eq. 14); a global
// scale of the covariances leaves the surface unchanged (sec. 5).
//
// Limit surface (Appendix B): the limit jets of the dual surface q(u, v) (limit and derivative
// masks, subdivision.h) are mapped through F^-1:
//   mu_u  = Sigma (qbar_u - [qq_u] mu)
//   mu_uu = Sigma (qbar_uu - [qq_uu] mu - 2 [qq_u] mu_u)
//   mu_uv = Sigma (qbar_uv - [qq_uv] mu - [qq_u] mu_v - [qq_v] mu_u)   (derived as the paper's
//           mu_uu; its text gives mu_uu and says "mu_vv is defined accordingly")
// (qq = quadratic part, qbar = linear part). Normal n = mu_u x mu_v / |.|; with the first and
// second fundamental forms (E, F, G; L, M, N = mu_uu.n, mu_uv.n, mu_vv.n):
//   K = (LN - M^2)/(EG - F^2), H = -(EN - 2FM + GL)/(2 (EG - F^2)),
// signed so that a sphere with outward (counter-clockwise) faces has H = +1/R.
// Curvature is exact at regular vertices only; elsewhere (extraordinary or boundary vertices, see
// VertexKind) it is the mean over the regular neighbours (0 when there is none) and flagged.
//
// Covariance inference for an ordinary mesh (sec. 6.1), sigma_0 a fraction of the bbox diagonal:
//   vertex-based (eq. 15): Sigma_i = cov(v_i and its 1-ring neighbours) + sigma_0^2 I;
//   face-based (eq. 16-17): Sigma_i = (sum_j Sigma_Dj^-1)^-1 over the faces D_j at v_i,
//     Sigma_Dj = cov(vertices of D_j) + sigma_0^2 I.
// cov is the population covariance (1/n; the paper does not say which, the authors' demo uses
// 1/n). Alternative bias (the authors' public demo, not eq. 15/17): + 0.05 lambda_max(cov) I
// per covariance instead of sigma_0^2 I (`bias=lambda_max`, factor `lambda_factor`).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "scanbench/algorithms/gps/subdivision.h"
#include "scanbench/core/covariance_mesh.h"
#include "scanbench/core/params.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::algorithms {

using Vector9d = Eigen::Matrix<double, 9, 1>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// vech(S) = (xx, xy, xz, yy, yz, zz) and its inverse [.] (GPS eq. 11-12).
Vector6d vech(const Eigen::Matrix3d& s);
Eigen::Matrix3d unvech(const Vector6d& v);

/// F(mu, Sigma) of eq. 11. Sigma must be symmetric positive definite (not checked here).
Vector9d gaussian_to_dual(const Eigen::Vector3d& mu, const Eigen::Matrix3d& sigma);
/// F^-1(q) of eq. 12. Returns false (outputs untouched) when [q_quad] is not positive definite.
bool dual_to_gaussian(const Vector9d& q, Eigen::Vector3d& mu, Eigen::Matrix3d& sigma);

/// Parameters of subdivide.loop / subdivide.catmull_clark / subdivide.gp_loop /
/// subdivide.gp_catmull_clark.
struct SubdivideParams {
  /// Subdivision levels.
  int levels = 3;
  /// Move the vertices of the last level to their limit positions (limit masks, in the dual
  /// space for GP schemes).
  bool limit = true;
  /// Loop's vertex weight: "loop" (Loop 1987, CGAL) or "warren" (3/(8n); libigl, authors' demo).
  std::string beta = "loop";

  static void declare(ParamDeclarer<SubdivideParams>& d) {
    d.integer("levels", &SubdivideParams::levels, Range::closed(0, 12), "",
              "subdivision levels (each multiplies the faces by 4); refused before allocating "
              "when the result would not fit in memory");
    d.flag("limit", &SubdivideParams::limit,
           "project the last level's vertices to the limit surface (limit masks; GPS Appendix "
           "B: in the dual space, then F^-1)");
    d.choice("beta", &SubdivideParams::beta, {"loop", "warren"},
             "Loop vertex weight: loop = (5/8 - (3/8 + cos(2pi/n)/4)^2)/n (Loop 1987, CGAL), "
             "warren = 3/(8n) (libigl, the GPS authors' demo)");
  }
  SubdivisionOptions options(SubdivisionScheme scheme) const {
    return {scheme, beta == "warren" ? LoopBeta::Warren : LoopBeta::Loop};
  }
};

/// Per-vertex differential geometry of a limit surface (GPS Appendix B).
struct SurfaceAnalysis {
  Eigen::Matrix3Xd positions;  ///< limit positions (means for GP schemes)
  Eigen::Matrix3Xd normals;    ///< unit limit normals (mu_u x mu_v)
  Eigen::VectorXd mean_curvature, gaussian_curvature;
  std::vector<VertexKind> kind;  ///< which quantities are exact (subdivision.h)
};

/// Linear subdivision of an ordinary polygon mesh (`positions` 3 x V): `levels` levels, then the
/// limit positions when p.limit. Throws as subdivide_values.
void subdivide_linear(Eigen::Matrix3Xd& positions, PolygonFaces& faces, SubdivisionScheme scheme,
                      const SubdivideParams& p, std::string_view where);

/// Gaussian-product subdivision of a covariance mesh: checks the covariances, maps every vertex
/// to the dual space, subdivides, and maps back (limit positions and covariances when p.limit).
/// Throws InputError naming the vertex for a covariance that is not SPD, naming the face for bad
/// connectivity, ParamError for levels that do not fit in memory. Phase timers "dual_map",
/// "subdivide", "limit" on ctx.
CovarianceMesh gp_subdivide(const CovarianceMesh& in, SubdivisionScheme scheme,
                            const SubdivideParams& p, RunContext& ctx, std::string_view where);

/// Limit analysis of a linear subdivision surface at the vertices of control mesh `positions`.
SurfaceAnalysis linear_limit_analysis(const Eigen::Matrix3Xd& positions, const PolygonFaces& faces,
                                      const SubdivisionOptions& options, std::string_view where);
/// Limit analysis of a GP subdivision surface at the vertices of covariance mesh `m` (Appendix B).
SurfaceAnalysis gp_limit_analysis(const CovarianceMesh& m, const SubdivisionOptions& options,
                                  std::string_view where);

/// Parameters of subdivide.infer_covariances (GPS sec. 6.1).
struct InferenceParams {
  std::string method = "face";  ///< "face" (eq. 16-17), "vertex" (eq. 15) or "isotropic"
  std::string bias = "sigma0";  ///< "sigma0" (eq. 15/17) or "lambda_max" (authors' demo)
  double sigma_0 = 0.01;        ///< fraction of the bbox diagonal
  double lambda_factor = 0.05;  ///< bias = lambda_factor * lambda_max(cov) with bias=lambda_max

  static void declare(ParamDeclarer<InferenceParams>& d) {
    d.choice("method", &InferenceParams::method, {"face", "vertex", "isotropic"},
             "face: Sigma_i = (sum_j Sigma_Dj^-1)^-1 over the faces at vertex i (GPS eq. 16-17); "
             "vertex: covariance of the vertex and its 1-ring (eq. 15); isotropic: sigma_0^2 I "
             "at every vertex (eq. 14: the linear scheme)");
    d.choice("bias", &InferenceParams::bias, {"sigma0", "lambda_max"},
             "sigma0: + sigma_0^2 I (eq. 15, 17); lambda_max: + lambda_factor * lambda_max I "
             "per covariance (the GPS authors' public demo)");
    d.real("sigma_0", &InferenceParams::sigma_0, Range::above(0.0), "diag",
           "bandwidth sigma_0 of eq. 15/17 as a fraction of the bbox diagonal");
    d.real("lambda_factor", &InferenceParams::lambda_factor, Range::open_min(0.0, 10.0), "",
           "factor of lambda_max with bias=lambda_max (0.05 in the authors' demo)");
  }
};

/// Covariances for an ordinary polygon mesh (GPS sec. 6.1). Throws InputError for bad
/// connectivity (naming the face) or non-finite positions (naming the vertex).
CovarianceMesh infer_covariances(const Eigen::Matrix3Xd& positions, const PolygonFaces& faces,
                                 const InferenceParams& p, std::string_view where);

/// A triangle mesh's faces as PolygonFaces (a covariance mesh holds PolygonFaces itself).
PolygonFaces faces_of(const TriangleMesh& m);
/// Triangle mesh of positions and polygon faces (n-gons fanned from their first vertex).
TriangleMesh triangle_mesh_of(const Eigen::Matrix3Xd& positions, const PolygonFaces& faces);

}  // namespace scanbench::algorithms

namespace scanbench::algorithms {

/// One modelling input of the GPS paper's figures.
struct FigureInput {
  std::string name;  ///< e.g. "cone_flat", "cube_isotropic"
  std::string doc;
  CovarianceMesh mesh;
};

/// The modelling inputs of GPS Fig. 10 and Fig. 9 (shipped as configs/gps/<name>.ply):
///  - cone (y up; apex (0, 1, 0), rings of 8 at y = 0.5 (radius 0.5) and y = 0 (radius 1), open
///    at the bottom; every vertex 0.01 I except the apex), the five apex covariances of Fig. 10
///    with the values of the authors' demo: cone_isotropic 0.01 I (ordinary Loop), cone_singular
///    1e-5 I (pointy apex), cone_vertical diag(.001, .01, .01) (concave ridge), cone_horizontal
///    diag(.01, .001, .01) (smooth plateau), cone_flat diag(1, 1e-5, 1) (sharp plateau);
///  - cube [-1, 1]^3 as 6 quads (Fig. 9; the paper gives no values, ours are stated here):
///    cube_isotropic 0.1 I (= Catmull-Clark, eq. 14), cube_flat_diagonal (each corner flat
///    across its diagonal d: 0.1 (I - 0.99 d d^T)), cube_needle_diagonal (elongated along d:
///    0.1 (0.01 I + d d^T)), cube_top_flat (top corners diag(.1, .1, 1e-4), bottom 0.1 I),
///    cube_axis_z (corners at x > 0 elongated along z: diag(.001, .001, .1), the others 0.1 I;
///    one constant covariance everywhere, anisotropic or not, is plain Catmull-Clark by eq. 14).
std::vector<FigureInput> gps_figure_inputs();

}  // namespace scanbench::algorithms

#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

/// Registry adapters (algorithms/src/registry.cpp): subdivide.loop and subdivide.catmull_clark
/// (mesh -> mesh; Catmull-Clark quads are split into two triangles in the output mesh, and a
/// triangle input is handled by the scheme), subdivide.gp_loop and subdivide.gp_catmull_clark
/// (covariance mesh -> covariance mesh and its mean mesh; primary: the mean mesh), and
/// subdivide.infer_covariances (mesh -> covariance mesh). The stage name prefixes every error.
StageData subdivide_loop_stage(const StageData& in, const SubdivideParams& p, RunContext& ctx);
StageData subdivide_catmull_clark_stage(const StageData& in, const SubdivideParams& p,
                                        RunContext& ctx);
StageData gp_loop_stage(const StageData& in, const SubdivideParams& p, RunContext& ctx);
StageData gp_catmull_clark_stage(const StageData& in, const SubdivideParams& p, RunContext& ctx);
StageData infer_covariances_stage(const StageData& in, const InferenceParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
