#pragma once
// mixture.hem: geometrically regularised hierarchical EM (Preiner et al. 2014, "Continuous
// Projection for Fast L1 Reconstruction", sections 5, 7, 9.2 and Algorithm 1 of the appendix).
//
// Reduces a point cloud P to a Gaussian mixture M = {w_s, mu_s, Sigma_s} that carries, on every
// component, a wrapped-normal distribution of normal axes (axis, spread sigma^2) for CSW normals.
//
//  - Level 0 (Algorithm 1 lines 1-9): one Gaussian per point. r = init_radius_factor x the mean
//    distance to the point's init_neighbors nearest distinct points (default 4; Algorithm 1 line
//    2 uses the nearest one, init_neighbors = 1); Sigma_r = covariance of the n points within r
//    (the point itself included); Sigma0 = Sigma_r * r / (sigma_max * cbrt(n)) + c I (eq. 12), c =
//    cov_bias * r^2. Weighted mixtures (eq. 26): w_j = 1 / (v_j |P|) as written (not renormalised
//    inside HEM, so the eq. 9 exponent w_j |P| is 1/v_j; the result's weights are normalised), with
//    the density v_j = 1 + sum_{j' != j} theta(|p_j - p_j'|), theta(r) = exp(-16 r^2 / h^2).
//    density = "support" (default) sums it over WLOP's whole support |p_j - p_j'| <= h (theta(h)
//    = 1.1e-7), WLOP's own v_j, which balances sampling densities as the paper's Fig. 6 shows.
//    "kernel" sums it over the neighbours within r in the same pass as Sigma_r, the literal reading
//    of Algorithm 1 line 3 and section 7 ("accumulate the sum (25) along with the points'
//    covariances in the initial kernel pass"); as r follows the local spacing, that v_j counts
//    about the same neighbours everywhere and balances densities only in part (measured: on a
//    plane 4x denser on one half, that half keeps 0.69 of the mass; 0.50 with "support", 0.80
//    unweighted). Unweighted: w_j = 1 / |P|. The normal axis m_j is the eigenvector of the
//    smallest eigenvalue of Sigma_r; its spread starts at normal_spread0 (rho = 1 would mean
//    sigma^2 = 0; the floor keeps it a distribution).
//  - Each level: every component is a parent with probability parent_probability (seeded: stream
//    "hem", one sub-stream per level and component, so thread-independent). A child i may merge
//    into parent s only if D_KL(Theta_i || Theta_s) < alpha^2 / 2 (eq. 11); since D_KL >= d_M^2/2
//    the children lie within alpha * sigma_max(s) of mu_s, which bounds the kd-tree query. Other
//    parents are never children (each parent is its own child). Responsibilities
//    r_is = w_s L_is / sum_s' w_s' L_is' with the HEM likelihood (eq. 9)
//    L_is = [g(mu_i | Theta_s) exp(-tr(Sigma_s^-1 Sigma_i) / 2)]^(w_i |P|), evaluated as log L and
//    normalised by log-sum-exp (no clamping); w_i |P| is the number of points the child stands
//    for, 1/v_j-weighted (eq. 26 and 10), as in the paper and the authors' code. M-step eq. 10 for
//    the Gaussians and eq. 29-30 for the normal axes (child axes flipped into the parent's
//    hemisphere first). Children in no parent's set (orphans) are carried unchanged.
//  - Stops after `levels` levels, or after a level that removed fewer than min_reduction of the
//    components (the paper's 2.5%).
//  - Covariances are symmetrised and their eigenvalues clamped to a floor (1e-6 of the largest
//    eigenvalue, and (1e-7 * bbox diagonal)^2) after every update, so every inversion is safe.
//
// Every length is a fraction of the input's bounding-box diagonal (unit "diag"). Results depend
// only on the input, the parameters and ctx.seed(), never on the thread count.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

