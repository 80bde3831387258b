#pragma once
// triangulate.bhattacharyya: a triangulation of a Gaussian mixture into a covariance mesh (GPS
// paper, Preiner et al. 2019, sec. 6.2 "Topological inference").
//
// Greedy front growing (Cohen-Steiner and Da 2004): start from a seed triangle and repeatedly add,
// across an open boundary edge of the front, the candidate triangle of highest plausibility
//   P(ijk) = BC_ij BC_jk BC_ik * beta_ijk / pi                                        (eq. 20-22)
// where BC is the Bhattacharyya coefficient of two Gaussians in closed form (eq. 19)
//   BC_ij = |S|^-1/2 |Sigma_i Sigma_j|^1/4 exp(-1/8 (mu_i - mu_j)^T S^-1 (mu_i - mu_j)),
//   S = (Sigma_i + Sigma_j) / 2,
// and beta_ijk the smallest dihedral angle between the candidate and the triangles it would share
// an edge with (pi = flat, 0 = folded back). A candidate is valid only if its three BC exceed
// `bc_min` and beta exceeds `beta_min_deg`. The seed is the triangle of highest BC_ij BC_jk BC_ik
// (eq. 20) among all valid triangles; when the front can no longer grow, the best triangle among
// still unused Gaussians seeds a further component (the paper: "several seeds can be used ...
// especially if comprising several distinct parts"), until none is left or `max_seeds` is reached.
//
// Where the paper is silent, and what is chosen here:
// - Candidates. The paper does not restrict them; CGAL's advancing front (the base method) offers
// only
//   Delaunay facets, which cannot express the anisotropic overlaps of Fig. 8 (a Delaunay facet
//   ignores the covariances). Here the candidates for a front edge (i, j) are the Gaussians k that
//   overlap both ends (BC_ik and BC_jk above bc_min): every valid triangle is a candidate. To bound
//   the work each Gaussian keeps its `max_neighbors` partners of highest BC (ties by index).
// - Manifoldness (the paper requires a manifold mesh): a candidate may not put a third face on an
//   edge, must use an existing edge in the direction opposite to its face there (one orientation),
//   and may reach a vertex already in the mesh only through an edge of the front. So every edge has
//   at most two faces. Where two fronts meet (closing a handle, e.g. around a torus) no such
//   candidate exists; when the front stalls, the best "glue" candidate over every stalled edge may
//   reach a front vertex through no edge (the gluing of Cohen-Steiner and Da), which pinches that
//   vertex until the ordinary steps that follow close the gap. (Gluing as an ordinary candidate in
//   the same queue was measured worse on the torus test: 119 boundary edges, 32 pinched vertices,
//   against 36 and 1.) A vertex still pinched when growing stops keeps only its largest fan (the
//   faces of the others are dropped, leaving holes), so the output is a manifold that
//   subdivide.gp_loop accepts (`pinched_vertices`, `unpinched_vertices`).
// - Orientation: consistent per component (a new face uses the front edge reversed); a closed
//   component with negative signed volume is flipped, so closed components face outward.
// - Gaussians in no triangle are left out of the output (they are counted in the run's log).
// - Ties in P are broken by vertex indices: the result is deterministic and independent of the
//   thread count (only the BC graph is built in parallel, per Gaussian).
//
// Input: a mixture (from mixture.hem; GPS appendix A). Output: a covariance mesh whose vertices are
// the triangulated components (mean and covariance) and whose faces are triangles.
#include <string>

#include "scanbench/core/covariance_mesh.h"
#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/params.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

struct BhattacharyyaParams {
  double bc_min = 0.01;
  double beta_min_deg = 30.0;
  int max_neighbors = 32;
  int max_seeds = 0;
  double max_angle_deg = 149.32;
  std::string candidates = "delaunay";

  static void declare(ParamDeclarer<BhattacharyyaParams>& d) {
    d.real("bc_min", &BhattacharyyaParams::bc_min, Range{0.0, 1.0, true, true}, "",
           "minimal Bhattacharyya coefficient of each pair of a triangle's Gaussians (GPS sec. "
           "6.2; the paper's value 0.01)");
    d.real("beta_min_deg", &BhattacharyyaParams::beta_min_deg, Range::half_open(0.0, 180.0), "deg",
           "minimal dihedral angle to the neighbouring triangles (GPS sec. 6.2 after Cohen-Steiner "
           "and Da 2004: pi/6)");
    d.real("max_angle_deg", &BhattacharyyaParams::max_angle_deg, Range::open_min(60.0, 180.0),
           "deg",
           "largest interior angle of a candidate triangle (Cohen-Steiner and Da 2004; CGAL's "
           "advancing front uses arccos(-0.86) = 149.32 deg; GPS sec. 6.2 is silent; 180 = off)");
    d.integer("max_neighbors", &BhattacharyyaParams::max_neighbors, Range::closed(3, 1024), "",
              "free candidates: partners of highest BC kept per Gaussian as candidates (a bound on "
              "the work; the paper does not restrict candidates)");
    d.integer("max_seeds", &BhattacharyyaParams::max_seeds, Range::closed(0, 1000000), "",
              "seed triangles (components) at most; 0 = as many as the mixture allows (free "
              "candidates only: CGAL's advancing front seeds every component it can)");
    d.choice("candidates", &BhattacharyyaParams::candidates, {"free", "delaunay"},
             "candidate triangles: delaunay = the Delaunay facets of the means through CGAL's "
             "advancing front (Cohen-Steiner and Da 2004) graded by GPS eq. 19-22 (closes the "
             "torus), free = every triangle of pairwise overlapping Gaussians (GPS sec. 6.2 does "
             "not restrict them)");
  }
};

/// Bhattacharyya coefficient of two Gaussians (GPS eq. 19), in (0, 1]; 1 for equal Gaussians.
/// Covariances must be symmetric positive definite.
double bhattacharyya_coefficient(const Eigen::Vector3d& mu_i, const Eigen::Matrix3d& sigma_i,
                                 const Eigen::Vector3d& mu_j, const Eigen::Matrix3d& sigma_j);

/// What one triangulation did.
struct TriangulationStats {
  Eigen::Index pairs = 0;   ///< Gaussian pairs with BC above bc_min (before the neighbour cap)
  Eigen::Index seeds = 0;   ///< components started
  Eigen::Index unused = 0;  ///< Gaussians left out of every triangle
  Eigen::Index boundary_edges = 0;      ///< edges with one face in the result
  Eigen::Index glued = 0;               ///< glue triangles (fronts meeting, see above)
  Eigen::Index pinched_vertices = 0;    ///< vertices left with two fans when growing stopped
  Eigen::Index unpinched_vertices = 0;  ///< of those, resolved by dropping their smaller fans
};

/// The triangulation of `mixture`. Throws ParamError for bc_min outside (0, 1] or beta_min_deg
/// outside [0, 180) (naming it), InputError for fewer than 3 components (an empty mixture), a
/// covariance that is not SPD (naming the component), or when no valid seed triangle exists
/// (naming bc_min): never an empty mesh. Phase timers "graph" (BC graph) and "front" (growing).
CovarianceMesh triangulate_bhattacharyya(const GaussianMixture& mixture,
                                         const BhattacharyyaParams& p, RunContext& ctx,
                                         TriangulationStats* stats = nullptr);

/// The registered step: the mixture of `in` -> its covariance mesh.
StageData triangulate_bhattacharyya_step(const StageData& in, const BhattacharyyaParams& p,
                                         RunContext& ctx);

}  // namespace scanbench::algorithms
