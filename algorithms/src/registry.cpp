#include "scanbench/algorithms/registry.h"

#include <concepts>
#include <string>
#include <string_view>
#include <utility>

#include "scanbench/algorithms/gpf/bilateral_normals.h"
#include "scanbench/algorithms/gpf/gpf.h"
#include "scanbench/algorithms/gps/bhattacharyya_triangulation.h"
#include "scanbench/algorithms/gps/decimate.h"
#include "scanbench/algorithms/gps/gps.h"
#include "scanbench/algorithms/lop/clop.h"
#include "scanbench/algorithms/lop/csw.h"
#include "scanbench/algorithms/lop/lop.h"
#include "scanbench/algorithms/lop/pca_normals.h"
#include "scanbench/algorithms/mixtures/hem.h"
#include "scanbench/algorithms/peers/cgal_peers.h"
#include "scanbench/algorithms/peers/external.h"
#include "scanbench/algorithms/peers/open3d_peers.h"
#include "scanbench/algorithms/peers/pcl_peers.h"
#include "scanbench/algorithms/reconstruction/cgal_reconstruction.h"
#include "scanbench/algorithms/reconstruction/poisson.h"

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

// A family, declared once: the docs page (under docs/) that documents its entries. Every entry
// added through it carries the page (RegistryEntry::page, `scanbench list --json`, the docs test)
// and names it at the end of its doc ("... docs/algorithms/gpf.md").
struct Family {
  std::string_view page;

  void add(AlgorithmRegistry& reg, AlgorithmRegistry::Entry entry) const {
    entry.page = std::string(page);
    entry.doc += " docs/" + entry.page;
    reg.add(std::move(entry));
  }
  // An entry that runs in its own process in a job (Algorithm::own_process): for steps whose
  // output depends on heap addresses, so that a job's bytes do not depend on what ran before.
  void add_own_process(AlgorithmRegistry& reg, AlgorithmRegistry::Entry entry) const {
    entry.fn.own_process = true;
    add(reg, std::move(entry));
  }
};

// The families: the LOP family (HEM, CLOP, CSW, PCA normals, LOP, WLOP; algorithms/src/lop/ and
// mixtures/), GPF (gpf/), GPS (gps/), the reconstructions (reconstruction/, with the peers'
// reconstructions and the external programs) and the peers' point-set steps (peers/).
constexpr Family kLopFamily{"algorithms/lop-family.md"};
constexpr Family kGpfFamily{"algorithms/gpf.md"};
constexpr Family kGpsFamily{"algorithms/gps.md"};
constexpr Family kReconstructionFamily{"algorithms/reconstruction.md"};
constexpr Family kPeersFamily{"algorithms/peers.md"};

// The LOP family (docs/algorithms/lop-family.md): HEM, CLOP, CSW, PCA normals, LOP, WLOP.
void register_lop_family(AlgorithmRegistry& reg) {
  kLopFamily.add(
      reg,
      make_entry<HemParams>(
          "mixture.hem",
          "Geometrically regularised hierarchical EM (CLOP paper sec. 5, Algorithm 1): a Gaussian "
          "mixture with wrapped normal axes.",
          hem_step, StageIo{DataKind::Points, DataKind::Mixture, DataKind::Mixture}));
  kLopFamily.add(reg, make_entry<ClopParams>(
                          "resample.clop",
                          "Continuous LOP (CLOP paper sec. 6-8): particles projected onto a "
                          "weighted HEM mixture.",
                          clop, kPointsToMixture));
  kLopFamily.add(reg, make_entry<CswParams>("normals.csw",
                                            "Continuous spherical Weiszfeld normals (CLOP paper "
                                            "sec. 9) from the mixture of a preceding "
                                            "mixture.hem step.",
                                            csw, kPointsAndMixtureToPoints));
  kLopFamily.add(reg, make_entry<PcaNormalsParams>("normals.pca",
                                                   "k-nearest-neighbour PCA normals (Hoppe et al. "
                                                   "1992), oriented toward the sensor or by MST "
                                                   "propagation.",
                                                   pca_normals));
  kLopFamily.add(
      reg, make_entry<LopParams>("resample.lop",
                                 "Locally optimal projection (Lipman et al. 2007; CLOP paper sec. "
                                 "3).",
                                 lop));
  kLopFamily.add(
      reg, make_entry<LopParams>("resample.wlop",
                                 "Weighted LOP (Huang et al. 2009; CLOP paper sec. 3, 7): LOP with "
                                 "density weights.",
                                 wlop));
}

