#include "scanbench/algorithms/registry.h"

#include <concepts>
#include <utility>

#include "scanbench/algorithms/bhattacharyya_triangulation.h"
#include "scanbench/algorithms/bilateral_normals.h"
#include "scanbench/algorithms/cgal_peers.h"
#include "scanbench/algorithms/cgal_reconstruction.h"
#include "scanbench/algorithms/clop.h"
#include "scanbench/algorithms/csw.h"
#include "scanbench/algorithms/decimate.h"
#include "scanbench/algorithms/external.h"
#include "scanbench/algorithms/gpf.h"
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

// Registers an entry that runs in its own process in a job (Algorithm::own_process): for steps
// whose output depends on heap addresses, so that a job's bytes do not depend on what ran before.
void add_own_process(AlgorithmRegistry& reg, AlgorithmRegistry::Entry entry) {
  entry.fn.own_process = true;
  reg.add(std::move(entry));
}

// The LOP family (docs/algorithms/lop-family.md): HEM, CLOP, CSW, PCA normals, LOP, WLOP.
void register_lop_family(AlgorithmRegistry& reg) {
  reg.add(make_entry<HemParams>(
      "mixture.hem",
      "Geometrically regularised hierarchical EM (CLOP paper sec. 5, Algorithm 1): a Gaussian "
      "mixture with wrapped normal axes. docs/algorithms/lop-family.md",
      hem_step, StageIo{DataKind::Points, DataKind::Mixture, DataKind::Mixture}));
  reg.add(make_entry<ClopParams>("resample.clop",
                                 "Continuous LOP (CLOP paper sec. 6-8): particles projected onto a "
                                 "weighted HEM mixture. docs/algorithms/lop-family.md",
                                 clop, kPointsToMixture));
  reg.add(make_entry<CswParams>(
      "normals.csw",
      "Continuous spherical Weiszfeld normals (CLOP paper sec. 9) from the mixture of a preceding "
      "mixture.hem step. docs/algorithms/lop-family.md",
      csw, kPointsAndMixtureToPoints));
  reg.add(make_entry<PcaNormalsParams>(
      "normals.pca",
      "k-nearest-neighbour PCA normals (Hoppe et al. 1992), oriented toward the sensor or by MST "
      "propagation. docs/algorithms/lop-family.md",
      pca_normals));
  reg.add(make_entry<LopParams>("resample.lop",
                                "Locally optimal projection (Lipman et al. 2007; CLOP paper sec. "
                                "3). docs/algorithms/lop-family.md",
                                lop));
  reg.add(make_entry<LopParams>("resample.wlop",
                                "Weighted LOP (Huang et al. 2009; CLOP paper sec. 3, 7): LOP with "
                                "density weights. docs/algorithms/lop-family.md",
                                wlop));
}

// GPF and its normal filter (docs/algorithms/gpf.md).
void register_gpf_family(AlgorithmRegistry& reg) {
  reg.add(make_entry<BilateralNormalsParams>(
      "normals.bilateral",
      "Bilateral normal filtering (Huang et al. 2013 sec. 4): normals only, needs input normals. "
      "docs/algorithms/gpf.md",
      bilateral_normals));
  reg.add(make_entry<GpfParams>("filter.gpf",
                                "GMM-inspired feature-preserving filtering (Lu et al. 2017, "
                                "Algorithm 1): needs filtered normals. docs/algorithms/gpf.md",
                                gpf));
}

// CGAL 5.5 point-set peers (docs/algorithms/peers.md).
void register_cgal_peers(AlgorithmRegistry& reg) {
  reg.add(make_entry<CgalWlopParams>("peer.cgal_wlop",
                                     "CGAL 5.5 WLOP (peer, not the definition; mu fixed at 0.45 by "
                                     "CGAL). docs/algorithms/peers.md",
                                     cgal_wlop));
  reg.add(
      make_entry<CgalBilateralParams>("peer.cgal_bilateral",
                                      "CGAL 5.5 bilateral point-set smoothing (Huang et al. 2013; "
                                      "peer): moves points and normals. docs/algorithms/peers.md",
                                      cgal_bilateral));
  reg.add(make_entry<CgalEarParams>("peer.cgal_ear",
                                    "CGAL 5.5 edge-aware upsampling (EAR, Huang et al. 2013 sec. "
                                    "5; peer): needs normals. docs/algorithms/peers.md",
                                    cgal_ear));
  reg.add(make_entry<CgalJetParams>(
      "peer.cgal_jet",
      "CGAL 5.5 jet smoothing (Cazals and Pouget 2005; peer). docs/algorithms/peers.md", cgal_jet));
}

