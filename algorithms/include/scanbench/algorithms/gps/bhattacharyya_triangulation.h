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
// - Candidates (`candidates`). The paper does not restrict them; CGAL's advancing front (the
//   implementation of Cohen-Steiner and Da) takes a priority functor but offers only the Delaunay
//   facets of the points. Both are implemented and measured; the default is "delaunay".
//   * "delaunay" (default): CGAL 5.5's Advancing_front_surface_reconstruction over the means, its
//     facet priority replaced by 1 / P (CGAL takes the smallest value first; infinity() means "not
//     a candidate": any BC at most bc_min, beta at most beta_min, or an angle above max_angle).
//     beta is measured against the surface facets sharing an edge with the candidate; before any
//     facet exists it is pi, so CGAL's seed (the smallest value over all Delaunay facets) is the
//     triangle of highest P_prob, as the paper seeds, and each further component is seeded the
//     same way among the unused means (CGAL's re-initialisation; max_seeds does not apply). CGAL's
//     own parameters: beta = pi (every candidate lies in CGAL's "beta-wedge", where CGAL orders the
//     front by the priority alone, i.e. by P; a narrower wedge would order the others by flatness,
//     which the paper does not do), radius_ratio_bound = 5 (CGAL's default; it only acts outside
//     the wedge, so never). CGAL's other fixed rules stay: its sliver test (normals more than
//     about 149 deg apart, i.e. beta below about 31 deg, close to the paper's pi/6), its
//     ear/glue handling where fronts meet, and its post-processing that closes small holes
//     (under 15 border edges) by dropping points that do not fit. A Delaunay facet ignores the
//     covariances, but the BC grading still decides which facets are taken: the thin sheets of
//     Fig. 8b are not bridged (their bridging facets are Delaunay facets with BC below bc_min).
//   * "free": every triangle of pairwise overlapping Gaussians is a candidate: for a front edge
//     (i, j) the Gaussians k with BC_ik and BC_jk above bc_min, each Gaussian keeping its
//     `max_neighbors` partners of highest BC (ties by index). Greedy growing with the manifold
//     and glue rules below.
//   Measured (test_triangulation_candidates.cpp, DISABLED_MeasureBothModes; a torus R 1, r 0.35
//   at 24x10 to 64x24 segments, 3 kernel sizes each): "delaunay" closes all 19 torus mixtures
//   (0 boundary edges, Euler characteristic 0) and the sphere (Euler 2); "free" leaves 0-13
//   boundary edges on the tori (Euler -4 to 0; 9 of 19 closed). On a scan (armadillo, moderate
//   scanner, CLOP, mixture.hem sigma0 0.0015: 35.8K Gaussians) "delaunay" took 5.2 s against
//   75 s, with the same surface error (chamfer 0.0019 vs 0.0018 of the diagonal) but more holes
//   (13.3K boundary edges against 6.3K of 61K-67K faces). The default is "delaunay": it closes
//   the closed test surfaces, as the paper's stopping rule promises ("a watertight mesh"), and is
//   an order of magnitude faster on scans; "free" fills more of a scan's sparse regions.
// - max_angle_deg (both modes): a candidate with an interior angle above 149.32 deg is refused.
//   GPS sec. 6.2 adopts only Cohen-Steiner and Da's dihedral bound; their front-edge angle bound
//   (CGAL: cosine -0.86) is what keeps P, which grades overlap and not shape, from choosing
//   slivers along the rings of a torus (three consecutive means of a ring overlap well). Without
//   it (180 = off) "delaunay" leaves 51-565 boundary edges on those tori (CGAL abandons a front
//   edge whose best candidate is such a sliver) and "free" 25-274.
// - Manifoldness ("free"; the paper requires a manifold mesh): a candidate may not put a third
//   face on an edge, must use an existing edge in the direction opposite to its face there (one
//   orientation), and may reach a vertex already in the mesh only through an edge of the front.
//   So every edge has at most two faces. Where two fronts meet (closing a handle, e.g. around a
//   torus) no such candidate exists; when the front stalls, the best "glue" candidate over every
//   stalled edge may reach a front vertex through no edge (the gluing of Cohen-Steiner and Da),
//   which pinches that vertex until the ordinary steps that follow close the gap. A vertex still
//   pinched when growing stops (either mode) keeps only its largest fan (the faces of the others
//   are dropped, leaving holes), so the output is a manifold that subdivide.gp_loop accepts
//   (`pinched_vertices`, `unpinched_vertices`).
// - Orientation: consistent per component; a component whose signed volume about the centroid of
//   its faces is negative is flipped, so components face outward (CGAL returns either).
// - Gaussians in no triangle are left out of the output (they are counted in the run's log).
// - Determinism: ties in P are broken by vertex indices ("free"; "delaunay" perturbs 1 / P by a
//   relative 1e-12 hashed from the facet's vertex indices, since CGAL would order equal values by
//   heap address) and the "delaunay" faces are returned in a canonical order: the result does not
//   depend on the thread count (only the BC graph of "free" is built in parallel).
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