// GPF and its normal filter (docs/algorithms/gpf.md).
void register_gpf_family(AlgorithmRegistry& reg) {
  kGpfFamily.add(reg,
                 make_entry<BilateralNormalsParams>("normals.bilateral",
                                                    "Bilateral normal filtering (Huang et al. 2013 "
                                                    "sec. 4): normals only, needs input normals.",
                                                    bilateral_normals));
  kGpfFamily.add(reg,
                 make_entry<GpfParams>("filter.gpf",
                                       "GMM-inspired feature-preserving filtering (Lu et al. 2017, "
                                       "Algorithm 1): needs filtered normals.",
                                       gpf));
}

// CGAL 5.5 point-set peers (docs/algorithms/peers.md).
void register_cgal_peers(AlgorithmRegistry& reg) {
  kPeersFamily.add(reg, make_entry<CgalWlopParams>(
                            "peer.cgal_wlop",
                            "CGAL 5.5 WLOP (peer, not the definition; mu fixed at 0.45 by "
                            "CGAL).",
                            cgal_wlop));
  kPeersFamily.add(reg, make_entry<CgalBilateralParams>(
                            "peer.cgal_bilateral",
                            "CGAL 5.5 bilateral point-set smoothing (Huang et al. 2013; "
                            "peer): moves points and normals.",
                            cgal_bilateral));
  kPeersFamily.add(
      reg, make_entry<CgalEarParams>("peer.cgal_ear",
                                     "CGAL 5.5 edge-aware upsampling (EAR, Huang et al. 2013 sec. "
                                     "5; peer): needs normals.",
                                     cgal_ear));
  kPeersFamily.add(reg, make_entry<CgalJetParams>(
                            "peer.cgal_jet",
                            "CGAL 5.5 jet smoothing (Cazals and Pouget 2005; peer).", cgal_jet));
}

// GPS: triangulation, subdivision surfaces (GPS paper, Preiner et al. 2019) and their linear
// baselines, decimation, covariance inference (docs/algorithms/gps.md).
void register_gps_family(AlgorithmRegistry& reg) {
  kGpsFamily.add(
      reg, make_entry<BhattacharyyaParams>(
               "triangulate.bhattacharyya",
               "Triangulation of a Gaussian mixture into a covariance mesh (GPS paper sec. 6.2).",
               triangulate_bhattacharyya_step,
               StageIo{DataKind::Mixture, DataKind::CovarianceMesh, DataKind::CovarianceMesh}));
  const StageIo mesh_io{DataKind::Mesh, DataKind::Mesh, DataKind::Mesh};
  const StageIo gp_io{DataKind::CovarianceMesh, DataKind::CovarianceMesh | DataKind::Mesh,
                      DataKind::Mesh};
  kGpsFamily.add(reg, make_entry<SubdivideParams>(
                          "subdivide.loop", "Loop subdivision (Loop 1987) with boundary rules.",
                          subdivide_loop_stage, mesh_io));
  kGpsFamily.add(
      reg, make_entry<SubdivideParams>("subdivide.catmull_clark",
                                       "Catmull-Clark subdivision (1978) of any polygon mesh with "
                                       "boundary rules.",
                                       subdivide_catmull_clark_stage, mesh_io));
  kGpsFamily.add(reg, make_entry<SubdivideParams>(
                          "subdivide.gp_loop",
                          "Gaussian-product Loop subdivision of a covariance mesh (GPS "
                          "paper sec. 4-5).",
                          gp_loop_stage, gp_io));
  kGpsFamily.add(
      reg, make_entry<SubdivideParams>("subdivide.gp_catmull_clark",
                                       "Gaussian-product Catmull-Clark subdivision of a covariance "
                                       "mesh (GPS paper sec. 4-5, Fig. 9).",
                                       gp_catmull_clark_stage, gp_io));
  kGpsFamily.add(
      reg, make_entry<DecimateParams>("mesh.decimate",
                                      "Edge-collapse simplification to a coarse control mesh (CGAL "
                                      "5.5 Surface_mesh_simplification).",
                                      decimate_mesh, mesh_io));
  kGpsFamily.add(
      reg, make_entry<InferenceParams>(
               "subdivide.infer_covariances",
               "Covariances for an ordinary mesh, face- or vertex-based (GPS paper sec. 6.1).",
               infer_covariances_stage,
               StageIo{DataKind::Mesh, DataKind::CovarianceMesh, DataKind::CovarianceMesh}));
}

