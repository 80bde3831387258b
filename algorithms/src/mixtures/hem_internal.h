#pragma once
// Internals of mixture.hem shared by its files (hem.cpp, hem_level0.cpp, hem_merge.cpp) and
// reachable by the oracle tests (tests/algorithms/test_hem_oracle.cpp). Private to the algorithms module (not installed, not a public header).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#include "scanbench/algorithms/mixtures/hem.h"

namespace scanbench::algorithms::hem_detail {

/// One component of a HEM level, in double precision (the likelihood exponent of eq. 9 and the
/// determinants of flat Gaussians are where float loses everything). `w` is the unnormalised
/// weight of eq. 10 (level 0: eq. 26, (v_j |P|)^-1), so w |P| is the eq. 9 exponent w-bar.
struct Component {
  Eigen::Vector3d mu;
  Eigen::Matrix3d cov;
  double w;
  Eigen::Vector3d axis;  ///< normal axis of the wrapped-normal distribution (section 9.2)
  double spread;         ///< its variance sigma^2 = -2 log rho
  double lmax;           ///< largest eigenvalue of cov
  double logdet;         ///< log |cov|
};

/// An allocator that default-initialises (leaves a Component's fields unset): every field is
/// written by the parallel loop that fills the vector, which also first-touches its pages there
/// instead of in a serial zero fill.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <class U>
  void construct(U* ptr) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(ptr)) U;
  }
  template <class U, class... Args>
  void construct(U* ptr, Args&&... args) {
    ::new (static_cast<void*>(ptr)) U(std::forward<Args>(args)...);
  }
};
using Components = std::vector<Component, DefaultInitAllocator<Component>>;

/// Stores in c the symmetric `sym` with its eigenvalues clamped to >= max(abs_floor, 1e-6
/// lambda_max), with its largest eigenvalue and log-determinant. `ev`: the eigenvalues of `sym`
/// (ascending); `vectors()`: its eigenvectors, asked for only when clamping is needed.
template <class Vectors>
void store_conditioned(Component& c, const Eigen::Matrix3d& sym, Eigen::Vector3d ev,
                       double abs_floor, Vectors&& vectors) {
  const double floor = std::max(abs_floor, 1e-6 * ev(2));
  if (ev(0) >= floor) {
    c.cov = sym;
  } else {
    ev = ev.cwiseMax(floor);
    const Eigen::Matrix3d v = vectors();
    const Eigen::Matrix3d r = v * ev.asDiagonal() * v.transpose();
    c.cov = 0.5 * (r + r.transpose());
  }
  c.lmax = ev(2);
  c.logdet = std::log(ev(0)) + std::log(ev(1)) + std::log(ev(2));
}

/// Stores in out[i] the symmetrised covs[i] with its eigenvalues clamped to >= max(abs_floor,
/// 1e-6 lambda_max), with its largest eigenvalue and log-determinant, for every i.
void set_conditioned(Component* out, const std::vector<Eigen::Matrix3d>& covs, double abs_floor);

/// Whether component i is chosen as a parent in the level of seed level_seed (Algorithm 1 line
/// 11: each with probability `probability`, an independent seeded draw per component).
bool chosen_as_parent(std::uint64_t level_seed, Eigen::Index i, double probability);

/// The level-0 mixture of Algorithm 1 lines 1-9 (eq. 12, eq. 26 weights, normal axes).
Components initial_mixture(const Eigen::Matrix3Xf& pts, const HemParams& p, double h_abs,
                           double abs_floor);

/// One HEM level (Algorithm 1 lines 11-18): the parents (chosen_as_parent) in index order, each
/// updated by eq. 10, 29 and 30 from its children (eq. 11 KL constraint, responsibilities eq. 8
/// with the likelihood eq. 9, exponent w_i |P| = w_i n_points), then the orphans unchanged.
Components cluster_level(const Components& comps, const HemParams& p, std::uint64_t level_seed,
                         double n_points, double abs_floor);

}  // namespace scanbench::algorithms::hem_detail
