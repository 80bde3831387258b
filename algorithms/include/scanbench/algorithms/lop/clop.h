#pragma once
// resample.clop: Continuous LOP (Preiner et al. 2014, "Continuous Projection for Fast L1
// Reconstruction", sections 6-8).
//
// The input P is reduced to a weighted Gaussian mixture M by mixture.hem (scanbench/algorithms/
// hem.h; timed as phase "hem"); the particles Q are then projected onto M:
//  - Q(0): `particles` points of P (a share in (0, 1] or an integral count > 1, which may exceed
//    |P|: upsampling, copies jittered by 0.01 h as in resample.lop), a seeded subset (stream
//    "particles").
//  - iteration 1: the continuous L2 initial iteration (eq. 23-24): Lambda = Sigma_s + (h1^2/32) I,
//    omega_s = w_s g(mu_s | q, Lambda), q' = sum_s omega_s (q + (h1^2/32) Lambda^-1 (mu_s - q)) /
//    sum_s omega_s, with h1 = h (`first_iteration` = paper, eq. 24) or h1 = 2 h
//    (`first_iteration` = authors: the authors' CLOP demo, Preiner 2014, doubles the kernel in
//    its first iteration; not in the paper).
//  - iterations 2..`iterations`: fixed-point steps q' = F1(q) + mu F2(q) with the continuous
//  attraction
//    (eq. 19-22) F1 = q + sum_sk sigma_k^2 h^2 Lambda_sk^-1 (mu_s - q) omega_sk / sum_sk omega_sk,
//    Lambda_sk = Sigma_s + sigma_k^2 h^2 I, omega_sk = w_s w_k sigma_k^3 |Lambda_sk|^-1/2
//    exp(-(mu_s - q)^T Lambda_sk^-1 (mu_s - q) / 2), where alpha(r) = theta(r)/r is replaced by
//    the three-Gaussian fit (w_k, sigma_k) below (eq. 16, Fig. 5b), and the repulsion F2
//    (eq. 5, eta(r) = -r; `repulsion_weights` = none as eq. 5 and the authors' demo, or wlop:
//    WLOP's particle density weights w_i', Huang et al. 2009) cut at
//    repulsion_cutoff * h (section 8: h/2; the density weights w_i' are summed within the same
//    cutoff, the whole repulsion kernel being cut) and, when `interleave`, recomputed only in every
//    second iteration (the previous F2 vector is reused; the last iteration always recomputes).
//  - kernel theta(r) = exp(-16 r^2 / h^2), h a fraction of the input's bbox diagonal.
//  - Components are gathered per cell of particles (cells of side h/4, doubled up to h where
//    particles are sparse) from uniform grids over the component means, one grid per size class
//    (largest covariance eigenvalue within a factor 2; algorithms/src/spatial/mixture_index.h). A term
//    (component, kernel) is dropped when its exponent -(mu_s - q)^T Lambda_sk^-1 (mu_s - q) / 2
//    is below -16: the same e^-16 truncation as LOP's support radius h (for a point-like Gaussian
//    the eq. 24 cutoff is exactly h). The search radius of a class, sqrt(32 (lambda_class + s^2))
//    with s^2 = sigma_1^2 h^2 (attraction) or h^2/32 (eq. 24), holds every term that is kept.
//  - The repulsion is a particle-particle sum over the project's neighbour grid
//    (algorithms/src/spatial/neighbor_grid.h), the same kernels as resample.wlop.
// Where this differs from the paper (README, "CLOP family: deviations from the paper"):
//  - none by default. `repulsion_weights` = wlop gives CLOP's repulsion WLOP's w_i' (Huang et
//    al. 2009; eq. 5 of the paper has none), so that CLOP and WLOP share one F2. The HEM flag
//    `weighted` (eq. 26, the initial Gaussians' weights) does not touch the repulsion.
//  - the initial kernel radius of eq. 12 follows the mean distance to init_neighbors (4) nearest
//    neighbours, where Algorithm 1 line 2 uses the nearest one (init_neighbors = 1 restores it).
//  - `first_iteration` = authors doubles h in the first iteration as the authors' demo does (not
//    in the paper's eq. 24; the default, paper, uses h).
// Phase timers: "init" (particle selection, mixture preparation), "hem", "attraction" (eq. 24
// and every F1), "repulsion" (density weights and F2). Results depend only on the input, the
// parameters and ctx.seed(), never on the thread count.
#include <Eigen/Core>
#include <array>
#include <string>

#include "scanbench/algorithms/mixtures/hem.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"