// Surface reconstructions (docs/algorithms/reconstruction.md).
void register_reconstruction_family(AlgorithmRegistry& reg) {
  kReconstructionFamily.add(
      reg, make_entry<PoissonParams>("reconstruct.poisson",
                                     "Screened Poisson reconstruction (Kazhdan and Hoppe 2013) "
                                     "through COLMAP 3.8: needs oriented "
                                     "normals.",
                                     poisson, kPointsToMesh));
  // Both CGAL meshers order facets by heap address: each runs in its own process in a job.
  kReconstructionFamily.add_own_process(
      reg, make_entry<CgalAdvancingFrontParams>(
               "peer.cgal_advancing_front",
               "CGAL 5.5 advancing-front surface reconstruction (Cohen-Steiner and Da "
               "2004; peer).",
               cgal_advancing_front, kPointsToMesh));
  kReconstructionFamily.add_own_process(
      reg, make_entry<CgalScaleSpaceParams>(
               "peer.cgal_scale_space",
               "CGAL 5.5 scale-space surface reconstruction (Digne et al. 2011; peer).",
               cgal_scale_space, kPointsToMesh));
}

// Open3D 0.16 (libopen3d-dev) and PCL 1.13 (pcl-tools programs) peers (docs/algorithms/peers.md,
// reconstruction.md).
void register_open3d_pcl_peers(AlgorithmRegistry& reg) {
  kReconstructionFamily.add(
      reg, make_entry<Open3dPoissonParams>("peer.open3d_poisson",
                                           "Open3D 0.16 screened Poisson reconstruction (Kazhdan "
                                           "and Hoppe 2013; peer): needs oriented "
                                           "normals.",
                                           open3d_poisson, kPointsToMesh));
  kReconstructionFamily.add(
      reg, make_entry<Open3dBallPivotingParams>(
               "peer.open3d_ball_pivoting",
               "Open3D 0.16 ball pivoting (Bernardini et al. 1999; peer): needs oriented normals.",
               open3d_ball_pivoting, kPointsToMesh));
  kReconstructionFamily.add(
      reg, make_entry<Open3dAlphaShapeParams>("peer.open3d_alpha_shape",
                                              "Open3D 0.16 alpha shape (Edelsbrunner and Muecke "
                                              "1994; peer).",
                                              open3d_alpha_shape, kPointsToMesh));
  kPeersFamily.add(reg, make_entry<Open3dOutlierParams>(
                            "peer.open3d_outlier_removal",
                            "Open3D 0.16 statistical or radius outlier removal (peer).",
                            open3d_outlier_removal));
  kPeersFamily.add(
      reg, make_entry<Open3dNormalsParams>("peer.open3d_normals",
                                           "Open3D 0.16 PCA normals with MST orientation (Hoppe et "
                                           "al. 1992; peer).",
                                           open3d_normals));
  kPeersFamily.add(
      reg, make_entry<PclMlsParams>(
               "peer.pcl_mls", "PCL 1.13 moving least squares smoothing through pcl-tools (peer).",
               pcl_mls));
  kPeersFamily.add(
      reg, make_entry<PclOutlierParams>("peer.pcl_outlier_removal",
                                        "PCL 1.13 statistical or radius outlier removal through "
                                        "pcl-tools (peer).",
                                        pcl_outlier_removal));
  kReconstructionFamily.add(
      reg, make_entry<PclPoissonParams>("peer.pcl_poisson",
                                        "PCL 1.13 Poisson reconstruction through pcl-tools (peer): "
                                        "needs oriented normals.",
                                        pcl_poisson, kPointsToMesh));
}

// Any program as a step (docs/algorithms/reconstruction.md).
void register_external(AlgorithmRegistry& reg) {
  kReconstructionFamily.add(
      reg, make_entry<ExternalParams>("external.points",
                                      "Any program as a step that writes points ({in}, {out} and "
                                      "{name} in `command`).",
                                      external_points));
  kReconstructionFamily.add(
      reg, make_entry<ExternalParams>("external.mesh",
                                      "Any program as a step that writes a triangle mesh (as "
                                      "external.points).",
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