/// Declares the HEM parameters on any struct T derived from HemSettings (HemParams, ClopParams
/// and CswParams share these declarations, so their names, ranges, defaults and docs cannot drift).
template <class T>
void declare_hem_params(ParamDeclarer<T>& d) {
  d.real("alpha", &T::alpha, Range::closed(0.5, 10.0), "",
         "HEM regularisation: a child merges into a parent only if D_KL < alpha^2/2 (CLOP eq. 11); "
         "paper recommends 2");
  d.integer("levels", &T::levels, Range::closed(0, 30), "",
            "maximum number of HEM levels (0 = the level-0 mixture, one Gaussian per point)");
  d.real("min_reduction", &T::min_reduction, Range::half_open(0.0, 1.0), "",
         "stop after a level that removes fewer than this share of the components (paper: 2.5%)");
  d.real("parent_probability", &T::parent_probability, Range::open_min(0.0, 1.0), "",
         "probability that a component is chosen as a parent in each level (paper: 1/3)");
  d.real("init_radius_factor", &T::init_radius_factor, Range::closed(1.0, 10.0), "",
         "initial kernel radius r as a multiple of each point's nearest-neighbour distance "
         "(alpha_0 of Algorithm 1, paper: 2-3)");
  d.integer("init_neighbors", &T::init_neighbors, Range::closed(1, 64), "",
            "the nearest-neighbour distance of Algorithm 1 line 2 is the mean distance to this "
            "many nearest distinct points (1 = the paper's literal nearest neighbour; more is "
            "stable on irregular sampling)");
  d.real("cov_bias", &T::cov_bias, Range::closed(0.0, 1.0), "r^2",
         "trace bias c of eq. 12 as a fraction of r^2 (gives every initial Gaussian a minimum "
         "extent)");
  d.flag("weighted", &T::weighted,
         "WLOP density weights w_j = 1/(v_j |P|) on the initial Gaussians (weighted CLOP, eq. 26)");
  d.choice("density", &T::density, {"support", "kernel"},
           "where the density v_j = 1 + sum theta(|p_j - p_j'|) of eq. 26 is summed: 'support' = "
           "over WLOP's whole support h (WLOP's own v_j; balances densities as the paper's Fig. 6 "
           "shows); 'kernel' = over the neighbours within r, in the eq. 12 kernel pass, the "
           "literal reading of Algorithm 1 line 3 (cheaper; r follows the local spacing, so it "
           "balances densities only in part)");
  d.real("normal_spread0", &T::normal_spread0, Range::closed(1e-8, 1.0), "rad^2",
         "initial wrapped-normal spread sigma^2 of each point's normal axis (CSW, section 9.2)");
}

/// The HEM settings with their defaults, held once: HemParams, ClopParams and CswParams derive
/// from it (declare_hem_params declares them on each).
struct HemSettings {
  double alpha = 2.0;
  int levels = 8;
  double min_reduction = 0.025;
  double parent_probability = 1.0 / 3.0;
  double init_radius_factor = 2.5;
  int init_neighbors = 4;
  double cov_bias = 1e-3;
  bool weighted = true;
  std::string density = "support";
  double normal_spread0 = 1e-3;
};

struct HemParams : HemSettings {
  double h = 0.02;  ///< kernel width of the density weights v_j, fraction of the bbox diagonal
  /// GPS paper (Preiner et al. 2019) Appendix A: the level-0 Gaussians either by local PCA (the
  /// eq. 12 kernel above: sigma0 = 0, the default and today's behaviour) or isotropic sigma0^2 I
  /// "with sigma0 chosen according to the input point density" (sigma0 > 0, a fraction of the bbox
  /// diagonal). The paper's Fig. 14 sweeps it: larger kernels merge more and smooth more. Only the
  /// covariances change; weights and normal axes stay those of the eq. 12 pass.
  double sigma0 = 0.0;

  static void declare(ParamDeclarer<HemParams>& d) {
    d.real("h", &HemParams::h, Range::open_min(0.0, 1.0), "diag",
           "kernel support radius of the WLOP density weights v_j, theta(r) = exp(-16 r^2/h^2)");
    d.real("sigma0", &HemParams::sigma0, Range::closed(0.0, 1.0), "diag",
           "GPS Appendix A: isotropic initial kernel size, every level-0 Gaussian gets "
           "sigma0^2 I (0 = local-PCA covariances of eq. 12, the default)");
    declare_hem_params(d);
  }
};

/// The HEM parameters of a struct T derived from HemSettings whose `h` is, as HemParams::h, a
/// fraction of the bbox diagonal (ClopParams). Every field keeps its unit: the absolute kernel
/// width goes to hem_mixture() as its own argument.
template <class T>
HemParams hem_params_of(const T& t) {
  HemParams p;
  static_cast<HemSettings&>(p) = t;
  p.h = t.h;
  return p;
}

/// What happened in one HEM run.
struct HemStats {
  std::vector<Eigen::Index> level_sizes;  ///< component count of level 0, 1, ... (last = result)
};

/// Builds the mixture of `points` (3 x n, n >= 1). `h_abs` is the absolute density-kernel width
/// (p.h, a diagonal fraction, is not read: the caller scales it by its own diagonal) and
/// `diagonal` the length used for the absolute covariance floor and for p.sigma0.
/// The result has normalised weights, normal axes and spreads. Throws InputError on an empty or
/// non-finite input.
GaussianMixture hem_mixture(const Eigen::Matrix3Xf& points, const HemParams& p, double h_abs,
                            double diagonal, RunContext& ctx, HemStats* stats = nullptr);

/// mixture.hem: the mixture of `in` (h relative to in's bbox diagonal). points = the component
/// means with normals = normal axes and weights = component weights; mixture = the mixture.
/// Throws InputError on an empty or invalid cloud.
AlgorithmOutput hem(const PointCloud& in, const HemParams& p, RunContext& ctx);

/// The registered step mixture.hem: only the mixture (the input points pass on unchanged, so a
/// following normals.csw or triangulation sees the scan and its sensors). A chain ending here is
/// scored on the mixture's component points (GaussianMixture::component_points).
StageData hem_step(const PointCloud& in, const HemParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