namespace scanbench::algorithms {

/// Coefficients of alpha(r) = theta(r)/r ~ sum_k w_k exp(-r^2 / (2 sigma_k^2 h^2)) for h = 1
/// (CLOP paper Fig. 5b, confirmed against the reference code). Fitted on r in [0, h]; the sum
/// matches alpha within 10% on [0.01 h, 0.2 h] and falls off beyond (ratio 0.82 at 0.25 h, 0.56 at
/// 0.3 h, 0.04 at 0.5 h): that is the method, not a bug (tests/algorithms/test_clop.cpp).
inline constexpr std::array<double, 3> kClopFitWeights = {11.453, 29.886, 97.761};
inline constexpr std::array<double, 3> kClopFitSigmas = {0.11772, 0.03287, 0.01010};

/// The three-Gaussian approximation of alpha at distance r for kernel width h (both absolute),
/// in units where alpha(r) = theta(r) / (r / h) (i.e. h = 1 scaling).
double clop_alpha_hat(double r, double h);

/// Declares the parameters of the CLOP projection (shared by ClopParams and CswParams, which
/// projects particles onto a given mixture with resample=true) on T derived from
/// ClopProjectionSettings.
template <class T>
void declare_clop_projection_params(ParamDeclarer<T>& d) {
  d.real("h", &T::h, Range::open_min(0.0, 1.0), "diag",
         "kernel support radius h, theta(r) = exp(-16 r^2/h^2) (LOP/CLOP convention)");
  d.real("mu", &T::mu, Range::half_open(0.0, 0.5), "", "repulsion weight mu of q = F1 + mu F2");
  d.integer("iterations", &T::iterations, Range::closed(1, 1000), "",
            "iterations, the first being the continuous L2 initial iteration (eq. 24), as in "
            "resample.lop");
  d.real("particles", &T::particles, Range::above(0.0), "",
         "particles: a share of the input in (0, 1] or an integral count > 1 (may exceed the "
         "input: upsampling); a seeded subset");
  d.real("repulsion_cutoff", &T::repulsion_cutoff, Range::open_min(0.0, 1.0), "h",
         "repulsion kernel cutoff as a fraction of h (section 8: 0.5)");
  d.flag("interleave", &T::interleave,
         "recompute the repulsion only every second iteration and in the last (section 8)");
}

/// Declares the CLOP parameters: the projection's, the two choices between the paper and the
/// authors' demo, and HEM's.
template <class T>
void declare_clop_params(ParamDeclarer<T>& d) {
  declare_clop_projection_params(d);
  d.choice("first_iteration", &T::first_iteration, {"paper", "authors"},
           "kernel of the continuous L2 first iteration: paper = h (eq. 24), authors = 2 h (the "
           "authors' CLOP demo, Preiner 2014; not in the paper)");
  d.choice("repulsion_weights", &T::repulsion_weights, {"none", "wlop"},
           "particle weights in the repulsion F2: none (eq. 5, and the authors' demo) or wlop "
           "(WLOP's density weights w_i', Huang et al. 2009, as resample.wlop)");
  declare_hem_params(d);
}

/// The settings of the CLOP projection with their defaults, held once.
struct ClopProjectionSettings {
  double h = 0.02;
  double mu = 0.4;
  int iterations = 10;
  double particles = 0.5;
  double repulsion_cutoff = 0.5;
  bool interleave = true;
};

/// The CLOP settings with their defaults (ClopParams derives from it).
struct ClopSettings : HemSettings, ClopProjectionSettings {
  std::string first_iteration = "paper";   ///< "paper" (eq. 24 at h) or "authors" (2 h)
  std::string repulsion_weights = "none";  ///< "none" (eq. 5) or "wlop" (w_i' in F2)
};

struct ClopParams : ClopSettings {
  static void declare(ParamDeclarer<ClopParams>& d) { declare_clop_params(d); }
};

/// CLOP projection of particles onto an existing mixture (no HEM): the eq. 24 initial iteration
/// followed by p.iterations - 1 steps of F1 + mu F2. `particles` are projected in place; h_abs is
/// absolute. Only h, mu, iterations, repulsion_cutoff, interleave, first_iteration and
/// repulsion_weights of p are used.
/// Throws InputError on an empty mixture.
void clop_project(const GaussianMixture& m, Eigen::Matrix3Xf& particles, const ClopParams& p,
                  double h_abs, RunContext& ctx);

/// The exact continuous attraction F1(q, M) of eq. 22 summed over every component (no cutoff;
/// a reference for tests, O(|M|)). h_abs absolute.
Eigen::Vector3f clop_attraction_reference(const Eigen::Vector3f& q, const GaussianMixture& m,
                                          double h_abs);

/// resample.clop on `in` (h relative to in's bbox diagonal). Output: the particles (no normals)
/// and the HEM mixture. Throws InputError on an empty or invalid cloud, ParamError on a bad
/// particle count.
AlgorithmOutput clop(const PointCloud& in, const ClopParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
