#pragma once
// Internal kernels of the locally optimal projection family (LOP, WLOP, CLOP), shared by
// lop.cpp and clop.cpp. Private to the algorithms module (not installed, not a public header).
//
// Conventions (CLOP paper sections 3, 7 and 8):
//  - theta(r) = exp(-16 r^2 / h^2) = exp(-r^2 / (h/4)^2), h an absolute length (callers convert
//    their "fraction of the bbox diagonal" parameter once). theta(h) = exp(-16) ~ 1.1e-7, so every
//    neighbour search uses the support radius h (the repulsion optionally a smaller cutoff).
//  - alpha(r) = theta(r) / r with r clamped below at kClampRatio * h (the Weiszfeld singularity at
//    r = 0; 0.01 h puts the discrete peak alpha(0.01h) ~ 100/h at the level of the finite peak
//    sum_k w_k ~ 139/h of CLOP's three-Gaussian fit, so LOP and CLOP treat coincident points
//    alike).
//  - Repulsion uses eta(r) = -r, so beta(r) = theta(r) / r * |eta'(r)| = alpha(r).
//
// Every function here works on one particle (or one point) and reads only const data, so callers
// run them in TBB parallel loops and get results that do not depend on the thread count. Hot
// loops are float; the kernel values of one neighbourhood are evaluated as one vectorised Eigen
// array expression.
#include <Eigen/Core>
#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "scanbench/core/kdtree.h"
#include "scanbench/core/rng.h"
#include "spatial/neighbor_grid.h"

