#pragma once
// normals.csw: continuous spherical Weiszfeld normals (Preiner et al. 2014, "Continuous Projection
// for Fast L1 Reconstruction", section 9).
//
// The step consumes points and the Gaussian mixture of a preceding mixture.hem step (chain
// `mixture.hem -> normals.csw`; scanbench/algorithms/mixtures/hem.h), which carries on every Gaussian a
// wrapped normal (axis mu_s, spread sigma_s^2) merged with the spatial responsibilities (eq.
// 29-30); the HEM parameters belong to that step. The particles are the CLOP particles projected
// onto that mixture (`resample`: a seeded subset of the points, then clop_project of
// scanbench/algorithms/lop/clop.h, sections 6-8, with this step's h, mu, iterations...) or the input
// points themselves. Each particle normal n starts from
//  - the input normal (only when not resampling and the input has normals), else
//  - the continuous PCA normal: the smallest eigenvector of sum_s omega_s (Sigma_s +
//    (mu_s - c)(mu_s - c)^T), c = sum_s omega_s mu_s / sum_s omega_s (the L2 counterpart),
// and takes csw_iterations continuous spherical Weiszfeld steps (eq. 31-34):
//    d_g = arccos |<mu_s, n>| (mu_s flipped into n's hemisphere), lambda_sk = sigma_s^2 +
//    sigma_k^2 H^2 with H = pi (the paper's relaxed spherical kernel), omega_sk = omega_s w_k
//    sigma_k^2 H^2 / lambda_sk exp(-d_g^2 / (2 lambda_sk)) (eq. 32), t = sigma_k^2 H^2 / lambda_sk,
//    mu_sk = the point at angle t d_g from n towards mu_s on their great circle (eq. 33-34; the
//    paper's mu_s t + n (1 - t), normalised, approximates this point; we take it exactly),
//    n' = normalise(sum_sk omega_sk mu_sk),
// with (w_k, sigma_k) the three-Gaussian fit of CLOP (kClopFitWeights / kClopFitSigmas).
// Spatial localisation (left implicit by the paper; our choice): omega_s is the continuous
// spatial kernel integral of eq. 24 at the particle, omega_s = w_s g(mu_s | q, Sigma_s +
// (normal_h^2/32) I) (theta with width normal_h integrated against Gaussian s), truncated where
// its exponent is below -16.
// Orientation: the normals are unoriented axes; each is flipped towards the sensor of the nearest
// input point when the input has scan ids and sensor origins, else to agree with the nearest
// input point's normal when the input has normals, else left as the iteration returns it.
// In the chain mixture.hem -> normals.csw the input points are the scan itself: mixture.hem
// produces only the mixture and the points pass on unchanged, so `particles` is a share of the
// scan and the normals are oriented toward its sensors.
#include "scanbench/algorithms/lop/clop.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

/// CSW settings; the CLOP projection settings (used when resample is true) come from
/// ClopProjectionSettings. The mixture's own settings are mixture.hem's.
struct CswParams : ClopProjectionSettings {
  bool resample = true;
  double normal_h = 0.02;
  int csw_iterations = 10;
  bool weighted = true;

  static void declare(ParamDeclarer<CswParams>& d) {
    d.flag("resample", &CswParams::resample,
           "compute normals for the CLOP particles of the input (else for the input points)");
    d.real("normal_h", &CswParams::normal_h, Range::open_min(0.0, 1.0), "diag",
           "spatial kernel width of the normal estimation (theta of width normal_h integrated "
           "against each Gaussian, eq. 24 weights)");
    d.integer("csw_iterations", &CswParams::csw_iterations, Range::closed(0, 1000), "",
              "continuous spherical Weiszfeld steps (eq. 31-34; the paper used 13)");
    declare_clop_projection_params(d);
    d.flag("weighted", &CswParams::weighted,
           "with resample: WLOP particle density weights w_i' in the CLOP repulsion (eq. 5)");
  }
};

/// CSW normals for `particles` (3 x m) from mixture `m` (which must carry normal axes). `initial`
/// holds one unit normal per particle, or is empty (continuous PCA start). normal_h_abs is
/// absolute. Returns 3 x m unit normals (unoriented). Throws InputError on a mixture without
/// normal axes or a size mismatch.
Eigen::Matrix3Xf csw_normals(const GaussianMixture& m, const Eigen::Matrix3Xf& particles,
                             const Eigen::Matrix3Xf& initial, double normal_h_abs, int iterations,
                             RunContext& ctx);

/// normals.csw on the points and mixture of `in` (lengths relative to the points' bbox
/// diagonal). Output: the particles (or the input points) with normals. Throws InputError on
/// empty or invalid points, a missing mixture or one without normal axes.
PointCloud csw(const StageData& in, const CswParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
