#include "scanbench/algorithms/registry.h"

#include <concepts>
#include "scanbench/algorithms/bhattacharyya_triangulation.h"
#include "scanbench/algorithms/bilateral_normals.h"
#include "scanbench/algorithms/cgal_peers.h"
#include "scanbench/algorithms/clop.h"
#include "scanbench/algorithms/csw.h"
#include "scanbench/algorithms/gpf.h"

#include "scanbench/algorithms/cgal_peers.h"
#include "scanbench/algorithms/cgal_reconstruction.h"
#include "scanbench/algorithms/clop.h"
#include "scanbench/algorithms/csw.h"
#include "scanbench/algorithms/decimate.h"
#include "scanbench/algorithms/external.h"
#include "scanbench/algorithms/gps.h"
#include "scanbench/algorithms/hem.h"
#include "scanbench/algorithms/lop.h"
#include "scanbench/algorithms/open3d_peers.h"
#include "scanbench/algorithms/pca_normals.h"
#include "scanbench/algorithms/pcl_peers.h"
#include "scanbench/algorithms/poisson.h"

namespace scanbench::algorithms {

namespace {

// Steps that summarise points in a Gaussian mixture and output points (the mixture rides along).
constexpr StageIo kPointsToMixture{DataKind::Points, DataKind::Points | DataKind::Mixture,
                                   DataKind::Points};
// Steps that consume points and a mixture (of a preceding mixture.hem) and output points.
constexpr StageIo kPointsAndMixtureToPoints{DataKind::Points | DataKind::Mixture, DataKind::Points,
                                            DataKind::Points};
// Reconstructions: points in, a triangle mesh out (the points ride along).
constexpr StageIo kPointsToMesh{DataKind::Points, DataKind::Mesh, DataKind::Mesh};

}  // namespace

const AlgorithmRegistry& registry() {
  static AlgorithmRegistry r = [] {  // not const: plugins add entries (add_plugin_entry)
    AlgorithmRegistry reg("algorithm");
    // One explicit list; every entry has a create-by-name test (tests/algorithms).
    reg.add(make_entry<HemParams>(
        "mixture.hem",
        "Geometrically regularised hierarchical EM (CLOP paper sec. 5, 7, 9.2, Algorithm 1): "
        "eq. 12 initial covariances, WLOP density weights (eq. 26), random parents (p = 1/3), "
        "KL constraint D_KL < alpha^2/2 (eq. 11), log-domain responsibilities (eq. 9), M-step "
        "eq. 10 and wrapped normal axes eq. 29-30, orphans carried; stops after `levels` or when "
        "a level removes < min_reduction. Output points = component means (normals = axes, "
        "weights = mixture weights); the mixture is written as a PLY.",
        hem_step, StageIo{DataKind::Points, DataKind::Mixture, DataKind::Mixture}));
    reg.add(make_entry<ClopParams>(
        "resample.clop",
        "Continuous LOP (CLOP paper sec. 6-8): weighted HEM mixture, continuous L2 initial "
        "iteration (eq. 24), continuous attraction with the three-Gaussian fit of theta(r)/r "
        "(eq. 19-22), WLOP repulsion cut at repulsion_cutoff*h and interleaved (sec. 8); "
        "theta(r) = exp(-16 r^2/h^2), h a fraction of the bbox diagonal; particles may exceed "
        "the input (upsampling). Phases init, hem, attraction, repulsion.",
        clop, kPointsToMixture));
    reg.add(make_entry<CswParams>(
        "normals.csw",
        "Continuous spherical Weiszfeld normals (CLOP paper sec. 9, eq. 29-34) from the mixture of "
        "a preceding mixture.hem step (chain mixture.hem -> normals.csw; its wrapped normal axes "
        "merged by HEM, eq. 29-30) for CLOP particles projected onto that mixture (sec. 6-8) or "
        "the input points with resample=false; spherical kernel H = pi, spatial localisation by "
        "the eq. 24 kernel integral of width normal_h; start from the input normals or the "
        "continuous PCA normal.",
        csw, kPointsAndMixtureToPoints));
    reg.add(make_entry<PcaNormalsParams>(
        "normals.pca",
        "k-nearest-neighbour PCA normals (Hoppe et al. 1992): smallest eigenvector of the "
        "neighbourhood covariance; oriented toward the scan's sensor when scan_ids and "
        "sensor_origins are known, else by MST propagation seeded outward at the point farthest "
        "from the centroid.",
        pca_normals));
    reg.add(make_entry<LopParams>(
        "resample.lop",
        "Locally optimal projection (Lipman et al. 2007; CLOP paper sec. 3): L2 first iteration "
        "(eq. 2), then q <- F1 + mu F2 (eq. 3-6) with theta(r) = exp(-16 r^2/h^2), h a fraction "
        "of the bbox diagonal, neighbours within h; v = w = 1.",
        lop));
    reg.add(make_entry<LopParams>(
        "resample.wlop",
        "Weighted LOP (Huang et al. 2009; CLOP paper sec. 3, 7 eq. 25): as resample.lop with input "
        "density weights v_j = 1 + sum theta (once) in F1 and particle weights w_i (every "
        "iteration) in F2.",
        wlop));
    reg.add(make_entry<BilateralNormalsParams>(
        "normals.bilateral",
        "Bilateral normal filtering (Huang et al. 2013 sec. 4; the GPF paper's pipeline, sec. 3): "
        "n_i <- normalise(sum_j theta(|p_i - p_j|) psi(n_i, n_j) n_j), theta = exp(-16 r^2/h^2), "
        "psi = exp(-((1 - n_i.n_j)/(1 - cos sigma_n))^2), signs aligned first, Jacobi "
        "iterations; normals only, points do not move (peer.cgal_bilateral moves them). Needs "
        "input normals (normals.pca).",
        bilateral_normals));
    reg.add(make_entry<GpfParams>(
        "filter.gpf",
        "GMM-inspired feature-preserving filtering (Lu et al. 2017 sec. 4, Algorithm 1): EM with "
        "E-step eq. 3 (uniform outlier term omega), M-step eq. 10 (point-to-plane data term along "
        "the input normals weighted by p_mn/rho_n, tangential WLOP-weighted repulsion mu_hat) and "
        "s2 update eq. 11; h in scanbench's kernel convention (GPF's h = h/2): data within h/4, "
        "repulsion within h/2; lengths in bbox-diagonal units. Needs filtered normals "
        "(normals.pca -> normals.bilateral). Output: M particles with normals. Phases normals, "
        "init, e_step, m_step.",
        gpf));
    reg.add(make_entry<CgalWlopParams>(
        "peer.cgal_wlop",
        "CGAL 5.5 wlop_simplify_and_regularize_point_set (peer, not the definition): h is "
        "scanbench's kernel width, passed to CGAL as neighbor_radius = h/2 because CGAL's "
        "kernel is exp(-4 r^2/R^2); CGAL hard-codes mu = 0.45, uses an L2 attraction "
        "(no 1/r) and theta/r^2 repulsion, no L2 first iteration; seeded particle subset; TBB.",
        cgal_wlop));
    reg.add(make_entry<CgalBilateralParams>(
        "peer.cgal_bilateral",
        "CGAL 5.5 bilateral_smooth_point_set (Huang et al. 2013; peer): edge-aware smoothing "
        "of points and normals, k nearest neighbours, CGAL's own kernel radius; input normals, "
        "else normals.pca first.",
        cgal_bilateral));
    reg.add(make_entry<CgalEarParams>(
        "peer.cgal_ear",
        "CGAL 5.5 edge_aware_upsample_point_set (EAR upsampling, Huang et al. 2013 sec. 5; the "
        "GPF paper's last step, Fig. 2(d); peer): needs normals (normals.pca -> "
        "normals.bilateral, or filter.gpf); CGAL returns only new points, the output is input + "
        "new; h in scanbench's convention (CGAL neighbor_radius = h/2; 0 = CGAL's 3 x spacing); "
        "input scaled to a unit diagonal at the boundary (CGAL issue 4662).",
        cgal_ear));
    reg.add(make_entry<CgalJetParams>(
        "peer.cgal_jet",
        "CGAL 5.5 jet_smooth_point_set (Cazals and Pouget 2005; peer): each point projected "
        "onto the jet fitted to its k nearest neighbours.",
        cgal_jet));
    reg.add(make_entry<BhattacharyyaParams>(
        "triangulate.bhattacharyya",
        "Triangulation of a Gaussian mixture into a covariance mesh (GPS paper sec. 6.2): greedy "
        "front growing (Cohen-Steiner and Da 2004) graded by P = BC_ij BC_jk BC_ik beta/pi (eq. "
        "19-22), every BC above bc_min, dihedral angle above beta_min_deg; seeded by the best "
        "BC triangle, further seeds for further components; manifold, holes where no valid "
        "triangle exists. Candidates: Delaunay facets of the means through CGAL 5.5's advancing "
        "front with the GPS grade as its priority (default), or free (every overlapping "
        "triangle). Needs no oriented normals. Chain it after mixture.hem.",
        triangulate_bhattacharyya_step,
        StageIo{DataKind::Mixture, DataKind::CovarianceMesh, DataKind::CovarianceMesh}));
    // Subdivision surfaces (GPS paper, Preiner et al. 2019) and their linear baselines.
    const StageIo mesh_io{DataKind::Mesh, DataKind::Mesh, DataKind::Mesh};
    const StageIo gp_io{DataKind::CovarianceMesh, DataKind::CovarianceMesh | DataKind::Mesh,
                        DataKind::Mesh};
    reg.add(make_entry<SubdivideParams>(
        "subdivide.loop",
        "Loop subdivision (Loop 1987) with boundary rules (edge 1/2 1/2, vertex 1/8 3/4 1/8); "
        "beta of Loop (CGAL) or Warren (libigl); limit positions by the limit mask.",
        subdivide_loop_stage, mesh_io));
    reg.add(make_entry<SubdivideParams>(
        "subdivide.catmull_clark",
        "Catmull-Clark subdivision (1978) of any polygon mesh with boundary rules; limit "
        "positions by the limit mask; the output quads are split into triangles.",
        subdivide_catmull_clark_stage, mesh_io));
    reg.add(make_entry<SubdivideParams>(
        "subdivide.gp_loop",
        "Gaussian-product Loop subdivision (GPS paper sec. 4-5): Loop on the dual vertices "
        "q = (vech(Sigma^-1), Sigma^-1 mu) (eq. 10-12), mapped back by eq. 12; limit positions by "
        "the limit mask in the dual space. Output: the covariance mesh and its mean mesh.",
        gp_loop_stage, gp_io));
    reg.add(make_entry<SubdivideParams>(
        "subdivide.gp_catmull_clark",
        "Gaussian-product Catmull-Clark subdivision (GPS paper sec. 4-5, Fig. 9): Catmull-Clark "
        "on the dual vertices (eq. 10-12). Output: the covariance mesh and its mean mesh.",
        gp_catmull_clark_stage, gp_io));
    reg.add(make_entry<DecimateParams>(
        "mesh.decimate",
        "Edge-collapse simplification to a coarse control mesh (CGAL 5.5 "
        "Surface_mesh_simplification; coarse inputs of GPS sec. 6.1 inference): policy "
        "lindstrom_turk (Lindstrom-Turk 1998 cost and placement, CGAL's default) or "
        "garland_heckbert (quadric error metrics); stops at `faces` (or ratio x input) faces; "
        "topology kept (closed stays closed); non-manifold input is an error naming the face.",
        decimate_mesh, mesh_io));
    reg.add(make_entry<InferenceParams>(
        "subdivide.infer_covariances",
        "Covariances for an ordinary mesh (GPS sec. 6.1): face-based (eq. 16-17) or vertex-based "
        "(eq. 15), biased by sigma_0^2 I (sigma_0 relative to the bbox diagonal) or by the "
        "authors' demo's 0.05 lambda_max.",
        infer_covariances_stage,
        StageIo{DataKind::Mesh, DataKind::CovarianceMesh, DataKind::CovarianceMesh}));
    reg.add(make_entry<PoissonParams>(
        "reconstruct.poisson",
        "Screened Poisson surface reconstruction (Kazhdan and Hoppe 2013; the GPS paper's sec. 6 "
        "baseline) through COLMAP 3.8's `colmap poisson_mesher` (PoissonRecon 8.0, one thread, "
        "private temp dir, timeout); needs oriented normals (chain normals.pca -> "
        "reconstruct.poisson); no trimming by default (COLMAP's trim 10 empties a sphere at "
        "depth 8).",
        poisson, kPointsToMesh));
    reg.add(make_entry<CgalAdvancingFrontParams>(
        "peer.cgal_advancing_front",
        "CGAL 5.5 advancing_front_surface_reconstruction (Cohen-Steiner and Da 2004; peer): "
        "greedy Delaunay-based interpolating surface, radius_ratio_bound and beta.",
        cgal_advancing_front, kPointsToMesh));
    reg.add(make_entry<CgalScaleSpaceParams>(
        "peer.cgal_scale_space",
        "CGAL 5.5 Scale_space_surface_reconstruction_3 (Digne et al. 2011; peer): weighted PCA or "
        "jet smoothing for `iterations` scales, alpha-shape or advancing-front meshing, facets "
        "back-projected onto the input points.",
        cgal_scale_space, kPointsToMesh));
    // Open3D 0.16 (libopen3d-dev) and PCL 1.13 (pcl-tools programs) peers.
    reg.add(make_entry<Open3dPoissonParams>(
        "peer.open3d_poisson",
        "Open3D 0.16 CreateFromPointCloudPoisson (Kazhdan and Hoppe 2013; peer): Neumann "
        "boundary, screening weight 2 and samples per node 1.5 fixed by Open3D, one solver "
        "thread; density_trim removes vertices below a quantile of Open3D's densities. Needs "
        "oriented normals (normals.pca -> peer.open3d_poisson).",
        open3d_poisson, kPointsToMesh));
    reg.add(make_entry<Open3dBallPivotingParams>(
        "peer.open3d_ball_pivoting",
        "Open3D 0.16 CreateFromPointCloudBallPivoting (Bernardini et al. 1999; peer): radii "
        "radius, 2 radius, ... as fractions of the bbox diagonal; interpolating, holes where no "
        "ball pivots. Needs oriented normals.",
        open3d_ball_pivoting, kPointsToMesh));
    reg.add(make_entry<Open3dAlphaShapeParams>(
        "peer.open3d_alpha_shape",
        "Open3D 0.16 CreateFromPointCloudAlphaShape (Edelsbrunner and Muecke 1994; peer): "
        "boundary of the Delaunay tetrahedra (Qhull) with circumradius below alpha (a fraction "
        "of the bbox diagonal).",
        open3d_alpha_shape, kPointsToMesh));
    reg.add(make_entry<Open3dOutlierParams>(
        "peer.open3d_outlier_removal",
        "Open3D 0.16 RemoveStatisticalOutliers (mean k-NN distance above mean + std_ratio "
        "sigma) or RemoveRadiusOutliers (fewer than min_points within radius, a fraction of "
        "the bbox diagonal); kept points keep every attribute.",
        open3d_outlier_removal));
    reg.add(make_entry<Open3dNormalsParams>(
        "peer.open3d_normals",
        "Open3D 0.16 EstimateNormals (k-NN or hybrid radius PCA) then "
        "OrientNormalsConsistentTangentPlane (Hoppe et al. 1992 MST), the global sign outward "
        "at the point farthest from the centroid (as normals.pca).",
        open3d_normals));
    reg.add(make_entry<PclMlsParams>(
        "peer.pcl_mls",
        "PCL 1.13 moving least squares through pcl_mls_smoothing (peer): local plane plus "
        "polynomial of polynomial_order within radius (a fraction of the bbox diagonal), "
        "Gaussian weight radius^2; points projected, PCL normals; no upsampling (the program "
        "offers none). Run by the external-program runner (pcl-tools).",
        pcl_mls));
    reg.add(make_entry<PclOutlierParams>(
        "peer.pcl_outlier_removal",
        "PCL 1.13 statistical or radius outlier removal through pcl_outlier_removal (peer); "
        "kept points matched back to the input, every attribute kept (pcl-tools).",
        pcl_outlier_removal));
    reg.add(make_entry<PclPoissonParams>(
        "peer.pcl_poisson",
        "PCL 1.13 pcl::Poisson through pcl_poisson_reconstruction (PCL's older PoissonRecon copy; "
        "peer): depth and screening point_weight, no density trimming. Needs oriented normals "
        "(normals.pca -> peer.pcl_poisson; pcl-tools).",
        pcl_poisson, kPointsToMesh));
    reg.add(make_entry<ExternalParams>(
        "external.points",
        "Any program as a step: `command` with {in} (the points as PLY), {out} (a point cloud, "
        "`extension` .ply or point-only .off) and {name} for name=value pairs of `vars`; run by "
        "/bin/sh in a private temp dir with a timeout; non-zero exit, timeout and exit 0 with "
        "no or empty output are errors.",
        external_points));
    reg.add(make_entry<ExternalParams>(
        "external.mesh",
        "As external.points, but {out} is a triangle mesh (.ply or .off), the step's product.",
        external_mesh, kPointsToMesh));
    return reg;
  }();
  return r;
}

}  // namespace scanbench::algorithms