// GPS: triangulation, subdivision surfaces (GPS paper, Preiner et al. 2019) and their linear
// baselines, decimation, covariance inference (docs/algorithms/gps.md).
void register_gps_family(AlgorithmRegistry& reg) {
  reg.add(make_entry<BhattacharyyaParams>(
      "triangulate.bhattacharyya",
      "Triangulation of a Gaussian mixture into a covariance mesh (GPS paper sec. 6.2). "
      "docs/algorithms/gps.md",
      triangulate_bhattacharyya_step,
      StageIo{DataKind::Mixture, DataKind::CovarianceMesh, DataKind::CovarianceMesh}));
  const StageIo mesh_io{DataKind::Mesh, DataKind::Mesh, DataKind::Mesh};
  const StageIo gp_io{DataKind::CovarianceMesh, DataKind::CovarianceMesh | DataKind::Mesh,
                      DataKind::Mesh};
  reg.add(make_entry<SubdivideParams>(
      "subdivide.loop", "Loop subdivision (Loop 1987) with boundary rules. docs/algorithms/gps.md",
      subdivide_loop_stage, mesh_io));
  reg.add(make_entry<SubdivideParams>("subdivide.catmull_clark",
                                      "Catmull-Clark subdivision (1978) of any polygon mesh with "
                                      "boundary rules. docs/algorithms/gps.md",
                                      subdivide_catmull_clark_stage, mesh_io));
  reg.add(make_entry<SubdivideParams>("subdivide.gp_loop",
                                      "Gaussian-product Loop subdivision of a covariance mesh (GPS "
                                      "paper sec. 4-5). docs/algorithms/gps.md",
                                      gp_loop_stage, gp_io));
  reg.add(make_entry<SubdivideParams>("subdivide.gp_catmull_clark",
                                      "Gaussian-product Catmull-Clark subdivision of a covariance "
                                      "mesh (GPS paper sec. 4-5, Fig. 9). docs/algorithms/gps.md",
                                      gp_catmull_clark_stage, gp_io));
  reg.add(make_entry<DecimateParams>("mesh.decimate",
                                     "Edge-collapse simplification to a coarse control mesh (CGAL "
                                     "5.5 Surface_mesh_simplification). docs/algorithms/gps.md",
                                     decimate_mesh, mesh_io));
  reg.add(make_entry<InferenceParams>(
      "subdivide.infer_covariances",
      "Covariances for an ordinary mesh, face- or vertex-based (GPS paper sec. 6.1). "
      "docs/algorithms/gps.md",
      infer_covariances_stage,
      StageIo{DataKind::Mesh, DataKind::CovarianceMesh, DataKind::CovarianceMesh}));
}

// Surface reconstructions (docs/algorithms/reconstruction.md).
void register_reconstruction_family(AlgorithmRegistry& reg) {
  reg.add(make_entry<PoissonParams>(
      "reconstruct.poisson",
      "Screened Poisson reconstruction (Kazhdan and Hoppe 2013) through COLMAP 3.8: needs oriented "
      "normals. docs/algorithms/reconstruction.md",
      poisson, kPointsToMesh));
  // Both CGAL meshers order facets by heap address: each runs in its own process in a job.
  add_own_process(reg, make_entry<CgalAdvancingFrontParams>(
                           "peer.cgal_advancing_front",
                           "CGAL 5.5 advancing-front surface reconstruction (Cohen-Steiner and Da "
                           "2004; peer). docs/algorithms/reconstruction.md",
                           cgal_advancing_front, kPointsToMesh));
  add_own_process(reg, make_entry<CgalScaleSpaceParams>(
                           "peer.cgal_scale_space",
                           "CGAL 5.5 scale-space surface reconstruction (Digne et al. 2011; peer). "
                           "docs/algorithms/reconstruction.md",
                           cgal_scale_space, kPointsToMesh));
}