namespace scanbench::algorithms::kernels {

/// theta(r) = exp(-kThetaFactor r^2 / h^2).
inline constexpr float kThetaFactor = 16.0f;
/// |p - q| and |q - q'| are clamped below at kClampRatio * h inside alpha and beta.
inline constexpr float kClampRatio = 0.01f;

/// theta(r) for one distance r >= 0 (absolute length) and kernel width h > 0.
float theta(float r, float h);
/// alpha(r) = theta(max(r, eps h)) / max(r, eps h), eps = kClampRatio.
float alpha(float r, float h);

/// Reusable per-thread scratch space for the neighbourhood of one query (avoids allocations in
/// the hot loops). Create one per TBB body invocation or per thread; never share between threads.
struct Scratch {
  std::vector<std::pair<Eigen::Index, float>> hits;
  Eigen::ArrayXf a, b, dx, dy, dz;
};

/// The L2 first iteration of LOP (CLOP eq. 2) for one particle q:
/// sum_j p_j theta(|p_j - q|) / sum_j theta(|p_j - q|) over the points within h of q.
/// Returns q itself when no point lies within h (the particle stays; documented, not an error).
Eigen::Vector3f l2_mean(const Eigen::Vector3f& q, const Eigen::Matrix3Xf& points,
                        const KdTree& tree, float h, Scratch& s);

/// The attraction F1 of one particle q (CLOP eq. 4; eq. 25 with density weights):
/// sum_j p_j (alpha_j / v_j) / sum_j (alpha_j / v_j) over the points within h of q.
/// `inverse_density` holds 1 / v_j per point, or is empty for LOP (v = 1).
/// Returns q itself when no point lies within h.
Eigen::Vector3f attraction(const Eigen::Vector3f& q, const Eigen::Matrix3Xf& points,
                           const KdTree& tree, const Eigen::VectorXf& inverse_density, float h,
                           Scratch& s);

/// The repulsion F2 of particle i (CLOP eq. 5 with eta(r) = -r; WLOP weights w_i'):
/// sum_{i' != i} (q_i - q_i') beta_i' w_i' / sum_{i' != i} beta_i' w_i' over the particles
/// within `cutoff` of q_i (cutoff <= h; CLOP section 8 uses h/2, LOP/WLOP use h).
/// `particle_weights` holds w_i' per particle, or is empty for LOP (w = 1). `tree` indexes
/// `particles`. Returns the zero vector when no other particle lies within the cutoff.
/// The caller forms q_i' = F1 + mu F2.
Eigen::Vector3f repulsion(Eigen::Index i, const Eigen::Matrix3Xf& particles, const KdTree& tree,
                          const Eigen::VectorXf& particle_weights, float h, float cutoff,
                          Scratch& s);

/// Batched forms of the kernels above for every query at once (TBB-parallel), over a
/// detail::NeighborGrid of the summed points (query_grid() for the radius it is queried with).
/// Each query streams the contiguous grid ranges around it and sums with SIMD packets
/// (distances, support mask, exp, clamp, division) in a fixed order, so results do not depend on
/// the thread count; they equal the per-query functions up to float summation order.
///
/// Points per occupied cell of side `radius` from which query_grid() takes cells of radius / 2.
inline constexpr double kDenseOccupancy = 48.0;
/// The grid of `points` (a cell's points in the order of `rank`, detail::GridLayout) for queries
/// of `radius`: cells of radius / 2 where the points are dense at that scale (at least
/// kDenseOccupancy per occupied cell of side `radius`; a query reads 5 x 5 columns), else cells
/// of `radius` (3 x 3 columns). A query costs a range lookup per column and a SIMD packet per
/// started packet of points: sparse points (CLOP's repulsion within h/2: 30 points per cell of
/// the radius on the Camel case, 7 at 3M points) waste most lanes of 25 short ranges, dense
/// points (WLOP's neighbourhoods within h: over a hundred per cell) put too many points beyond
/// the radius into 9 wide ones (docs/performance.md has the measurements).
detail::NeighborGrid query_grid(const Eigen::Matrix3Xf& points, float radius,
                                const std::vector<Eigen::Index>* rank = nullptr);
/// Density weights 1 + sum_{j' != j, |p_j - p_j'| <= cutoff} theta(|p_j - p_j'|) of every point
/// (WLOP's v_j for input points, computed once; w_i for particles, every iteration; CLOP eq. 25
/// with the section 8 cutoff). `grid` was built from `points` (its weights are ignored).
Eigen::VectorXf density_weights(const detail::NeighborGrid& grid, const Eigen::Matrix3Xf& points,
                                float h, float cutoff);
/// l2_mean() of every column of q (grid over the input points; its weights are ignored).
Eigen::Matrix3Xf l2_means(const Eigen::Matrix3Xf& q, const detail::NeighborGrid& grid, float h);
/// attraction() of every column of q; the grid's weights are 1 / v_j (all 1 for LOP).
Eigen::Matrix3Xf attractions(const Eigen::Matrix3Xf& q, const detail::NeighborGrid& grid, float h);
/// repulsion() of every particle; `grid` was built from `particles` and its weights are w_i'
/// (all 1 for LOP).
Eigen::Matrix3Xf repulsions(const Eigen::Matrix3Xf& particles, const detail::NeighborGrid& grid,
                            float h, float cutoff);

/// The number of particles for the `particles` parameter of the projection operators: a value
/// in (0, 1] is a share of the n input points (rounded to nearest, at least 1); a value > 1 is a
/// count and must be an integer (it may exceed n: upsampling). Throws ParamError naming
/// "<where>.particles" for a non-integral count or a non-positive value.
Eigen::Index particle_count(double particles, Eigen::Index n, std::string_view where);

/// A seeded subset of m <= n of the indices 0..n-1 (partial Fisher-Yates shuffle on `rng`, m
/// draws), as flags: flags[j] = 1 when j is chosen. initial_particles() draws its subset with it,
/// so a caller that needs the chosen indices (filter.gpf carries the points' normals) gets the
/// same subset from the same seed.
std::vector<char> seeded_subset(Eigen::Index n, Eigen::Index m, Rng& rng);

/// The initial particles Q(0): m points of `points` chosen by a seeded partial Fisher-Yates
/// shuffle, listed in increasing input order. For m > n every point is used floor(m/n) times and
/// a seeded subset once more; every copy after the first is displaced by an isotropic normal
/// offset of standard deviation `jitter` (absolute length; > 0 is needed for upsampling so that
/// coinciding particles can repel each other). Random numbers come only from Rng(seed).
/// Throws InputError when points is empty and m > 0.
Eigen::Matrix3Xf initial_particles(const Eigen::Matrix3Xf& points, Eigen::Index m,
                                   std::uint64_t seed, float jitter);

}  // namespace scanbench::algorithms::kernels