// Open3D 0.16 (libopen3d-dev) and PCL 1.13 (pcl-tools programs) peers (docs/algorithms/peers.md,
// reconstruction.md).
void register_open3d_pcl_peers(AlgorithmRegistry& reg) {
  reg.add(make_entry<Open3dPoissonParams>(
      "peer.open3d_poisson",
      "Open3D 0.16 screened Poisson reconstruction (Kazhdan and Hoppe 2013; peer): needs oriented "
      "normals. docs/algorithms/reconstruction.md",
      open3d_poisson, kPointsToMesh));
  reg.add(make_entry<Open3dBallPivotingParams>(
      "peer.open3d_ball_pivoting",
      "Open3D 0.16 ball pivoting (Bernardini et al. 1999; peer): needs oriented normals. "
      "docs/algorithms/reconstruction.md",
      open3d_ball_pivoting, kPointsToMesh));
  reg.add(make_entry<Open3dAlphaShapeParams>("peer.open3d_alpha_shape",
                                             "Open3D 0.16 alpha shape (Edelsbrunner and Muecke "
                                             "1994; peer). docs/algorithms/reconstruction.md",
                                             open3d_alpha_shape, kPointsToMesh));
  reg.add(make_entry<Open3dOutlierParams>(
      "peer.open3d_outlier_removal",
      "Open3D 0.16 statistical or radius outlier removal (peer). docs/algorithms/peers.md",
      open3d_outlier_removal));
  reg.add(make_entry<Open3dNormalsParams>("peer.open3d_normals",
                                          "Open3D 0.16 PCA normals with MST orientation (Hoppe et "
                                          "al. 1992; peer). docs/algorithms/peers.md",
                                          open3d_normals));
  reg.add(make_entry<PclMlsParams>(
      "peer.pcl_mls",
      "PCL 1.13 moving least squares smoothing through pcl-tools (peer). docs/algorithms/peers.md",
      pcl_mls));
  reg.add(make_entry<PclOutlierParams>("peer.pcl_outlier_removal",
                                       "PCL 1.13 statistical or radius outlier removal through "
                                       "pcl-tools (peer). docs/algorithms/peers.md",
                                       pcl_outlier_removal));
  reg.add(make_entry<PclPoissonParams>("peer.pcl_poisson",
                                       "PCL 1.13 Poisson reconstruction through pcl-tools (peer): "
                                       "needs oriented normals. docs/algorithms/reconstruction.md",
                                       pcl_poisson, kPointsToMesh));
}

// Any program as a step (docs/algorithms/reconstruction.md).
void register_external(AlgorithmRegistry& reg) {
  reg.add(make_entry<ExternalParams>("external.points",
                                     "Any program as a step that writes points ({in}, {out} and "
                                     "{name} in `command`). docs/algorithms/reconstruction.md",
                                     external_points));
  reg.add(make_entry<ExternalParams>("external.mesh",
                                     "Any program as a step that writes a triangle mesh (as "
                                     "external.points). docs/algorithms/reconstruction.md",
                                     external_mesh, kPointsToMesh));
}

}  // namespace

const AlgorithmRegistry& registry() {
  static AlgorithmRegistry r = [] {  // not const: plugins add entries (add_plugin_entry)
    AlgorithmRegistry reg("algorithm");
    // One explicit list, family by family; every entry has a create-by-name test
    // (tests/algorithms).
    register_lop_family(reg);
    register_gpf_family(reg);
    register_cgal_peers(reg);
    register_gps_family(reg);
    register_reconstruction_family(reg);
    register_open3d_pcl_peers(reg);
    register_external(reg);
    return reg;
  }();
  return r;
}

}  // namespace scanbench::algorithms
